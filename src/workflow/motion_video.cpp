#include "topo_gaussian/workflow/motion_video.h"

#include <chrono>
#include <cmath>
#include <string>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/number_text.h"

namespace topo_gaussian::workflow {

vision::SplatCamera rigCameraAlongX(const Eigen::Vector3d& target, double distance_m, double horizontal_fov_deg,
                                    int width, int height) {
  vision::SplatCamera c;
  c.width = width;
  c.height = height;
  c.fx = c.fy = 0.5 * width / std::tan(0.5 * horizontal_fov_deg * M_PI / 180.0);
  c.cx = 0.5 * (width - 1);
  c.cy = 0.5 * (height - 1);
  c.t_wc = target - Eigen::Vector3d(distance_m, 0.0, 0.0);
  c.R_wc = vision::lookAtRotation(c.t_wc, target);
  c.validate();
  return c;
}

vision::Splats posedSplats(const std::vector<Eigen::Vector3d>& points, const std::vector<Eigen::Vector3d>& normals,
                           const inference::BodyPose& pose, double radius_m, const cv::Vec3b& colour) {
  vision::Splats s;
  s.radius_m = radius_m;
  s.colours = {colour};
  s.positions.reserve(points.size());
  s.normals.reserve(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    s.positions.push_back(pose.rotation * points[i] + pose.translation);
    s.normals.push_back(pose.rotation * normals[i]);
  }
  return s;
}

vision::TrackResult trackRenderedMotion(const std::vector<Eigen::Vector3d>& points,
                                        const std::vector<Eigen::Vector3d>& normals,
                                        const std::function<inference::BodyPose(double)>& pose_at,
                                        const vision::SplatCamera& camera, const MotionVideoOptions& o) {
  if (points.empty())
    throw TopoError("rendered motion", "has no surface points to draw", "pass the object's surface points");
  if (normals.size() != points.size())
    throw TopoError("rendered motion normals",
                    "has " + std::to_string(normals.size()) + " for " + std::to_string(points.size()) + " points",
                    "pass one normal per surface point");
  if (!(o.fps > 0) || !(o.duration_s > 0) || !(o.splat_radius_m > 0) || !std::isfinite(o.fps + o.duration_s))
    throw TopoError("rendered motion options",
                    "need fps > 0, duration_s > 0 and splat_radius_m > 0 (fps " + numberText(o.fps) + ", duration " +
                        numberText(o.duration_s) + " s, radius " + numberText(o.splat_radius_m) + " m)",
                    "give e.g. 30 frames/s over 8 s with splats of 0.8 spacings");
  vision::TrackOptions t;
  t.kind = "tilt";
  t.tilt_reference_deg = o.tilt_reference_deg;
  t.tracker.method = "silhouette";  // foreground auto: Otsu for tilt (MOG2 would absorb an object rocking in place)
  t.fps = o.fps;
  vision::MotionTracker tracker(t);
  vision::SplatShading shading;
  shading.noise_sigma = o.noise_sigma;
  const int frames = static_cast<int>(o.fps * o.duration_s);
  double render_s = 0;
  for (int k = 0; k < frames; ++k) {
    shading.noise_seed = o.noise_seed + static_cast<unsigned>(k);
    const auto t0 = std::chrono::steady_clock::now();
    const cv::Mat img = vision::renderSplats(
        camera, posedSplats(points, normals, pose_at(o.start_s + k / o.fps), o.splat_radius_m, o.colour), shading);
    render_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    tracker.addFrame(img, k / o.fps);
  }
  if (o.render_ms) *o.render_ms = frames > 0 ? 1e3 * render_s / frames : 0.0;
  return tracker.finish();
}

}  // namespace topo_gaussian::workflow
