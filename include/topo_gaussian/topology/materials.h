// Materials from the indicator (DESIGN "Physics"): a per-particle property interpolated between
// the value at r = 0 (material A, e.g. hollow) and at r = 1 (material B, e.g. solid) with a
// SIMP-style power p and a small floor so nothing becomes massless or singular:
//   q_i = max(floor, q_A + r_i^p (q_B − q_A)).
// Continuous mode (the paper's ablation): r is used directly as a fraction, p = 1, and results are
// not binarised when reported.
#pragma once

#include <vector>

namespace topo_gaussian {

struct MaterialInterpolation {
  double value_r0 = 0.0;     ///< e.g. density of the hollow material [kg/m³]
  double value_r1 = 1000.0;  ///< e.g. density of the solid material [kg/m³]
  double power = 1.0;        ///< p ≥ 1
  double floor = 1e-3;       ///< lower bound of the result, in the same unit (> 0)
  bool continuous = false;   ///< r is a material fraction (forces p = 1)

  /// Throws TopoError naming `what` for non-finite values, power < 1, floor ≤ 0 or a negative value.
  void validate(const char* what) const;
  double value(double r) const;
  double derivative(double r) const;  ///< dq/dr (0 where the floor is active)
  /// q_i and dq_i/dr_i for all particles (resizes both; dq may be null).
  void apply(const std::vector<double>& r, std::vector<double>* q, std::vector<double>* dq) const;
};

}  // namespace topo_gaussian
