// Test and bench helper: a pneumatic soft body built directly on the physics (no task), so GPU
// parity tests and benches share one setup.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <vector>

#include "test_clouds.h"
#include "topo_gaussian/physics/soft_body.h"

namespace topo_test {

/// The cloud as a StVK corotated-SPH body (rotations from F̃, the spacing the cloud's): the walls of
/// `wall`, the particles with chamber[i] != 0 of `chamber_material` and pressurised to pressure_pa,
/// those with clamp[i] != 0 clamped.
inline std::unique_ptr<topo_gaussian::SoftBodySimulator> pneumaticBody(
    const topo_gaussian::VolumeCloud& cloud, const std::vector<std::uint8_t>& clamp,
    const std::vector<std::uint8_t>& chamber, topo_gaussian::LameParameters wall,
    topo_gaussian::LameParameters chamber_material, double pressure_pa, const topo_gaussian::SoftBodyOptions& so) {
  using namespace topo_gaussian;
  CorotatedSphOptions o;
  o.spacing = cloud.spacing;
  o.model = SphEnergyModel::StVK;
  o.rotation = SphRotationSource::CorrectedGradient;
  CorotatedSph sph = CorotatedSph::fromCloud(cloud, wall, o);
  std::vector<double> mu = sph.shearModuli(), lambda = sph.lameLambdas();
  PneumaticActuation a;
  a.chamber.assign(cloud.size(), 0.0);
  for (std::size_t i = 0; i < cloud.size(); ++i)
    if (chamber[i]) {
      a.chamber[i] = 1.0;
      mu[i] = chamber_material.mu;
      lambda[i] = chamber_material.lambda;
    }
  sph.setMaterial(mu, lambda);
  auto sim = std::make_unique<SoftBodySimulator>(std::move(sph), so);
  sim->setClamped(clamp);
  a.pressure_pa = pressure_pa;
  sim->setActuation(a);
  return sim;
}

/// A cells_x × 4 × 4-cell cantilever of a 5 mm lattice (the finger's kind of problem): walls E 1e7, a
/// pressurised core of E chamber_young reaching chamber_cells cells from x = min, ν 0.45, clamped over
/// clamp_cells cells at x = min, gravity and 2e4 Pa.
inline std::unique_ptr<topo_gaussian::SoftBodySimulator> pneumaticCantilever(int cells_x, double chamber_young,
                                                                             int chamber_cells,
                                                                             const topo_gaussian::SoftBodyOptions& so,
                                                                             int clamp_cells = 1) {
  using namespace topo_gaussian;
  const double d = 0.005;
  const VolumeCloud cloud = boxCloud(cells_x * d, 4 * d, 4 * d, d);
  double xmin = 1e300;
  for (const auto& X : cloud.X) xmin = std::min(xmin, X.x());
  std::vector<std::uint8_t> clamp(cloud.size(), 0), chamber(cloud.size(), 0);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3d& X = cloud.X[i];
    clamp[i] = X.x() < xmin + (clamp_cells + 0.5) * d;
    chamber[i] = !clamp[i] && std::abs(X.y()) < d && X.z() > -d && X.z() < d && X.x() < xmin + chamber_cells * d;
  }
  return pneumaticBody(cloud, clamp, chamber, lameFromYoung(1e7, 0.45), lameFromYoung(chamber_young, 0.45), 2e4, so);
}

}  // namespace topo_test
