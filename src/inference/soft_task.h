// Internal: what the soft-body tasks (finger, pear, cantilever) share — the SPH discretisation of
// the volume cloud (built once), the materials from r (Young's modulus and density interpolated
// like the rigid tasks' density; chamber weight 1 − r), and the chain from the simulator's design
// gradient (∂L/∂m_i, ∂L/∂μ_i, ∂L/∂λ_i, ∂L/∂w_i) back to ∂L/∂r_i.
#pragma once

#include <memory>
#include <vector>

#include "topo_gaussian/inference/task.h"
#include "topo_gaussian/physics/soft_rollout.h"

namespace topo_gaussian::inference {

class SoftTask : public Task {
 protected:
  SoftTask(const TaskConfig& config, const VolumeCloud& cloud);

  struct Materials {
    std::vector<double> mass, dmass_dr, mu, dmu_dr, lambda, dlambda_dr, chamber;  ///< chamber w_i = 1 − r_i (finger)
  };
  Materials materials(const std::vector<double>& r, bool with_chamber) const;
  /// A simulator with the design applied (clamps, contact, actuation are the task's business).
  std::unique_ptr<SoftBodySimulator> simulator(const Materials& m) const;
  /// ∂L/∂r_i = ∂L/∂m_i dm_i/dr_i + ∂L/∂μ_i dμ_i/dr_i + ∂L/∂λ_i dλ_i/dr_i − ∂L/∂w_i.
  void chain(const Materials& m, const SoftDesignGradient& g, bool with_chamber, std::vector<double>* dL_dr) const;

  CorotatedSph sph_;  ///< rest discretisation, material replaced per evaluation
  /// The Lamé parameters are interpolated between the two materials' values (from E and ν of each)
  /// with the SIMP power of the stiffness.
  MaterialInterpolation mu_interp_, lambda_interp_;
  double E_solid_ = 0.0, rho_solid_ = 0.0;
  SoftBodyOptions sim_options_;
};

/// ½ Σ (x − X)·… helpers are per task; this one is shared: the CorotatedSph options of a config.
CorotatedSphOptions sphOptionsFromConfig(const TaskConfig& c, double spacing);

}  // namespace topo_gaussian::inference
