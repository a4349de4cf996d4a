// Signal analysis of a tracked angle over time (paper §7: "features extracted by OpenCV"):
// oscillation period (sub-frame: interpolated equilibrium crossings, refined by the autocorrelation
// peak), maximum tilt, amplitude, damping (logarithmic decrement), equilibrium angle, and a
// confidence. Samples may be irregular (dropped frames): everything works on (t, y) pairs.
// A signal without a clear oscillation is reported as such (oscillation_found = false, low
// confidence), never with a made-up period.
#pragma once

#include <string>
#include <vector>

namespace topo_gaussian::vision {

struct SignalOptions {
  double min_amplitude_deg = 1.0;  ///< swings smaller than this (half peak-to-peak) are "no oscillation"
  int min_cycles = 2;              ///< fewer full cycles in the clip → not found, with a message
  double smoothing_s = 0.0;        ///< optional moving-average window before analysis (0 = none)
};

struct SignalFeatures {
  bool oscillation_found = false;
  std::string message;  ///< why not found / what limited the estimate
  double period_s = 0.0;
  double max_tilt_deg = 0.0;                          ///< max |y|
  double amplitude_deg = 0.0;                         ///< mean half peak-to-peak
  double equilibrium_deg = 0.0;                       ///< oscillation centre (for a static signal: its median)
  double log_decrement = 0.0;                         ///< δ = ln(A_k / A_{k+1}) per cycle
  double damping_ratio = 0.0;                         ///< ζ = δ / sqrt(4π² + δ²)
  int cycles = 0;                                     ///< full cycles used for the period
  double confidence = 0.0;                            ///< 0..1: regularity of the cycles and signal-to-noise
  double t_start_s = 0.0, t_end_s = 0.0;              ///< time range analysed
  std::vector<double> crossing_times_s;               ///< equilibrium crossings used
  std::vector<double> peak_times_s, peak_values_deg;  ///< turning points used
};

/// t in seconds (increasing), y in degrees; sizes must agree. Throws TopoError for mismatched sizes,
/// non-increasing or non-finite times.
SignalFeatures analyseSignal(const std::vector<double>& t, const std::vector<double>& y,
                             const SignalOptions& options = SignalOptions());

/// Static pose: median and spread (MAD) of y; for hanging/standing objects.
struct StaticPose {
  double angle_deg = 0.0;
  double spread_deg = 0.0;
  double confidence = 0.0;
};
StaticPose analyseStatic(const std::vector<double>& y);

}  // namespace topo_gaussian::vision
