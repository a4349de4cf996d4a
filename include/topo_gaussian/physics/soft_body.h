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
// dt = 1.2 Δx/c and blew up at 1.5 Δx/c, so the estimate keeps a margin of about 1.5–1.9×
// (test StableTimeStepIsBelowTheLeapfrogLimit compares it with 2/ω_max from power iteration).
// Second-order kernel gradients raise ω_max by 2.37×; the estimate is divided by that factor.
//
// Quasi-static mode: relaxToEquilibrium() minimises by FIRE (fast inertial relaxation engine,
// Bitzek et al. 2006), a damped dynamic relaxation with adaptive step and velocity mixing.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "topo_gaussian/physics/corotated_sph.h"
#include "topo_gaussian/physics/newton_solver.h"
#include "topo_gaussian/physics/pneumatic_actuation.h"
#include "topo_gaussian/physics/rest_factor_reuse.h"
#include "topo_gaussian/physics/rest_stiffness.h"
#include "topo_gaussian/physics/run_limits.h"
#include "topo_gaussian/physics/soft_contact.h"

namespace topo_gaussian {

class SoftBodySimulator;

/// The stiffness product computed outside this library (the GPU under backend cuda:
/// cuda/soft_stiffness_cuda.h), which the physics cannot call itself (module layering).
class ExternalStiffness {
 public:
  virtual ~ExternalStiffness() = default;
  /// The state the products are taken at: positions (clamped particles at rest), the clock, and the
  /// chamber's pressure schedule now (pressure_pa reached after ramp_s; PneumaticActuation).
  virtual void setState(const std::vector<Eigen::Vector3d>& x, double time_s, double pressure_pa, double ramp_s) = 0;
  /// out = (∂²(E_el + E_a)/∂x²) p at that state (elastic, hourglass and chamber terms; no contact);
  /// the rows and columns of clamped particles are the caller's business.
  virtual void product(const Eigen::VectorXd& p, Eigen::VectorXd* out) = 0;
};
/// Builds one for a simulator's body (masses, materials, clamps, chamber): called again after any of
/// them changes. Throws TopoError when it cannot (no device, too little memory).
using ExternalStiffnessFactory = std::function<std::unique_ptr<ExternalStiffness>(const SoftBodySimulator&)>;

struct SoftBodyOptions {
  Eigen::Vector3d gravity = Eigen::Vector3d(0.0, 0.0, -9.81);  ///< [m/s²], world z-up
  /// Mass-proportional damping coefficient c [1/s]: force −c m_i v_i. 0 = undamped.
  double damping = 0.0;
  /// CFL factor of stableTimeStep() (see the header comment).
  double cfl = 0.8;
  /// Preconditioner of every linear solve (Newton steps, adjoints, modal analysis): the Cholesky
  /// factor of the rest stiffness (+ inertia), rest_stiffness.h, factorised once per material and
  /// inertia, for bodies of up to this many particles whose factor fits cholesky_max_factor_bytes;
  /// Jacobi otherwise (thousands of CG iterations a Newton step on a slender body: preconditionerNote()
  /// says why). 0 = always Jacobi.
  std::size_t cholesky_max_particles = 500000;
  /// Most memory of the Cholesky preconditioner [bytes]: the assembled rest stiffness and its factor,
  /// predicted before they are computed (rest_stiffness.h). ≤ 0 (default): half the memory available
  /// when it is built (/proc/meminfo; no limit where the system does not say).
  double cholesky_max_factor_bytes = 0.0;
  /// Where the rest stiffness's factor is computed and applied instead of the host (backend cuda: a
  /// dense Cholesky on the GPU, cuda/dense_cholesky_cuda.h; the tasks set it). Empty: the host. When it
  /// refuses (too little GPU memory), the host factorises and preconditionerNote() says why, unless
  /// cholesky_external_required (backend cuda asked for explicitly): then the refusal is the error.
  CholeskySolverFactory cholesky_external;
  bool cholesky_external_required = false;
  /// Where the linear solves' stiffness products (systemProduct: Newton's CG, the adjoints) are
  /// computed instead of the host (backend cuda: cuda/soft_stiffness_cuda.h); the forces and energies
  /// stay on the host. Not used while the body has contact (its Hessian is the host's). When it fails,
  /// the host computes them from then on and preconditionerNote() says why, unless
  /// cholesky_external_required: then the failure is the error (ExternalFactorRefused).
  ExternalStiffnessFactory stiffness_external;
  /// Shared by the simulators of one body's designs (an inference's tasks set it): the rest stiffness's
  /// factor of an earlier design preconditions the next one's solves until a new factor costs less than
  /// the extra iterations (rest_factor_reuse.h). Null: every simulator factorises its own.
  std::shared_ptr<RestFactorReuse> rest_factor_reuse;
  /// Polled every step (explicit, implicit), every Newton line-search evaluation, FIRE iteration and
  /// SoftRollout step; true throws SimulationCancelled (physics/run_limits.h).
  StopCheck should_stop;
};

struct RelaxResult {
  bool converged = false;
  int iterations = 0;
  /// max_i |f_net,i| / force scale over free particles (see relaxToEquilibrium()).
  double residual = 0.0;
  std::vector<Eigen::Vector3d> x;  ///< the relaxed positions (also set on the simulator)
};

/// Result of an implicit step or a quasi-static solve.
struct SolveReport {
  NewtonResult newton;  ///< of the last Newton solve
  double pressure_pa = 0.0;
  int load_increments = 1;  ///< static solves: converged load increments (more than asked after halvings)
  /// solveStaticFrom(): Newton converged from the given guess at the full load (else the state it was
  /// given was the equilibrium already, or it was solved from there with the load steps, the guess's
  /// iterations in guess_iterations)
  bool from_guess = false;
  int guess_iterations = 0;  ///< Newton iterations spent from the guess (also when it did not converge)
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
  /// Conservative forces at the current positions: elastic + actuation (at pressureNow()) + contact
  /// normal forces (no gravity, damping or friction).
  const std::vector<Eigen::Vector3d>& conservativeForces() const { return f_cons_; }

  // ------------------------------------------------------------ design (what inference varies)
  /// Per-particle masses [kg] (default ρ0 V_i). Throws TopoError for a size mismatch or m ≤ 0.
  void setMasses(const std::vector<double>& m);
  /// Per-particle Lamé parameters [Pa]; updates the stability limit.
  void setMaterial(const std::vector<double>& mu, const std::vector<double>& lambda);
  /// Pneumatic chamber and pressure schedule (see pneumatic_actuation.h).
  void setActuation(const PneumaticActuation& actuation);
  const PneumaticActuation& actuation() const { return act_; }
  double pressureNow() const { return act_.pressureAt(time_); }
  /// Ground / clamp contact. A stiffness ≤ 0 is set to max(λ+2μ) × spacing [N/m] (the stiffness of
  /// one particle's worth of the stiffest material).
  void setContact(const SoftContact& contact);
  const SoftContact& contact() const { return contact_; }
  /// Sets the clock (the pressure schedule reads it); steps advance it.
  void setTime(double t_s);

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
  /// Implicit Euler step (paper appendix A.2): x_{n+1} minimises the incremental potential
  ///   ½|x − x_n − dt v_n|²_M / dt² + ½ (c/dt)|x − x_n|²_M + E_el(x) + E_a(x; p(t_{n+1})) + E_c(x)
  ///   − Σ m_i g·x_i − f_friction(x_n, v_n)·x
  /// by Newton's method with matrix-free PCG (systemPreconditioner()) and a backtracking line search; v_{n+1} =
  /// (x_{n+1} − x_n)/dt. Any dt > 0 is accepted. Requires a conservative elastic model (StVK, or corotated linear with
  /// SphRotationSource::CorrectedGradient). Throws TopoError naming the step and the Newton residual when Newton does
  /// not converge (the state is left at the start of the step).
  SolveReport stepImplicit(double dt, const NewtonOptions& newton = NewtonOptions());
  /// Quasi-static equilibrium at the current pressure and gravity by Newton (load stepping over
  /// `load_steps` equal increments of gravity and pressure; an increment that fails is retried
  /// from the last equilibrium with half the increment, down to 1/8 of it). Throws TopoError
  /// naming the load reached and the last failure when even that fails.
  SolveReport solveStatic(const NewtonOptions& newton = NewtonOptions(), int load_steps = 1);
  /// solveStatic() started from a guess of the equilibrium, e.g. the equilibrium of the design before
  /// this one in an inference: Newton at the full load from `guess` (clamped particles at rest), at
  /// most `guess_iterations` iterations; when that does not converge (or the guess is inverted or
  /// not finite), solveStatic(newton, load_steps) from the state the simulator had; that state is
  /// kept when it is the equilibrium at the full load already (e.g. the rest shape of a design
  /// without a chamber). On an exception (cancelled, a refused GPU factor) the simulator is left in
  /// the state it was given. The equilibrium is
  /// the same to Newton's tolerance (a neighbouring design's equilibrium is 3-5 Newton iterations
  /// from the next, against ~10 for the load steps from rest).
  SolveReport solveStaticFrom(const std::vector<Eigen::Vector3d>& guess, const NewtonOptions& newton, int load_steps,
                              int guess_iterations = 8);

  // ------------------------------------------------------------ kernels for the adjoint (soft_rollout.h)
  /// Evaluate the state at positions x (clamped particles forced to rest) and time t.
  void evaluateAt(const std::vector<Eigen::Vector3d>& x, double t_s);
  /// As evaluateAt() for a state whose conservative forces are already known (a forward pass
  /// computed them at the same x and t): the SPH state only (no force gather), conservativeForces()
  /// set to f_cons. For the adjoint sweep of SoftRollout; elasticForces() throws until the next step.
  void evaluateStateAt(const std::vector<Eigen::Vector3d>& x, double t_s, const std::vector<Eigen::Vector3d>& f_cons);
  /// (∂²Φ/∂x²) dx at the current state, Φ = elastic + actuation + contact normal potential; rows and
  /// columns of clamped particles are zero.
  std::vector<Eigen::Vector3d> stiffnessProduct(const std::vector<Eigen::Vector3d>& dx) const;
  /// stiffnessProduct(dx) and the SPH material directional derivatives along the same (clamp-zeroed)
  /// dx (CorotatedSph::materialDirectional) in one pass.
  std::vector<Eigen::Vector3d> stiffnessProduct(const std::vector<Eigen::Vector3d>& dx, std::vector<double>* d_mu,
                                                std::vector<double>* d_lambda) const;
  /// Flat (3N) form for linear solves: out = (∂²Φ/∂x² + inertia·M) p, clamped rows zero.
  void systemProduct(const Eigen::VectorXd& p, double inertia, Eigen::VectorXd* out) const;
  /// Jacobi approximation of that system's diagonal: inertia·m_i + (λ_i+2μ_i)V_i/h² + the contact
  /// diagonal (1 on clamped rows).
  Eigen::VectorXd systemDiagonal(double inertia) const;
  /// Preconditioner of that system: (K0 + inertia·M)⁻¹ by the rest stiffness's Cholesky factor
  /// (cached per material, masses, clamps and inertia; contact is left to CG) when the body has at
  /// most options().cholesky_max_particles particles and the factor fits
  /// options().cholesky_max_factor_bytes, else Jacobi on systemDiagonal().
  LinearOperator systemPreconditioner(double inertia) const;
  /// Why the last systemPreconditioner() is Jacobi and not the Cholesky factor (the limit that
  /// refused it, with the fix), or why the factor is on the host and not where
  /// options().cholesky_external puts it; empty when it is the factor where asked or none was built yet.
  const std::string& preconditionerNote() const { return preconditioner_note_; }
  /// Where the last systemPreconditioner()'s factor is (RestStiffnessPreconditioner::where()); empty
  /// for Jacobi or before the first.
  std::string preconditionerWhere() const { return rest_factor_ ? rest_factor_->where() : std::string(); }
  /// Friction forces at the current positions for velocities v.
  std::vector<Eigen::Vector3d> frictionForces(const std::vector<Eigen::Vector3d>& v) const;
  /// Lowest natural frequency [Hz] of small vibrations about the current state (clamps respected):
  /// inverse iteration on K φ = ω² M φ with K the stiffnessProduct (each solve by PCG), started from
  /// the static deflection under gravity (or a uniform field). Throws TopoError when the body is
  /// unsupported (K singular) or the iteration does not settle to `tolerance` (relative change of ω).
  double firstNaturalFrequency(double tolerance = 1e-6, int max_iterations = 50) const;
  /// Highest natural frequency [rad/s] by power iteration on M⁻¹K (the explicit stability limit of
  /// leapfrog is 2/ω_max).
  double maxAngularFrequency(int iterations = 200) const;

  /// Largest load per particle [N] (gravity, pressure, elastic scale): the Newton force scale.
  double forceScale() const;
  /// The round-off floor of the Newton gradient [N] at the current positions for a system with this
  /// inertia (0 static, 1/dt² + c/dt implicit): 64 ε |x|∞ max_i D_ii over free particles, D the
  /// Jacobi diagonal (systemDiagonal). Newton declares convergence at max(tolerance × forceScale(),
  /// this) (newton_solver.h).
  double roundoffForce(double inertia) const;

  /// Advances by `duration` seconds in ceil(duration / (safety·stableTimeStep())) equal steps;
  /// refuses (TopoError, before the first step) more than the step budget of run_limits.h.
  void advance(double duration, double safety = 0.5);
  long stepCount() const { return steps_; }
  double time() const { return time_; }

  /// cfl × Δx / c_max (see header comment) [s].
  double stableTimeStep() const { return dt_stable_; }
  double waveSpeed() const { return c_max_; }  ///< c_max [m/s]
  double spacing() const { return dx_; }       ///< Δx [m]

  double kineticEnergy() const;                           ///< ½ Σ m_i |v_i|²
  double gravitationalEnergy() const;                     ///< −Σ m_i g·x_i (zero at the origin)
  double elasticEnergy() const { return sph_.energy(); }  ///< elastic + hourglass (the force potential)
  double actuationEnergy() const { return act_.energy(sph_, pressureNow()); }
  double contactEnergy() const { return contact_.energy(x_); }
  /// Kinetic + gravitational + elastic + actuation + contact.
  double totalEnergy() const {
    return kineticEnergy() + gravitationalEnergy() + elasticEnergy() + actuationEnergy() + contactEnergy();
  }

  /// Quasi-static equilibrium under the current gravity by FIRE. residual = max over free particles
  /// of |f_el,i + m_i g| divided by the force scale max(max_i m_i|g|, max_i |f_el,i|) (relative, 1 =
  /// the size of the loads). Converged when residual ≤ tolerance; leaves velocities 0 and the
  /// simulator at the relaxed state. Throws TopoError when it does not converge in max_steps (the
  /// simulator keeps the last state), for tolerance ≤ 0 or max_steps ≤ 0.
  RelaxResult relaxToEquilibrium(double tolerance = 1e-6, int max_steps = 200000);

 private:
  /// The SPH state and conservative forces at x_; with known_forces (evaluateStateAt) the SPH state
  /// only, and those forces.
  void refreshForces(const std::string& where, const std::vector<Eigen::Vector3d>* known_forces = nullptr);
  /// Ψ_static at the current (refreshed) state: elastic + actuation at pressureNow() + contact normal
  /// energy − Σ m_i g·x_i over free particles (newtonSolve's objective without the inertia terms).
  double staticPotential() const;
  void invalidateRestFactor() {
    rest_factor_.reset();
    rest_factor_inertia_ = -1.0;
    ext_stiffness_.reset();
    ext_version_ = -1;
  }
  void enforceClamp();
  double residual() const;
  void updateStability();
  void requireConservative(const std::string& where) const;
  SolveReport newtonSolve(const std::string& where, double dt, const std::vector<Eigen::Vector3d>& x0,
                          const std::vector<Eigen::Vector3d>& v0, const NewtonOptions& newton);

  CorotatedSph sph_;
  SoftBodyOptions opt_;
  std::vector<double> m_;
  std::vector<Eigen::Vector3d> x_, v_, f_cons_;
  std::vector<std::uint8_t> clamped_;
  PneumaticActuation act_;
  SoftContact contact_;
  double dx_ = 0.0, c_max_ = 0.0, dt_stable_ = 0.0, time_ = 0.0;
  double dx_typical_ = 0.0;  ///< cube root of the median particle volume [m]: the automatic contact stiffness scale
  long steps_ = 0;
  /// Cholesky factor for rest_factor_inertia_ (< 0: none yet; null with inertia ≥ 0: K0 + inertia·M
  /// is singular, Jacobi is used). Reset when masses, materials or clamps change.
  mutable std::shared_ptr<const RestStiffnessPreconditioner> rest_factor_;
  /// The external stiffness product (options().stiffness_external), built at the first product after
  /// the body changed; ext_version_ is the state_version_ it was last given (−1: none).
  mutable std::unique_ptr<ExternalStiffness> ext_stiffness_;
  mutable long ext_version_ = -1;
  mutable double ext_time_ = 0.0, ext_pressure_ = 0.0, ext_ramp_ = 0.0;
  mutable bool ext_failed_ = false;
  long state_version_ = 0;  ///< bumped whenever the forces are re-evaluated (refreshForces)
  mutable double rest_factor_inertia_ = -1.0;
  /// This simulator among all (RestFactorReuse tells one use of a kept factor from the next by it).
  std::uint64_t serial_ = 0;
  mutable std::string preconditioner_note_;
};

}  // namespace topo_gaussian
