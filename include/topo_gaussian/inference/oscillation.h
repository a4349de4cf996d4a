// Oscillation features of a sampled signal (a tilt angle over time), differentiable: with a
// forward-mode scalar (Dual10) every feature carries its derivative. Extrema are located to
// sub-sample accuracy by parabolic interpolation through the three samples around each one, and
// small jitter extrema are dropped; the equilibrium is the mean of (max + min)/2 over neighbouring
// turning points, the amplitude half the mean peak-to-peak, and the period twice the mean spacing
// of the equilibrium crossings (interpolated; steep there, so robust to contact jitter).
#pragma once

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace topo_gaussian::inference {

template <typename S>
struct Extremum {
  S time;
  S value;
  bool maximum;
};

template <typename S>
struct OscillationFeatures {
  bool valid = false;          ///< at least one full period was seen
  std::string message;         ///< why not, when invalid
  S period = S(0);
  S max_abs = S(0);            ///< max |signal| including the first sample (a release at rest)
  S equilibrium = S(0);
  S amplitude = S(0);
  int extrema = 0;
};

inline double valueOfScalar(double x) { return x; }
template <typename S>
double valueOfScalar(const S& x) { return x.value(); }

/// Interior extrema of y sampled at t0 + k·dt.
template <typename S>
std::vector<Extremum<S>> findExtrema(const std::vector<S>& y, double t0, double dt) {
  std::vector<Extremum<S>> out;
  for (std::size_t k = 1; k + 1 < y.size(); ++k) {
    const double a = valueOfScalar(y[k - 1]), b = valueOfScalar(y[k]), c = valueOfScalar(y[k + 1]);
    const bool mx = b > a && b >= c, mn = b < a && b <= c;
    if (!mx && !mn) continue;
    const S den = y[k - 1] - 2.0 * y[k] + y[k + 1];
    S delta = S(0);
    if (std::abs(valueOfScalar(den)) > 1e-300) delta = (y[k - 1] - y[k + 1]) / (2.0 * den);
    const S value = y[k] - 0.25 * (y[k - 1] - y[k + 1]) * delta;
    out.push_back(Extremum<S>{t0 + dt * (static_cast<double>(k) + delta), value, mx});
  }
  return out;
}

/// Keeps alternating extrema whose swing exceeds `fraction` of the signal's range (contact jitter
/// near a turning point makes small spurious extrema); of consecutive same-kind ones the more extreme
/// survives.
template <typename S>
std::vector<Extremum<S>> prominentExtrema(const std::vector<Extremum<S>>& ex, double range, double fraction) {
  std::vector<Extremum<S>> out;
  for (const auto& e : ex) {
    if (!out.empty() && out.back().maximum == e.maximum) {
      const bool more = e.maximum ? valueOfScalar(e.value) > valueOfScalar(out.back().value)
                                  : valueOfScalar(e.value) < valueOfScalar(out.back().value);
      if (more) out.back() = e;
      continue;
    }
    if (!out.empty() && std::abs(valueOfScalar(e.value) - valueOfScalar(out.back().value)) < fraction * range) continue;
    out.push_back(e);
  }
  return out;
}

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
  double lo = 1e300, hi = -1e300;
  for (const auto& v : y) lo = std::min(lo, valueOfScalar(v)), hi = std::max(hi, valueOfScalar(v));
  f.max_abs = abs(y[0]);
  auto raw = findExtrema(y, t0, dt);
  // Released at rest: the first sample is the first turning point (jitter extrema next to it merge
  // into it in the prominence filter).
  if (starts_at_rest) raw.insert(raw.begin(), Extremum<S>{S(t0), y[0], valueOfScalar(y[0]) >= valueOfScalar(y[1])});
  auto ex = prominentExtrema(raw, hi - lo, 0.1);
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
      if ((a <= 0) != (b <= 0) && std::abs(b - a) > slope) slope = std::abs(b - a), best = i + 1;
    }
    if (slope == 0) continue;
    const std::size_t i = best - 1;
    const S a = y[i] - f.equilibrium, b = y[i + 1] - f.equilibrium;
    crossings.push_back(t0 + dt * static_cast<double>(i) + dt * a / (a - b));
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
