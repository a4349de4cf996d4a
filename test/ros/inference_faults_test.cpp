// rostest node for interior_inference's bad input (test/ros/inference_faults.test): no volume, no
// targets, an unknown parameter, ~export/~simulate before any result; every answer names the cause
// and the fix, and the node survives all of them (a last valid goal succeeds).
#include <actionlib/client/simple_action_client.h>
#include <gtest/gtest.h>
#include <ros/ros.h>

#include <geometry_msgs/InertiaStamped.h>
#include <ros/topic.h>
#include <sensor_msgs/PointCloud2.h>
#include <signal.h>
#include <sys/wait.h>

#include <cstdio>
#include <fstream>
#include <iterator>
#include <regex>
#include <string>
#include <vector>

#include "topo_gaussian/ExportInterior.h"
#include "topo_gaussian/IdentifiedInertia.h"
#include "topo_gaussian/InferInteriorAction.h"
#include "topo_gaussian/SimulateInterior.h"
#include "topo_gaussian/physics/default_shapes.h"
#include "topo_gaussian/ros/conversions.h"

namespace {

using Client = actionlib::SimpleActionClient<topo_gaussian::InferInteriorAction>;

std::string abortReason(const topo_gaussian::InferInteriorGoal& goal) {
  Client c("infer_interior", false);
  EXPECT_TRUE(c.waitForServer(ros::Duration(30.0)));
  c.sendGoal(goal);
  EXPECT_TRUE(c.waitForResult(ros::Duration(60.0)));
  EXPECT_EQ(c.getState(), actionlib::SimpleClientGoalState::ABORTED) << c.getResult()->message;
  return c.getResult()->message;
}

sensor_msgs::PointCloud2 tumblerVolume() {
  return topo_gaussian::topo_ros::toPointCloud2(topo_gaussian::defaultShapeCloud("tumbler", 0.006), "object",
                                                ros::Time());
}

}  // namespace

TEST(InferenceFaults, GoalWithoutAVolumeAborts) {
  topo_gaussian::InferInteriorGoal g;
  g.task = "tumbler";
  g.targets = {"period_s=0.5"};
  const std::string why = abortReason(g);
  EXPECT_NE(why.find("no volume cloud"), std::string::npos) << why;
  EXPECT_NE(why.find("cloud_ingest"), std::string::npos) << "names the fix: " << why;
}

TEST(InferenceFaults, GoalWithoutTargetsAborts) {
  topo_gaussian::InferInteriorGoal g;
  g.task = "tumbler";
  g.volume = tumblerVolume();
  const std::string why = abortReason(g);
  EXPECT_NE(why.find("period_s"), std::string::npos) << why;
  EXPECT_NE(why.find("motion_features"), std::string::npos) << "says none arrived: " << why;
}

TEST(InferenceFaults, UnknownOverrideAndNegativeIterationsAreNamed) {
  topo_gaussian::InferInteriorGoal g;
  g.task = "tumbler";
  g.volume = tumblerVolume();
  g.targets = {"period_s=0.5"};
  g.overrides = {"initial_tilt_degs=5"};
  std::string why = abortReason(g);
  EXPECT_NE(why.find("initial_tilt_degs"), std::string::npos) << why;
  EXPECT_NE(why.find("initial_tilt_deg"), std::string::npos) << "suggests the nearest key: " << why;
  g.overrides.clear();
  g.max_iterations = -3;
  why = abortReason(g);
  EXPECT_NE(why.find("max_iterations"), std::string::npos) << why;
}

TEST(InferenceFaults, ServicesBeforeAnyResultAnswerWithAReason) {
  topo_gaussian::ExportInterior ex;
  ASSERT_TRUE(ros::service::waitForService("/interior_inference/export", ros::Duration(30.0)));
  ASSERT_TRUE(ros::service::call("/interior_inference/export", ex));
  EXPECT_FALSE(ex.response.success);
  EXPECT_NE(ex.response.message.find("no inference has finished"), std::string::npos) << ex.response.message;
  topo_gaussian::SimulateInterior sim;
  ASSERT_TRUE(ros::service::call("/interior_inference/simulate", sim));
  EXPECT_FALSE(sim.response.success);
  EXPECT_NE(sim.response.message.find("no inference has run"), std::string::npos) << sim.response.message;
}

TEST(InferenceFaults, AStepBudgetOverrideAbortsWithTheNumbers) {
  topo_gaussian::InferInteriorGoal g;
  g.task = "tumbler";
  g.volume = tumblerVolume();
  g.targets = {"period_s=0.5"};
  g.overrides = {"max_substep_s=1e-12"};
  const std::string why = abortReason(g);
  EXPECT_NE(why.find("2e+12 steps"), std::string::npos) << why;
  EXPECT_NE(why.find("max_substep_s >="), std::string::npos) << "names the fix: " << why;
}

TEST(InferenceFaults, ASlowGoalCancelledIsPreemptedWithinTwoSecondsAndTheNextGoalIsAccepted) {
  Client c("infer_interior", false);
  ASSERT_TRUE(c.waitForServer(ros::Duration(30.0)));
  topo_gaussian::InferInteriorGoal g;
  g.task = "tumbler";
  g.volume = tumblerVolume();
  g.targets = {"period_s=0.5"};
  g.overrides = {"max_substep_s=2e-7"};  // 1e7 substeps per simulation: minutes without a cancel
  c.sendGoal(g);
  const ros::WallTime sent = ros::WallTime::now();
  while (c.getState() != actionlib::SimpleClientGoalState::ACTIVE &&
         ros::WallTime::now() - sent < ros::WallDuration(10))
    ros::WallDuration(0.02).sleep();
  ASSERT_EQ(c.getState(), actionlib::SimpleClientGoalState::ACTIVE);
  ros::WallDuration(1.0).sleep();  // well inside the first simulation
  const ros::WallTime cancelled = ros::WallTime::now();
  c.cancelGoal();
  ASSERT_TRUE(c.waitForResult(ros::Duration(10.0)));
  const double latency_s = (ros::WallTime::now() - cancelled).toSec();
  std::printf("cancel to PREEMPTED: %.3f s\n", latency_s);
  EXPECT_EQ(c.getState(), actionlib::SimpleClientGoalState::PREEMPTED) << c.getResult()->message;
  EXPECT_LT(latency_s, 2.0);
  EXPECT_TRUE(c.getResult()->preempted);
  // The node is free again: the next goal is accepted and runs.
  g.overrides.clear();
  g.max_iterations = 1;
  c.sendGoal(g);
  ASSERT_TRUE(c.waitForResult(ros::Duration(60.0)));
  EXPECT_EQ(c.getState(), actionlib::SimpleClientGoalState::SUCCEEDED) << c.getResult()->message;
}

std::uint32_t g_valid_result_points = 0;  // set by the valid goal, checked after the restart
std::string g_valid_result_dir;           // its run folder, read back by the CLI
double g_valid_result_mass_kg = 0.0;      // its mass, published again by the restarted node

TEST(InferenceFaults, TheNodeStillServesAValidGoal) {
  Client c("infer_interior", false);
  ASSERT_TRUE(c.waitForServer(ros::Duration(30.0)));
  topo_gaussian::InferInteriorGoal g;
  g.task = "tumbler";
  g.volume = tumblerVolume();
  g.targets = {"period_s=0.5"};
  g.max_iterations = 3;
  c.sendGoal(g);
  ASSERT_TRUE(c.waitForResult(ros::Duration(120.0)));
  EXPECT_EQ(c.getState(), actionlib::SimpleClientGoalState::SUCCEEDED) << c.getResult()->message;
  EXPECT_FALSE(c.getResult()->files.empty());
  g_valid_result_points = c.getResult()->interior.width;
  g_valid_result_dir = c.getResult()->output_dir;
  g_valid_result_mass_kg = c.getResult()->mass_kg;
}

// The result's mass properties for a robot: latched as geometry_msgs/InertiaStamped in the object's frame,
// and with the analysis's standard deviations as IdentifiedInertia, the same numbers as the result's.
TEST(InferenceFaults, TheResultsMassPropertiesAreLatchedForARobot) {
  ASSERT_GT(g_valid_result_mass_kg, 0.0) << "needs the valid goal's result";
  const auto in = ros::topic::waitForMessage<geometry_msgs::InertiaStamped>("inertia", ros::Duration(10.0));
  ASSERT_TRUE(in) << "no latched message on inertia";
  EXPECT_EQ(in->header.frame_id, "object_simulated") << "the frame of the interior (inference.launch object_frame)";
  EXPECT_EQ(in->inertia.m, g_valid_result_mass_kg);
  const auto id = ros::topic::waitForMessage<topo_gaussian::IdentifiedInertia>("inertia_identified", ros::Duration(10.0));
  ASSERT_TRUE(id) << "no latched message on inertia_identified";
  EXPECT_EQ(id->inertia.m, in->inertia.m);
  EXPECT_EQ(id->inertia.ixy, in->inertia.ixy);
  EXPECT_EQ(id->moment_names.size(), 10u);
  EXPECT_EQ(id->moment_std.size(), 10u);
  EXPECT_TRUE(id->analysed) << "the tumbler's period observes the mass moments: " << id->summary;
}

// Goals that name an object add their experiment to its earlier ones, with the targets those were run
// with; another material for the same object is refused naming it, and the record stays as it was.
TEST(InferenceFaults, AnObjectsExperimentsAccumulateAcrossGoals) {
  Client c("infer_interior", false);
  ASSERT_TRUE(c.waitForServer(ros::Duration(30.0)));
  auto send = [&](const std::vector<std::string>& targets, const std::vector<std::string>& overrides) {
    topo_gaussian::InferInteriorGoal g;
    g.task = "hanging";
    g.volume = tumblerVolume();
    g.targets = targets;
    g.overrides = overrides;
    g.ignore_motion_features = true;
    g.max_iterations = 3;
    g.object_id = "doll";
    c.sendGoal(g);
    EXPECT_TRUE(c.waitForResult(ros::Duration(60.0)));
    return *c.getResult();
  };
  const auto first = send({"target_roll_deg=5", "target_pitch_deg=0"}, {});
  EXPECT_EQ(c.getState(), actionlib::SimpleClientGoalState::SUCCEEDED) << first.message;
  EXPECT_EQ(first.experiment_names.size(), 1u) << first.message;
  const auto second = send({"target_roll_deg=-4", "target_pitch_deg=2"}, {});
  EXPECT_EQ(c.getState(), actionlib::SimpleClientGoalState::SUCCEEDED) << second.message;
  EXPECT_EQ(second.experiment_names, std::vector<std::string>({"hanging", "hanging_2"})) << second.message;
  const std::string refused = send({"target_roll_deg=1", "target_pitch_deg=0"}, {"density_solid=7800"}).message;
  EXPECT_EQ(c.getState(), actionlib::SimpleClientGoalState::ABORTED) << refused;
  EXPECT_NE(refused.find("object 'doll'"), std::string::npos) << refused;
  const auto third = send({"target_roll_deg=0", "target_pitch_deg=-3"}, {});
  EXPECT_EQ(third.experiment_names, std::vector<std::string>({"hanging", "hanging_2", "hanging_3"})) << third.message;
}

TEST(InferenceFaults, ARestartedNodeRestoresTheLatestResult) {
  // A second instance on the same output directory (as after a crash or a restart) publishes the
  // newest run again on its latched `interior`, so rviz gets it back.
  ASSERT_GT(g_valid_result_points, 0u) << "needs the valid goal's run";
  const std::string cmd = std::string(TOPO_NODE_DIR) +
                          "/interior_inference __ns:=/restarted _output_dir:=/tmp/topo_rostest_faults "
                          "> /tmp/topo_rostest_restarted.log 2>&1 & echo $!";
  FILE* p = popen(cmd.c_str(), "r");
  ASSERT_TRUE(p);
  int pid = 0;
  ASSERT_EQ(fscanf(p, "%d", &pid), 1);
  pclose(p);
  const auto cloud = ros::topic::waitForMessage<sensor_msgs::PointCloud2>("/restarted/interior", ros::Duration(60.0));
  const auto inertia =
      ros::topic::waitForMessage<geometry_msgs::InertiaStamped>("/restarted/inertia", ros::Duration(10.0));
  kill(pid, SIGINT);
  ASSERT_TRUE(inertia) << "the restarted node published no inertia (see /tmp/topo_rostest_restarted.log)";
  // the mass of the run it restored, as that run's report.json holds it (its log, complete once it exited)
  for (int i = 0; i < 100 && kill(pid, 0) == 0; ++i) ros::WallDuration(0.1).sleep();
  std::ifstream log("/tmp/topo_rostest_restarted.log");
  const std::string text((std::istreambuf_iterator<char>(log)), std::istreambuf_iterator<char>());
  std::smatch dir, mass;
  ASSERT_TRUE(std::regex_search(text, dir, std::regex("restored the latest result from (\\S+) \\(task"))) << text;
  std::ifstream rep(dir[1].str() + "/report.json");
  const std::string report((std::istreambuf_iterator<char>(rep)), std::istreambuf_iterator<char>());
  ASSERT_TRUE(std::regex_search(report, mass, std::regex("\"mass_kg\": ([-+0-9.eE]+)"))) << dir[1].str();
  EXPECT_EQ(inertia->inertia.m, std::stod(mass[1].str())) << dir[1].str();
  ASSERT_TRUE(cloud) << "the restarted node published no interior (see /tmp/topo_rostest_restarted.log)";
  EXPECT_EQ(cloud->width, g_valid_result_points);
  EXPECT_TRUE(topo_gaussian::topo_ros::hasField(*cloud, "solid"));
}

/// Runs a shell command; its exit status, and its output in *out.
int shell(const std::string& cmd, std::string* out) {
  FILE* p = popen((cmd + " 2>&1").c_str(), "r");
  if (!p) return -1;
  char buf[512];
  while (fgets(buf, sizeof buf, p)) *out += buf;
  const int st = pclose(p);
  return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

TEST(InferenceFaults, TheCliReadsTheNodesRunFolder) {
  ASSERT_FALSE(g_valid_result_dir.empty()) << "needs the valid goal's run";
  std::string out;
  const std::string topo = std::string(TOPO_NODE_DIR) + "/topo";
  EXPECT_EQ(shell(topo + " simulate --task tumbler --volume " + g_valid_result_dir + "/volume.ply --interior " +
                      g_valid_result_dir + "/interior.ply --json",
                  &out),
            0)
      << out;
  EXPECT_NE(out.find("\"period_s\""), std::string::npos) << out;
}

TEST(InferenceFaults, ANodeRestoresARunOfTheCli) {
  // `topo infer` writes a run folder under a fresh output directory; a node started on that directory
  // publishes it, as it would its own.
  const std::string dir = "/tmp/topo_rostest_cli_runs", topo = std::string(TOPO_NODE_DIR) + "/topo";
  std::string out;
  ASSERT_EQ(shell("rm -rf " + dir + " && mkdir -p " + dir + " && " + topo + " shape tumbler --spacing 0.006 --volume " +
                      dir + "/tumbler.ply",
                  &out),
            0)
      << out;
  const int rc = shell(topo + " infer --task tumbler --volume " + dir +
                           "/tumbler.ply --target period_s=0.5 "
                           "--set max_evaluations=2 --no-export --quiet --output " +
                           dir + "/tumbler_cli",
                       &out);
  ASSERT_TRUE(rc == 0 || rc == 3) << out;
  const std::string cmd = std::string(TOPO_NODE_DIR) + "/interior_inference __ns:=/cli_restored _output_dir:=" + dir +
                          " > /tmp/topo_rostest_cli_restored.log 2>&1 & echo $!";
  FILE* p = popen(cmd.c_str(), "r");
  ASSERT_TRUE(p);
  int pid = 0;
  ASSERT_EQ(fscanf(p, "%d", &pid), 1);
  pclose(p);
  const auto cloud =
      ros::topic::waitForMessage<sensor_msgs::PointCloud2>("/cli_restored/interior", ros::Duration(60.0));
  kill(pid, SIGINT);
  ASSERT_TRUE(cloud) << "the node published no interior from the CLI's run (see /tmp/topo_rostest_cli_restored.log)";
  std::string particles;
  ASSERT_EQ(shell("grep -a 'element vertex' " + dir + "/tumbler_cli/volume.ply", &particles), 0);
  EXPECT_EQ(std::to_string(cloud->width),
            particles.substr(particles.rfind(' ') + 1, particles.find('\n') - particles.rfind(' ') - 1));
}

/// Runs a node binary of this package with one bad private parameter; returns its exit status and
/// output (it must stop at start, naming the parameter).
int runNode(const std::string& node, const std::string& args, std::string* out) {
  static int run = 0;  // a new name each time: private parameters persist on the parameter server
  return shell(std::string(TOPO_NODE_DIR) + "/" + node + " __name:=bad_" + node + std::to_string(++run) + " " + args,
               out);
}

TEST(InferenceFaults, ParametersOutOfRangeStopTheNodesAtStartNamingThem) {
  std::string out;
  EXPECT_EQ(runNode("interior_inference", "_replay_rate_hz:=-5", &out), 1) << out;
  EXPECT_NE(out.find("~replay_rate_hz"), std::string::npos) << out;
  out.clear();
  EXPECT_EQ(runNode("interior_inference", "_default_task:=no_such_task", &out), 1) << out;
  EXPECT_NE(out.find("no_such_task"), std::string::npos) << out;
  out.clear();
  EXPECT_EQ(runNode("rig_simulator", "_fps:=-30", &out), 1) << out;
  EXPECT_NE(out.find("~fps"), std::string::npos) << out;
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "inference_faults_test");
  ros::AsyncSpinner spinner(1);
  spinner.start();
  const int rc = RUN_ALL_TESTS();
  ros::shutdown();
  return rc;
}
