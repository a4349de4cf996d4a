// Soft-body simulator (paper appendix "Soft body dynamics", DESIGN.md "Physics"): particles with
// masses m_i, positions x_i and velocities v_i (structure of arrays) driven by the corotated SPH
// elastic forces of a CorotatedSph, gravity and optional mass-proportional damping, with Dirichlet
// (clamped) particles held at their rest positions.
//
// Passive motion: explicit leapfrog (kick-drift-kick velocity Verlet, symplectic, second order):
//   v ← v + ½dt a(x, v);  x ← x + dt v;  update forces at x;  v ← v + ½dt a(x, v)
// with a = f_el/m + g − c v (c = damping per second, applied explicitly in each half kick).
//
// Stability: step(dt) refuses dt > stableTimeStep() (no silent substepping; the caller chooses
// dt, e.g. 0.5 × stableTimeStep(), or calls advance(), which substeps with a stable dt).
//   stableTimeStep() = cfl × Δx / c_max,  c_max = max_i √((λ_i + 2μ_i)/ρ_i),  ρ_i = m_i / V_i,
//   Δx = ∛(min_i V_i) (the lattice spacing for lattice clouds).
// The default cfl = 0.8 is calibrated on cubic-spline corotated SPH with h = 1.5 Δx and hourglass
// α = 0.1 (cantilever 0.2 × 0.02 × 0.02 m, Δx = 4 mm, E = 1e6, ν = 0.3): leapfrog stayed stable at
// dt = 1.2 Δx/c and blew up at 1.5 Δx/c, so the estimate keeps a margin of about 1.5–1.9×.
//
// Quasi-static mode: relaxToEquilibrium() minimises by FIRE (fast inertial relaxation engine,
// Bitzek et al. 2006), a damped dynamic relaxation with adaptive step and velocity mixing.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "topo_gaussian/physics/corotated_sph.h"

namespace topo_gaussian {

struct SoftBodyOptions {
  Eigen::Vector3d gravity = Eigen::Vector3d(0.0, 0.0, -9.81);  ///< [m/s²], world z-up
  /// Mass-proportional damping coefficient c [1/s]: force −c m_i v_i. 0 = undamped.
  double damping = 0.0;
  /// CFL factor of stableTimeStep() (see the header comment).
  double cfl = 0.8;
};

struct RelaxResult {
  bool converged = false;
  int iterations = 0;
  /// max_i |f_net,i| / force scale over free particles (see relaxToEquilibrium()).
  double residual = 0.0;
  std::vector<Eigen::Vector3d> x;  ///< the relaxed positions (also set on the simulator)
};

class SoftBodySimulator {
 public:
  /// Starts at rest in the rest configuration, no particle clamped. Masses are sph.masses().
  explicit SoftBodySimulator(CorotatedSph sph, const SoftBodyOptions& options = SoftBodyOptions());

  std::size_t size() const { return x_.size(); }
  const SoftBodyOptions& options() const { return opt_; }
  /// Gravity / damping may be changed between steps (e.g. release from a static shape).
  void setGravity(const Eigen::Vector3d& g);
  void setDamping(double per_second);
  const CorotatedSph& sph() const { return sph_; }
  const std::vector<double>& masses() const { return m_; }
  const std::vector<Eigen::Vector3d>& restPositions() const { return sph_.restPositions(); }
  const std::vector<Eigen::Vector3d>& positions() const { return x_; }
  const std::vector<Eigen::Vector3d>& velocities() const { return v_; }
  /// Elastic (+ hourglass) forces at the current positions.
  const std::vector<Eigen::Vector3d>& elasticForces() const { return sph_.forces(); }

  /// Dirichlet mask (1 = clamped): clamped particles are put back at their rest positions with zero
  /// velocity and stay there. Throws TopoError when the size is not size().
  void setClamped(const std::vector<std::uint8_t>& mask);
  const std::vector<std::uint8_t>& clamped() const { return clamped_; }
  std::size_t clampedCount() const;

  /// Set the state (clamped particles are overridden). Throws TopoError on a size mismatch, a
  /// non-finite value or an inverted configuration.
  void setPositions(const std::vector<Eigen::Vector3d>& x);
  void setVelocities(const std::vector<Eigen::Vector3d>& v);

  /// Leapfrog step. Throws TopoError when dt ≤ 0, dt > stableTimeStep() (the message names both and
  /// the fix), or the state becomes non-finite / inverted (the message names the step number).
  void step(double dt);
  /// Advances by `duration` seconds in ceil(duration / (safety·stableTimeStep())) equal steps.
  void advance(double duration, double safety = 0.5);
  long stepCount() const { return steps_; }
  double time() const { return time_; }

  /// cfl × Δx / c_max (see header comment) [s].
  double stableTimeStep() const { return dt_stable_; }
  double waveSpeed() const { return c_max_; }  ///< c_max [m/s]
  double spacing() const { return dx_; }       ///< Δx [m]

  double kineticEnergy() const;        ///< ½ Σ m_i |v_i|²
  double gravitationalEnergy() const;  ///< −Σ m_i g·x_i (zero at the origin)
  double elasticEnergy() const { return sph_.energy(); }  ///< elastic + hourglass (the force potential)
  double totalEnergy() const { return kineticEnergy() + gravitationalEnergy() + elasticEnergy(); }

  /// Quasi-static equilibrium under the current gravity by FIRE. residual = max over free particles
  /// of |f_el,i + m_i g| divided by the force scale max(max_i m_i|g|, max_i |f_el,i|) (relative, 1 =
  /// the size of the loads). Converged when residual ≤ tolerance; leaves velocities 0 and the
  /// simulator at the relaxed state. Throws TopoError when it does not converge in max_steps (the
  /// simulator keeps the last state), for tolerance ≤ 0 or max_steps ≤ 0.
  RelaxResult relaxToEquilibrium(double tolerance = 1e-6, int max_steps = 200000);

 private:
  void refreshForces(const std::string& where);
  void enforceClamp();
  double residual() const;

  CorotatedSph sph_;
  SoftBodyOptions opt_;
  std::vector<double> m_;
  std::vector<Eigen::Vector3d> x_, v_;
  std::vector<std::uint8_t> clamped_;
  double dx_ = 0.0, c_max_ = 0.0, dt_stable_ = 0.0, time_ = 0.0;
  long steps_ = 0;
};

}  // namespace topo_gaussian
