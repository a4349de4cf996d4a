// Oscillation features of a sampled signal (a tilt angle over time), differentiable: with a
// forward-mode scalar (Dual10) every feature carries its derivative. Extrema are located to
// sub-sample accuracy by parabolic interpolation through the three samples around each one; the
// period is the mean spacing of successive maxima and of successive minima; the equilibrium is the
// mean of (max + min)/2 over neighbouring extrema; the amplitude is half the mean peak-to-peak.
#pragma once

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace topo_gaussian {
namespace inference {

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

template <typename S>
OscillationFeatures<S> analyseOscillation(const std::vector<S>& y, double t0, double dt) {
  using std::abs;
  OscillationFeatures<S> f;
  if (y.empty()) {
    f.message = "empty signal";
    return f;
  }
  f.max_abs = abs(y[0]);
  const auto ex = findExtrema(y, t0, dt);
  f.extrema = static_cast<int>(ex.size());
  for (const auto& e : ex)
    if (valueOfScalar(abs(e.value)) > valueOfScalar(f.max_abs)) f.max_abs = abs(e.value);
  // Period from maxima and minima separately, weighted by the number of intervals.
  S sum = S(0);
  int intervals = 0;
  for (int kind = 0; kind < 2; ++kind) {
    const Extremum<S>* first = nullptr;
    const Extremum<S>* last = nullptr;
    int n = 0;
    for (const auto& e : ex)
      if (e.maximum == (kind == 0)) {
        if (!first) first = &e;
        last = &e;
        ++n;
      }
    if (n >= 2) {
      sum = sum + (last->time - first->time);
      intervals += n - 1;
    }
  }
  if (intervals == 0) {
    f.message = ex.empty() ? "no oscillation: the signal has no turning point"
                           : "fewer than one full period: simulate longer (duration_s)";
    return f;
  }
  f.period = sum / static_cast<double>(intervals);
  S eq = S(0), amp = S(0);
  int pairs = 0;
  for (std::size_t k = 0; k + 1 < ex.size(); ++k) {
    if (ex[k].maximum == ex[k + 1].maximum) continue;
    eq = eq + 0.5 * (ex[k].value + ex[k + 1].value);
    amp = amp + 0.5 * abs(ex[k].value - ex[k + 1].value);
    ++pairs;
  }
  if (pairs > 0) {
    f.equilibrium = eq / static_cast<double>(pairs);
    f.amplitude = amp / static_cast<double>(pairs);
  }
  f.valid = true;
  return f;
}

}  // namespace inference
}  // namespace topo_gaussian
