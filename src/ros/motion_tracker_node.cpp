#include "topo_gaussian/ros/motion_tracker_node.h"

#include <cv_bridge/cv_bridge.h>
#include <image_transport/exception.h>
#include <sensor_msgs/image_encodings.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/number_text.h"
#include "topo_gaussian/ros/ascii_text.h"
#include "topo_gaussian/ros/motion_features_msg.h"
#include "topo_gaussian/ros/param_reader.h"
#include "topo_gaussian/ros/service_guard.h"
#include "topo_gaussian/vision/camera_model.h"
#include "topo_gaussian/vision/motion_features.h"

namespace topo_gaussian::topo_ros {
namespace {
/// Rotation matrix of a quaternion that is not zero (normalised here).
cv::Matx33d rotationOf(double qx, double qy, double qz, double qw) {
  const double n = std::sqrt(qx * qx + qy * qy + qz * qz + qw * qw);
  const double x = qx / n, y = qy / n, z = qz / n, w = qw / n;
  return cv::Matx33d(1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w), 2 * (x * y + z * w),
                     1 - 2 * (x * x + z * z), 2 * (y * z - x * w), 2 * (x * z - y * w), 2 * (y * z + x * w),
                     1 - 2 * (x * x + y * y));
}
}  // namespace

StampWindow::Decision StampWindow::next(double stamp_s) {
  Decision d;
  if (!started_) {
    started_ = true;
    start_s_ = last_s_ = stamp_s;
    d.action = Action::Start;
    return d;
  }
  const double step = stamp_s - last_s_;
  char text[256];
  if (std::abs(step) > max_jump_s_ || !std::isfinite(step)) {
    std::snprintf(text, sizeof text,
                  "the stamp jumped %s by %.3f s (from %.3f s to %.3f s; more than ~max_stamp_jump_s %.3g s): the "
                  "analysis window restarts at this frame; check the camera's clock",
                  step < 0 ? "back" : "forward", std::abs(step), last_s_, stamp_s, max_jump_s_);
    d.warning = text;
    d.action = Action::Restart;
    start_s_ = last_s_ = stamp_s;
    return d;
  }
  if (step <= 0) {
    std::snprintf(text, sizeof text, "stamp %.3f s is not after the previous frame's (%.3f s); frame skipped", stamp_s,
                  last_s_);
    d.warning = text;
    d.action = Action::Skip;
    return d;
  }
  last_s_ = stamp_s;
  if (stamp_s - start_s_ > window_s_) {
    start_s_ = stamp_s;
    d.action = Action::Restart;
    return d;
  }
  d.action = Action::Add;
  d.t_s = stamp_s - start_s_;
  return d;
}

vision::TrackOptions MotionTrackerParams::optionsFor(const std::string& name) const {
  vision::TrackOptions o = options;
  const auto it = tilt_reference_deg.find(name);
  if (it != tilt_reference_deg.end()) o.tilt_reference_deg = it->second;
  return o;
}

std::pair<std::string, double> parseTiltReference(const std::string& entry, const std::string& what) {
  const auto eq = entry.find('=');
  const std::string name = eq == std::string::npos ? "" : entry.substr(0, eq), v = entry.substr(eq + 1);
  char* end = nullptr;
  const double deg = std::strtod(v.c_str(), &end);
  if (v.empty() || *end != '\0' || !(std::abs(deg) <= 180.0) || (eq != std::string::npos && name.empty()))
    throw TopoError(what, "is not [EXPERIMENT=]DEG with DEG in -180..180 (the tilt the object starts near)",
                    "e.g. 'hang=50' for an experiment 'hang' whose object rests ~50 deg over, or '0'");
  return {name, deg};
}

MotionTrackerParams loadMotionTrackerParams(const ::ros::NodeHandle& pnh) {
  const ParamReader r(pnh, "motion_tracker");
  MotionTrackerParams p;
  p.video_file = r.text("video_file", "");
  p.experiment = r.text("experiment", "");
  p.options.tracker.method = r.text("method", "marker");
  p.options.kind = r.text("kind", "pendulum");
  p.options.tracker.foreground = r.text("foreground", p.options.tracker.foreground);
  p.options.tracker.polarity = r.text("polarity", p.options.tracker.polarity);
  p.options.rotate_deg = int(r.integer("rotate_deg", 0, "deg", Range::between(0, 270)));
  p.options.tip_fraction = r.number("tip_fraction", p.options.tip_fraction, "unitless");
  p.options.profile_segments =
      int(r.integer("profile_segments", p.options.profile_segments, "", Range::between(2, 64)));
  const std::vector<double> gravity = r.numbers("gravity", {}, 2, "", "[0, 1] (image-down)");
  if (!gravity.empty()) p.options.gravity = cv::Vec2d(gravity[0], gravity[1]);
  const std::vector<double> hsv_lower = r.numbers("hsv_lower", {}, 3, "", "[35, 45, 150] (OpenCV H 0..180, S, V)");
  const std::vector<double> hsv_upper = r.numbers("hsv_upper", {}, 3, "", "[65, 255, 255]");
  if (hsv_lower.empty() != hsv_upper.empty())
    throw TopoError(r.displayName("hsv_lower") + "/hsv_upper", "must be given together",
                    "set both, e.g. _hsv_lower:=[35,45,150] _hsv_upper:=[65,255,255], or neither (red)");
  if (!hsv_lower.empty())
    p.options.tracker.hsv = {vision::HsvRange{cv::Scalar(hsv_lower[0], hsv_lower[1], hsv_lower[2]),
                                              cv::Scalar(hsv_upper[0], hsv_upper[1], hsv_upper[2])}};
  p.options.tracker.min_area_px = r.number("min_area_px", p.options.tracker.min_area_px, "px", Range::atLeast(0.0));
  const std::vector<double> roi = r.numbers("roi", {}, 4, "px", "[100, 50, 300, 300]");
  if (!roi.empty()) {
    for (double v : roi)
      if (v != std::floor(v))
        throw TopoError(r.displayName("roi"), "must be whole pixels [x, y, width, height]",
                        "e.g. _roi:=[100,50,300,300]");
    if (roi[2] <= 0 || roi[3] <= 0)
      throw TopoError(r.displayName("roi"), "must be [x, y, width, height] with a positive size",
                      "e.g. _roi:=[100,50,300,300], or leave it unset for the whole frame");
    p.options.tracker.roi = cv::Rect(int(roi[0]), int(roi[1]), int(roi[2]), int(roi[3]));
    p.options.tracker.roi_given = true;
  }
  p.options.video.start_s = r.number("start_s", 0.0, "s", Range::atLeast(0.0));
  p.options.video.end_s = r.number("end_s", -1.0, "s");
  p.options.video.stride = int(r.integer("stride", 1, "", Range::between(1, 1e6)));
  const std::vector<double> pivot = r.numbers("pivot", {}, 2, "px", "[320, 60]");
  if (!pivot.empty()) {
    p.options.pivot_given = true;
    p.options.pivot = cv::Point2d(pivot[0], pivot[1]);
  }
  const std::vector<double> plane = r.numbers("plane", {}, 4, "", "[0, 0, 1, 0] for the floor");
  if (!plane.empty()) {
    if (std::sqrt(plane[0] * plane[0] + plane[1] * plane[1] + plane[2] * plane[2]) == 0)
      throw TopoError(r.displayName("plane"),
                      "must be [nx, ny, nz, d] with a non-zero normal (plane n.x = d, world frame)",
                      "e.g. [0, 0, 1, 0] for the floor");
    p.plane_given = true;
    p.plane = cv::Vec4d(plane[0], plane[1], plane[2], plane[3]);
  }
  const std::vector<double> pose =
      r.numbers("camera_pose", {}, 7, "", "[0, 0, 0, 0, 0, 0, 1] (x, y, z, qx, qy, qz, qw)");
  if (!pose.empty()) {
    const double n = std::sqrt(pose[3] * pose[3] + pose[4] * pose[4] + pose[5] * pose[5] + pose[6] * pose[6]);
    if (!(n > 0)) throw TopoError(r.displayName("camera_pose"), "quaternion is zero", "e.g. [0, 0, 0, 0, 0, 0, 1]");
    p.camera_R = rotationOf(pose[3], pose[4], pose[5], pose[6]);
    p.camera_t = cv::Vec3d(pose[0], pose[1], pose[2]);
    p.camera_pose_given = true;
  }
  p.world_frame = r.text("world_frame", p.world_frame);
  if (p.world_frame.empty())
    throw TopoError(r.displayName("world_frame"), "is empty", "name the frame of ~plane, e.g. world");
  p.tf_timeout_s = r.number("tf_timeout_s", p.tf_timeout_s, "s", Range::between(0.0, 60.0));
  p.image_transport = r.text("image_transport", p.image_transport);
  p.window_s = r.number("window_s", 20.0, "s", Range::above(0.0));
  p.publish_period_s = r.number("publish_period_s", 1.0, "s", Range::above(0.0));
  p.max_stamp_jump_s = r.number("max_stamp_jump_s", p.max_stamp_jump_s, "s", Range::above(0.0));
  p.stale_after_s = r.number("stale_after_s", 5.0, "s", Range::atLeast(0.0));  // 0: never report a stale camera
  for (const std::string& e : r.texts("tilt_reference_deg", {}, "['hang=50', '0']", "; \t")) {
    const auto [name, deg] = parseTiltReference(e, r.displayName("tilt_reference_deg") + " entry '" + e + "'");
    if (name.empty())
      p.options.tilt_reference_deg = deg;
    else
      p.tilt_reference_deg[name] = deg;
  }
  vision::MotionTracker check(p.options);  // validates kind and method (throws TopoError)
  return p;
}

cv::Mat imageToBgr(const sensor_msgs::Image& msg, const std::string& topic) {
  namespace enc = sensor_msgs::image_encodings;
  const std::string& e = msg.encoding;
  const bool ok = e == enc::MONO8 || e == enc::BGR8 || e == enc::RGB8 || e == enc::BGRA8 || e == enc::RGBA8 ||
                  e == enc::MONO16 || e.rfind("bayer_", 0) == 0;
  if (!ok)
    throw TopoError(topic, "has encoding '" + e + "', which is not a camera image the tracker can use",
                    "publish mono8, bgr8, rgb8, bgra8, rgba8 or bayer_* (e.g. the driver's image_raw or image_color)");
  try {
    return cv_bridge::toCvCopy(msg, enc::BGR8)->image;
  } catch (const cv_bridge::Exception& ex) {
    throw TopoError(topic, std::string("cannot convert encoding '") + e + "' to bgr8: " + ex.what(),
                    "check the camera driver's encoding and image size");
  }
}

MotionTrackerNode::MotionTrackerNode(const ::ros::NodeHandle& nh, const ::ros::NodeHandle& pnh)
    : nh_(nh),
      pnh_(pnh),
      params_(loadMotionTrackerParams(pnh)),
      window_(params_.window_s, std::min(params_.max_stamp_jump_s, params_.window_s)),
      it_(nh_),
      tf_listener_(tf_buffer_) {
  features_pub_ = nh_.advertise<topo_gaussian::MotionFeatures>("motion_features", 1, true);
  debug_pub_ = pnh_.advertise<sensor_msgs::Image>("debug_image", 2);
  last_R_ = params_.camera_R;
  last_t_ = params_.camera_t;
  try {
    image_sub_ = it_.subscribe("image", 5, &MotionTrackerNode::onImage, this,
                               image_transport::TransportHints(params_.image_transport, ::ros::TransportHints(), pnh_));
  } catch (const image_transport::TransportLoadException& e) {
    std::string installed;
    for (const std::string& t : it_.getLoadableTransports()) installed += (installed.empty() ? "" : ", ") + t;
    ROS_ERROR("motion_tracker: %s; listening raw instead",
              TopoError(pnh_.resolveName("image_transport") + " '" + params_.image_transport + "'",
                        std::string("is not an installed image_transport plugin (") + e.what() + ")",
                        "use one of the installed (" + installed +
                            "), install its plugin, or republish: rosrun image_transport republish " +
                            params_.image_transport + " in:=IMAGE raw out:=image")
                  .what());
    image_sub_ = it_.subscribe("image", 5, &MotionTrackerNode::onImage, this, image_transport::TransportHints("raw"));
  }
  info_sub_ = nh_.subscribe("camera_info", 1, &MotionTrackerNode::onCameraInfo, this);
  experiment_ = live_experiment_ = params_.experiment;
  experiment_sub_ = nh_.subscribe("experiment", 1, &MotionTrackerNode::onExperiment, this);
  tilt_reference_sub_ = nh_.subscribe("tilt_reference", 10, &MotionTrackerNode::onTiltReference, this);
  service_ = pnh_.advertiseService("extract_motion", &MotionTrackerNode::onExtractMotion, this);
  started_wall_ = ::ros::WallTime::now();
  timer_ = nh_.createTimer(::ros::Duration(params_.publish_period_s), &MotionTrackerNode::onTimer, this);
  ROS_INFO("motion_tracker: method %s, kind %s; listening on %s (%s), service %s",
           params_.options.tracker.method.c_str(), params_.options.kind.c_str(), image_sub_.getTopic().c_str(),
           image_sub_.getTransport().c_str(), service_.getService().c_str());
  if (!params_.video_file.empty()) trackStartupFile();
}

void MotionTrackerNode::publish(const vision::TrackResult& result_in, const std::string& frame_id) {
  vision::TrackResult result = result_in;
  if (params_.plane_given) {
    if (camera_info_.K[0] > 0) {
      const auto& K = camera_info_.K;
      const vision::CameraModel cam(cv::Matx33d(K[0], K[1], K[2], K[3], K[4], K[5], K[6], K[7], K[8]),
                                    std::vector<double>(camera_info_.D.begin(), camera_info_.D.end()), last_R_,
                                    last_t_);
      vision::placeOnPlane(cam, cv::Vec3d(params_.plane[0], params_.plane[1], params_.plane[2]), params_.plane[3],
                           result);
    } else {
      ROS_WARN_THROTTLE(10.0,
                        "motion_tracker: ~plane is set but no camera_info has arrived: trajectories stay in pixels");
    }
  }
  topo_gaussian::MotionFeatures m = toMotionFeaturesMsg(vision::toMotionFeatures(result));
  m.experiment = live_experiment_;
  m.header.stamp = ::ros::Time::now();
  m.header.frame_id = frame_id;
  features_pub_.publish(m);
}

void MotionTrackerNode::trackStartupFile() {
  try {
    const vision::TrackResult r =
        vision::trackVideo(params_.video_file, params_.optionsFor(params_.experiment), [&](const cv::Mat& overlay) {
          if (debug_pub_.getNumSubscribers() == 0) return;
          cv_bridge::CvImage img(std_msgs::Header(), "bgr8", overlay);
          debug_pub_.publish(img.toImageMsg());
        });
    publish(r, "camera");
    ROS_INFO("motion_tracker: %s: %s", params_.video_file.c_str(), asciiText(r.message).c_str());
  } catch (const std::exception& e) {
    ROS_ERROR("motion_tracker: ~video_file: %s", asciiText(e.what()).c_str());
  }
}

void MotionTrackerNode::onExperiment(const std_msgs::StringConstPtr& msg) {
  if (msg->data == experiment_) return;
  // The window so far belongs to the previous experiment: publish it with its tag, then start anew.
  finishLive();
  ROS_INFO("motion_tracker: experiment '%s' -> '%s': a new window starts", experiment_.c_str(), msg->data.c_str());
  experiment_ = live_experiment_ = msg->data;
  live_.reset();
  window_.reset();
  live_dirty_ = false;
}

void MotionTrackerNode::onTiltReference(const std_msgs::StringConstPtr& msg) {
  try {
    const auto [name, deg] = parseTiltReference(msg->data, tilt_reference_sub_.getTopic() + " '" + msg->data + "'");
    if (name.empty())
      params_.options.tilt_reference_deg = deg;
    else
      params_.tilt_reference_deg[name] = deg;
    ROS_INFO("motion_tracker: tilt reference of %s: %s deg", name.empty() ? "every other experiment" : name.c_str(),
             numberText(deg).c_str());
    if (name == live_experiment_ || name.empty()) live_.reset();  // the live window starts again with it
  } catch (const std::exception& e) {
    ROS_ERROR("motion_tracker: %s: ignored", asciiText(e.what()).c_str());
  }
}

void MotionTrackerNode::reportProblem(const std::string& key, const std::string& what,
                                      ::ros::console::levels::Level level, const std::string& text) {
  const ::ros::WallTime now = ::ros::WallTime::now();
  auto& [when, last] = reported_[key];
  if (last == what && !when.isZero() && (now - when).toSec() < 10.0) return;
  when = now;
  last = what;
  if (level == ::ros::console::levels::Error)
    ROS_ERROR("motion_tracker: %s", asciiText(text).c_str());
  else
    ROS_WARN("motion_tracker: %s", asciiText(text).c_str());
}

void MotionTrackerNode::onCameraInfo(const sensor_msgs::CameraInfoConstPtr& msg) {
  const auto& K = msg->K;
  const bool usable = K[0] > 0 && K[4] > 0 && K[8] > 0 && std::isfinite(K[2]) && std::isfinite(K[5]) &&
                      (msg->D.empty() || msg->D.size() == 4 || msg->D.size() == 5 || msg->D.size() == 8);
  if (!usable) {
    reportProblem("camera_info", "unusable", ::ros::console::levels::Error,
                  TopoError(info_sub_.getTopic(),
                            "has no usable intrinsics (fx " + numberText(K[0]) + ", fy " + numberText(K[4]) + ", " +
                                std::to_string(msg->D.size()) + " distortion coefficients)",
                            "calibrate the camera (camera_calibration) and let the driver publish its camera_info; "
                            "until then the tilt stays in image angles (the last good camera_info is kept)")
                      .what());
    return;
  }
  camera_info_ = *msg;
}

std::unique_ptr<vision::PlaneView> MotionTrackerNode::viewFor(const sensor_msgs::Image& msg) {
  if (!params_.plane_given) return nullptr;
  if (!(camera_info_.K[0] > 0)) {
    reportProblem("camera_info", "none", ::ros::console::levels::Warn,
                  TopoError(info_sub_.getTopic(),
                            "has sent no usable camera_info (" + std::to_string(info_sub_.getNumPublishers()) +
                                " publishers)",
                            "remap camera_info to the driver's CameraInfo topic; until then the tilt stays in image "
                            "angles")
                      .what());
    return nullptr;
  }
  std::string source;
  cv::Matx33d R;
  cv::Vec3d t;
  try {
    if (msg.header.frame_id.empty())
      throw tf2::TransformException("the image has no header.frame_id (the camera's optical frame)");
    // while it fails, wait for tf at most once a second, so the images queued meanwhile are not dropped
    const ::ros::WallTime now = ::ros::WallTime::now();
    const bool wait = !tf_failing_ || (now - tf_waited_).toSec() > 1.0;
    if (wait) tf_waited_ = now;
    const geometry_msgs::TransformStamped T = tf_buffer_.lookupTransform(
        params_.world_frame, msg.header.frame_id, msg.header.stamp, ::ros::Duration(wait ? params_.tf_timeout_s : 0.0));
    const auto& q = T.transform.rotation;
    R = rotationOf(q.x, q.y, q.z, q.w);
    t = cv::Vec3d(T.transform.translation.x, T.transform.translation.y, T.transform.translation.z);
    source = "tf " + params_.world_frame + " <- " + msg.header.frame_id;
    tf_failing_ = false;
  } catch (const tf2::TransformException& e) {
    tf_failing_ = true;
    const std::string what = "tf " + params_.world_frame + " <- '" + msg.header.frame_id + "' at the image's stamp " +
                             fixedText(msg.header.stamp.toSec(), 3) + " s";
    if (!params_.camera_pose_given) {
      reportProblem("tf", msg.header.frame_id, ::ros::console::levels::Error,
                    TopoError(what, std::string("failed or is stale (") + e.what() + ")",
                              "publish the camera pose on tf (the driver's, or a static_transform_publisher) or set "
                              "~camera_pose; until then the tilt stays in image angles and the points on ~plane use the last pose "
                              "found (at first ~camera_pose, or the world origin)")
                        .what());
      return nullptr;
    }
    reportProblem("tf", msg.header.frame_id, ::ros::console::levels::Warn,
                  what + " failed or is stale (" + e.what() + "): the camera pose is ~camera_pose");
    R = params_.camera_R;
    t = params_.camera_t;
    source = "~camera_pose";
  }
  if (source != pose_source_) {
    ROS_INFO("motion_tracker: the camera pose comes from %s", source.c_str());
    pose_source_ = source;
  }
  last_R_ = R;
  last_t_ = t;
  const auto& K = camera_info_.K;
  auto view = std::make_unique<vision::PlaneView>();
  view->camera = vision::CameraModel(cv::Matx33d(K[0], K[1], K[2], K[3], K[4], K[5], K[6], K[7], K[8]),
                                     std::vector<double>(camera_info_.D.begin(), camera_info_.D.end()), R, t);
  view->plane = params_.plane;
  return view;
}

void MotionTrackerNode::onImage(const sensor_msgs::ImageConstPtr& msg) {
  cv::Mat bgr;
  try {
    bgr = imageToBgr(*msg, image_sub_.getTopic());
  } catch (const std::exception& e) {
    ROS_ERROR_THROTTLE(5.0, "motion_tracker: %s", asciiText(e.what()).c_str());
    return;
  }
  const double t = msg->header.stamp.isZero() ? ::ros::Time::now().toSec() : msg->header.stamp.toSec();
  last_image_wall_ = ::ros::WallTime::now();
  if (stale_reported_) {
    ROS_INFO("motion_tracker: %s publishes again", image_sub_.getTopic().c_str());
    stale_reported_ = false;
  }
  // the camera model (tf + camera_info) of this frame; the first one after frames without restarts the
  // window, so a window is measured in the plane from the moment it can be (a driver's first
  // camera_info comes just after its first image)
  const std::unique_ptr<vision::PlaneView> view = viewFor(*msg);
  if (view && live_missing_view_) {
    live_.reset();
    window_.reset();
  }
  const StampWindow::Decision d = window_.next(t);
  if (d.action == StampWindow::Action::Skip) {
    ROS_WARN_THROTTLE(5.0, "motion_tracker: %s: %s", image_sub_.getTopic().c_str(), d.warning.c_str());
    return;
  }
  if (!d.warning.empty())  // a jump: its own throttle, so skipped frames do not hide it
    ROS_WARN_THROTTLE(5.0, "motion_tracker: %s: %s", image_sub_.getTopic().c_str(), d.warning.c_str());
  try {
    if (!live_ || d.action != StampWindow::Action::Add) {
      live_ = std::make_unique<vision::MotionTracker>(params_.optionsFor(live_experiment_));
      live_missing_view_ = false;
    }
    live_->addFrame(bgr, d.t_s, view.get());
    live_missing_view_ = live_missing_view_ || (params_.plane_given && !view);
    live_frame_id_ = msg->header.frame_id;
    live_dirty_ = true;
    if (debug_pub_.getNumSubscribers() > 0) {
      cv_bridge::CvImage img(msg->header, "bgr8", live_->overlay());
      debug_pub_.publish(img.toImageMsg());
    }
  } catch (const std::exception& e) {
    ROS_ERROR_THROTTLE(5.0, "motion_tracker: %s: %s", image_sub_.getTopic().c_str(), asciiText(e.what()).c_str());
    live_.reset();
    window_.reset();
  }
}

void MotionTrackerNode::finishLive() {
  if (!live_ || !live_dirty_) return;
  live_dirty_ = false;
  try {
    vision::TrackResult r = live_->finish();
    r.source = image_sub_.getTopic();
    if (r.refused)  // published all the same (confidence 0, the reason in `message`), and logged
      ROS_WARN_THROTTLE(10.0, "motion_tracker: %s: %s", r.source.c_str(), asciiText(r.message).c_str());
    publish(r, live_frame_id_);
  } catch (const std::exception& e) {
    ROS_ERROR_THROTTLE(5.0, "motion_tracker: %s", asciiText(e.what()).c_str());
  }
}

void MotionTrackerNode::onTimer(const ::ros::TimerEvent&) {
  // A camera that never sent: say so (log every ~stale_after_s × 6, and once a features message whose
  // message the inference quotes when it refuses a goal for want of a measurement).
  if (params_.stale_after_s > 0 && last_image_wall_.isZero() && params_.video_file.empty()) {
    const double waited = (::ros::WallTime::now() - started_wall_).toSec();
    if (waited > params_.stale_after_s) {
      const std::string text = "stale: no image on " + image_sub_.getTopic() + " since the start (" +
                               fixedText(waited, 0) + " s, " + std::to_string(image_sub_.getNumPublishers()) +
                               " publishers): is the camera driver running, and is `image` remapped to its topic?";
      ROS_WARN_THROTTLE(6.0 * params_.stale_after_s, "motion_tracker: %s", text.c_str());
      if (!never_reported_) {
        never_reported_ = true;
        topo_gaussian::MotionFeatures m;
        m.header.stamp = ::ros::Time::now();
        m.source = image_sub_.getTopic();
        m.kind = params_.options.kind;
        m.method = params_.options.tracker.method;
        m.message = text;
        features_pub_.publish(m);
      }
    }
  }
  // A camera that stopped: say so once (log and a features message), keep the last features latched.
  if (params_.stale_after_s > 0 && !last_image_wall_.isZero() && !stale_reported_) {
    const double silent = (::ros::WallTime::now() - last_image_wall_).toSec();
    if (silent > params_.stale_after_s) {
      stale_reported_ = true;
      ROS_WARN(
          "motion_tracker: no image on %s for %.1f s (~stale_after_s %.1f): the camera stopped; the latest "
          "motion_features are stale",
          image_sub_.getTopic().c_str(), silent, params_.stale_after_s);
      topo_gaussian::MotionFeatures m;
      m.header.stamp = ::ros::Time::now();
      m.header.frame_id = live_frame_id_;
      m.source = image_sub_.getTopic();
      m.kind = params_.options.kind;
      m.method = params_.options.tracker.method;
      m.message = "stale: no image on " + image_sub_.getTopic() + " for " + std::to_string(silent) +
                  " s; check the camera driver";
      features_pub_.publish(m);
      live_.reset();
      window_.reset();
      live_dirty_ = false;
    }
  }
  finishLive();
}

bool MotionTrackerNode::onExtractMotion(topo_gaussian::ExtractMotion::Request& req,
                                        topo_gaussian::ExtractMotion::Response& res) {
  return guardService("motion_tracker", service_.getService(), res, [&] {
    vision::TrackOptions o = params_.options;
    if (!req.method.empty()) o.tracker.method = req.method;
    if (!req.kind.empty()) o.kind = req.kind;
    if (!req.roi.empty()) {
      if (req.roi.size() != 4)
        throw TopoError("extract_motion roi", "must be [x, y, width, height]", "or leave it empty for the whole frame");
      o.tracker.roi = cv::Rect(req.roi[0], req.roi[1], req.roi[2], req.roi[3]);
      o.tracker.roi_given = true;
    }
    if (req.start_s > 0) o.video.start_s = req.start_s;
    if (req.end_s > 0) o.video.end_s = req.end_s;
    if (req.stride > 1) o.video.stride = req.stride;
    const vision::TrackResult r = vision::trackVideo(req.video_file, o);
    res.features = toMotionFeaturesMsg(vision::toMotionFeatures(r));
    res.features.header.stamp = ::ros::Time::now();
    // a refusal (not one object, not a pendulum's path, ...) is published too, with confidence 0,
    // so the inference sees why; the service says it failed
    res.success = !r.refused;
    res.message = r.message;
    if (r.refused) ROS_WARN("motion_tracker: %s: %s", req.video_file.c_str(), asciiText(r.message).c_str());
    publish(r, "camera");
  });
}

}  // namespace topo_gaussian::topo_ros
