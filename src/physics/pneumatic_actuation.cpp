// Pneumatic actuation energy; see pneumatic_actuation.h.
#include "topo_gaussian/physics/pneumatic_actuation.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "topo_gaussian/common/error.h"

namespace topo_gaussian {

Eigen::Matrix3d cofactor(const Eigen::Matrix3d& F) {
  Eigen::Matrix3d C;
  C.col(0) = F.col(1).cross(F.col(2));
  C.col(1) = F.col(2).cross(F.col(0));
  C.col(2) = F.col(0).cross(F.col(1));
  return C;
}

Eigen::Matrix3d cofactorDifferential(const Eigen::Matrix3d& F, const Eigen::Matrix3d& dF) {
  Eigen::Matrix3d C;
  C.col(0) = dF.col(1).cross(F.col(2)) + F.col(1).cross(dF.col(2));
  C.col(1) = dF.col(2).cross(F.col(0)) + F.col(2).cross(dF.col(0));
  C.col(2) = dF.col(0).cross(F.col(1)) + F.col(0).cross(dF.col(1));
  return C;
}

double PneumaticActuation::pressureAt(double t) const {
  if (ramp_s <= 0.0) return pressure_pa;
  return pressure_pa * std::clamp(t / ramp_s, 0.0, 1.0);
}

void PneumaticActuation::validate(std::size_t n) const {
  if (!std::isfinite(pressure_pa) || !std::isfinite(ramp_s) || ramp_s < 0.0)
    throw TopoError("pneumatic actuation", "pressure or ramp time is not finite (or the ramp is negative)",
                    "give a finite pressure [Pa] and ramp_s >= 0");
  if (chamber.empty()) return;
  if (chamber.size() != n)
    throw TopoError("pneumatic actuation",
                    std::to_string(chamber.size()) + " chamber weights for " + std::to_string(n) + " particles",
                    "give one weight in [0, 1] per particle");
  for (std::size_t i = 0; i < n; ++i)
    if (!std::isfinite(chamber[i]))
      throw TopoError("pneumatic actuation", "chamber weight " + std::to_string(i) + " is not finite",
                      "give weights in [0, 1]");
}

double PneumaticActuation::energy(const CorotatedSph& sph, double p) const {
  if (chamber.empty() || p == 0.0) return 0.0;
  double e = 0.0;
  for (std::size_t i = 0; i < sph.size(); ++i)
    if (chamber[i] != 0.0) e -= p * chamber[i] * sph.volumes()[i] * (sph.deformationGradient(i).determinant() - 1.0);
  return e;
}

double PneumaticActuation::chamberVolume(const CorotatedSph& sph) const {
  double v = 0.0;
  for (std::size_t i = 0; i < chamber.size(); ++i)
    v += chamber[i] * sph.volumes()[i] * sph.deformationGradient(i).determinant();
  return v;
}

void PneumaticActuation::addForces(const CorotatedSph& sph, double p, std::vector<Eigen::Vector3d>* f) const {
  if (chamber.empty() || p == 0.0) return;
  std::vector<Eigen::Matrix3d> G(sph.size());
  for (std::size_t i = 0; i < sph.size(); ++i)
    G[i] = (-p * chamber[i] * sph.volumes()[i]) * cofactor(sph.deformationGradient(i));
  const auto grad = sph.stressDivergence(G);  // ∂E_a/∂x
  for (std::size_t i = 0; i < sph.size(); ++i) (*f)[i] -= grad[i];
}

void PneumaticActuation::addHessianProduct(const CorotatedSph& sph, double p, const std::vector<Eigen::Vector3d>& dx,
                                           std::vector<Eigen::Vector3d>* out) const {
  if (chamber.empty() || p == 0.0) return;
  const auto dF = sph.gradientField(dx);
  std::vector<Eigen::Matrix3d> G(sph.size());
  for (std::size_t i = 0; i < sph.size(); ++i)
    G[i] = (-p * chamber[i] * sph.volumes()[i]) * cofactorDifferential(sph.deformationGradient(i), dF[i]);
  const auto h = sph.stressDivergence(G);
  for (std::size_t i = 0; i < sph.size(); ++i) (*out)[i] += h[i];
}

std::vector<double> PneumaticActuation::chamberDirectional(const CorotatedSph& sph, double p,
                                                           const std::vector<Eigen::Vector3d>& a) const {
  std::vector<double> d(sph.size(), 0.0);
  if (p == 0.0) return d;
  const auto dF = sph.gradientField(a);
  for (std::size_t i = 0; i < sph.size(); ++i)
    d[i] = -p * sph.volumes()[i] * (cofactor(sph.deformationGradient(i)).array() * dF[i].array()).sum();
  return d;
}

std::vector<double> PneumaticActuation::chamberEnergies(const CorotatedSph& sph, double p) const {
  std::vector<double> e(sph.size(), 0.0);
  for (std::size_t i = 0; i < sph.size(); ++i)
    e[i] = -p * sph.volumes()[i] * (sph.deformationGradient(i).determinant() - 1.0);
  return e;
}

}  // namespace topo_gaussian
