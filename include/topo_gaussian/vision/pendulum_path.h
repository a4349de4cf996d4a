// The pendulum's pivot and angle from the tracked path (paper §7, the hanging/pendulum experiments):
//   angle θ_i = atan2(g_y·d_x − g_x·d_y, g·d),  d = c_i − pivot,  g = the image direction of gravity,
// so θ = 0 hangs along gravity and θ > 0 is towards image-right for g = (0, 1); unwrapped in time.
// The pivot is given, or the centre of a Kåsa least-squares circle through the path. The path must
// behave like a pendulum's, or the analysis refuses with the reason:
//  - it swings across gravity: the path's principal direction within 45° of horizontal (a path along
//    gravity is a bounce or a vertical oscillation);
//  - it is an arc: circle-fit rms ≤ max(3 px, 10 % of the path's spread);
//  - it hangs: the pivot lies against gravity from the path (above it), and the path spans < 170°
//    about it (a pivot inside the path makes the angle jump by ±180°).
// A nearly straight path (circle radius > 30 path extents) has no measurable pivot: the period is
// still measured from the displacement along the path, but angles are not (amplitude_known false).
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace topo_gaussian::vision {

struct PendulumPath {
  bool valid = false;   ///< the path is a pendulum's (else `problem` says why)
  std::string problem;  ///< for a person, with the fix
  std::string note;     ///< a limitation that did not refuse (e.g. no measurable pivot)
  cv::Point2d pivot;    ///< pixels
  bool pivot_estimated = false;
  bool angles_known = false;  ///< the signal is an angle in degrees (else a displacement in px)
  double radius_px = 0.0, fit_rms_px = 0.0;
  /// relative standard error of the fitted radius (circle fits to 4 groups of 10-frame blocks); the
  /// angles' relative uncertainty. 0 for a given pivot.
  double radius_rel_uncertainty = 0.0;
  /// 0..1: (1 − rms/limit) / (1 + (radius_rel_uncertainty / 8 %)²) — 0.5 where the angles are uncertain
  /// by about the 10 % the README states for amplitudes; 1 for a given pivot
  double pivot_confidence = 0.0;
  std::vector<double> signal;  ///< unwrapped angle [deg] (angles_known) or displacement along the path [px]
};

/// `pts`: the object's centroid per found frame; `gravity`: image direction (need not be unit);
/// `pivot_given`: the user's pivot or nullptr.
PendulumPath analysePendulumPath(const std::vector<cv::Point2d>& pts, const cv::Vec2d& gravity,
                                 const cv::Point2d* pivot_given);

/// RMS distance of the points from their mean [px] (0 for none): how far a path spreads.
double pointSpreadPx(const std::vector<cv::Point2d>& pts);

/// Kåsa algebraic circle fit; returns false when the points do not define a circle.
bool fitCircleKasa(const std::vector<cv::Point2d>& pts, cv::Point2d& centre, double& radius, double& rms);

}  // namespace topo_gaussian::vision
