// Bounces of a dropped object from its height signal h(t) = −(p·g) [px] (g: the image direction of
// gravity), the trajectory kind of the tracker (paper §7, the bouncing-ball experiments):
//  - flight arcs: between candidate contacts (local minima of h with prominence ≥ max(3 px, 5 % of
//    the range)), a least-squares parabola h = a t² + b t + c over the samples of the arc (at least
//    min_arc_samples, the two next to each contact left out); a flight arc has a < 0, rms ≤
//    max(2 px, 2.5 % of its rise), an acceleration within a factor 2 of the median arc's (one g), and
//    (when the across-gravity coordinate is given) a straight line across gravity: rms ≤ max(2 px,
//    2.5 % of its rise) — no horizontal force in flight (a swinging bob fails this);
//  - a bounce is a contact with a flight arc on both sides; its time is where the two parabolas meet
//    (h_before(t) = h_after(t), the root nearest the sample minimum), its height that common value;
//  - apexes are the vertices of the flight arcs, kept only inside the arc's time range and inside the
//    frame; apex height = apex h − the height of the bounce the arc rose from (the floor line may drift
//    when the ball comes nearer the camera); floor_h_px is the mean bounce height;
//  - restitution at bounce k, from heights e_h = √(H_after / H_before) and from flight times
//    e_t = (rise time after) / (fall time before) (free flight: t_fall = √(2H/g));
//  - free fall has a scale: g / D = 9.81 m/s² / D is 10 … 1000 object diameters per s² for objects
//    1 cm … 1 m across (a slow-motion clip played k times slower divides it by k²); arcs whose median acceleration in
//    diameters/s² falls outside [min_g_diameters, max_g_diameters] are not flight (a swinging bob's "arcs" fall far too
//    slowly);
//  - the arc before the first bounce is the release (its top above that bounce: the release height)
//    only when it starts at its top; one that rises first in free flight followed a bounce or a throw:
//    after a low point whose fall is not a flight arc (blurred, in the hand), that bounce is placed
//    where the rising parabola meets the next bounce's floor line (no restitution: the fall is
//    unknown); otherwise the message says the object was already rising; no release height either way;
//  - the trajectory ends at the first arc after a bounce that is not free flight (the object was picked
//    up, rolls or stopped) or at a gap of lost frames longer than max_gap_s (the first run of at least
//    max(8, 10 %) of the samples is analysed); the message says which.
#pragma once

#include <limits>
#include <string>
#include <vector>

namespace topo_gaussian::vision {

struct BounceOptions {
  double min_prominence_px = 0.0;  ///< 0 = max(3 px, 5 % of the height range)
  int min_arc_samples = 4;
  double max_gap_s = 0.25;          ///< a longer run of lost frames ends the trajectory
  double object_diameter_px = 0.0;  ///< the object's size in the image (0: unknown, no scale check)
  double min_g_diameters = 4.0, max_g_diameters = 1000.0;  ///< 4: allows a tennis ball filmed at 6x slow motion
};

struct FlightArc {
  double t0 = 0, t1 = 0;   ///< time range of the arc's samples
  double accel_px_s2 = 0;  ///< 2a (negative: downwards)
  double rms_px = 0;
  double apex_t = 0, apex_h = 0;
  bool apex_inside = false;  ///< the vertex lies inside the arc's time range and the frame
  bool flight = false;       ///< passes the free-flight checks
};

struct BounceFeatures {
  std::vector<double> bounce_times_s, bounce_h_px;
  std::vector<double> apex_times_s, apex_h_px, apex_heights_px;  ///< apex_heights_px above the preceding bounce
  double floor_h_px = 0.0;
  /// highest point of the first arc above the first bounce; NaN when that arc rises first (the object
  /// was not let go in view: a bounce or a throw came before the first bounce found)
  double release_height_px = 0.0;
  std::vector<double> restitution_from_heights, restitution_from_times;        ///< per bounce (NaN if not measurable)
  double restitution_heights_mean = std::numeric_limits<double>::quiet_NaN();  ///< NaN if none
  double restitution_times_mean = std::numeric_limits<double>::quiet_NaN();
  double gravity_px_s2 = 0.0;  ///< median |2a| of the flight arcs
  std::vector<FlightArc> arcs;
  double end_time_s = 0.0;  ///< where the analysed trajectory ends
  std::string end_reason;   ///< empty when it ran to the end of the data
  double confidence = 0.0;  ///< 0..1: arc fit quality and agreement of the arcs' accelerations
  std::string message;
};

/// t increasing [s], h [px] (up positive); h_min/h_max: the frame's limits in the same coordinate
/// (apexes outside them are not kept). Throws TopoError for mismatched sizes.
/// `across` (optional, same length): the position across gravity [px].
BounceFeatures analyseBounces(const std::vector<double>& t, const std::vector<double>& h, double h_min, double h_max,
                              const BounceOptions& options = BounceOptions(),
                              const std::vector<double>* across = nullptr);

}  // namespace topo_gaussian::vision
