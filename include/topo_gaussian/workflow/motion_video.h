// Motion → video → features, as a lab measures an experiment: a rigid motion (body poses over time)
// rendered by a rig camera (vision::renderSplats of points on the object's surface, each frame with
// its own pixel noise) and measured by the motion tracker (vision::MotionTracker, silhouette tilt),
// so observations can come from images rather than from the simulator's own numbers. What the
// rig_simulator node publishes frame by frame and motion_tracker measures, in one library call
// (used by the rig twin's tests and bench/interiors).
//
// The rig camera looks along +x (it stands on −x, level with its target, image-up along world +z),
// so the silhouette's tilt is the rotation about x: a doll rocking about x, or a hung body's roll.
#pragma once

#include <Eigen/Core>
#include <functional>
#include <opencv2/core.hpp>
#include <vector>

#include "topo_gaussian/inference/body_motion.h"
#include "topo_gaussian/vision/motion_tracker.h"
#include "topo_gaussian/vision/splat_renderer.h"

namespace topo_gaussian::workflow {

/// The launch files' rig camera: `distance_m` (1.5 m) along −x from `target` (world), looking
/// horizontally at it, width × height (640 × 480) px with `horizontal_fov_deg` (8°).
vision::SplatCamera rigCameraAlongX(const Eigen::Vector3d& target, double distance_m = 1.5,
                                    double horizontal_fov_deg = 8.0, int width = 640, int height = 480);

/// The surface points (body frame) at `pose`, as splats of `radius_m` in one colour (BGR).
vision::Splats posedSplats(const std::vector<Eigen::Vector3d>& points, const std::vector<Eigen::Vector3d>& normals,
                           const inference::BodyPose& pose, double radius_m,
                           const cv::Vec3b& colour = cv::Vec3b(40, 40, 150));

struct MotionVideoOptions {
  double fps = 30.0;        ///< frame rate [frames/s]
  double start_s = 0.0;     ///< motion time of the first frame [s]
  double duration_s = 0.0;  ///< [s] (> 0)
  double splat_radius_m = 0.002;
  cv::Vec3b colour = cv::Vec3b(40, 40, 150);  ///< a dark red object on the light backdrop
  double noise_sigma = 2.0;                   ///< Gaussian pixel noise [grey levels], seeded per frame
  unsigned noise_seed = 1000;                 ///< frame k uses noise_seed + k
  double tilt_reference_deg = 0.0;            ///< the tilt the object starts near (TrackOptions)
  double* render_ms = nullptr;                ///< optional: mean rendering time per frame [ms]
};

/// Renders `duration_s` of the motion pose_at(t) from `camera` at `fps` and tracks the silhouette's
/// tilt (kind "tilt", method "silhouette"). Frame k is the pose at start_s + k / fps and carries the
/// time k / fps. Throws TopoError for no points, points and normals of different sizes, or a
/// non-positive fps, duration or splat radius.
vision::TrackResult trackRenderedMotion(const std::vector<Eigen::Vector3d>& points,
                                        const std::vector<Eigen::Vector3d>& normals,
                                        const std::function<inference::BodyPose(double)>& pose_at,
                                        const vision::SplatCamera& camera, const MotionVideoOptions& options);

}  // namespace topo_gaussian::workflow
