// Bend profile of a finger: θ_k = dir(S_k − S_{k−1}) − φ_rest, k = 1..K [deg], the direction of the
// chord between consecutive stations S_0..S_K at equal arc length s_k = k L / K along the finger's
// centreline (vision/finger_centreline.h; S_0 at the base end of the visible finger, where it leaves
// the clamp, S_K at the tip), minus the rest axis φ_rest: the median, over the rest frames (the finger
// tracker's straightest frames, vision/motion_tracker.h), of the direction of the line fitted to the
// centreline's base third (s ≤ L/3). Image angles, atan2(dy, dx), + clockwise on screen (image y down),
// as the tracker's bending angle; θ_1 is wrapped into (−180, 180] and each next one continues from the
// one before (a finger curling past 180° keeps counting). A finger bent with uniform curvature κ over
// its length L has θ_k = κ L (k − ½) / K.
// Over a clip: the profile of every frame, and at the held bend (the frames the bending angle is taken
// from) the median of each θ_k over them, with the profile's own confidence factor (0..1):
//   (held frames with a centreline / held frames) · (1 − spread/5°)₊ · 1/(1 + (jitter/3°)²)
// (spread: the largest mean |θ_k − median| over the held frames; jitter: the largest median
// frame-to-frame change of a θ_k), and 0 — not measured, with a note — when the held frames' tip lies
// on the region's border in most of them (the finger leaves the frame or the ROI), their centreline is
// more than 5 % shorter than at rest (the tip is hidden or cut, or the finger bends out of the image
// plane: a camera sees it shortened), their base end moved by more than max(3 px, 3 % of L) from rest
// (the base end is not the clamp's edge: something covers it, or the camera moved), or a segment would
// be shorter than 3 px.
#pragma once

#include <cstddef>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace topo_gaussian::vision {

/// One frame's centreline, base first.
struct ProfileFrame {
  bool ok = false;                      ///< a centreline was found
  std::vector<cv::Point2d> centreline;  ///< from the base end to the tip, full-frame pixels
  double length_px = 0.0;               ///< its arc length L
  bool base_at_border = false;          ///< the base end lies on the region's border (a clamp out of view)
  bool tip_at_border = false;           ///< the tip end lies on the region's border
};

/// θ_k, k = 1..K, of the stations S_0..S_K against the rest direction (image angle, degrees).
std::vector<double> chordAnglesDeg(const std::vector<cv::Point2d>& stations, double rest_dir_deg);

struct BendProfile {
  int segments = 0;                             ///< K
  std::vector<std::vector<double>> frames_deg;  ///< θ_k of every frame given (empty: no centreline)
  std::vector<double> held_deg;                 ///< θ_k at the held bend; empty: not measured
  double rest_axis_deg = 0.0;                   ///< φ_rest, image angle [deg]
  double confidence_factor = 0.0;               ///< the profile's own factor (above), 0..1
  int held_frames_used = 0;                     ///< held frames with a centreline
  double spread_deg = 0.0, jitter_deg = 0.0;
  double rest_length_px = 0.0, held_length_px = 0.0;  ///< median centreline length at rest and held
  double base_shift_px = 0.0;                         ///< base station at the held bend minus at rest
  std::vector<std::string> notes;                     ///< what limited it, for the tracker's message
};

/// The direction [deg, image angle] of the line fitted (least squares, perpendicular distances) to the
/// centreline's points with arc length s ≤ L/3 from its first point, pointing along the centreline.
double baseThirdDirectionDeg(const std::vector<cv::Point2d>& centreline);

/// The profile of `frames` (one per bend sample), with `rest` and `held` indices into them (the
/// tracker's straightest frames and the bending angle's held frames). Without a centreline in any rest
/// frame, φ_rest is `fallback_rest_dir_deg` (the tracker's rest axis) and the confidence is halved.
BendProfile analyseBendProfile(const std::vector<ProfileFrame>& frames, const std::vector<std::size_t>& rest,
                               const std::vector<std::size_t>& held, double fallback_rest_dir_deg, int segments);

}  // namespace topo_gaussian::vision
