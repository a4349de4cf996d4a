// Signal analysis of a tracked angle over time: period (least-squares fit of interpolated
// equilibrium-crossing times, cross-checked with the autocorrelation peak), turning points (parabola
// refinement), equilibrium, amplitude, logarithmic decrement and a confidence. Works on irregular
// (t, y) samples. A signal without a clear oscillation is reported as such, never with a made-up period.
// The fits, turning-point vertices and crossing interpolation are common/oscillation.h's, the same
// primitives the tasks' differentiable analysis (inference/oscillation.h) uses.
#include "topo_gaussian/vision/signal_analysis.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numeric>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/number_text.h"
#include "topo_gaussian/common/oscillation.h"
#include "topo_gaussian/common/statistics.h"

namespace topo_gaussian::vision {

namespace {

constexpr double kPi = 3.14159265358979323846;

double mad(const std::vector<double>& v, double centre) {
  std::vector<double> d(v.size());
  for (size_t i = 0; i < v.size(); ++i) d[i] = std::abs(v[i] - centre);
  return median(d);
}

/// Least-squares polynomial fit in (x - x0) (common/oscillation.h's fitPolynomial, degree 1 or 2);
/// coefficients c0 + c1 τ + c2 τ² and, when hat is given, the leverage of the point τ = 0 (for residual
/// scaling). Returns false when singular.
bool polyFit(const std::vector<double>& x, const std::vector<double>& y, double x0, int degree, Eigen::VectorXd& coef,
             double* hat = nullptr) {
  double c[3];
  if (x.size() != y.size() || !oscillation::fitPolynomial(x.data(), y.data(), x.size(), x0, degree, c, hat))
    return false;
  coef = Eigen::Map<const Eigen::VectorXd>(c, degree + 1);
  return true;
}

/// Robust white-noise level: residual of local quadratic fits (7 samples) at their centre.
double noiseLevel(const std::vector<double>& t, const std::vector<double>& y) {
  const int n = static_cast<int>(t.size());
  const int half = 3;
  std::vector<double> r;
  for (int i = half; i + half < n; ++i) {
    std::vector<double> xs(t.begin() + i - half, t.begin() + i + half + 1);
    std::vector<double> ys(y.begin() + i - half, y.begin() + i + half + 1);
    Eigen::VectorXd c;
    double h = 0.0;
    if (!polyFit(xs, ys, t[i], 2, c, &h) || h >= 0.999) continue;
    r.push_back((y[i] - c(0)) / std::sqrt(1.0 - h));
  }
  if (r.empty()) return 0.0;
  return 1.4826 * mad(r, median(r));
}

/// Local quadratic smoothing over 7 neighbouring samples (index window), evaluated at each sample.
std::vector<double> localSmooth(const std::vector<double>& t, const std::vector<double>& y) {
  const int n = static_cast<int>(t.size());
  std::vector<double> s(y);
  const int half = 3;
  for (int i = 0; i < n; ++i) {
    int lo = std::max(0, i - half), hi = std::min(n - 1, i + half);
    while (hi - lo < 2 * half && (lo > 0 || hi < n - 1)) {
      if (lo > 0) --lo;
      if (hi - lo < 2 * half && hi < n - 1) ++hi;
    }
    std::vector<double> xs(t.begin() + lo, t.begin() + hi + 1);
    std::vector<double> ys(y.begin() + lo, y.begin() + hi + 1);
    Eigen::VectorXd c;
    if (polyFit(xs, ys, t[i], 2, c)) s[i] = c(0);
  }
  return s;
}

/// Samples (times, values) with t in [a, b].
void window(const std::vector<double>& t, const std::vector<double>& y, double a, double b, std::vector<double>& xs,
            std::vector<double>& ys) {
  xs.clear();
  ys.clear();
  auto it = std::lower_bound(t.begin(), t.end(), a);
  for (size_t i = static_cast<size_t>(it - t.begin()); i < t.size() && t[i] <= b; ++i) {
    xs.push_back(t[i]);
    ys.push_back(y[i]);
  }
}

struct TurningPoint {
  double t, value;
  int side;  // +1 maximum, -1 minimum
};

/// Linear interpolation of a signal at time q (t increasing).
double interp(const std::vector<double>& t, const std::vector<double>& y, double q) {
  if (q <= t.front()) return y.front();
  if (q >= t.back()) return y.back();
  const size_t j = static_cast<size_t>(std::upper_bound(t.begin(), t.end(), q) - t.begin());
  const double f = (q - t[j - 1]) / (t[j] - t[j - 1]);
  return y[j - 1] + f * (y[j] - y[j - 1]);
}

/// Period from the autocorrelation of the resampled signal near a guess; 0 when not available.
double autocorrelationPeriod(const std::vector<double>& t, const std::vector<double>& y, double centre, double guess,
                             double dt) {
  const double span = t.back() - t.front();
  if (!(dt > 0.0) || span < 1.4 * guess) return 0.0;
  const int N = static_cast<int>(std::floor(span / dt)) + 1;
  std::vector<double> x(N);
  for (int i = 0; i < N; ++i) x[i] = interp(t, y, t.front() + i * dt) - centre;
  const double m = std::accumulate(x.begin(), x.end(), 0.0) / N;
  for (double& v : x) v -= m;
  const int lmin = std::max(1, static_cast<int>(std::floor(0.7 * guess / dt)));
  const int lmax = std::min(N - 3, static_cast<int>(std::ceil(1.3 * guess / dt)));
  if (lmax - lmin < 2) return 0.0;
  std::vector<double> r(lmax + 2, 0.0);
  auto corr = [&](int L) {
    double s = 0.0;
    for (int i = 0; i + L < N; ++i) s += x[i] * x[i + L];
    return s / (N - L);
  };
  int best = -1;
  double bestv = -std::numeric_limits<double>::infinity();
  for (int L = lmin; L <= lmax; ++L) {
    r[L] = corr(L);
    if (r[L] > bestv) {
      bestv = r[L];
      best = L;
    }
  }
  if (best <= lmin || best >= lmax) return 0.0;  // no interior peak
  const double a = r[best - 1], b = r[best], c = r[best + 1];
  const double den = a - 2.0 * b + c;
  double off = (std::abs(den) > 0.0) ? 0.5 * (a - c) / den : 0.0;
  off = std::max(-0.5, std::min(0.5, off));
  return (best + off) * dt;
}

void validate(const std::vector<double>& t, const std::vector<double>& y) {
  if (t.size() != y.size())
    throw TopoError(
        "signal",
        "time and angle arrays differ in size (" + std::to_string(t.size()) + " vs " + std::to_string(y.size()) + ")",
        "pass one angle per time stamp");
  if (t.empty()) throw TopoError("signal", "no samples", "track at least a few frames");
  for (size_t i = 0; i < t.size(); ++i) {
    if (!std::isfinite(t[i]))
      throw TopoError("signal", "time stamp " + std::to_string(i) + " is not finite",
                      "drop frames without a valid time stamp");
    if (!std::isfinite(y[i]))
      throw TopoError("signal", "angle sample " + std::to_string(i) + " is not finite (NaN/inf)",
                      "drop frames where the tracker lost the object instead of passing NaN");
    if (i > 0 && !(t[i] > t[i - 1]))
      throw TopoError("signal",
                      "time stamps are not strictly increasing at sample " + std::to_string(i) + " (" +
                          numberText(t[i - 1], 8) + " then " + numberText(t[i], 8) + ")",
                      "sort the samples by time and remove duplicates");
  }
}

}  // namespace

SignalFeatures analyseSignal(const std::vector<double>& t_in, const std::vector<double>& y_in,
                             const SignalOptions& options) {
  validate(t_in, y_in);
  SignalFeatures f;
  const std::vector<double>& t = t_in;
  std::vector<double> y = y_in;
  const int n = static_cast<int>(t.size());
  f.t_start_s = t.front();
  f.t_end_s = t.back();
  const double min_amp = std::max(0.0, options.min_amplitude_deg);
  const int min_cycles = std::max(1, options.min_cycles);

  // Optional moving average.
  if (options.smoothing_s > 0.0) {
    std::vector<double> s(n);
    const double hw = 0.5 * options.smoothing_s;
    int lo = 0, hi = 0;
    double sum = 0.0;
    for (int i = 0; i < n; ++i) {
      while (hi < n && t[hi] <= t[i] + hw) sum += y[hi++];
      while (t[lo] < t[i] - hw) sum -= y[lo++];
      s[i] = sum / (hi - lo);
    }
    y = s;
  }

  const double med = median(y);
  f.equilibrium_deg = med;
  if (n < 8) {
    f.max_tilt_deg = 0.0;
    for (double v : y) f.max_tilt_deg = std::max(f.max_tilt_deg, std::abs(v));
    f.message = "no oscillation found: too few samples (" + std::to_string(n) +
                "), fewer than 8 are needed and fewer than " + std::to_string(min_cycles) + " full periods can be seen";
    f.confidence = 0.05;
    return f;
  }

  std::vector<double> dts(n - 1);
  for (int i = 0; i + 1 < n; ++i) dts[i] = t[i + 1] - t[i];
  const double dt = median(dts);
  const double sigma = noiseLevel(t, y);
  const std::vector<double> s = localSmooth(t, y);
  const double smax = *std::max_element(s.begin(), s.end());
  const double smin = *std::min_element(s.begin(), s.end());
  const double half_range = 0.5 * (smax - smin);
  for (double v : s) f.max_tilt_deg = std::max(f.max_tilt_deg, std::abs(v));

  auto notFoundStatic = [&](const std::string& why) {
    f.oscillation_found = false;
    f.equilibrium_deg = med;
    f.amplitude_deg = half_range;
    f.message = "no oscillation found: " + why;
    const double rel = (min_amp > 0.0) ? std::min(1.0, half_range / min_amp) : 1.0;
    f.confidence = 0.05 + 0.1 * rel * 0.5;
    return f;
  };

  if (half_range < min_amp)
    return notFoundStatic("the signal swings only ±" + numberText(half_range, 3) +
                          " deg, below min_amplitude_deg = " + numberText(min_amp, 3));
  if (half_range < 3.0 * sigma)
    return notFoundStatic("the signal is mostly noise: it swings ±" + numberText(half_range, 3) + " deg but jumps by " +
                          numberText(sigma, 3) +
                          " deg from sample to sample (the object or its angle is not followed smoothly)");

  // Hysteresis segmentation about the median.
  const double H = std::max({4.0 * sigma, 0.5 * min_amp, 0.1 * half_range});
  std::vector<int> state(n, 0);
  int cur = 0;
  std::vector<int> change_idx;  // first index of each new run (after the first run)
  for (int i = 0; i < n; ++i) {
    int st = cur;
    if (y[i] > med + H)
      st = 1;
    else if (y[i] < med - H)
      st = -1;
    if (st != cur && cur != 0) change_idx.push_back(i);
    cur = st;
    state[i] = cur;
  }
  if (change_idx.empty()) return notFoundStatic("the signal never swings across its centre (a drift or a static pose)");
  if (change_idx.size() < 2) {
    f.oscillation_found = false;
    f.amplitude_deg = half_range;
    f.message =
        "no oscillation found: the signal crosses its centre only once (a single swing or a "
        "drift); fewer than " +
        std::to_string(min_cycles) + " full periods in the clip";
    f.confidence = 0.08;
    return f;
  }
  std::vector<double> change_t;
  for (int i : change_idx) change_t.push_back(t[i]);
  std::vector<double> cd;
  for (size_t k = 1; k < change_t.size(); ++k) cd.push_back(change_t[k] - change_t[k - 1]);
  const double T_rough = 2.0 * median(cd);

  // Runs: [start, change_0), [change_0, change_1), ... ; the first run starts at the first non-zero state.
  std::vector<std::pair<int, int>> runs;
  {
    int first = 0;
    while (first < n && state[first] == 0) ++first;
    int a = first;
    for (int c : change_idx) {
      runs.emplace_back(a, c - 1);
      a = c;
    }
    runs.emplace_back(a, n - 1);
  }

  // Turning points refined with a parabola over ±w.
  const double w = std::max(0.1 * T_rough, 2.5 * dt);
  std::vector<TurningPoint> tps;
  std::vector<double> xs, ys;
  for (const auto& run : runs) {
    const int side = state[run.first];
    if (side == 0) continue;
    int arg = run.first;
    for (int i = run.first; i <= run.second; ++i)
      if (side * s[i] > side * s[arg]) arg = i;
    if (t[arg] < t.front() + 0.5 * w || t[arg] > t.back() - 0.5 * w) continue;  // at the clip edge
    double tc = t[arg];
    double value = s[arg];
    for (int iter = 0; iter < 2; ++iter) {
      window(t, y, tc - w, tc + w, xs, ys);
      Eigen::VectorXd c;
      if (!polyFit(xs, ys, tc, 2, c)) break;
      if (side * c(2) >= 0.0) break;  // not a proper extremum: keep the smoothed sample
      double tau = 0.0, vertex = 0.0;
      oscillation::parabolaVertex(c.data(), tau, vertex);
      if (std::abs(tau) > w) break;
      const double tv = tc + tau;
      if (tv < t.front() || tv > t.back()) break;
      value = vertex;
      const double moved = std::abs(tau);
      tc = tv;
      if (moved < 0.5 * dt) break;
    }
    tps.push_back({tc, value, side});
  }
  for (const auto& tp : tps) {
    f.peak_times_s.push_back(tp.t);
    f.peak_values_deg.push_back(tp.value);
  }
  if (tps.size() < 2) {
    f.oscillation_found = false;
    f.amplitude_deg = half_range;
    f.message = "no oscillation found: fewer than two turning points inside the clip; fewer than " +
                std::to_string(min_cycles) + " full periods in the clip";
    f.confidence = 0.08;
    return f;
  }

  // Equilibrium: weighted midpoints of neighbouring turning points (cancels a linear amplitude decay).
  std::vector<double> mids;
  if (tps.size() >= 3) {
    for (size_t k = 1; k + 1 < tps.size(); ++k)
      mids.push_back(0.25 * tps[k - 1].value + 0.5 * tps[k].value + 0.25 * tps[k + 1].value);
  } else {
    mids.push_back(0.5 * (tps[0].value + tps[1].value));
  }
  const double eq = std::accumulate(mids.begin(), mids.end(), 0.0) / mids.size();
  f.equilibrium_deg = eq;

  // Amplitude: mean half peak-to-peak of neighbouring turning points.
  double amp_sum = 0.0;
  for (size_t k = 1; k < tps.size(); ++k) amp_sum += 0.5 * std::abs(tps[k].value - tps[k - 1].value);
  f.amplitude_deg = amp_sum / (tps.size() - 1);

  // Max tilt: turning points and the clip ends (one-sided quadratic fit).
  {
    double mt = 0.0;
    for (const auto& tp : tps) mt = std::max(mt, std::abs(tp.value));
    const double we = std::max(0.2 * T_rough, 5.0 * dt);
    for (int end = 0; end < 2; ++end) {
      const double te = end == 0 ? t.front() : t.back();
      window(t, y, end == 0 ? te : te - we, end == 0 ? te + we : te, xs, ys);
      Eigen::VectorXd c;
      if (xs.size() >= 5 && polyFit(xs, ys, te, 2, c))
        mt = std::max(mt, std::abs(c(0)));
      else
        mt = std::max(mt, std::abs(end == 0 ? s.front() : s.back()));
    }
    f.max_tilt_deg = mt;
  }

  // Equilibrium crossings: a line fitted to the samples within the central band of each swing.
  std::vector<double> crossings;
  auto crossingIn = [&](double ta, double tb, int dir, double band, bool edge_start, bool edge_end) {
    // dir: +1 rising, -1 falling between ta and tb
    std::vector<double> bx, by;
    int lo = static_cast<int>(std::lower_bound(t.begin(), t.end(), ta) - t.begin());
    int hi = static_cast<int>(std::upper_bound(t.begin(), t.end(), tb) - t.begin()) - 1;
    if (edge_start) {  // restrict to after the last sample clearly on the far side
      int last = -1;
      for (int i = lo; i <= hi; ++i)
        if (-dir * (s[i] - eq) > band) last = i;
      if (last < 0) return false;
      lo = last + 1;
    }
    if (edge_end) {  // restrict to before the first sample clearly on the far side
      int first = -1;
      for (int i = lo; i <= hi; ++i)
        if (dir * (s[i] - eq) > band) {
          first = i;
          break;
        }
      if (first < 0) return false;
      hi = first - 1;
    }
    int below = 0, above = 0;
    for (int i = lo; i <= hi; ++i) {
      if (std::abs(y[i] - eq) < band) {
        bx.push_back(t[i]);
        by.push_back(y[i]);
        (y[i] < eq ? below : above)++;
      }
    }
    if (bx.size() >= 3 && below > 0 && above > 0) {
      Eigen::VectorXd c;
      const double tm = 0.5 * (bx.front() + bx.back());
      if (polyFit(bx, by, tm, 1, c) && dir * c(1) > 0.0) {
        const double tcx = tm + (eq - c(0)) / c(1);
        if (tcx >= bx.front() - dt && tcx <= bx.back() + dt) {
          crossings.push_back(tcx);
          return true;
        }
      }
    }
    // Fallback: median of the interpolated sign changes.
    std::vector<double> cands;
    for (int i = std::max(lo, 0); i + 1 <= hi && i + 1 < n; ++i) {
      const double a = y[i] - eq, b = y[i + 1] - eq;
      if (oscillation::isSignChange(a, b)) cands.push_back(oscillation::crossingTime(t[i], a, t[i + 1], b));
    }
    if (cands.empty()) return false;
    crossings.push_back(median(cands));
    return true;
  };
  {
    const TurningPoint& first = tps.front();
    crossingIn(t.front(), first.t, first.side, 0.5 * std::abs(first.value - eq), true, false);
    for (size_t k = 0; k + 1 < tps.size(); ++k) {
      const double band = 0.5 * std::min(std::abs(tps[k].value - eq), std::abs(tps[k + 1].value - eq));
      crossingIn(tps[k].t, tps[k + 1].t, tps[k + 1].side, band, false, false);
    }
    const TurningPoint& last = tps.back();
    crossingIn(last.t, t.back(), -last.side, 0.5 * std::abs(last.value - eq), false, true);
  }
  std::sort(crossings.begin(), crossings.end());
  f.crossing_times_s = crossings;

  if (crossings.size() < 2) {
    f.oscillation_found = false;
    f.message = "no oscillation found: fewer than two equilibrium crossings; fewer than " + std::to_string(min_cycles) +
                " full periods in the clip";
    f.confidence = 0.08;
    return f;
  }

  // Least-squares fit of crossing times against their half-cycle index. The index is counted from
  // one crossing to the next (a gap of about two half cycles is a missed crossing), not from the
  // first one: T_rough comes from the hysteresis runs about the median, which alternate long and
  // short when the clip holds a fractional number of cycles (the median is then off the centre),
  // and a few % of error in it would misnumber crossings after ten half cycles.
  double half = 0.5 * T_rough;
  std::vector<double> idx(crossings.size(), 0.0);
  for (size_t j = 1; j < crossings.size(); ++j)
    idx[j] = idx[j - 1] + std::max(1.0, std::round((crossings[j] - crossings[j - 1]) / half));
  double period = 0.0, fit_rms = 0.0;
  {
    Eigen::VectorXd c;
    if (crossings.size() >= 3 && polyFit(idx, crossings, 0.0, 1, c)) {
      half = c(1);
      double ss = 0.0;
      for (size_t j = 0; j < crossings.size(); ++j) {
        const double r = crossings[j] - (c(0) + c(1) * idx[j]);
        ss += r * r;
      }
      fit_rms = std::sqrt(ss / std::max<size_t>(1, crossings.size() - 2));
    } else {
      half = (crossings.back() - crossings.front()) / std::max(1.0, idx.back());
    }
    period = 2.0 * half;
  }
  const double periods_seen = (t.back() - t.front()) / period;
  const int cycles = static_cast<int>(std::floor(idx.back() / 2.0 + 1e-9));
  if (periods_seen < min_cycles - 0.1 || cycles < 1) {
    f.oscillation_found = false;
    f.period_s = 0.0;
    f.cycles = cycles;
    if (periods_seen < min_cycles - 0.1)
      f.message = "oscillation too short: fewer than " + std::to_string(min_cycles) + " full periods in the clip (" +
                  numberText(periods_seen, 2) + " periods of about " + numberText(period, 3) +
                  " s seen); record a longer clip";
    else
      f.message = "no oscillation found: the clip is long enough for " + numberText(periods_seen, 2) +
                  " periods of about " + numberText(period, 3) +
                  " s, but its centre crossings do not form one full regular cycle (irregular or one-sided "
                  "motion)";
    f.confidence = 0.1;
    return f;
  }

  f.oscillation_found = true;
  f.period_s = period;
  f.cycles = cycles;

  // Damping: ln amplitude vs time, common slope with one intercept per side.
  if (tps.size() >= 3) {
    const int m = static_cast<int>(tps.size());
    Eigen::MatrixXd A(m, 3);
    Eigen::VectorXd b(m);
    int rows = 0;
    int nplus = 0, nminus = 0;
    for (const auto& tp : tps) {
      const double a = tp.side * (tp.value - eq);
      if (!(a > 0.0)) continue;
      A(rows, 0) = tp.t - t.front();
      A(rows, 1) = tp.side > 0 ? 1.0 : 0.0;
      A(rows, 2) = tp.side > 0 ? 0.0 : 1.0;
      b(rows) = std::log(a);
      (tp.side > 0 ? nplus : nminus)++;
      ++rows;
    }
    if (rows >= 3) {
      Eigen::MatrixXd Ar = A.topRows(rows);
      Eigen::VectorXd br = b.head(rows);
      if (nplus == 0 || nminus == 0) {  // one side only: single intercept
        Ar.col(1).setOnes();
        Ar.conservativeResize(rows, 2);
      }
      const Eigen::VectorXd c = Ar.colPivHouseholderQr().solve(br);
      if (c.allFinite()) {
        const double lambda = -c(0);
        f.log_decrement = lambda * period;
        f.damping_ratio = f.log_decrement / std::sqrt(4.0 * kPi * kPi + f.log_decrement * f.log_decrement);
      }
    }
  }

  // Cross-check with the autocorrelation peak.
  const double T_ac = autocorrelationPeriod(t, y, eq, period, dt);
  double ac_factor = 0.7;
  std::string note;
  if (T_ac > 0.0) {
    const double rel = std::abs(T_ac - period) / period;
    ac_factor = std::exp(-(rel / 0.03) * (rel / 0.03));
    ac_factor = std::max(0.3, ac_factor);
    if (rel > 0.03)
      note = "; autocorrelation period " + numberText(T_ac, 4) + " s differs by " + numberText(100.0 * rel, 2) + " %";
  } else {
    note = "; autocorrelation check not available";
  }

  // Confidence: regularity of the half periods, signal-to-noise, number of cycles, cross-check.
  double cv = 0.0;
  if (crossings.size() >= 3) {
    std::vector<double> d;
    for (size_t j = 1; j < crossings.size(); ++j)
      d.push_back((crossings[j] - crossings[j - 1]) / std::max(1.0, idx[j] - idx[j - 1]));
    const double mean = std::accumulate(d.begin(), d.end(), 0.0) / d.size();
    double var = 0.0;
    for (double v : d) var += (v - mean) * (v - mean);
    cv = std::sqrt(var / d.size()) / mean;
  }
  bool missed = false;
  for (size_t j = 1; j < idx.size(); ++j)
    if (idx[j] - idx[j - 1] != 1.0) missed = true;
  const double regularity = 1.0 / (1.0 + (cv / 0.05) * (cv / 0.05));
  const double snr = sigma > 0.0 ? f.amplitude_deg / sigma : 1e6;
  const double snr_factor = 1.0 - std::exp(-snr / 5.0);
  const double cycle_factor = std::min(1.0, periods_seen / (1.5 * min_cycles));
  f.confidence =
      std::max(0.0, std::min(1.0, regularity * snr_factor * cycle_factor * ac_factor * (missed ? 0.8 : 1.0)));
  f.message = "oscillation: " + std::to_string(f.cycles) + " full cycles, period " + numberText(period, 5) +
              " s (crossing fit rms " + numberText(1000.0 * fit_rms, 3) + " ms), amplitude " +
              numberText(f.amplitude_deg, 3) + " deg, noise " + numberText(sigma, 3) + " deg" + note +
              (missed ? "; some crossings were missed" : "");
  return f;
}

StaticPose analyseStatic(const std::vector<double>& y) {
  if (y.empty()) throw TopoError("static pose", "no samples", "track at least one frame");
  for (size_t i = 0; i < y.size(); ++i)
    if (!std::isfinite(y[i]))
      throw TopoError("static pose", "angle sample " + std::to_string(i) + " is not finite (NaN/inf)",
                      "drop frames where the tracker lost the object");
  StaticPose p;
  p.angle_deg = median(y);
  p.spread_deg = 1.4826 * mad(y, p.angle_deg);
  // 1 for a perfectly steady pose, 0.5 at 2 deg spread; fewer samples lower it slightly.
  const double spread_factor = 1.0 / (1.0 + (p.spread_deg / 2.0) * (p.spread_deg / 2.0));
  const double count_factor = std::min(1.0, static_cast<double>(y.size()) / 10.0);
  p.confidence = spread_factor * (0.5 + 0.5 * count_factor);
  return p;
}

}  // namespace topo_gaussian::vision
