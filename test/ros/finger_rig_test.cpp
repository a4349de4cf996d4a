// rostest node for the soft-finger rig on its twin (test/ros/finger_rig.test = soft_finger_rig.launch):
//  - end to end: motion_tracker measures the bend at the full pressure on the twin's images (kind
//    finger) within 0.25 deg of the twin's truth (the stated tolerance is 1 deg); the infer_interior goal
//    takes that window as its target and its result reproduces the true bend within 2 %; the chamber
//    found is reported against the twin's (IoU of the chamber on the recovered particles, volume
//    error) and exported; the result's chamber must exist (one bend angle cannot fix its shape: the
//    numbers are reported, not judged);
//  - a rosbag of the twin's camera and pressure, recorded with `rosbag record` and played back with
//    `rosbag play` onto /bag/image and /bag/camera_info (how a real camera's topics arrive, remapped),
//    is measured by a second tracker (/bag/motion_features) as the live one.
#include <actionlib/client/simple_action_client.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <ros/topic.h>
#include <sensor_msgs/point_cloud2_iterator.h>
#include <std_msgs/Float64.h>

#include <Eigen/Core>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "topo_gaussian/InferInteriorAction.h"
#include "topo_gaussian/MotionFeatures.h"
#include "topo_gaussian/RigGroundTruth.h"

namespace {

using Client = actionlib::SimpleActionClient<topo_gaussian::InferInteriorAction>;

double valueOf(const std::vector<std::string>& names, const std::vector<double>& values, const std::string& name) {
  for (std::size_t k = 0; k < names.size() && k < values.size(); ++k)
    if (names[k] == name) return values[k];
  return NAN;
}

/// A window with the rest and the full pressure in it: a bend measured with confidence, ≥ 4 s long.
topo_gaussian::MotionFeatures::ConstPtr waitForBend(const std::string& topic, double wait_s) {
  const ros::WallTime until = ros::WallTime::now() + ros::WallDuration(wait_s);
  while (ros::ok() && ros::WallTime::now() < until) {
    const auto f = ros::topic::waitForMessage<topo_gaussian::MotionFeatures>(topic, ros::Duration(2.0));
    if (f && f->kind == "finger" && f->bending_confidence >= 0.5 && f->end_time_s - f->start_time_s >= 4.0) return f;
  }
  return nullptr;
}

struct Labelled {
  std::vector<Eigen::Vector3d> x;
  std::vector<bool> solid;
  std::vector<double> volume;  // [m³] where the cloud has a volume field (else empty)
};

Labelled readInterior(const sensor_msgs::PointCloud2& c) {
  Labelled out;
  sensor_msgs::PointCloud2ConstIterator<float> px(c, "x"), ps(c, "solid");
  for (; px != px.end(); ++px, ++ps) {
    out.x.emplace_back(px[0], px[1], px[2]);
    out.solid.push_back(*ps >= 0.5f);
  }
  return out;
}

/// The chamber's IoU on the recovered particles (each takes the true label of its nearest twin particle).
double chamberIou(const Labelled& recovered, const Labelled& truth) {
  double inter = 0, uni = 0;
  for (std::size_t i = 0; i < recovered.x.size(); ++i) {
    std::size_t best = 0;
    double d = 1e300;
    for (std::size_t j = 0; j < truth.x.size(); ++j) {
      const double e = (truth.x[j] - recovered.x[i]).squaredNorm();
      if (e < d) d = e, best = j;
    }
    const bool t = !truth.solid[best], r = !recovered.solid[i];
    inter += t && r;
    uni += t || r;
  }
  return uni > 0 ? inter / uni : NAN;
}

}  // namespace

TEST(FingerRig, EndToEndMeasuresTheBendAndFindsAChamber) {
  const auto truth =
      ros::topic::waitForMessage<topo_gaussian::RigGroundTruth>("/rig_simulator/ground_truth", ros::Duration(120.0));
  ASSERT_TRUE(truth) << "no ground truth from the finger twin";
  EXPECT_EQ(truth->task, "finger");
  const double bend = valueOf(truth->feature_names, truth->feature_values, "bend_angle_deg");
  const double chamber_m3 = valueOf(truth->feature_names, truth->feature_values, "chamber_volume_m3");
  const double chamber_fraction = valueOf(truth->feature_names, truth->feature_values, "chamber_volume_fraction");
  ASSERT_GT(bend, 3.0) << "the twin's finger bends at its full pressure";
  ASSERT_GT(chamber_m3, 0.0);

  const auto f = waitForBend("/motion_features", 120.0);
  ASSERT_TRUE(f) << "motion_tracker published no window with the finger bent";
  std::printf(
      "[finger rig] twin truth: bend %.3f deg at the full pressure; tracker: %.3f deg on screen "
      "(confidence %.2f, %.1f..%.1f s)\n",
      bend, f->bending_angle_deg, f->bending_confidence, f->start_time_s, f->end_time_s);
  EXPECT_NEAR(std::abs(f->bending_angle_deg), bend, 0.25) << f->message;

  Client c("infer_interior", false);
  ASSERT_TRUE(c.waitForServer(ros::Duration(60.0))) << "no infer_interior action server";
  topo_gaussian::InferInteriorGoal g;
  g.task = "finger";
  g.overrides = {"youngs_modulus_solid=2e6"};  // the twin's materials (config/rigs/finger_twin.yaml)
  g.features = *f;
  c.sendGoal(g);
  ASSERT_TRUE(c.waitForResult(ros::Duration(600.0))) << "no result in 600 s";
  ASSERT_EQ(c.getState(), actionlib::SimpleClientGoalState::SUCCEEDED) << c.getResult()->message;
  const auto res = c.getResult();
  const double got = valueOf(res->feature_names, res->achieved, "bend_angle_deg");
  const double got_fraction = valueOf(res->feature_names, res->achieved, "chamber_volume_fraction");
  EXPECT_NEAR(got, bend, 0.02 * bend) << res->message;
  EXPECT_GT(got_fraction, 0.0) << "a chamber was found";
  const Labelled recovered = readInterior(res->interior), twin = readInterior(truth->interior);
  const double iou = chamberIou(recovered, twin);
  std::printf(
      "[finger rig] recovered: bend %.3f deg (%+.2f %% of the truth), chamber volume fraction %.4f (twin %.4f, "
      "%+.1f %%), chamber IoU %.3f, %d evaluations\n",
      got, 100 * (got / bend - 1), got_fraction, chamber_fraction, 100 * (got_fraction / chamber_fraction - 1), iou,
      res->iterations);
  EXPECT_TRUE(std::isfinite(iou));
  for (const auto& file : res->files) EXPECT_TRUE(std::filesystem::exists(file)) << file;
  EXPECT_GE(res->files.size(), 4u) << "the result is exported";
}

TEST(FingerRig, ABagOfTheTwinPlayedBackThroughTheRigMeasuresTheSameBend) {
  ros::NodeHandle pnh("~");
  std::string bag;
  pnh.param<std::string>("bag_file", bag, "/tmp/topo_finger_twin.bag");
  std::filesystem::create_directories(std::filesystem::path(bag).parent_path());
  std::filesystem::remove(bag);
  const auto truth =
      ros::topic::waitForMessage<topo_gaussian::RigGroundTruth>("/rig_simulator/ground_truth", ros::Duration(120.0));
  ASSERT_TRUE(truth);
  const double bend = valueOf(truth->feature_names, truth->feature_values, "bend_angle_deg");
  // one pressure cycle and a little more: rest and full pressure
  const std::string record =
      "rosbag record --duration=9 -O " + bag + " /image /camera_info /pressure_pa >/dev/null 2>&1";
  ASSERT_EQ(std::system(record.c_str()), 0) << record;
  ASSERT_TRUE(std::filesystem::exists(bag)) << bag;
  std::printf("[finger rig] recorded %s (%.1f MB)\n", bag.c_str(), std::filesystem::file_size(bag) / 1e6);
  const std::string play = "rosbag play -q " + bag +
                           " /image:=/bag/image /camera_info:=/bag/camera_info /pressure_pa:=/bag/pressure_pa "
                           ">/dev/null 2>&1 &";
  ASSERT_EQ(std::system(play.c_str()), 0) << play;
  const auto f = waitForBend("/bag/motion_features", 60.0);
  ASSERT_TRUE(f) << "the tracker on the played-back bag published no window with the finger bent";
  std::printf("[finger rig] bag played back: bend %.3f deg on screen (confidence %.2f), twin truth %.3f deg\n",
              f->bending_angle_deg, f->bending_confidence, bend);
  EXPECT_NEAR(std::abs(f->bending_angle_deg), bend, 0.25) << f->message;
  EXPECT_EQ(f->source, "/bag/image");
  std::system("pkill -f 'rosbag play -q' >/dev/null 2>&1");
  std::filesystem::remove(bag);  // ~240 MB of raw frames
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "finger_rig_test");
  ros::NodeHandle nh;
  ros::AsyncSpinner spinner(1);
  spinner.start();
  return RUN_ALL_TESTS();
}
