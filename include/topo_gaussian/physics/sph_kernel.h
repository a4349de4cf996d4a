// Cubic spline SPH kernel of Monaghan & Lattanzio (1985), as written in the TopoGaussian paper
// (appendix "Soft body dynamics"):
//
//   W(r, h) = 1/(π h³) · { 1 − 1.5 q² + 0.75 q³   0 ≤ q < 1
//                          0.25 (2 − q)³           1 ≤ q < 2
//                          0                       q ≥ 2 },      q = |r| / h.
//
// Normalised in 3-D (∫ W dV = 1), C², support radius 2h. Header-only.
#pragma once

#include <Eigen/Core>
#include <cmath>

namespace topo_gaussian {

/// Support radius of the cubic spline kernel: W(r, h) = 0 for |r| ≥ 2h.
inline double cubicSplineSupport(double h) { return 2.0 * h; }

/// W(|r|, h).
inline double cubicSplineW(double r, double h) {
  const double q = r / h;
  const double s = 1.0 / (M_PI * h * h * h);
  if (q < 1.0) return s * (1.0 - 1.5 * q * q + 0.75 * q * q * q);
  if (q < 2.0) {
    const double t = 2.0 - q;
    return s * 0.25 * t * t * t;
  }
  return 0.0;
}

/// W(r, h) for a vector argument.
inline double cubicSplineW(const Eigen::Vector3d& r, double h) { return cubicSplineW(r.norm(), h); }

/// dW/d|r| (≤ 0).
inline double cubicSplineDW(double r, double h) {
  const double q = r / h;
  const double s = 1.0 / (M_PI * h * h * h * h);
  if (q < 1.0) return s * (-3.0 * q + 2.25 * q * q);
  if (q < 2.0) {
    const double t = 2.0 - q;
    return s * (-0.75 * t * t);
  }
  return 0.0;
}

/// ∇_r W(r, h) = W'(|r|) r / |r| (zero at r = 0, where the kernel is smooth and flat).
inline Eigen::Vector3d cubicSplineGradW(const Eigen::Vector3d& r, double h) {
  const double n = r.norm();
  if (n <= 0.0) return Eigen::Vector3d::Zero();
  return (cubicSplineDW(n, h) / n) * r;
}

}  // namespace topo_gaussian
