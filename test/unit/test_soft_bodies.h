// Test and bench helper: a pneumatic soft body built directly on the physics (no task), so GPU
// parity tests and benches share one setup.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

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

}  // namespace topo_test
