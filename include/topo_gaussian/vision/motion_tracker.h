// The tracking pipeline (paper §7): frames → tracker (marker / silhouette / klt) → per-frame
// measurements → an angle signal or point trajectories → features (analyseSignal / analyseStatic):
//  - kind "pendulum":   angle of the marker/centroid about a pivot (given, or a Kåsa least-squares
//                       circle fit to the trajectory), from gravity, unwrapped (vision/pendulum_path.h):
//                       0 = hanging along gravity, + towards image-right for gravity image-down,
//                       degrees; a path that is not a hanging arc is refused;
//  - kind "tilt":       silhouette principal axis from image vertical (tumbler / standing object):
//                       of the two principal axes, the one nearest image vertical in the first frame,
//                       then followed continuously frame to frame (an object wider than tall, like
//                       the default tumbler, is followed by its upright minor axis); + towards
//                       image-right, degrees;
//  - kind "trajectory": point trajectories in pixels; bounces between free-flight arcs, apexes, the
//                       floor line and restitution (vision/bounce_analysis.h), heights along −gravity;
//  - kind "finger":     the finger task's bending angle (finger_task.cpp), seen from the side:
//                       direction of the chord from the centroid of the segment before the tip to the
//                       tip segment's (each tip_fraction of the silhouette's principal-axis extent)
//                       minus the rest axis (image angles, atan2(dy, dx), + clockwise on screen). The
//                       rest axis is the base line (fitted to the medial band of the base third) in the
//                       straightest frames (smallest tip-third minus base-third line angle): the base
//                       is clamped and the camera fixed, while a bent finger's base third turns with
//                       its free part. The base is the end that moves least; signed, with its maximum
//                       |bend| and when it happened. On a rendered side view of the simulated finger
//                       (test/unit/vision_finger_bend.cpp) it is the task's angle within 0.3 deg.
//                       Also the bend profile (vision/finger_profile.h): the chord angles of
//                       profile_segments equal arc-length segments of the silhouette's centreline
//                       (vision/finger_centreline.h) from the base end to the tip, against the line
//                       of its base third in the same straightest frames, per frame and at the held
//                       bend.
// Before any feature, what was tracked must behave like one rigid object (vision/object_checks.h);
// otherwise the result is a refusal (refused = true, every feature confidence 0, the reason in
// `message`). Every confidence = tracking share × object score × the feature's own fit confidence.
// Orientation: frames are rotated clockwise by `rotate_deg` first (ROI and pivot are in the rotated
// frame); `gravity` is the image direction of gravity in the (rotated) frame, default image-down.
// Use trackVideo() for a file, or MotionTracker (addFrame / overlay / finish) for live frames.
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "topo_gaussian/vision/bounce_analysis.h"
#include "topo_gaussian/vision/camera_model.h"
#include "topo_gaussian/vision/colour_survey.h"
#include "topo_gaussian/vision/object_checks.h"
#include "topo_gaussian/vision/pendulum_path.h"
#include "topo_gaussian/vision/signal_analysis.h"
#include "topo_gaussian/vision/trackers.h"
#include "topo_gaussian/vision/video_source.h"

namespace topo_gaussian::vision {

struct TrackOptions {
  std::string kind = "pendulum";  ///< pendulum | tilt | trajectory | finger
  TrackerOptions tracker;         ///< method (marker | silhouette | klt), ROI, HSV ranges, ...
  VideoOptions video;             ///< start/end time, stride, image-sequence fps
  bool pivot_given = false;
  cv::Point2d pivot;  ///< pendulum pivot in pixels (pivot_given)
  SignalOptions signal;
  double fps = 0.0;                  ///< nominal frame rate for MotionTracker (0: from the timestamps)
  double lost_warn_fraction = 0.05;  ///< more lost frames than this → the message says where
  double min_prominence_px = 0.0;    ///< trajectory: extremum prominence (0 = max(3 px, 5 % of the y range))
  int rotate_deg = 0;                ///< 0 | 90 | 180 | 270: rotate every frame clockwise first
  cv::Vec2d gravity{0.0, 1.0};       ///< image direction of gravity in the (rotated) frame
  /// finger: the tip segment and the one before it are each this fraction of the silhouette's
  /// length (the finger task's tip_fraction, whose bend the tracker measures)
  double tip_fraction = 0.15;
  /// finger: K, the number of equal arc-length segments of the bend profile (the finger task's
  /// profile_segments), 2..64
  int profile_segments = 8;
  /// tilt: the silhouette's principal axes are a line pair, known modulo 90°: the first frame takes
  /// the one nearest this tilt [deg from image-up, clockwise positive], later frames follow by
  /// continuity. 0 (upright) for a doll rocking on the ground; about the tilt it hangs at for an
  /// object hung off its axis. An object resting more than 30° from it is reported ambiguous
  /// (TrackResult::tilt_axis_ambiguous): its absolute angles get confidence 0.
  double tilt_reference_deg = 0.0;
  ObjectCheckOptions checks;
};

/// Throws TopoError naming the option for an unknown kind/method/foreground/polarity, a rotation other
/// than 0/90/180/270, a zero gravity vector, a bad HSV range, a pivot that is not finite, or a kind
/// the method cannot serve.
void validateTrackOptions(const TrackOptions& options);

struct TrajectorySample {
  double t, x, y;
};

struct TrackResult {
  std::string source, method, kind;
  double fps = 0.0;
  int frames_total = 0;                  ///< frames in the source (container's count)
  int frames_used = 0;                   ///< frames given to the tracker
  int first_frame = 0, last_frame = -1;  ///< source frame indices of the range used
  double t_start_s = 0.0, t_end_s = 0.0;
  bool object_found = false;
  ObjectCheck object;    ///< is it one rigid object (vision/object_checks.h)
  bool refused = false;  ///< no feature is given: `message` says why (confidence 0)
  int rotate_deg = 0;    ///< rotation applied to the frames (the option plus the container's)
  cv::Vec2d gravity{0.0, 1.0};
  int lost_frames = 0;
  int dropped_frames = 0;            ///< frames missing according to timestamp gaps > 1.5 / fps
  bool variable_frame_rate = false;  ///< the frame steps vary (analyseFrameSteps): none counts as dropped
  std::vector<double> t, angle_deg;  ///< the angle (pendulum/tilt) or bend (finger) signal; trajectory: image y
  std::vector<std::vector<TrajectorySample>> trajectories;  ///< per tracked point (marker: 1)
  // pendulum
  cv::Point2d pivot;
  bool pivot_estimated = false;
  double pivot_fit_rms_px = 0.0;
  double pivot_radius_rel_uncertainty = 0.0;  ///< relative standard error of the pendulum length (angles scale with it)
  bool angles_known = true;  ///< false: the path is too straight for a pivot, angle_deg holds px along it
  // pendulum / tilt
  /// tilt: the object rests more than 30° from TrackOptions::tilt_reference_deg, so it may rest on the
  /// other principal axis (90° away): the absolute angles have confidence 0, `message` says both readings
  bool tilt_axis_ambiguous = false;
  /// tilt: the angles are in the motion plane through the camera (MotionTracker::addFrame with a
  /// PlaneView), not image angles
  bool perspective = false;
  SignalFeatures signal;
  StaticPose static_pose;
  // finger
  double bend_final_deg = 0.0;
  double bend_max_deg = 0.0;  ///< the signed bend of largest magnitude
  double bend_t_max_s = 0.0;  ///< when it happened
  /// the bend at the full pressure: median of the frames within max(0.2 deg, 10 %) of the maximum
  /// |bend| (the held plateau of a pressure step or the top of a ramp); the finger's feature
  double bend_held_deg = 0.0;
  int bend_held_frames = 0;
  double bend_rest_axis_deg = 0.0;    ///< image direction of the rest axis (the straightest frames' base line)
  double bend_straightest_deg = 0.0;  ///< tip-minus-base line angle of the straightest frame (0: a straight finger)
  /// The bend profile (vision/finger_profile.h): θ_k [deg], k = 1..profile_segments, chords between
  /// equal arc-length stations from the base end to the tip minus the rest axis, signed as the bend.
  int profile_segments = 0;
  std::vector<double> bend_profile_deg;  ///< at the held bend (median of the held frames); empty: not measured
  std::vector<std::vector<double>> bend_profile_series_deg;  ///< per sample of `t` (empty: no centreline)
  double profile_rest_axis_deg = 0.0;   ///< the profile's rest axis: its base third's line at rest (image angle)
  double profile_rest_length_px = 0.0;  ///< centreline length at rest (the straightest frames)
  double profile_held_length_px = 0.0;  ///< centreline length at the held bend
  // trajectory (y: image coordinate along gravity; heights along −gravity)
  std::vector<double> bounce_times_s, bounce_y_px, apex_times_s, apex_y_px, apex_heights_px;
  double floor_y_px = 0.0;
  BounceFeatures bounces;  ///< the full analysis: arcs, restitution, release height, end of trajectory
  /// trajectories placed on a known plane through a camera model (placeOnPlane), world frame [m];
  /// NaN where a ray misses the plane. Empty unless placeOnPlane was called.
  std::vector<std::vector<cv::Vec3d>> points_on_plane;
  std::map<std::string, double> confidence;  ///< per feature, 0..1
  std::string message;                       ///< for a person: what was found and what limited it
  /// marker tracking with the default colour, refused: which colour range or method would find what
  /// moves (vision/colour_survey.h), tried on the clip's frames; `available` false otherwise
  ColourSuggestion suggestion;
};

class MotionTracker {
 public:
  /// Throws TopoError for an unknown kind/method or a kind the method cannot serve.
  explicit MotionTracker(const TrackOptions& options);
  ~MotionTracker();
  /// Tracks one BGR frame taken at t_s (increasing). The first frame validates the ROI (TopoError).
  void addFrame(const cv::Mat& bgr, double t_s);
  /// The same with the camera's view of the plane the object's axis moves in (kind tilt, rotate_deg
  /// 0): when every frame of the window has one, the tilt is measured in that plane through the
  /// camera (tiltInPlaneDeg, perspective; up from the view, not `gravity`) and TrackResult::perspective
  /// says so; otherwise image angles, with a note. nullptr: no view for this frame.
  void addFrame(const cv::Mat& bgr, double t_s, const PlaneView* view);
  /// The last frame with the tracked points, contour, axis/pivot and angle text (empty before a frame):
  /// the live view, with the pivot as fitted so far.
  cv::Mat overlay() const;
  /// Frame `index` (0-based, in the order added; `bgr` is that frame as given to addFrame) drawn with
  /// the final result `result` = finish(): the same pivot, signed angle/bend, bounces and refusal as
  /// the JSON. Text scales with the frame.
  cv::Mat overlayWithResult(const cv::Mat& bgr, int index, const TrackResult& result) const;
  int framesAdded() const;
  /// Features of everything added so far (may be called repeatedly).
  TrackResult finish() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Whole-video entry point; `overlay_sink` (optional) receives every frame drawn with the final result
/// (overlayWithResult; a second pass over the file, after the analysis).
/// Throws TopoError for unreadable videos, bad ROIs and bad options.
TrackResult trackVideo(const std::string& path, const TrackOptions& options,
                       const std::function<void(const cv::Mat&)>& overlay_sink = nullptr);

class CameraModel;
/// Intersects every trajectory sample's pixel ray with the plane n·x = d (world frame) and stores
/// the points in result.points_on_plane, so simulated points can be compared in 3D (or, the other
/// way, projected into the same camera with CameraModel::project).
void placeOnPlane(const CameraModel& camera, const cv::Vec3d& plane_normal, double plane_d, TrackResult& result);

/// The tracker-only details as one JSON object (fps, frame counts, lost/dropped frames; pendulum/tilt:
/// cycles, static pose, pivot; trajectory: bounces, apexes, floor line; finger: the held, final and
/// largest bend, the bend profile and, with_series, the profile of every sample; every confidence).
/// The features themselves go through toMotionFeatures (vision/motion_features.h) and
/// io::motionFeaturesJson; `topo track --json` puts this object under their "tracker" key.
std::string trackerJson(const TrackResult& result, bool with_series = false);

}  // namespace topo_gaussian::vision
