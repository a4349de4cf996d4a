// The motion-features JSON document: what `topo track --json` prints and `topo infer --features FILE`
// reads (motion::MotionFeatures, common/motion_features.h). One object:
//   "format": "topo_gaussian.motion_features", "version": 1,
//   "kind" (pendulum | tilt | trajectory | finger), "method", "source", "message",
//   "side_data":  {NAME: value} (only when the window was tagged: `topo track --tag-topic`),
//   "features":   {oscillation_found, period_s, amplitude_deg, max_tilt_deg, equilibrium_deg,
//                  log_decrement, damping_ratio, bending_angle_deg, bend_profile_deg: [θ_1 .. θ_K] or null,
//                  profile_segments: K},
//   "confidence": {period_s, amplitude_deg, equilibrium_deg, bending_angle_deg, bend_profile_deg} (0..1),
//   "range":      {start_time_s, end_time_s, first_frame, last_frame, frames_used, frames_lost},
//   "series":     {time_s: [...], angle_deg: [...]}                     (with_series only),
//   "trajectories": [{name, time_s, x_px, y_px, points_on_plane: [[x, y, z], ...]}]
//                  (with_series, or kind "trajectory", or when a trajectory has points_on_plane),
// and optionally a "tracker" object (`topo track`'s tracker-only details: fps, pivot, bounces, the
// full confidence map), which the reader ignores. Units in the key names (s, deg, px; points_on_plane
// in world metres). A number that was not measured is written as null (NaN), and a feature that is
// null or absent is read as not measured: value 0 and confidence 0.
#pragma once

#include <string>

#include "topo_gaussian/common/motion_features.h"

namespace topo_gaussian::io {

/// The document above, as one line of JSON text.
std::string motionFeaturesJson(const motion::MotionFeatures& features, bool with_series);

/// Reads a document written by motionFeaturesJson (or `topo track --json > FILE`). Throws TopoError
/// naming the file, the key and the fix for an unreadable file, text that is not JSON, an unknown
/// kind, a value of the wrong type, a confidence outside 0..1, or a bend profile with another number of
/// angles than its profile_segments.
motion::MotionFeatures readMotionFeaturesJson(const std::string& path);

/// The same from JSON text; `origin` names it in errors (the file, or e.g. "motion features").
motion::MotionFeatures parseMotionFeaturesJson(const std::string& text, const std::string& origin);

}  // namespace topo_gaussian::io
