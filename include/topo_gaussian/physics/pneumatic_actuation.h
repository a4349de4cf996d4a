// Pneumatic actuation (paper §"Actuation model", Luo et al. 2022): the air in a chamber does work
// on the material it inflates. Discretised over the chamber particles (weights w_i ∈ [0, 1], the
// topology indicator of the chamber) with the SPH deformation gradient F̃_i:
//
//   E_a(x) = −p Σ_i w_i V_i (det F̃_i − 1)
//
// Sign convention: p is the gauge pressure [Pa]; p > 0 inflates (the chamber's deformed volume
// Σ w_i V_i det F̃_i grows, which lowers E_a). The paper writes E_a = Σ p|F_i|V_i with the
// opposite sign convention for p. The force −∂E_a/∂x is conservative and its Hessian is exact
// (d cof F), so it enters implicit steps and adjoints like the elastic energy.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "topo_gaussian/physics/corotated_sph.h"

namespace topo_gaussian {

struct PneumaticActuation {
  std::vector<double> chamber;  ///< w_i per particle (empty = no actuation)
  double pressure_pa = 0.0;     ///< final gauge pressure p [Pa]
  double ramp_s = 0.0;          ///< p(t) = p · min(1, t / ramp_s); 0 = applied at once

  bool active() const { return !chamber.empty() && pressure_pa != 0.0; }
  double pressureAt(double t_s) const;
  /// Throws TopoError when the weights do not match n particles or a value is not finite.
  void validate(std::size_t n) const;

  /// E_a at the state of sph's last update().
  double energy(const CorotatedSph& sph, double p) const;
  /// Chamber volume Σ w_i V_i det F̃_i [m³].
  double chamberVolume(const CorotatedSph& sph) const;
  /// f += −∂E_a/∂x.
  void addForces(const CorotatedSph& sph, double p, std::vector<Eigen::Vector3d>* f) const;
  /// out += (∂²E_a/∂x²) dx.
  void addHessianProduct(const CorotatedSph& sph, double p, const std::vector<Eigen::Vector3d>& dx,
                         std::vector<Eigen::Vector3d>* out) const;
  /// d[i] = a · ∂(∂E_a/∂x)/∂w_i (mixed derivative, for adjoints).
  std::vector<double> chamberDirectional(const CorotatedSph& sph, double p,
                                         const std::vector<Eigen::Vector3d>& a) const;
  /// ∂E_a/∂w_i.
  std::vector<double> chamberEnergies(const CorotatedSph& sph, double p) const;
};

/// cof(F) = det(F) F⁻ᵀ (columns f₂×f₃, f₃×f₁, f₁×f₂), the derivative of det F.
Eigen::Matrix3d cofactor(const Eigen::Matrix3d& F);
/// Its differential along dF.
Eigen::Matrix3d cofactorDifferential(const Eigen::Matrix3d& F, const Eigen::Matrix3d& dF);

}  // namespace topo_gaussian
