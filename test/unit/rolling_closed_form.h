// Closed-form references for rigid bodies rolling without slipping on a plane (tests only; the
// ground truths the user-path rigid tests hold our simulator to, never computed by our model).
//
// Rocking of a body whose bottom is a sphere of radius R (centre O), centre of mass a below O,
// released at rest from tilt A (paper §7 "Wobbly Doll"; the exact large-amplitude period):
//   T(A) = 4 ∫₀^A √( J(θ) / (2 (V(A) − V(θ))) ) dθ,
//   J(θ) = m (R² − 2 R a cos θ + a²) + I_cm     (moment of inertia about the contact point),
//   V(θ) = m g (R − a cos θ)                    (height of the centre of mass × m g).
// The 1/√ singularity at θ = A is removed by θ = A sin φ, φ ∈ [0, π/2]; V(A) − V(θ) is written as
// 2 m g a sin((A+θ)/2) sin((A−θ)/2) so it keeps its digits near θ = A. Small amplitude:
//   T₀ = 2π √((I_cm + m (R − a)²) / (m g a)).
// Solid hemisphere of radius R: a = 3R/8, I_cm = (83/320) m R² about a horizontal axis.
//
// A ball rolling down an incline of angle β: a = g sin β / (1 + I/(m R²)) (solid: 5/7 g sin β).
// A ball dropped with spin ω₀ about a horizontal axis and no horizontal velocity: the ground's
// forces act at the contact point, so the angular momentum about it, I ω + m R v, is conserved
// through the bounces and the skid; once it rolls (v = ω R): v = I ω₀ R / (I + m R²)
// (solid ball: v = (2/7) ω₀ R).
#pragma once

#include <cmath>

namespace topo_test {

constexpr double kRollPi = 3.14159265358979323846;

/// A body with a spherical bottom: sphere radius R [m], centre of mass a [m] below the sphere centre,
/// radius of gyration² about the horizontal axis through the centre of mass k² = I_cm / m [m²].
struct RoundBottom {
  double R = 0.0;
  double a = 0.0;
  double k2 = 0.0;
};

/// Solid hemisphere of radius R (flat face up, sphere centre at the centre of the flat face).
inline RoundBottom solidHemisphere(double R) { return {R, 3.0 * R / 8.0, 83.0 / 320.0 * R * R}; }

/// Mass moments (per unit density) along the symmetry axis z of an axisymmetric body, origin at the
/// sphere centre: volume V, first moment Σ V z, and the second moment about the x axis through the
/// origin Jxx = ∫ (y² + z²) dV.
struct AxialMoments {
  double volume = 0.0, first_z = 0.0, Jxx = 0.0;
  AxialMoments operator-(const AxialMoments& o) const { return {volume - o.volume, first_z - o.first_z, Jxx - o.Jxx}; }
};
/// Solid hemisphere z ≤ 0 of radius R: V = 2/3 π R³, centroid −3R/8, Jxx = 2/5 V R².
inline AxialMoments hemisphereMoments(double R) {
  const double V = 2.0 / 3.0 * kRollPi * R * R * R;
  return {V, -3.0 * R / 8.0 * V, 0.4 * V * R * R};
}
/// Solid sphere of radius R about the origin cut flat at z = c (−R < c < R), the part z ≤ c: with
/// ρ² = R² − z², V = π ∫ ρ² dz, Σ V z = π ∫ ρ² z dz, Jxx = π ∫ (ρ⁴/4 + ρ² z²) dz over [−R, c].
inline AxialMoments truncatedSphereMoments(double R, double c) {
  auto V = [&](double z) { return kRollPi * (R * R * z - z * z * z / 3.0); };
  auto F = [&](double z) { return kRollPi * (R * R * z * z / 2.0 - z * z * z * z / 4.0); };
  auto J = [&](double z) {
    return kRollPi * (R * R * R * R * z / 4.0 + R * R * z * z * z / 6.0 - 3.0 * z * z * z * z * z / 20.0);
  };
  return {V(c) - V(-R), F(c) - F(-R), J(c) - J(-R)};
}
/// Solid ball of radius r centred at (0, 0, z0): Jxx = V (2/5 r² + z0²).
inline AxialMoments ballMoments(double r, double z0) {
  const double V = 4.0 / 3.0 * kRollPi * r * r * r;
  return {V, V * z0, V * (0.4 * r * r + z0 * z0)};
}
/// The round-bottom description of a body with these moments rocking on a sphere of radius R.
inline RoundBottom roundBottomFromMoments(double R, const AxialMoments& m) {
  const double cz = m.first_z / m.volume;
  return {R, -cz, m.Jxx / m.volume - cz * cz};
}

/// Small-amplitude rocking period [s]: T₀ = 2π √((k² + (R − a)²) / (g a)).
inline double smallAmplitudeRockingPeriod(const RoundBottom& b, double g = 9.81) {
  return 2.0 * kRollPi * std::sqrt((b.k2 + (b.R - b.a) * (b.R - b.a)) / (g * b.a));
}

/// Exact rocking period [s] released at rest from amplitude A [rad] (0 < A < π/2), rolling without
/// slipping: T = 4 ∫₀^{π/2} √(J(θ)/(2 m g a (cos θ − cos A))) A cos φ dφ with θ = A sin φ, by composite
/// 16-point Gauss–Legendre on 64 panels (the integrand is smooth in φ; error far below 1e-9 s).
inline double rockingPeriod(const RoundBottom& b, double A, double g = 9.81) {
  if (!(A > 0.0)) return smallAmplitudeRockingPeriod(b, g);
  static const double x16[8] = {0.0950125098376374, 0.2816035507792589, 0.4580167776572274, 0.6178762444026438,
                                0.7554044083550030, 0.8656312023878318, 0.9445750230732326, 0.9894009349916499};
  static const double w16[8] = {0.1894506104550685, 0.1826034150449236, 0.1691565193950025, 0.1495959888165767,
                                0.1246289712555339, 0.0951585116824928, 0.0622535239386479, 0.0271524594117541};
  auto integrand = [&](double phi) {
    const double theta = A * std::sin(phi);
    const double J = b.k2 + b.R * b.R - 2.0 * b.R * b.a * std::cos(theta) + b.a * b.a;            // per unit mass
    const double dV = 2.0 * g * b.a * std::sin(0.5 * (A + theta)) * std::sin(0.5 * (A - theta));  // per unit mass
    // A cos φ / √(sin((A−θ)/2)) stays finite at φ = π/2: write sin((A−θ)/2) with 1 − sin φ = 2 sin²(π/4 − φ/2).
    const double c = std::cos(phi);
    if (dV <= 0.0) {  // φ = π/2 exactly (never a Gauss node): the limit
      return std::sqrt(J / (g * b.a * std::sin(A))) * std::sqrt(A);
    }
    return std::sqrt(J / (2.0 * dV)) * A * c;
  };
  const int panels = 64;
  const double h = 0.5 * kRollPi / panels;
  double sum = 0.0;
  for (int p = 0; p < panels; ++p) {
    const double mid = (p + 0.5) * h;
    for (int k = 0; k < 8; ++k) {
      const double dx = 0.5 * h * x16[k];
      sum += w16[k] * (integrand(mid - dx) + integrand(mid + dx));
    }
  }
  return 4.0 * 0.5 * h * sum;
}

/// Acceleration [m/s²] of a ball (I = k² m about its centre) rolling without slipping down an incline
/// of angle beta [rad]: g sin β / (1 + k²/R²); a solid ball: 5/7 g sin β.
inline double inclineRollingAcceleration(double R, double k2, double beta, double g = 9.81) {
  return g * std::sin(beta) / (1.0 + k2 / (R * R));
}

/// Horizontal speed [m/s] of a ball (I = k² m about its centre) dropped with spin omega0 [rad/s] about
/// a horizontal axis and no horizontal velocity, once it rolls: v = k² ω₀ R / (k² + R²) (solid: 2/7 ω₀ R).
inline double spinDropRollingSpeed(double R, double k2, double omega0) { return k2 * omega0 * R / (k2 + R * R); }

}  // namespace topo_test
