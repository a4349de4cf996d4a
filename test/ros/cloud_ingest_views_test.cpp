// rostest node for cloud_ingest's depth views (test/ros/cloud_ingest_views.test): depth clouds of a
// sphere from a simulated structured-light camera (depth-dependent sigma, edge and random dropouts;
// test/unit/depth_views.h) are published on `depth_points` in a moving camera frame whose pose goes
// out on tf at each cloud's stamp; ~finish_views must refuse a one-sided scan naming the hole, and
// fill an all-round scan to the sphere's volume. Bad frames are skipped and the node keeps serving.
//
// Private parameters: ~node (the node's name, default /cloud_ingest).
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/point_cloud2_iterator.h>
#include <std_msgs/String.h>
#include <std_srvs/Trigger.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <tf2_ros/transform_broadcaster.h>

#include <chrono>
#include <cmath>
#include <mutex>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "../unit/depth_views.h"
#include "topo_gaussian/ros/conversions.h"

namespace {

namespace geo = topo_gaussian::geometry;
namespace tr = topo_gaussian::topo_ros;
using sensor_msgs::PointCloud2;

const Eigen::Vector3d kCentre(0.1, -0.05, 0.3);  // the sphere, in world
constexpr double kR = 0.05;
const Eigen::Vector3d kTurntable(0.0, 0.0, 0.1);  // world <- turntable: a translation

std::string g_node = "/cloud_ingest";

/// The newest message on a latched String topic, and every volume.
struct Listener {
  std::mutex m;
  std::string status;
  std::size_t statuses = 0;
  std::vector<sensor_msgs::PointCloud2ConstPtr> volumes;
  ros::Subscriber status_sub, volume_sub;
  void onStatus(const std_msgs::StringConstPtr& s) {
    std::lock_guard<std::mutex> l(m);
    status = s->data;
    ++statuses;
  }
  void onVolume(const sensor_msgs::PointCloud2ConstPtr& v) {
    std::lock_guard<std::mutex> l(m);
    volumes.push_back(v);
  }
  std::string lastStatus() {
    std::lock_guard<std::mutex> l(m);
    return status;
  }
  std::size_t volumeCount() {
    std::lock_guard<std::mutex> l(m);
    return volumes.size();
  }
  /// Waits until the status contains `text`; false on timeout.
  bool waitStatus(const std::string& text, double timeout_s) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    while (ros::ok() && std::chrono::steady_clock::now() < end) {
      if (lastStatus().find(text) != std::string::npos) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return false;
  }
};
Listener* g_listen = nullptr;

geometry_msgs::TransformStamped transformMsg(const Eigen::Isometry3d& T, const std::string& parent,
                                             const std::string& child, const ros::Time& stamp) {
  geometry_msgs::TransformStamped t;
  t.header.frame_id = parent;
  t.header.stamp = stamp;
  t.child_frame_id = child;
  t.transform.translation.x = T.translation().x();
  t.transform.translation.y = T.translation().y();
  t.transform.translation.z = T.translation().z();
  const Eigen::Quaterniond q(T.linear());
  t.transform.rotation.w = q.w();
  t.transform.rotation.x = q.x();
  t.transform.rotation.y = q.y();
  t.transform.rotation.z = q.z();
  return t;
}

/// An organised x y z cloud (NaN where the camera had no return) in `frame`.
PointCloud2 cloudMsg(const geo::DepthView& v, int width, int height, const std::string& frame, const ros::Time& stamp) {
  PointCloud2 msg;
  msg.header.frame_id = frame;
  msg.header.stamp = stamp;
  msg.width = std::uint32_t(width);
  msg.height = std::uint32_t(height);
  sensor_msgs::PointCloud2Modifier mod(msg);
  mod.setPointCloud2FieldsByString(1, "xyz");
  mod.resize(std::size_t(width) * std::size_t(height));
  msg.width = std::uint32_t(width);
  msg.height = std::uint32_t(height);
  msg.row_step = msg.point_step * msg.width;
  msg.is_dense = false;
  sensor_msgs::PointCloud2Iterator<float> x(msg, "x");
  for (const auto& p : v.points) {
    for (int k = 0; k < 3; ++k) x[k] = float(p[k]);
    ++x;
  }
  return msg;
}

class DepthRig {
 public:
  DepthRig() {
    ros::NodeHandle nh;
    pub_ = nh.advertise<PointCloud2>("/depth_points", 20);
    static_tf_.sendTransform(transformMsg(Eigen::Isometry3d(Eigen::Translation3d(kTurntable)), "world", "turntable",
                                          ros::Time::now()));
  }
  bool connected() {
    for (int i = 0; i < 200 && pub_.getNumSubscribers() == 0; ++i) ros::Duration(0.05).sleep();
    return pub_.getNumSubscribers() > 0;
  }
  /// One view of the sphere from kCentre + 0.4 m * dir: its tf (turntable <- depth_camera) at the
  /// cloud's stamp first, then the cloud; a cloud `cloud_age_s` older than its tf is stale.
  void publishView(const Eigen::Vector3d& dir, const std::string& frame = "depth_camera", double cloud_age_s = 0.0,
                   bool no_return = false) {
    const topo_test::DepthCamera cam;
    geo::DepthView v = topo_test::depthView(topo_test::sphereSolid(kCentre, kR), kCentre + 0.4 * dir.normalized(),
                                                  kCentre, cam, rng_);
    const ros::Time stamp = ros::Time::now();
    const Eigen::Isometry3d turntable_from_camera =
        Eigen::Isometry3d(Eigen::Translation3d(-kTurntable)) * v.world_from_sensor;
    tf_.sendTransform(transformMsg(turntable_from_camera, "turntable", "depth_camera", stamp));
    ros::Duration(0.05).sleep();
    if (no_return) v.points.assign(v.points.size(), Eigen::Vector3d::Constant(std::nan("")));
    pub_.publish(cloudMsg(v, cam.width, cam.height, frame, stamp - ros::Duration(cloud_age_s)));
  }

 private:
  ros::Publisher pub_;
  tf2_ros::TransformBroadcaster tf_;
  tf2_ros::StaticTransformBroadcaster static_tf_;
  std::mt19937 rng_{42};
};
DepthRig* g_rig = nullptr;

std_srvs::Trigger call(const std::string& name) {
  std_srvs::Trigger srv;
  EXPECT_TRUE(ros::service::waitForService(g_node + "/" + name, ros::Duration(10.0))) << name;
  EXPECT_TRUE(ros::service::call(g_node + "/" + name, srv)) << name;
  return srv;
}

TEST(CloudIngestViews, UnknownFramesStaleStampsAndEmptyCloudsAreSkippedAndTheNodeServes) {
  ASSERT_TRUE(g_rig->connected()) << g_node << " does not subscribe /depth_points";
  const std::size_t volumes = g_listen->volumeCount();
  g_rig->publishView(Eigen::Vector3d::UnitX(), "no_such_frame");
  g_rig->publishView(Eigen::Vector3d::UnitX(), "");
  g_rig->publishView(Eigen::Vector3d::UnitX(), "depth_camera", 30.0);  // beyond tf's 10 s of history
  g_rig->publishView(Eigen::Vector3d::UnitX(), "depth_camera", 0.0, /*no_return=*/true);
  ros::Duration(3.0).sleep();  // the node waits ~tf_timeout_s (0.5 s) for each missing transform
  const std_srvs::Trigger srv = call("finish_views");
  EXPECT_FALSE(srv.response.success);
  EXPECT_NE(srv.response.message.find("no depth view"), std::string::npos) << srv.response.message;
  EXPECT_EQ(g_listen->volumeCount(), volumes);
  EXPECT_EQ(g_listen->lastStatus(), "") << "a skipped cloud was counted as a view";
}

TEST(CloudIngestViews, OneSideOnlyIsRefusedNamingTheHoleAndTheViewsStay) {
  const std::size_t volumes = g_listen->volumeCount();
  for (const auto& d : {Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(1, 0.5, 0), Eigen::Vector3d(1, -0.5, 0)})
    g_rig->publishView(d);
  ASSERT_TRUE(g_listen->waitStatus("view 3 (frame depth_camera) added", 30.0)) << g_listen->lastStatus();
  EXPECT_NE(g_listen->lastStatus().find("add views where the holes are"), std::string::npos) << g_listen->lastStatus();
  std_srvs::Trigger srv = call("finish_views");
  EXPECT_FALSE(srv.response.success);
  const std::string& m = srv.response.message;
  EXPECT_NE(m.find("(-x)"), std::string::npos) << m;
  EXPECT_NE(m.find("add a view from around"), std::string::npos) << m;
  EXPECT_NE(m.find("frame world"), std::string::npos) << m;
  EXPECT_NE(m.find("3 views kept"), std::string::npos) << m;
  ros::Duration(0.3).sleep();
  EXPECT_EQ(g_listen->volumeCount(), volumes) << "a refused fusion published a volume";
  srv = call("clear_views");
  EXPECT_TRUE(srv.response.success);
  EXPECT_NE(srv.response.message.find("cleared 3"), std::string::npos) << srv.response.message;
}

TEST(CloudIngestViews, AllRoundScanFillsWithinTwoPercentOfTheSphere) {
  const std::size_t volumes = g_listen->volumeCount();
  const auto dirs = topo_test::allRoundDirections();
  for (const auto& d : dirs) g_rig->publishView(d);
  ASSERT_TRUE(g_listen->waitStatus("view " + std::to_string(dirs.size()) + " (frame depth_camera) added", 60.0))
      << g_listen->lastStatus();
  EXPECT_NE(g_listen->lastStatus().find("Enough to fill"), std::string::npos) << g_listen->lastStatus();
  const std_srvs::Trigger srv = call("finish_views");
  ASSERT_TRUE(srv.response.success) << srv.response.message;
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (g_listen->volumeCount() == volumes && std::chrono::steady_clock::now() < end)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  ASSERT_GT(g_listen->volumeCount(), volumes) << "no volume published after finish_views";
  sensor_msgs::PointCloud2ConstPtr msg;
  {
    std::lock_guard<std::mutex> l(g_listen->m);
    msg = g_listen->volumes.back();
  }
  EXPECT_EQ(msg->header.frame_id, "world");
  const topo_gaussian::VolumeCloud c = tr::fromPointCloud2(*msg, "/volume");
  const double exact = 4.0 / 3.0 * M_PI * kR * kR * kR;
  EXPECT_NEAR(c.totalVolume(), exact, 0.02 * exact) << srv.response.message;
  EXPECT_LT((c.centroid() - kCentre).norm(), 0.02 * kR) << "the volume sits where the sphere is, in world";
  std::printf("[ INFO ] filled %.6g m^3 against %.6g m^3 (%+.2f %%): %s\n", c.totalVolume(), exact,
              100.0 * (c.totalVolume() / exact - 1.0), srv.response.message.c_str());
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "cloud_ingest_views_test");
  ros::NodeHandle nh, pnh("~");
  pnh.param<std::string>("node", g_node, g_node);
  ros::AsyncSpinner spinner(2);
  spinner.start();
  Listener listen;
  listen.status_sub = nh.subscribe(g_node + "/views_status", 10, &Listener::onStatus, &listen);
  listen.volume_sub = nh.subscribe("/volume", 10, &Listener::onVolume, &listen);
  g_listen = &listen;
  DepthRig rig;
  g_rig = &rig;
  const int rc = RUN_ALL_TESTS();
  spinner.stop();
  ros::shutdown();
  return rc;
}
