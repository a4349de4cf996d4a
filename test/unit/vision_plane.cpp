// Trajectories as 3D points on a known plane: a generated pendulum video is tracked
// and its marker placed on the plane z = 2 m in front of a pinhole camera; the points must lie
// where the rendered bob was, back-projected analytically.
#include <gtest/gtest.h>

#include <cmath>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/io/motion_features_json.h"
#include "topo_gaussian/vision/camera_model.h"
#include "topo_gaussian/vision/motion_features.h"
#include "topo_gaussian/vision/motion_tracker.h"
#include "topo_gaussian/vision/synthetic_video.h"

using namespace topo_gaussian::vision;

TEST(PlaneTrajectories, MarkerLandsWhereTheBobWas) {
  PendulumScene s;
  s.duration_s = 3.0;
  s.noise_sigma = 3.0;
  const std::string file = testing::TempDir() + "/plane_pendulum.avi";
  writeVideo(renderPendulum(s), s.fps, file);
  TrackOptions o;
  TrackResult r = trackVideo(file, o);
  ASSERT_EQ(r.trajectories.size(), 1u);
  const double f = 500.0, cx = 320.0, cy = 240.0, depth = 2.0;
  const CameraModel cam(cv::Matx33d(f, 0, cx, 0, f, cy, 0, 0, 1), {});
  placeOnPlane(cam, cv::Vec3d(0, 0, 1), depth, r);
  ASSERT_EQ(r.points_on_plane.size(), 1u);
  ASSERT_EQ(r.points_on_plane[0].size(), r.trajectories[0].size());
  double worst = 0;
  for (std::size_t k = 0; k < r.trajectories[0].size(); ++k) {
    const double t = r.trajectories[0][k].t, th = pendulumAngleDeg(s, t) * M_PI / 180.0;
    const cv::Point2d px = s.pivot + s.length_px * cv::Point2d(std::sin(th), std::cos(th));
    const cv::Vec3d expected((px.x - cx) / f * depth, (px.y - cy) / f * depth, depth);
    worst = std::max(worst, cv::norm(r.points_on_plane[0][k] - expected));
  }
  // One pixel at 2 m with f = 500 px is 4 mm; allow 1.5 px of tracking error (and the frame-time
  // quantisation of the codec).
  EXPECT_LT(worst, 0.006) << "worst distance " << worst << " m";
  EXPECT_NE(topo_gaussian::io::motionFeaturesJson(toMotionFeatures(r), false).find("\"points_on_plane\""),
            std::string::npos);
  EXPECT_THROW(placeOnPlane(cam, cv::Vec3d(0, 0, 0), 1.0, r), topo_gaussian::TopoError);
}

// A tilt measured in the image is the plane's tilt only for a level camera far away; through the
// camera model (tiltInPlaneDeg) a line in the plane reads its own angle from a camera that is near,
// pitched down, off to the side and has a distorting lens.
TEST(PlaneTilt, ALineInThePlaneReadsItsAngleThroughAPitchedCamera) {
  const double pitch = -25.0 * M_PI / 180.0;  // looking down at the plane x = 0
  const cv::Matx33d level(0, 0, 1, -1, 0, 0, 0, -1, 0);  // optical x, y, z = world -y, -z, +x
  const cv::Matx33d rx(1, 0, 0, 0, std::cos(pitch), -std::sin(pitch), 0, std::sin(pitch), std::cos(pitch));
  PlaneView view;
  view.camera = CameraModel(cv::Matx33d(900, 0, 330, 0, 900, 250, 0, 0, 1), {-0.12, 0.05, 0.001, -0.002},
                            level * rx, cv::Vec3d(-0.5, 0.08, 0.35));
  view.plane = cv::Vec4d(1, 0, 0, 0);
  const cv::Vec3d centre(0, 0.02, 0.12);
  double worst = 0, worst_image = 0;
  for (double deg : {-30.0, -12.0, -2.0, 0.0, 5.0, 17.0, 40.0}) {
    const double th = deg * M_PI / 180.0;
    const cv::Vec3d dir(0, -std::sin(th), std::cos(th));  // + towards world -y, which images to the right
    const cv::Point2d a = view.camera.project(centre - 0.002 * dir), b = view.camera.project(centre + 0.002 * dir);
    const double image_deg = std::atan2(b.x - a.x, -(b.y - a.y)) * 180.0 / M_PI;
    const double in_plane = tiltInPlaneDeg(view, view.camera.project(centre), image_deg);
    worst = std::max(worst, std::abs(in_plane - deg));
    worst_image = std::max(worst_image, std::abs(image_deg - deg));
  }
  std::printf("[plane tilt] worst error in the plane %.5f deg; the image angle is off by up to %.2f deg\n", worst,
              worst_image);
  EXPECT_GT(worst_image, 1.0);  // the camera's perspective matters here
  EXPECT_LT(worst, 0.01);
  PlaneView horizontal = view;
  horizontal.plane = cv::Vec4d(0, 0, 1, 0);
  EXPECT_THROW(tiltInPlaneDeg(horizontal, view.camera.project(centre), 0.0), topo_gaussian::TopoError);
}
