// The primitives of oscillation analysis, shared by the tracker's signal analysis
// (vision/signal_analysis.h: irregular, noisy samples) and the tasks' differentiable analysis of
// simulated signals (inference/oscillation.h: uniform samples, forward-mode duals): a least-squares
// line or parabola through samples, the parabola's vertex (a turning point to sub-sample accuracy),
// local extrema refined that way, the prominence filter for jitter extrema, and equilibrium crossings
// interpolated between the two samples around a sign change. One implementation of turning points
// and crossings. Templated on the signal's scalar S (double or a dual with .value()); times are
// double. Header-only, standard library only.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <type_traits>
#include <vector>

namespace topo_gaussian::oscillation {

inline double valueOfScalar(double x) { return x; }
template <typename S>
double valueOfScalar(const S& x) {
  return x.value();
}

template <typename S>
struct Extremum {
  S time;
  S value;
  bool maximum;
};

/// Least-squares polynomial of `degree` (1 or 2) through (t[i], y[i]), i < n, in τ = t − t_ref:
/// coef[0] + coef[1] τ + coef[2] τ². With exactly degree + 1 samples it is the interpolating one.
/// `hat` (optional): the leverage of the point τ = 0, for scaling residuals. Returns false when the
/// samples do not determine the polynomial (too few, or coincident times).
template <typename S>
bool fitPolynomial(const double* t, const S* y, std::size_t n, double t_ref, int degree, S* coef,
                   double* hat = nullptr) {
  if (degree < 1 || degree > 2 || n < static_cast<std::size_t>(degree) + 1) return false;
  const int m = degree + 1;
  double scale = 0.0;  // τ is scaled to [−1, 1] for conditioning
  for (std::size_t i = 0; i < n; ++i) scale = std::max(scale, std::abs(t[i] - t_ref));
  if (!(scale > 0.0)) return false;
  // Normal equations N c = r (N from the times only, so it is double even when y is a dual).
  double N[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
  S r[3] = {S(0), S(0), S(0)};
  for (std::size_t i = 0; i < n; ++i) {
    const double tau = (t[i] - t_ref) / scale;
    double p[3] = {1.0, tau, tau * tau};
    for (int a = 0; a < m; ++a) {
      r[a] = r[a] + p[a] * y[i];
      for (int b = 0; b < m; ++b) N[a][b] += p[a] * p[b];
    }
  }
  // Gaussian elimination with partial pivoting; a pivot that vanishes against the matrix is singular.
  double norm = 0.0;
  for (int a = 0; a < m; ++a)
    for (int b = 0; b < m; ++b) norm = std::max(norm, std::abs(N[a][b]));
  int perm[3] = {0, 1, 2};
  double L[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
  for (int k = 0; k < m; ++k) {
    int piv = k;
    for (int a = k + 1; a < m; ++a)
      if (std::abs(N[a][k]) > std::abs(N[piv][k])) piv = a;
    if (!(std::abs(N[piv][k]) > 1e-12 * norm)) return false;
    if (piv != k) {
      for (int b = 0; b < m; ++b) std::swap(N[k][b], N[piv][b]);
      for (int b = 0; b < k; ++b) std::swap(L[k][b], L[piv][b]);
      std::swap(perm[k], perm[piv]);
    }
    for (int a = k + 1; a < m; ++a) {
      L[a][k] = N[a][k] / N[k][k];
      for (int b = k; b < m; ++b) N[a][b] -= L[a][k] * N[k][b];
    }
  }
  // Solves (P^-1 L U) x = rhs for a right-hand side of scalar T.
  auto solve = [&](auto rhs, auto* x) {
    using T = std::decay_t<decltype(rhs[0])>;
    T z[3] = {rhs[perm[0]], m > 1 ? rhs[perm[1]] : T(0), m > 2 ? rhs[perm[2]] : T(0)};
    for (int a = 0; a < m; ++a)
      for (int b = 0; b < a; ++b) z[a] = z[a] - L[a][b] * z[b];
    for (int a = m - 1; a >= 0; --a) {
      T v = z[a];
      for (int b = a + 1; b < m; ++b) v = v - N[a][b] * x[b];
      x[a] = v / N[a][a];
    }
  };
  S c[3];
  solve(r, c);
  for (int a = 0; a < m; ++a)
    if (!std::isfinite(valueOfScalar(c[a]))) return false;
  if (hat) {
    const double e0[3] = {1.0, 0.0, 0.0};
    double x[3];
    solve(e0, x);
    *hat = x[0];
  }
  double s = 1.0;
  for (int a = 0; a < m; ++a) {
    coef[a] = c[a] / s;
    s *= scale;
  }
  return true;
}

/// Vertex of c0 + c1 τ + c2 τ² (c2 ≠ 0): its offset τ and value.
template <typename S>
void parabolaVertex(const S* c, S& tau, S& value) {
  tau = -c[1] / (2.0 * c[2]);
  value = c[0] - c[1] * c[1] / (4.0 * c[2]);
}

/// Interior local extrema of y at times t(i) (a callable: uniform t0 + i·dt or a sample array), each
/// refined by the parabola through its sample and the two neighbours.
template <typename S, typename TimeAt>
std::vector<Extremum<S>> findExtrema(const std::vector<S>& y, const TimeAt& t) {
  std::vector<Extremum<S>> out;
  for (std::size_t k = 1; k + 1 < y.size(); ++k) {
    const double a = valueOfScalar(y[k - 1]), b = valueOfScalar(y[k]), c = valueOfScalar(y[k + 1]);
    const bool mx = b > a && b >= c, mn = b < a && b <= c;
    if (!mx && !mn) continue;
    const double ts[3] = {t(k - 1), t(k), t(k + 1)};
    S coef[3];
    S tau = S(0), value = y[k];
    if (fitPolynomial(ts, &y[k - 1], 3, ts[1], 2, coef) && std::abs(valueOfScalar(coef[2])) > 1e-300)
      parabolaVertex(coef, tau, value);
    out.push_back(Extremum<S>{ts[1] + tau, value, mx});
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

/// Where the line through (ta, a) and (tb, b) is zero; a and b are the signal minus the level at
/// two neighbouring samples, on opposite sides (isSignChange).
template <typename S>
S crossingTime(double ta, const S& a, double tb, const S& b) {
  return ta + (tb - ta) * a / (a - b);
}

/// Whether the signal minus the level changes side between two neighbouring samples (zero counts as
/// below, so a touch is one crossing and a ≠ b).
inline bool isSignChange(double a, double b) { return (a <= 0) != (b <= 0); }

}  // namespace topo_gaussian::oscillation
