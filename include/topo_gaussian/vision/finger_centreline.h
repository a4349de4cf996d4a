// Centreline of a finger silhouette: the curve c(s), s ∈ [0, L] from one end of the blob to the other,
// that bisects every cut across the finger perpendicular to it, c(s) = midpoint of the cut along the
// normal n(s) at c(s), extended at both ends straight along its end tangent to the outline (the end
// face of a finger cut by a clamp or the frame, the extremity of a rounded tip). The outline is the
// 0.5 level of a field blurred by mask_blur_px: each pixel's colour between the background's and the
// finger's where the frame is given (sub-pixel), else the mask. A finger wider than 48 px is worked on
// shrunk to that width (the precision is relative to the width; the work falls with its square).
//  1. the two ends: the pixel farthest from any pixel along the blob (chamfer geodesic distance), and
//     the one farthest from that; a coarse centreline: the centroids of the blob's pixels in bands of
//     geodesic distance from the first end, ordered by it (robust to any bend or curl);
//  2. `iterations` times: the centreline resampled every step_px, its tangent over about a
//     half-width, a cut along the normal through every sample, the cut's midpoint (its two 0.5
//     crossings interpolated linearly); cuts that do not cross both sides (the outline's normal more
//     than 15° from the cut both at its own scale and blurred to a third of the half-width, which
//     smooths ribs out: an end face, a round tip's cap) or narrower than half the median width are
//     left out; a moving average over ±smooth_px along the arc (it moves a curve of radius R inwards
//     by smooth_px²/(6R): 0.02 px at R = 150 px); each end extended along the tangent of a parabola
//     fitted over its last 1.5 widths, robustly (bumps at a corner left out and trimmed off; a chord's
//     tangent would lag by κ·width/2);
//  3. equalArcStations: K + 1 points at equal arc length s_k = k L / K along it.
// Pixels in the full frame (mask offset added). An end whose extension reaches the region's border is
// flagged: the finger runs on beyond it (cut by the frame or the ROI).
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace topo_gaussian::vision {

struct CentrelineOptions {
  double step_px = 1.0;       ///< spacing of the centreline's samples along the arc
  double mask_blur_px = 1.0;  ///< σ of the Gaussian that turns the binary mask into a sub-pixel edge field
  double smooth_px = 4.0;     ///< half-window of the moving average along the arc
  int iterations = 3;         ///< cut-and-bisect refinements of the coarse centreline
};

struct FingerCentreline {
  bool ok = false;
  std::string problem;              ///< why there is none (ok false): for a person
  std::vector<cv::Point2d> points;  ///< from one end to the other, step_px apart (full-frame pixels)
  double length_px = 0.0;           ///< arc length L
  double width_px = 0.0;            ///< median width of the perpendicular cuts
  bool start_at_border = false;     ///< the first end lies on the region's border (the finger runs on)
  bool end_at_border = false;       ///< the last end lies on the region's border
};

/// The centreline of the one blob in `mask` (CV_8U, non-zero = finger; `offset` = the mask's top-left
/// corner in the frame). `bgr` (optional, CV_8UC3, the frame under the mask, the mask's size) gives the
/// outline to sub-pixel precision: the 0.5 level of each pixel's colour between the background's and
/// the finger's mean (an anti-aliased edge's colour is its covered fraction's mix); without it, the
/// mask's own outline, quantised to a pixel along edges that run with the pixel grid. Not ok when the
/// blob is smaller than 50 pixels, shorter than twice its width, or no cut across it bisects it.
FingerCentreline fingerCentreline(const cv::Mat& mask, const cv::Point& offset,
                                  const CentrelineOptions& options = CentrelineOptions(),
                                  const cv::Mat& bgr = cv::Mat());

/// The K + 1 points at equal arc length s_k = k L / K, k = 0..K, along the polyline from its first
/// point (station 0) to its last (station K). Empty for fewer than 2 points or K < 1.
std::vector<cv::Point2d> equalArcStations(const std::vector<cv::Point2d>& polyline, int segments);

}  // namespace topo_gaussian::vision
