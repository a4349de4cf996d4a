// rostest node for the finger twin's pressure faults (test/ros/finger_faults.test, ~pressure_profile
// command, ~pressure_timeout_s 2): no set point → a warning naming the topic and the fix, the finger
// held at 0 Pa; 9e9 Pa and NaN → an error naming the value and the range, ignored; 2.5e5 Pa →
// followed (pressure_pa, a bend between rest and the full pressure's); the node keeps publishing
// images throughout; a goal on the unpressurised finger's window is refused with the tracker's reason.
#include <actionlib/client/simple_action_client.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <ros/topic.h>
#include <rosgraph_msgs/Log.h>
#include <sensor_msgs/Image.h>
#include <std_msgs/Float64.h>

#include <cmath>
#include <mutex>
#include <string>
#include <vector>

#include "topo_gaussian/InferInteriorAction.h"
#include "topo_gaussian/MotionFeatures.h"
#include "topo_gaussian/RigGroundTruth.h"

namespace {

std::mutex log_mutex;
std::vector<std::string> log_lines;

bool logged(const std::string& needle, double wait_s) {
  const ros::WallTime until = ros::WallTime::now() + ros::WallDuration(wait_s);
  while (ros::ok() && ros::WallTime::now() < until) {
    {
      std::lock_guard<std::mutex> l(log_mutex);
      for (const auto& s : log_lines)
        if (s.find(needle) != std::string::npos) return true;
    }
    ros::WallDuration(0.1).sleep();
  }
  return false;
}

double pressureNow() {
  const auto p = ros::topic::waitForMessage<std_msgs::Float64>("/pressure_pa", ros::Duration(5.0));
  return p ? p->data : NAN;
}

bool imagesFlow() { return ros::topic::waitForMessage<sensor_msgs::Image>("/image", ros::Duration(5.0)) != nullptr; }

}  // namespace

TEST(FingerFaults, BadOrMissingPressureCommandsAreReportedAndTheTwinKeepsServing) {
  ros::NodeHandle nh;
  ros::Subscriber logs = nh.subscribe<rosgraph_msgs::Log>("/rosout", 100, [&](const rosgraph_msgs::LogConstPtr& m) {
    std::lock_guard<std::mutex> l(log_mutex);
    log_lines.push_back(m->msg);
  });
  const auto truth =
      ros::topic::waitForMessage<topo_gaussian::RigGroundTruth>("/rig_simulator/ground_truth", ros::Duration(120.0));
  ASSERT_TRUE(truth) << "the finger twin did not start";
  ASSERT_TRUE(imagesFlow());
  // no set point yet: held at 0 Pa, and said so
  EXPECT_EQ(pressureNow(), 0.0);
  EXPECT_TRUE(logged("no pressure command on /pressure_command", 15.0)) << "no warning about the missing set point";

  ros::Publisher cmd = nh.advertise<std_msgs::Float64>("/pressure_command", 10);
  for (int i = 0; i < 100 && cmd.getNumSubscribers() == 0; ++i) ros::WallDuration(0.05).sleep();
  ASSERT_GT(cmd.getNumSubscribers(), 0u);
  std_msgs::Float64 m;
  m.data = 9e9;
  cmd.publish(m);
  EXPECT_TRUE(logged("pressure command 9e+09 Pa on /pressure_command is outside [0, 5e+05] Pa", 10.0));
  EXPECT_EQ(pressureNow(), 0.0) << "an out-of-range set point is ignored";
  ros::WallDuration(2.5).sleep();  // past the error's throttle
  m.data = NAN;
  cmd.publish(m);
  EXPECT_TRUE(logged("pressure command nan Pa", 10.0));
  EXPECT_EQ(pressureNow(), 0.0);
  EXPECT_TRUE(imagesFlow()) << "the twin stopped publishing after bad set points";

  // the unpressurised finger's window: no bend measured, and a goal on it is refused with the reason
  const auto f = ros::topic::waitForMessage<topo_gaussian::MotionFeatures>("/motion_features", ros::Duration(30.0));
  ASSERT_TRUE(f);
  actionlib::SimpleActionClient<topo_gaussian::InferInteriorAction> client("infer_interior", false);
  ASSERT_TRUE(client.waitForServer(ros::Duration(60.0)));
  topo_gaussian::InferInteriorGoal g;
  g.task = "finger";
  g.overrides = {"youngs_modulus_solid=2e6"};
  g.features = *f;
  client.sendGoal(g);
  ASSERT_TRUE(client.waitForResult(ros::Duration(120.0)));
  EXPECT_EQ(client.getState(), actionlib::SimpleClientGoalState::ABORTED) << client.getResult()->message;
  EXPECT_NE(client.getResult()->message.find("no measured bending angle"), std::string::npos)
      << client.getResult()->message;
  EXPECT_NE(client.getResult()->message.find("did not bend"), std::string::npos) << client.getResult()->message;

  // a good set point is followed
  m.data = 2.5e5;
  cmd.publish(m);
  ros::WallDuration(0.5).sleep();
  EXPECT_EQ(pressureNow(), 2.5e5);
  const auto bend = ros::topic::waitForMessage<std_msgs::Float64>("/rig_simulator/true_bend_deg", ros::Duration(5.0));
  ASSERT_TRUE(bend);
  double full = NAN;
  for (std::size_t k = 0; k < truth->feature_names.size(); ++k)
    if (truth->feature_names[k] == "bend_angle_deg") full = truth->feature_values[k];
  EXPECT_GT(bend->data, 0.1 * full);
  EXPECT_LT(bend->data, 0.9 * full) << "the bend at half the pressure lies between rest and full";
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "finger_faults_test");
  ros::NodeHandle nh;
  ros::AsyncSpinner spinner(2);
  spinner.start();
  return RUN_ALL_TESTS();
}
