// Oscillation features of a sampled signal (a tilt angle over time), differentiable: with a
// forward-mode scalar (Dual10) every feature carries its derivative. Built on the turning-point and
// crossing primitives of common/oscillation.h (the tracker's analysis uses the same ones). Extrema are located to
// sub-sample accuracy by parabolic interpolation through the three samples around each one, and
// small jitter extrema are dropped; the equilibrium is the mean of (max + min)/2 over neighbouring
// turning points, the amplitude half the mean peak-to-peak, and the period twice the mean spacing
// of the equilibrium crossings (interpolated; steep there, so robust to contact jitter).
#pragma once

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "topo_gaussian/common/oscillation.h"

namespace topo_gaussian::inference {

// The primitives live in common/oscillation.h (shared with vision::analyseSignal); these names keep
// working here.
using oscillation::Extremum;
using oscillation::prominentExtrema;
using oscillation::valueOfScalar;

template <typename S>
struct OscillationFeatures {
  bool valid = false;   ///< at least one full period was seen
  std::string message;  ///< why not, when invalid
  S period = S(0);
  S max_abs = S(0);  ///< max |signal| including the first sample (a release at rest)
  S equilibrium = S(0);
  S amplitude = S(0);
  int extrema = 0;
};

/// Interior extrema of y sampled at t0 + k·dt.
template <typename S>
std::vector<Extremum<S>> findExtrema(const std::vector<S>& y, double t0, double dt) {
  return oscillation::findExtrema(y, [&](std::size_t k) { return t0 + dt * static_cast<double>(k); });
}

/// The turning points the analysis below measures (y.size() ≥ 2): the interior extrema, and the first
/// sample when the motion starts at rest (jitter extrema next to it merge into it), of which those
/// whose swing is under 10 % of the signal's range are dropped as jitter.
template <typename S>
std::vector<Extremum<S>> measuredTurningPoints(const std::vector<S>& y, double t0, double dt, bool starts_at_rest) {
  double lo = 1e300, hi = -1e300;
  for (const auto& v : y) lo = std::min(lo, valueOfScalar(v)), hi = std::max(hi, valueOfScalar(v));
  auto raw = findExtrema(y, t0, dt);
  if (starts_at_rest) raw.insert(raw.begin(), Extremum<S>{S(t0), y[0], valueOfScalar(y[0]) >= valueOfScalar(y[1])});
  return prominentExtrema(raw, hi - lo, 0.1);
}

/// Watches a signal while it is being sampled (a simulation under way) and says when it holds all that
/// analyseOscillation(y, t0, dt, max_cycles, starts_at_rest) measures: the first 2 max_cycles + 1
/// turning points (and the crossings between them), the last one final. The jitter filter keeps a
/// turning point by its swing against 10 % of the whole signal's range, so the watch decides only once
/// that range is settled: the signal's highest and lowest samples lie at kept turning points (a
/// passive oscillation's extremes are those of its first swing; before it, near a release or a push,
/// contact jitter would pass a filter scaled by the little range seen so far), and the turning points
/// are then taken again with it. The last one is final once the signal has moved away from it by more
/// than 10 % of the range: whatever comes later, the next turning point is then kept, so no later one of
/// the same kind can replace it. Later samples can then change the features only by widening the
/// range, which a passive oscillation's do not. Never complete when max_cycles ≤ 0 (every cycle counts),
/// nor while the signal's extremes are not turning points (e.g. a push from the highest tilt): the
/// whole signal is then analysed. Cost: a comparison a sample, and the turning points of the samples so
/// far at each local extremum and whenever the range has grown since.
class MeasuredCyclesWatch {
 public:
  MeasuredCyclesWatch(double dt, int max_cycles, bool starts_at_rest)
      : dt_(dt), max_cycles_(max_cycles), starts_at_rest_(starts_at_rest) {}
  /// Adds the next sample; true once the samples so far hold everything the analysis measures.
  bool add(double y) {
    y_.push_back(y);
    lo_ = std::min(lo_, y);
    hi_ = std::max(hi_, y);
    const std::size_t n = y_.size();
    if (max_cycles_ <= 0 || n < 3) return false;
    const double a = y_[n - 3], b = y_[n - 2], c = y_[n - 1];
    if ((b > a && b >= c) || (b < a && b <= c)) update();
    const std::size_t need = static_cast<std::size_t>(2 * max_cycles_ + 1);
    if (turning_.size() < need) return false;
    if (range_ != hi_ - lo_) update();  // the range grew since: the filter's verdicts with it
    if (turning_.size() < need || !rangeAtTurningPoints()) return false;
    if (turning_.size() > need) return true;
    const Extremum<double>& last = turning_.back();
    return (last.maximum ? last.value - y : y - last.value) > 0.1 * (hi_ - lo_);
  }

 private:
  void update() {
    turning_ = measuredTurningPoints(y_, 0.0, dt_, starts_at_rest_);
    range_ = hi_ - lo_;
  }
  /// Whether the highest and the lowest sample are kept turning points (a refined vertex lies beyond
  /// the samples it is fitted through, or is one of them).
  bool rangeAtTurningPoints() const {
    double top = -1e300, bottom = 1e300;
    for (const auto& e : turning_) top = std::max(top, e.value), bottom = std::min(bottom, e.value);
    return top >= hi_ && bottom <= lo_;
  }
  double dt_;
  int max_cycles_;
  bool starts_at_rest_;
  std::vector<double> y_;
  double lo_ = 1e300, hi_ = -1e300, range_ = -1.0;
  std::vector<Extremum<double>> turning_;
};

/// max_cycles > 0 limits the period and equilibrium to the first max_cycles full cycles, so the
/// features do not jump when the simulated window happens to hold one more crossing (the period of a
/// damped, non-linear rocker drifts with its amplitude).
/// starts_at_rest: the motion is released from rest, so the first sample is a turning point.
template <typename S>
OscillationFeatures<S> analyseOscillation(const std::vector<S>& y, double t0, double dt, int max_cycles = 0,
                                          bool starts_at_rest = false) {
  using std::abs;
  OscillationFeatures<S> f;
  if (y.size() < 3) {
    f.message = "signal too short";
    return f;
  }
  f.max_abs = abs(y[0]);
  auto ex = measuredTurningPoints(y, t0, dt, starts_at_rest);
  if (max_cycles > 0 && ex.size() > static_cast<std::size_t>(2 * max_cycles + 1)) ex.resize(2 * max_cycles + 1);
  // The first sample is a turning point too when the motion starts at rest.
  f.extrema = static_cast<int>(ex.size());
  for (const auto& e : ex)
    if (valueOfScalar(abs(e.value)) > valueOfScalar(f.max_abs)) f.max_abs = abs(e.value);
  if (ex.size() < 3) {
    f.message = ex.empty() ? "no oscillation: the signal has no turning point"
                           : "fewer than one full period: simulate longer (duration_s)";
    return f;
  }
  // Equilibrium and amplitude from neighbouring turning points.
  S eq = S(0), amp = S(0);
  for (std::size_t k = 0; k + 1 < ex.size(); ++k) {
    eq = eq + 0.5 * (ex[k].value + ex[k + 1].value);
    amp = amp + 0.5 * abs(ex[k].value - ex[k + 1].value);
  }
  f.equilibrium = eq / static_cast<double>(ex.size() - 1);
  f.amplitude = amp / static_cast<double>(ex.size() - 1);
  // Period from the crossings of the equilibrium between turning points (steep there, so jitter-free):
  // linear interpolation between the two samples around the crossing.
  std::vector<S> crossings;
  for (std::size_t k = 0; k + 1 < ex.size(); ++k) {
    const double ta = valueOfScalar(ex[k].time), tb = valueOfScalar(ex[k + 1].time);
    std::size_t best = 0;
    double slope = 0;
    for (std::size_t i = static_cast<std::size_t>(std::max(0.0, std::ceil((ta - t0) / dt)));
         i + 1 < y.size() && t0 + (i + 1) * dt <= tb + dt; ++i) {
      const double a = valueOfScalar(y[i] - f.equilibrium), b = valueOfScalar(y[i + 1] - f.equilibrium);
      if (oscillation::isSignChange(a, b) && std::abs(b - a) > slope) slope = std::abs(b - a), best = i + 1;
    }
    if (slope == 0) continue;
    const std::size_t i = best - 1;
    const S a = y[i] - f.equilibrium, b = y[i + 1] - f.equilibrium;
    crossings.push_back(
        oscillation::crossingTime(t0 + dt * static_cast<double>(i), a, t0 + dt * static_cast<double>(i + 1), b));
  }
  if (crossings.size() < 2) {
    f.message = "fewer than one full period: simulate longer (duration_s)";
    return f;
  }
  f.period = 2.0 * (crossings.back() - crossings.front()) / static_cast<double>(crossings.size() - 1);
  f.valid = true;
  return f;
}

}  // namespace topo_gaussian::inference
