// rostest node for test/ros/motion_tracker_perspective.test: the tumbler twin seen from a camera
// 0.6 m away looking 20 deg down. Each tracker's tilt series (motion_features: time_s from its
// window's first frame, angle_deg) is matched to the image stamps seen on /camera_info and compared
// frame by frame with the twin's true tilt, tf world -> object_true at that stamp. The tilt bias is
// the mean of |tracked| - |true| over the window's frames.
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include "topo_gaussian/MotionFeatures.h"

namespace {

struct Comparison {
  double bias_deg = NAN;   ///< mean of |tracked| - |true|
  double worst_deg = NAN;  ///< largest |tracked - true|
  double max_tilt_deg = NAN, true_max_tilt_deg = NAN;
  int frames = 0;
};

/// The true tilt [deg] of object_true at `stamp`: its z axis from world up, + towards world -y (which
/// the camera, looking along +x, sees to the right).
bool trueTilt(const tf2_ros::Buffer& tf, const ros::Time& stamp, double* deg) {
  try {
    const auto T = tf.lookupTransform("world", "object_true", stamp);
    const auto& q = T.transform.rotation;
    // the rotated z axis
    const double uy = 2 * (q.y * q.z - q.x * q.w), uz = 1 - 2 * (q.x * q.x + q.y * q.y);
    *deg = std::atan2(-uy, uz) * 180.0 / M_PI;
    return true;
  } catch (const tf2::TransformException&) {
    return false;
  }
}

/// Matches the window (times from its first frame) to the stamps seen: the first frame is the stamp
/// whose match gives the smallest mean |error| (frames at the same spacing fit any start; the motion
/// decides), among those that match at least 90 % of the window's frames.
Comparison compare(const topo_gaussian::MotionFeatures& f, const std::vector<ros::Time>& stamps,
                   const tf2_ros::Buffer& tf) {
  std::map<std::int64_t, double> truth;  // stamp [ns] -> true tilt
  for (const ros::Time& s : stamps) {
    double d;
    if (trueTilt(tf, s, &d)) truth[s.toNSec()] = d;
  }
  Comparison best;
  double best_abs = 1e300;
  const std::int64_t tol = 2000000;  // 2 ms
  for (const auto& [s0, unused] : truth) {
    double sum_abs = 0, bias = 0, worst = 0, mx = 0, true_mx = 0;
    int n = 0;
    for (std::size_t i = 0; i < f.time_s.size(); ++i) {
      const std::int64_t want = s0 + std::llround(f.time_s[i] * 1e9);
      auto it = truth.lower_bound(want - tol);
      if (it == truth.end() || it->first > want + tol) continue;  // a stamp not seen here, or without tf
      const double e = f.angle_deg[i] - it->second;
      sum_abs += std::abs(e);
      bias += std::abs(f.angle_deg[i]) - std::abs(it->second);
      worst = std::max(worst, std::abs(e));
      mx = std::max(mx, std::abs(f.angle_deg[i]));
      true_mx = std::max(true_mx, std::abs(it->second));
      ++n;
    }
    if (n < 0.9 * f.time_s.size()) continue;  // most of the window must be matched
    if (n <= 0 || sum_abs / n >= best_abs) continue;
    best_abs = sum_abs / n;
    best.bias_deg = bias / n;
    best.worst_deg = worst;
    best.max_tilt_deg = mx;
    best.true_max_tilt_deg = true_mx;
    best.frames = n;
  }
  return best;
}

}  // namespace

TEST(MotionTrackerPerspective, CloserTiltedCameraReadsTheTrueTilt) {
  ros::NodeHandle nh;
  tf2_ros::Buffer tf(ros::Duration(300.0));
  tf2_ros::TransformListener listener(tf);
  std::mutex mu;
  std::vector<ros::Time> stamps;
  std::map<std::string, topo_gaussian::MotionFeatures> latest;
  ros::Subscriber info = nh.subscribe<sensor_msgs::CameraInfo>("/camera_info", 100,
                                                               [&](const sensor_msgs::CameraInfoConstPtr& m) {
                                                                 std::lock_guard<std::mutex> l(mu);
                                                                 stamps.push_back(m->header.stamp);
                                                               });
  std::vector<ros::Subscriber> subs;
  for (const std::string ns : {"persp", "flat"})
    subs.push_back(nh.subscribe<topo_gaussian::MotionFeatures>(
        "/" + ns + "/motion_features", 10, [&, ns](const topo_gaussian::MotionFeaturesConstPtr& m) {
          std::lock_guard<std::mutex> l(mu);
          if (m->oscillation_found && m->frames_used >= 150) latest[ns] = *m;
        }));
  // the twin simulates first (tens of seconds on a shared machine), then a 6 s window fills
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(400.0);
  std::map<std::string, topo_gaussian::MotionFeatures> windows;
  while (ros::WallTime::now() < deadline && windows.size() < 2) {
    {
      std::lock_guard<std::mutex> l(mu);
      if (latest.size() == 2) windows = latest;
    }
    ros::WallDuration(0.2).sleep();
  }
  ASSERT_EQ(windows.size(), 2u) << "no complete tilt window from both trackers";
  ros::WallDuration(2.0).sleep();  // the stamps and tf of the windows' last frames arrive here too
  std::vector<ros::Time> seen;
  {
    std::lock_guard<std::mutex> l(mu);
    seen = stamps;
  }
  const auto& persp = windows["persp"];
  const auto& flat = windows["flat"];
  const Comparison p = compare(persp, seen, tf), o = compare(flat, seen, tf);
  std::printf(
      "[perspective] in the plane through the camera: tilt bias %+.4f deg, worst frame %.3f deg, max tilt %.3f deg "
      "(true %.3f), %d frames\n[perspective] image angles: tilt bias %+.4f deg, worst frame %.3f deg, max tilt %.3f "
      "deg (true %.3f), %d frames\n",
      p.bias_deg, p.worst_deg, p.max_tilt_deg, p.true_max_tilt_deg, p.frames, o.bias_deg, o.worst_deg, o.max_tilt_deg,
      o.true_max_tilt_deg, o.frames);
  std::printf("[perspective] %zu image stamps seen; windows of %zu and %zu frames\n", seen.size(),
              persp.time_s.size(), flat.time_s.size());
  ASSERT_GE(p.frames, 135) << persp.message;  // 90 % of a window of at least 150 frames
  ASSERT_GE(o.frames, 135) << flat.message;
  EXPECT_NE(persp.message.find("perspective"), std::string::npos) << persp.message;
  EXPECT_LT(std::abs(p.bias_deg), 0.05);
  EXPECT_GT(std::abs(o.bias_deg), 4 * std::abs(p.bias_deg));  // the camera's tilt matters here
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "motion_tracker_perspective_test");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  return RUN_ALL_TESTS();
}
