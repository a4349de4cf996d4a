// rostest node for interior_inference killed while it writes (test/ros/inference_crash.test): this
// node starts interior_inference itself on a fresh ~output_dir, lets one goal finish, kills the node
// with SIGKILL during a second goal's export and during a third goal's optimisation, adds two
// folders as a torn write leaves them, restarts the node on the same ~output_dir and checks that it
// restores the newest *complete* run and names every folder it passed over, with the reason; and that a
// node restoring a run whose simulation takes minutes answers goals at once and stops on SIGINT.
#include <actionlib/client/simple_action_client.h>
#include <fcntl.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <ros/topic.h>
#include <sensor_msgs/PointCloud2.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "topo_gaussian/InferInteriorAction.h"
#include "topo_gaussian/io/interior_ply.h"
#include "topo_gaussian/io/run_folder.h"
#include "topo_gaussian/io/volume_ply.h"
#include "topo_gaussian/physics/default_shapes.h"
#include "topo_gaussian/ros/conversions.h"

namespace {

namespace fs = std::filesystem;
using Client = actionlib::SimpleActionClient<topo_gaussian::InferInteriorAction>;

const std::string kOutputDir = "/tmp/topo_rostest_crash";

/// interior_inference as a child process (its output in `log`), killed with SIGKILL or SIGINT.
class NodeProcess {
 public:
  NodeProcess(const std::string& log, bool restore, const std::string& output_dir = kOutputDir) : log_(log) {
    // Everything the child needs is prepared before fork (only async-signal-safe calls after it).
    const std::string bin = std::string(TOPO_NODE_DIR) + "/interior_inference";
    const std::string out = "_output_dir:=" + output_dir;
    const std::string rest = std::string("_restore_latest:=") + (restore ? "true" : "false");
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    pid_ = fork();
    if (pid_ == 0) {
      if (fd < 0 || dup2(fd, 1) < 0 || dup2(fd, 2) < 0) _exit(126);
      execl(bin.c_str(), bin.c_str(), "__name:=interior_inference", out.c_str(), rest.c_str(), "_replay_rate_hz:=0.0",
            "_volume_wait_s:=5.0", static_cast<char*>(nullptr));
      _exit(127);
    }
    if (fd >= 0) ::close(fd);
  }
  ~NodeProcess() { stop(SIGINT); }
  /// Sends `sig` and waits up to 10 s; returns false when the node had to be killed (it did not stop).
  bool stop(int sig) {
    if (pid_ <= 0) return true;
    kill(pid_, sig);
    int status = 0;
    pid_t done = 0;
    for (int i = 0; i < 200 && (done = waitpid(pid_, &status, WNOHANG)) == 0; ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    const bool stopped = done == pid_;
    if (!stopped) {
      kill(pid_, SIGKILL);
      waitpid(pid_, &status, 0);
    }
    pid_ = -1;
    return stopped;
  }
  std::string log() const {
    std::ifstream f(log_);
    std::stringstream s;
    s << f.rdbuf();
    return s.str();
  }

 private:
  std::string log_;
  pid_t pid_ = -1;
};

topo_gaussian::InferInteriorGoal goal(int iterations, const std::string& target) {
  topo_gaussian::InferInteriorGoal g;
  g.task = "tumbler";
  g.volume =
      topo_gaussian::topo_ros::toPointCloud2(topo_gaussian::defaultShapeCloud("tumbler", 0.006), "object", ros::Time());
  g.targets = {target};
  g.max_iterations = iterations;
  return g;
}

std::set<std::string> runFolders() {
  std::set<std::string> s;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(kOutputDir, ec))
    if (e.is_directory()) s.insert(e.path().string());
  return s;
}

/// The folder in `now` that is not in `before`, or "".
std::string newFolder(const std::set<std::string>& before) {
  for (const auto& d : runFolders())
    if (!before.count(d)) return d;
  return "";
}

/// Sends `g` and SIGKILLs the node once `when(dir)` holds for the goal's new run folder. Returns that folder.
template <typename When>
std::string killDuring(NodeProcess& node, const topo_gaussian::InferInteriorGoal& g, When when, double timeout_s) {
  Client c("infer_interior", false);
  EXPECT_TRUE(c.waitForServer(ros::Duration(30.0)));
  const auto before = runFolders();
  c.sendGoal(g);
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  std::string dir;
  while (std::chrono::steady_clock::now() < end) {
    if (dir.empty()) dir = newFolder(before);
    if (!dir.empty() && when(dir)) break;
    std::this_thread::sleep_for(std::chrono::microseconds(500));
  }
  node.stop(SIGKILL);
  return dir;
}

bool has(const std::string& dir, const char* file) { return fs::exists(fs::path(dir) / file); }

}  // namespace

TEST(InferenceCrash, RestartAfterSigkillRestoresTheNewestCompleteRun) {
  fs::remove_all(kOutputDir);
  fs::create_directories(kOutputDir);
  std::string complete;  // run A: finished
  {
    NodeProcess node("/tmp/topo_rostest_crash_1.log", false);
    Client c("infer_interior", false);
    ASSERT_TRUE(c.waitForServer(ros::Duration(30.0))) << node.log();
    c.sendGoal(goal(3, "period_s=0.5"));
    ASSERT_TRUE(c.waitForResult(ros::Duration(120.0)));
    ASSERT_EQ(c.getState(), actionlib::SimpleClientGoalState::SUCCEEDED) << c.getResult()->message;
    complete = c.getResult()->output_dir;
    ASSERT_NO_THROW(topo_gaussian::io::loadRunFolder(complete));
  }
  std::string killed_exporting;  // run B: killed once its report.json is written, before volume.ply
  {
    NodeProcess node("/tmp/topo_rostest_crash_2.log", false);
    killed_exporting = killDuring(
        node, goal(3, "period_s=0.5"), [](const std::string& d) { return has(d, "report.json"); }, 120.0);
    ASSERT_FALSE(killed_exporting.empty()) << node.log();
  }
  std::string killed_optimising;  // run C: killed while it optimised (no file written yet)
  {
    NodeProcess node("/tmp/topo_rostest_crash_3.log", false);
    killed_optimising = killDuring(
        node, goal(400, "period_s=0.9"),
        [seen = std::chrono::steady_clock::time_point()](const std::string&) mutable {
          if (seen == std::chrono::steady_clock::time_point()) seen = std::chrono::steady_clock::now();
          return std::chrono::steady_clock::now() - seen > std::chrono::milliseconds(200);  // into the optimisation
        },
        60.0);
    ASSERT_FALSE(killed_optimising.empty()) << "the third goal made no run folder:\n" << node.log();
    ASSERT_FALSE(has(killed_optimising, "report.json")) << "the third goal finished before it was killed";
  }
  // Two folders as a torn write leaves them (a copy interrupted, a file system without atomic
  // rename): a report and an interior but no volume.ply, and an interior.ply cut in half.
  const std::string no_volume = kOutputDir + "/tumbler_29990101_000000";
  const std::string cut_interior = kOutputDir + "/tumbler_29990101_000001";
  for (const auto& d : {no_volume, cut_interior}) {
    fs::create_directories(d);
    for (const char* f : {"volume.ply", "interior.ply", "report.json"})
      fs::copy_file(fs::path(complete) / f, fs::path(d) / f, fs::copy_options::overwrite_existing);
  }
  fs::remove(fs::path(no_volume) / "volume.ply");
  fs::resize_file(fs::path(cut_interior) / "interior.ply", fs::file_size(fs::path(cut_interior) / "interior.ply") / 2);

  // What the restart must pick: the newest run folder that loads.
  const topo_gaussian::io::LatestRun expected = topo_gaussian::io::findLatestRun(kOutputDir);
  ASSERT_TRUE(expected.found);
  EXPECT_TRUE(expected.run.dir == complete || expected.run.dir == killed_exporting) << expected.run.dir;
  EXPECT_NE(expected.run.dir, no_volume);
  EXPECT_NE(expected.run.dir, cut_interior);

  NodeProcess node("/tmp/topo_rostest_crash_restart.log", true);
  const auto cloud = ros::topic::waitForMessage<sensor_msgs::PointCloud2>("/interior", ros::Duration(60.0));
  ASSERT_TRUE(cloud) << "the restarted node published no interior:\n" << node.log();
  EXPECT_EQ(cloud->width * cloud->height, expected.run.volume.size());
  node.stop(SIGINT);  // ROS_INFO goes to a buffered stdout: read the log once the node has exited
  const std::string log = node.log();
  EXPECT_NE(log.find("restored the latest result from " + expected.run.dir), std::string::npos) << log;
  // Every folder passed over is named, with the reason.
  for (const auto& d : {no_volume, cut_interior})
    EXPECT_NE(log.find("restore skipped " + d + ":"), std::string::npos) << d << "\n" << log;
  EXPECT_NE(log.find("volume.ply"), std::string::npos) << log;
  EXPECT_NE(log.find("restore skipped " + killed_optimising + ": no report.json"), std::string::npos)
      << "the run killed mid-optimisation is not named:\n"
      << log;
  if (!has(killed_exporting, "volume.ply") && has(killed_exporting, "report.json")) {
    EXPECT_NE(log.find("restore skipped " + killed_exporting + ":"), std::string::npos) << log;
  }
}

TEST(InferenceCrash, ARestartOnARunThatTakesMinutesToSimulateServesAtOnce) {
  // The restore publishes the run's interior at once and simulates its motion off the main thread: the
  // node answers goals while it does, and stops the simulation when asked to stop.
  const std::string dir = "/tmp/topo_rostest_heavy_restore", run = dir + "/tumbler_29990101_000000";
  fs::remove_all(dir);
  fs::create_directories(run);
  {  // a 10 cm box, contact samples every 1.6 mm: landing on its face it takes minutes to simulate
    std::ofstream obj(dir + "/box.obj");
    obj << "v -0.05 -0.05 0\nv 0.05 -0.05 0\nv 0.05 0.05 0\nv -0.05 0.05 0\n"
           "v -0.05 -0.05 0.1\nv 0.05 -0.05 0.1\nv 0.05 0.05 0.1\nv -0.05 0.05 0.1\n"
           "f 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 2 3 7\nf 2 7 6\nf 3 4 8\nf 3 8 7\n"
           "f 4 1 5\nf 4 5 8\n";
  }
  const std::string fill = std::string(TOPO_NODE_DIR) + "/topo fill --input " + dir + "/box.obj --output " + run +
                           "/volume.ply --count 5000 --contact-spacing 0.0016 > " + dir + "/fill.log 2>&1";
  ASSERT_EQ(std::system(fill.c_str()), 0) << "see " << dir << "/fill.log";
  const topo_gaussian::VolumeCloud volume = topo_gaussian::io::readVolumePly(run + "/volume.ply");
  topo_gaussian::io::writeInteriorPly(run + "/interior.ply", volume, std::vector<double>(volume.size(), 1.0),
                                      std::vector<double>(volume.size(), 1000.0), false);
  std::ofstream(run + "/report.json") << "{\"task\": \"tumbler\", \"cancelled\": false}\n";
  ASSERT_TRUE(topo_gaussian::io::findLatestRun(dir).found);

  NodeProcess node("/tmp/topo_rostest_heavy_restore.log", true, dir);
  const auto t0 = std::chrono::steady_clock::now();
  Client c("infer_interior", false);
  ASSERT_TRUE(c.waitForServer(ros::Duration(20.0))) << "no action server 20 s after the start:\n" << node.log();
  topo_gaussian::InferInteriorGoal g;
  g.task = "no_such_task";
  c.sendGoal(g);
  ASSERT_TRUE(c.waitForResult(ros::Duration(10.0))) << node.log();
  EXPECT_EQ(c.getState(), actionlib::SimpleClientGoalState::ABORTED);
  EXPECT_NE(c.getResult()->message.find("no_such_task"), std::string::npos) << c.getResult()->message;
  const auto cloud = ros::topic::waitForMessage<sensor_msgs::PointCloud2>("/interior", ros::Duration(10.0));
  ASSERT_TRUE(cloud) << "the restored interior was not published:\n" << node.log();
  EXPECT_EQ(cloud->width * cloud->height, volume.size());
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 30.0);
  EXPECT_TRUE(node.stop(SIGINT)) << "the node did not stop within 10 s of SIGINT:\n" << node.log();
  const std::string log = node.log();
  EXPECT_NE(log.find("restored the latest result from " + run), std::string::npos) << log;
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "inference_crash_test");
  ros::NodeHandle nh;
  ros::AsyncSpinner spinner(1);
  spinner.start();
  const int rc = RUN_ALL_TESTS();
  spinner.stop();
  ros::shutdown();
  return rc;
}
