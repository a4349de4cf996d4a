// MotionTrackerNode: the ROS face of the vision stage (video or camera → MotionFeatures).
//   in : topic `image` (sensor_msgs/Image: mono8, bgr8, rgb8, bgra8, rgba8, bayer_* are converted;
//        other encodings are refused with a throttled error and the node keeps running),
//        through image_transport (~image_transport: raw, or a plugin that is installed),
//        topic `camera_info` (intrinsics + distortion: the tilt in ~plane, the trajectory rays),
//        tf ~world_frame <- the image's frame_id at each image's stamp (the camera pose; ~camera_pose
//        only when that lookup fails, said in the log), parameter ~video_file (tracked once at
//        start), service ~extract_motion (ExtractMotion.srv: a file + options → features)
//        topic `tilt_reference` (std_msgs/String "[EXPERIMENT=]DEG", as a ~tilt_reference_deg entry: sets
//        it for that experiment from then on, e.g. what infer_client sends before a rig performs a hang)
//   out: topic `motion_features` (MotionFeatures, latched), topic ~debug_image (the tracker overlay)
// A camera that stops for ~stale_after_s, or never sends in that long after the start, is logged
// (throttled) and reported once as a features message whose `message` starts "stale:" (nothing
// measured), which the inference quotes when it refuses a goal for want of a measurement.
// The node owns handles and parameters; vision::MotionTracker / vision::trackVideo do the work.
#pragma once

#include <image_transport/image_transport.h>
#include <ros/ros.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <std_msgs/String.h>

#include <map>
#include <memory>
#include <string>

#include "topo_gaussian/ExtractMotion.h"
#include "topo_gaussian/MotionFeatures.h"
#include "topo_gaussian/vision/motion_tracker.h"

namespace topo_gaussian::topo_ros {

struct MotionTrackerParams {
  std::string video_file;  ///< ~video_file: tracked once at start when set
  /// ~experiment: the experiment the windows belong to (MotionFeatures.experiment), until a message on
  /// `experiment` (std_msgs/String) names another; "" = untagged.
  std::string experiment;
  vision::TrackOptions
      options;             ///< ~method, ~kind, ~foreground, ~roi [x,y,w,h], ~start_s, ~end_s, ~stride, ~pivot [x,y]
  double window_s = 20.0;  ///< ~window_s: live stream analysed over windows this long [s]
  double publish_period_s = 1.0;  ///< ~publish_period_s: live features published this often [s]
  /// ~max_stamp_jump_s: a frame stamped this much before or after the previous one restarts the
  /// window (StampWindow) [s]
  double max_stamp_jump_s = 10.0;
  /// ~stale_after_s: no image for this long → the camera is reported stale (log + a features
  /// message saying so); 0 = never
  double stale_after_s = 5.0;
  /// ~plane [nx, ny, nz, d] in ~world_frame: the plane the object's axis moves in (kind tilt: the
  /// tilt is measured in it through the camera, vision::tiltInPlaneDeg) and trajectories are placed on
  bool plane_given = false;
  cv::Vec4d plane;
  /// ~camera_pose [x, y, z, qx, qy, qz, qw]: optical frame in ~world_frame; the fallback when tf has none
  bool camera_pose_given = false;
  cv::Matx33d camera_R = cv::Matx33d::eye();
  cv::Vec3d camera_t = cv::Vec3d(0, 0, 0);
  std::string world_frame = "world";  ///< ~world_frame: the frame of ~plane, its +z up (against gravity)
  double tf_timeout_s = 0.1;          ///< ~tf_timeout_s: how long a camera pose lookup waits for tf [s]
  std::string image_transport = "raw";  ///< ~image_transport: raw, or an installed plugin (compressed, theora)
  /// ~tilt_reference_deg: a list of "[NAME=]DEG" (or one string of them separated by ';'): the tilt
  /// each experiment's object starts near (TrackOptions::tilt_reference_deg); an entry without NAME
  /// is every other experiment's (in options).
  std::map<std::string, double> tilt_reference_deg;
  /// The options of a window of `experiment`: options with its tilt reference.
  vision::TrackOptions optionsFor(const std::string& experiment) const;
};

/// "[EXPERIMENT=]DEG" (a ~tilt_reference_deg entry or a `tilt_reference` message) as (name, degrees);
/// throws TopoError starting with `what` when it is not that or DEG is outside −180..180.
std::pair<std::string, double> parseTiltReference(const std::string& entry, const std::string& what);

/// The live stream's time line: which frame stamps go into the current analysis window. A camera
/// whose clock jumps (a driver restart, a bag replayed with --clock, three frames stamped 1e6 s
/// ahead) must not stall the tracker: a jump of more than max_jump_s, back or forward, restarts the
/// window at the new frame with a warning that names the jump; a small step back (reordered frames)
/// skips the frame; a window older than window_s restarts silently.
class StampWindow {
 public:
  enum class Action {
    Start,    ///< first frame (or first after reset()): a new window starts here
    Add,      ///< next frame of the current window, at relative time t_s
    Skip,     ///< not after the previous frame, within max_jump_s: dropped
    Restart,  ///< a new window starts here (the window is full, or the stamp jumped)
  };
  struct Decision {
    Action action = Action::Start;
    double t_s = 0.0;     ///< the frame's time in the window [s] (0 for Start/Restart)
    std::string warning;  ///< non-empty for a jump or a skipped frame: what happened, in ASCII
  };
  StampWindow(double window_s, double max_jump_s) : window_s_(window_s), max_jump_s_(max_jump_s) {}
  /// Decides where the frame stamped `stamp_s` goes, and moves the window accordingly.
  Decision next(double stamp_s);
  /// Forget the window (after a tracker error or a stale camera): the next frame starts one.
  void reset() { started_ = false; }

 private:
  double window_s_, max_jump_s_;
  bool started_ = false;
  double start_s_ = 0.0, last_s_ = 0.0;
};

/// Reads and validates the private parameters; throws TopoError naming the parameter and the fix.
MotionTrackerParams loadMotionTrackerParams(const ::ros::NodeHandle& pnh);

/// BGR copy of an Image message. Throws TopoError naming the topic and the encoding, with the fix,
/// for encodings that are not images of light (e.g. 16UC1 depth, 32FC1).
cv::Mat imageToBgr(const sensor_msgs::Image& msg, const std::string& topic);

class MotionTrackerNode {
 public:
  MotionTrackerNode(const ::ros::NodeHandle& nh, const ::ros::NodeHandle& pnh);

 private:
  void onImage(const sensor_msgs::ImageConstPtr& msg);
  void onCameraInfo(const sensor_msgs::CameraInfoConstPtr& msg);
  void onTimer(const ::ros::TimerEvent&);
  bool onExtractMotion(topo_gaussian::ExtractMotion::Request& req, topo_gaussian::ExtractMotion::Response& res);
  void trackStartupFile();
  void publish(const vision::TrackResult& result, const std::string& frame_id);

  ::ros::NodeHandle nh_, pnh_;
  MotionTrackerParams params_;
  ::ros::Publisher features_pub_, debug_pub_;
  image_transport::ImageTransport it_;
  image_transport::Subscriber image_sub_;
  ::ros::Subscriber info_sub_;
  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_listener_;
  /// The camera's view of ~plane for the image `msg`: tf (or ~camera_pose) and camera_info; null with a
  /// throttled message naming what is missing when either is (the tilt then stays in image angles).
  std::unique_ptr<vision::PlaneView> viewFor(const sensor_msgs::Image& msg);
  /// Logs `text` at `level` when `what` differs from the last problem logged under `key`, else at most
  /// every 10 s (a tf failure for another frame is not hidden by the throttle of the first).
  void reportProblem(const std::string& key, const std::string& what, ::ros::console::levels::Level level,
                     const std::string& text);
  std::map<std::string, std::pair<::ros::WallTime, std::string>> reported_;
  std::string pose_source_;     ///< where the last camera pose came from (logged when it changes)
  bool live_missing_view_ = false;  ///< ~plane is set and a frame of the live window had no camera model
  bool tf_failing_ = false;     ///< the last lookup failed: the next ones wait only once a second
  ::ros::WallTime tf_waited_;   ///< when a lookup last waited
  cv::Matx33d last_R_ = cv::Matx33d::eye();  ///< the last camera pose found (trajectory rays)
  cv::Vec3d last_t_ = cv::Vec3d(0, 0, 0);
  ::ros::ServiceServer service_;
  ::ros::Timer timer_;
  std::unique_ptr<vision::MotionTracker> live_;
  StampWindow window_;
  ::ros::WallTime last_image_wall_;  ///< for the stale-camera check
  bool stale_reported_ = false;
  ::ros::WallTime started_wall_;  ///< for the never-sending-camera check
  bool never_reported_ = false;
  void finishLive();
  std::string live_frame_id_;
  std::string experiment_;       ///< the current experiment (~experiment, then the `experiment` topic)
  std::string live_experiment_;  ///< the experiment of the live window
  ::ros::Subscriber experiment_sub_;
  void onExperiment(const std_msgs::StringConstPtr& msg);
  ::ros::Subscriber tilt_reference_sub_;
  void onTiltReference(const std_msgs::StringConstPtr& msg);
  bool live_dirty_ = false;
  sensor_msgs::CameraInfo camera_info_;
};

}  // namespace topo_gaussian::topo_ros
