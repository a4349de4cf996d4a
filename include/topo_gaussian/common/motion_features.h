// MotionFeatures: what a camera saw an object do (paper §7), the observed side of an inference.
// The tracker (vision) produces it, `topo track --json` writes it and `topo infer --features` reads it
// (io/motion_features_json.h), motion_tracker publishes it as topo_gaussian/MotionFeatures (a plain
// conversion, ros/conversions.h), and the inference turns it into a task's targets
// (inference/motion_targets.h: each task declares which features it takes). Angles in degrees,
// times in seconds, pixels in the image (x right, y down). A feature that was not measured has
// confidence 0. Header-only, standard library only, so vision and inference share it without
// depending on each other.
#pragma once

#include <array>
#include <map>
#include <string>
#include <vector>

// Namespace motion: the ROS messages of the same names are topo_gaussian::MotionFeatures and
// topo_gaussian::PixelTrajectory.
namespace topo_gaussian::motion {

/// One tracked point over time in pixels; points_on_plane (world frame [m]) when a camera model and
/// a plane were given, else empty.
struct PixelTrajectory {
  std::string name;
  std::vector<double> time_s, x_px, y_px;
  std::vector<std::array<double, 3>> points_on_plane;
};

struct MotionFeatures {
  std::string kind;     ///< pendulum | tilt | trajectory | finger
  std::string method;   ///< marker | silhouette | klt
  std::string source;   ///< video file or image topic
  std::string message;  ///< what limited the measurement
  /// The experiment of a multi-experiment inference this window belongs to ("rock_y"); empty: the
  /// only (or the first) experiment.
  std::string experiment;
  /// Side data in force over the window (`topo track --tag-topic`): the topic's name without its
  /// leading '/' → the median of its samples in the window, e.g. "pressure_pa" → 3.3e5; empty: none.
  std::map<std::string, double> side_data;

  bool oscillation_found = false;
  double period_s = 0.0;
  double amplitude_deg = 0.0;  ///< mean half peak-to-peak
  double max_tilt_deg = 0.0;
  double equilibrium_deg = 0.0;  ///< oscillation centre, or the static pose
  double log_decrement = 0.0;    ///< damping per cycle
  double damping_ratio = 0.0;
  double bending_angle_deg = 0.0;  ///< finger: tip direction minus base direction, final value
  /// finger: the bend profile at the full pressure, θ_k [deg] for k = 1..profile_segments: the chord
  /// between consecutive stations at equal arc length along the centreline from the base end (the
  /// clamp's edge) to the tip, minus the rest axis, signed as bending_angle_deg (vision/finger_profile.h);
  /// empty: not measured
  std::vector<double> bend_profile_deg;
  int profile_segments = 0;  ///< finger: K, the number of segments the profile was asked for (0: not a finger)

  double period_confidence = 0.0;  ///< 0..1
  double amplitude_confidence = 0.0;
  double equilibrium_confidence = 0.0;
  double bending_confidence = 0.0;
  double bend_profile_confidence = 0.0;

  double start_time_s = 0.0, end_time_s = 0.0;  ///< time range used
  int first_frame = 0, last_frame = -1, frames_used = 0, frames_lost = 0;

  std::vector<double> time_s, angle_deg;  ///< the sampled signal (angle or bending angle)
  std::vector<PixelTrajectory> trajectories;

  bool empty() const { return kind.empty(); }
};

}  // namespace topo_gaussian::motion
