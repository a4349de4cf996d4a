// rostest node for motion_tracker (test/ros/motion_tracker.test): a pendulum video generated here
// goes through ~extract_motion; the same pendulum replayed as an image stream (stamped at 30 fps,
// sent faster than real time) must give the same period on `motion_features`; a 32FC1 image is
// refused while the node keeps serving; a red texture is refused as "not one object".
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <ros/topic.h>
#include <rosgraph_msgs/Log.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <tf2_ros/transform_broadcaster.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/image_encodings.h>

#include <cv_bridge/cv_bridge.h>

#include <mutex>
#include <string>

#include "topo_gaussian/ExtractMotion.h"
#include "topo_gaussian/MotionFeatures.h"
#include "topo_gaussian/common/error.h"
#include "topo_gaussian/ros/motion_tracker_node.h"
#include "topo_gaussian/vision/synthetic_video.h"

namespace {

namespace vis = topo_gaussian::vision;

vis::PendulumScene scene() {
  vis::PendulumScene s;
  s.period_s = 1.1;
  s.amplitude_deg = 14.0;
  s.equilibrium_deg = 3.0;
  s.duration_s = 5.0;
  s.noise_sigma = 4.0;
  return s;
}

bool callExtract(const std::string& file, topo_gaussian::ExtractMotion& srv) {
  ros::ServiceClient c =
      ros::NodeHandle().serviceClient<topo_gaussian::ExtractMotion>("/motion_tracker/extract_motion");
  if (!c.waitForExistence(ros::Duration(20.0))) return false;
  srv.request.video_file = file;
  return c.call(srv);
}

}  // namespace

TEST(MotionTrackerNode, ExtractMotionFromAGeneratedVideo) {
  const vis::PendulumScene s = scene();
  const std::string file = "/tmp/topo_rostest_pendulum.avi";
  vis::writeVideo(vis::renderPendulum(s), s.fps, file);
  topo_gaussian::ExtractMotion srv;
  ASSERT_TRUE(callExtract(file, srv));
  ASSERT_TRUE(srv.response.success) << srv.response.message;
  const auto& f = srv.response.features;
  EXPECT_TRUE(f.oscillation_found);
  EXPECT_NEAR(f.period_s, s.period_s, 0.005 * s.period_s);
  EXPECT_NEAR(f.amplitude_deg, s.amplitude_deg, 1.0);
  EXPECT_NEAR(f.equilibrium_deg, s.equilibrium_deg, 1.0);
  EXPECT_GT(f.period_confidence, 0.5);
  EXPECT_EQ(f.source, file);
  // A missing file: success false with the path in the message, and the node keeps serving.
  topo_gaussian::ExtractMotion bad;
  ASSERT_TRUE(callExtract("/tmp/no_such_video.mp4", bad));
  EXPECT_FALSE(bad.response.success);
  EXPECT_NE(bad.response.message.find("/tmp/no_such_video.mp4"), std::string::npos) << bad.response.message;
}

// A red texture (bricks flickering between frames, no object): the node refuses with the reason,
// publishes the refusal (confidence 0) and keeps serving.
TEST(MotionTrackerNode, RefusesATextureAndSaysWhy) {
  std::vector<cv::Mat> frames;
  cv::RNG rng(3);
  for (int i = 0; i < 60; ++i) {
    cv::Mat f(240, 320, CV_8UC3, cv::Scalar(180, 180, 180));
    for (int y = 0; y < 240; y += 20)
      for (int x = (y / 20) % 2 * 20; x < 320; x += 40)
        if (rng.uniform(0.0, 1.0) < 0.6) cv::rectangle(f, cv::Rect(x, y, 17, 17), cv::Scalar(30, 30, 200), cv::FILLED);
    frames.push_back(f);
  }
  const std::string file = "/tmp/topo_rostest_texture.avi";
  vis::writeVideo(frames, 30.0, file);
  topo_gaussian::ExtractMotion srv;
  ASSERT_TRUE(callExtract(file, srv));
  EXPECT_FALSE(srv.response.success);
  EXPECT_NE(srv.response.message.find("refused"), std::string::npos) << srv.response.message;
  EXPECT_NE(srv.response.message.find("not one object"), std::string::npos) << srv.response.message;
  EXPECT_FALSE(srv.response.features.oscillation_found);
  EXPECT_EQ(srv.response.features.period_confidence, 0.0);
  EXPECT_EQ(srv.response.features.amplitude_confidence, 0.0);
  // still serving
  topo_gaussian::ExtractMotion good;
  const vis::PendulumScene s = scene();
  const std::string ok = "/tmp/topo_rostest_pendulum2.avi";
  vis::writeVideo(vis::renderPendulum(s), s.fps, ok);
  ASSERT_TRUE(callExtract(ok, good));
  EXPECT_TRUE(good.response.success) << good.response.message;
}

/// The latest features once they use at least `frames` frames (the callback fills `last` and `got`
/// under `mu`), or empty features (frames_used 0) after 30 s.
topo_gaussian::MotionFeatures waitForFeatures(std::mutex& mu, const bool& got,
                                              const topo_gaussian::MotionFeatures& last, int frames) {
  const ros::Time deadline = ros::Time::now() + ros::Duration(30.0);
  while (ros::Time::now() < deadline) {
    {
      std::lock_guard<std::mutex> l(mu);
      if (got && last.frames_used >= frames) return last;
    }
    ros::Duration(0.1).sleep();
  }
  return topo_gaussian::MotionFeatures();
}

TEST(MotionTrackerNode, ImageStreamGivesTheSamePeriod) {
  ros::NodeHandle nh;
  ros::Publisher pub = nh.advertise<sensor_msgs::Image>("/image", 300);
  ros::Publisher info_pub = nh.advertise<sensor_msgs::CameraInfo>("/camera_info", 1, true);
  sensor_msgs::CameraInfo info;
  info.width = 640;
  info.height = 480;
  info.K = {500, 0, 320, 0, 500, 240, 0, 0, 1};
  info_pub.publish(info);
  std::mutex mu;
  topo_gaussian::MotionFeatures last;
  bool got = false;
  std::string stale;  // the "stale: ..." message once the stream stops
  ros::Subscriber sub = nh.subscribe<topo_gaussian::MotionFeatures>(
      "/motion_features", 10, [&](const topo_gaussian::MotionFeaturesConstPtr& m) {
        std::lock_guard<std::mutex> l(mu);
        if (m->message.rfind("stale:", 0) == 0) {
          stale = m->message;
          return;
        }
        if (m->source == "/image") {
          last = *m;
          got = true;
        }
      });
  for (int i = 0; i < 100 && pub.getNumSubscribers() == 0; ++i) ros::Duration(0.05).sleep();
  ASSERT_GT(pub.getNumSubscribers(), 0u);
  // A 32FC1 image first: refused (logged), the node must stay alive.
  cv_bridge::CvImage depth(std_msgs::Header(), sensor_msgs::image_encodings::TYPE_32FC1,
                           cv::Mat(48, 64, CV_32FC1, 1.0f));
  depth.header.stamp = ros::Time(100.0);
  pub.publish(depth.toImageMsg());
  const vis::PendulumScene s = scene();
  const std::vector<cv::Mat> frames = vis::renderPendulum(s);
  for (std::size_t k = 0; k < frames.size(); ++k) {
    cv_bridge::CvImage img(std_msgs::Header(), "bgr8", frames[k]);
    img.header.stamp = ros::Time(200.0 + k / s.fps);
    img.header.frame_id = "camera";
    pub.publish(img.toImageMsg());
    ros::Duration(0.012).sleep();
  }
  // Wait for features covering (almost) the whole stream.
  const topo_gaussian::MotionFeatures f = waitForFeatures(mu, got, last, static_cast<int>(0.9 * frames.size()));
  ASSERT_GE(f.frames_used, static_cast<int>(0.9 * frames.size())) << "no complete features on /motion_features";
  EXPECT_TRUE(f.oscillation_found) << f.message;
  EXPECT_NEAR(f.period_s, s.period_s, 0.01 * s.period_s) << f.message;
  EXPECT_NEAR(f.amplitude_deg, s.amplitude_deg, 1.0);
  EXPECT_EQ(f.header.frame_id, "camera");
  EXPECT_FALSE(f.time_s.empty());
  // ~plane with camera_info: the marker's trajectory also as points on z = 2 m.
  ASSERT_EQ(f.trajectories.size(), 1u);
  ASSERT_EQ(f.trajectories[0].points_on_plane.size(), f.trajectories[0].x_px.size());
  for (std::size_t k = 0; k < f.trajectories[0].x_px.size(); k += 17) {
    const auto& p = f.trajectories[0].points_on_plane[k];
    EXPECT_NEAR(p.z, 2.0, 1e-9);
    EXPECT_NEAR(p.x, (f.trajectories[0].x_px[k] - 320) / 500 * 2.0, 1e-6);
  }
  // Still serving after the bad image.
  topo_gaussian::ExtractMotion srv;
  EXPECT_TRUE(callExtract("/tmp/no_such_video.mp4", srv));
  // The camera stopped: after ~stale_after_s (2 s in the .test) the tracker says so.
  const ros::Time stale_deadline = ros::Time::now() + ros::Duration(10.0);
  std::string why;
  while (ros::Time::now() < stale_deadline && why.empty()) {
    {
      std::lock_guard<std::mutex> l(mu);
      why = stale;
    }
    ros::Duration(0.1).sleep();
  }
  EXPECT_NE(why.find("no image on /image for"), std::string::npos) << "no stale-camera report: '" << why << "'";
}

// A camera that never sends (the tracker in /dead listens to /dead/image, which nobody publishes):
// after ~stale_after_s the tracker says so, once on motion_features (latched) with the fix.
TEST(MotionTrackerNode, ACameraThatNeverSendsIsReported) {
  const auto m =
      ros::topic::waitForMessage<topo_gaussian::MotionFeatures>("/dead/motion_features", ros::Duration(30.0));
  ASSERT_TRUE(m) << "no report from the tracker whose camera never sent";
  EXPECT_EQ(m->message.rfind("stale: no image on /dead/image since the start", 0), 0u) << m->message;
  EXPECT_NE(m->message.find("remapped"), std::string::npos) << m->message;
  EXPECT_EQ(m->bending_confidence, 0.0);
  EXPECT_EQ(m->period_confidence, 0.0);
}

// Three frames stamped 1e6 s in the future, then a normal 30 Hz stream: the stream used to be dropped
// frame by frame forever ("not after the previous frame's"); now the jump restarts the window and
// the stream's features arrive.
TEST(MotionTrackerNode, FutureStampsDoNotStallTheStream) {
  ros::NodeHandle nh;
  ros::Publisher pub = nh.advertise<sensor_msgs::Image>("/image", 300);
  std::mutex mu;
  topo_gaussian::MotionFeatures last;
  bool got = false;
  const ros::Time start = ros::Time::now();
  ros::Subscriber sub = nh.subscribe<topo_gaussian::MotionFeatures>(
      "/motion_features", 10, [&](const topo_gaussian::MotionFeaturesConstPtr& m) {
        std::lock_guard<std::mutex> l(mu);
        if (m->source == "/image" && m->header.stamp > start && m->message.rfind("stale:", 0) != 0) {
          last = *m;
          got = true;
        }
      });
  for (int i = 0; i < 100 && pub.getNumSubscribers() == 0; ++i) ros::Duration(0.05).sleep();
  ASSERT_GT(pub.getNumSubscribers(), 0u);
  const vis::PendulumScene s = scene();
  const std::vector<cv::Mat> frames = vis::renderPendulum(s);
  for (int k = 0; k < 3; ++k) {
    cv_bridge::CvImage img(std_msgs::Header(), "bgr8", frames[std::size_t(k)]);
    img.header.stamp = ros::Time(1e6 + 400.0 + k / s.fps);
    img.header.frame_id = "camera";
    pub.publish(img.toImageMsg());
    ros::Duration(0.012).sleep();
  }
  for (std::size_t k = 0; k < frames.size(); ++k) {
    cv_bridge::CvImage img(std_msgs::Header(), "bgr8", frames[k]);
    img.header.stamp = ros::Time(400.0 + k / s.fps);
    img.header.frame_id = "camera";
    pub.publish(img.toImageMsg());
    ros::Duration(0.012).sleep();
  }
  const topo_gaussian::MotionFeatures f = waitForFeatures(mu, got, last, static_cast<int>(0.9 * frames.size()));
  ASSERT_GE(f.frames_used, static_cast<int>(0.9 * frames.size()))
      << "the 30 Hz stream after three future frames gave no features (frames dropped?); last: " << last.message;
  EXPECT_TRUE(f.oscillation_found) << f.message;
  EXPECT_NEAR(f.period_s, s.period_s, 0.01 * s.period_s) << f.message;
}

// The tilt tracker in /persp measures in a plane through its camera: camera_info missing, then zero,
// then an image frame without tf, then a tf that is older than the images are each named in the log
// (topic or frames, and the fix), and the node keeps tracking (in image angles) and publishing.
TEST(MotionTrackerNode, MissingCameraInfoAndTfAreNamed) {
  ros::NodeHandle nh;
  std::mutex mu;
  std::vector<std::string> log;
  int features = 0;
  ros::Subscriber rosout = nh.subscribe<rosgraph_msgs::Log>("/rosout", 100, [&](const rosgraph_msgs::LogConstPtr& m) {
    std::lock_guard<std::mutex> l(mu);
    if (m->name == "/persp/motion_tracker") log.push_back(m->msg);
  });
  ros::Subscriber sub = nh.subscribe<topo_gaussian::MotionFeatures>(
      "/persp/motion_features", 10, [&](const topo_gaussian::MotionFeaturesConstPtr& m) {
        std::lock_guard<std::mutex> l(mu);
        if (m->frames_used > 0) ++features;
      });
  tf2_ros::TransformBroadcaster tf;  // created first: its /tf connection is up when it sends
  ros::Publisher pub = nh.advertise<sensor_msgs::Image>("/persp/image", 50);
  ros::Publisher info_pub = nh.advertise<sensor_msgs::CameraInfo>("/persp/camera_info", 1, true);
  for (int i = 0; i < 100 && pub.getNumSubscribers() == 0; ++i) ros::Duration(0.05).sleep();
  ASSERT_GT(pub.getNumSubscribers(), 0u);
  const std::vector<cv::Mat> frames = vis::renderPendulum(scene());
  double stamp = 300.0;
  auto send = [&](const std::string& frame, int n) {
    for (int k = 0; k < n; ++k) {
      cv_bridge::CvImage img(std_msgs::Header(), "bgr8", frames[std::size_t(k) % frames.size()]);
      img.header.stamp = ros::Time(stamp += 1.0 / 30);
      img.header.frame_id = frame;
      pub.publish(img.toImageMsg());
      ros::Duration(0.02).sleep();
    }
  };
  auto logged = [&](const std::vector<std::string>& parts) {
    const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(10.0);
    while (ros::WallTime::now() < deadline) {
      {
        std::lock_guard<std::mutex> l(mu);
        for (const std::string& m : log) {
          bool all = true;
          for (const std::string& p : parts) all = all && m.find(p) != std::string::npos;
          if (all) return m;
        }
      }
      ros::WallDuration(0.1).sleep();
    }
    return std::string();
  };
  send("cam_a", 10);  // no camera_info yet
  EXPECT_FALSE(logged({"/persp/camera_info", "has sent no usable camera_info", "remap camera_info"}).empty());
  sensor_msgs::CameraInfo info;
  info.width = 640;
  info.height = 480;
  info_pub.publish(info);  // K all zero
  ros::Duration(0.3).sleep();
  send("cam_a", 5);
  EXPECT_FALSE(logged({"/persp/camera_info", "has no usable intrinsics", "calibrate"}).empty());
  info.K = {500, 0, 320, 0, 500, 240, 0, 0, 1};
  info_pub.publish(info);
  ros::Duration(0.3).sleep();
  send("cam_a", 10);  // no tf world <- cam_a at all
  EXPECT_FALSE(logged({"tf world <- 'cam_a'", "failed or is stale", "~camera_pose"}).empty());
  // a moving camera whose tf stopped 5 s before the images: stale
  geometry_msgs::TransformStamped T;
  T.header.frame_id = "world";
  T.child_frame_id = "cam_b";
  T.transform.rotation.w = 1.0;
  for (int k = 0; k < 5; ++k) {
    T.header.stamp = ros::Time(stamp - 5.0 + 0.1 * k);
    tf.sendTransform(T);
  }
  ros::Duration(0.3).sleep();
  send("cam_b", 10);
  const std::string stale = logged({"tf world <- 'cam_b'", "failed or is stale", "extrapolation"});
  EXPECT_FALSE(stale.empty());
  // a static camera pose: from then on the pose comes from tf, and the node said so
  tf2_ros::StaticTransformBroadcaster static_tf;
  T.child_frame_id = "cam_c";
  T.transform.translation.x = -1.0;
  T.transform.rotation.x = -0.5, T.transform.rotation.y = 0.5, T.transform.rotation.z = -0.5;
  T.transform.rotation.w = 0.5;
  static_tf.sendTransform(T);
  ros::Duration(0.5).sleep();
  send("cam_c", 10);
  EXPECT_FALSE(logged({"the camera pose comes from tf world <- cam_c"}).empty());
  // still serving: features of the frames tracked meanwhile
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(10.0);
  int got = 0;
  while (ros::WallTime::now() < deadline && got == 0) {
    {
      std::lock_guard<std::mutex> l(mu);
      got = features;
    }
    ros::WallDuration(0.1).sleep();
  }
  EXPECT_GT(got, 0) << "no motion_features from /persp after the bad camera input";
}

// ParamReader through a real parameter server: absent → defaults, a good value, a wrong type and
// a value out of range (the latter two name the parameter as "~name (/resolved/name)").
TEST(MotionTrackerParams, TypedAndChecked) {
  ros::NodeHandle scratch("/motion_tracker_param_check");
  scratch.deleteParam("");
  const topo_gaussian::topo_ros::MotionTrackerParams d = topo_gaussian::topo_ros::loadMotionTrackerParams(scratch);
  EXPECT_EQ(d.window_s, 20.0);
  EXPECT_EQ(d.options.video.stride, 1);
  EXPECT_EQ(d.options.tracker.method, "marker");
  scratch.setParam("window_s", 7);  // an int where a number is expected
  scratch.setParam("stride", 2);
  const topo_gaussian::topo_ros::MotionTrackerParams g = topo_gaussian::topo_ros::loadMotionTrackerParams(scratch);
  EXPECT_EQ(g.window_s, 7.0);
  EXPECT_EQ(g.options.video.stride, 2);
  auto errorWith = [&](const std::string& name, const auto& value) {
    scratch.deleteParam("");
    scratch.setParam(name, value);
    std::string what = "(no error)";
    try {
      topo_gaussian::topo_ros::loadMotionTrackerParams(scratch);
    } catch (const topo_gaussian::TopoError& e) {
      what = e.what();
    }
    scratch.deleteParam(name);
    return what;
  };
  std::string e = errorWith("window_s", std::string("long"));
  EXPECT_NE(e.find("~window_s (/motion_tracker_param_check/window_s)"), std::string::npos) << e;
  EXPECT_NE(e.find("a string (\"long\"), not a number [s]"), std::string::npos) << e;
  e = errorWith("stride", 1.5);
  EXPECT_NE(e.find("~stride"), std::string::npos) << e;
  EXPECT_NE(e.find("not a whole number"), std::string::npos) << e;
  e = errorWith("publish_period_s", -1.0);
  EXPECT_NE(e.find("outside (0, inf) s"), std::string::npos) << e;
  e = errorWith("roi", std::string("left half"));
  EXPECT_NE(e.find("~roi"), std::string::npos) << e;
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "motion_tracker_test");
  ros::AsyncSpinner spinner(1);
  spinner.start();
  return RUN_ALL_TESTS();
}
