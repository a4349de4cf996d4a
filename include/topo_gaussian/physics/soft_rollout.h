// Differentiable soft-body rollout (paper §"Differentiability"): runs a SoftBodySimulator for a
// number of steps with an explicit (symplectic Euler) or implicit Euler integrator, accumulates a
// loss Σ_k ℓ_k(x_k, v_k), and returns its gradient with respect to the per-particle design — masses
// m_i, Lamé parameters μ_i, λ_i and chamber weights w_i — and the initial state, by reverse mode
// through time:
//   explicit step  v' = v + dt (f(x)/m + f_fr(x, v)/m + g − c v),  x' = x + dt v'
//     adjoint: w = v̄' + dt x̄',  a = dt w / m,  x̄ = x̄' − H(x) a + (∂f_fr/∂x)ᵀa,
//              v̄ = (1 − c dt) w + (∂f_fr/∂v)ᵀa,  θ̄ += aᵀ ∂f/∂θ  (m̄_i −= a_i·f_i / m_i)
//   implicit step  g(x') = M(x' − x − dt v)/dt² + cM(x' − x)/dt + ∇Φ(x') − Mg − f_fr(x, v) = 0
//     adjoint: K λ = x̄' + v̄'/dt with K = M(1/dt² + c/dt) + H(x') (matrix-free CG),
//              x̄ = −v̄'/dt + M(1/dt² + c/dt) λ + (∂f_fr/∂x)ᵀλ,  v̄ = Mλ/dt + (∂f_fr/∂v)ᵀλ,
//              θ̄ −= λᵀ ∂g/∂θ.
// (The symplectic Euler step is the leapfrog in its velocity-staggered form.) Memory stays bounded
// by checkpointing: states are stored every K steps (K = ⌈√steps⌉ by default) and each segment is
// recomputed from its checkpoint during the backward pass, so at most steps/K + K states are held.
// Clamped particles are constants (zero adjoint).
#pragma once

#include <Eigen/Core>
#include <functional>
#include <vector>

#include "topo_gaussian/physics/soft_body.h"

namespace topo_gaussian {

enum class SoftIntegrator { SymplecticEuler, ImplicitEuler };

struct SoftRolloutOptions {
  SoftIntegrator integrator = SoftIntegrator::SymplecticEuler;
  double dt = 0.0;  ///< [s]; explicit steps must satisfy dt ≤ stableTimeStep()
  int steps = 0;
  /// K; ≤ 0 = ⌈√steps⌉ (on the GPU, runSoftRolloutCuda: every state kept where they fit in half of its
  /// free memory, else ⌈√steps⌉)
  int checkpoint_every = 0;
  NewtonOptions newton;  ///< implicit steps
  double adjoint_cg_tolerance = 1e-11;
  int adjoint_cg_max_iterations = 20000;
  /// The steps k at which the loss may be nonzero (empty: every step). Elsewhere the loss is not
  /// called (forward or backward): it must be zero there. A GPU rollout then copies only those
  /// states to the host (cuda/soft_rollout_cuda.h).
  std::function<bool(int k)> loss_at;
};

/// ℓ_k for state k (k = 0..steps, t = t0 + k dt). When dl_dx / dl_dv are non-null they are sized
/// N and zeroed by the caller; the function adds ∂ℓ_k/∂x_k and ∂ℓ_k/∂v_k.
using SoftStepLoss =
    std::function<double(int k, double t, const std::vector<Eigen::Vector3d>& x, const std::vector<Eigen::Vector3d>& v,
                         std::vector<Eigen::Vector3d>* dl_dx, std::vector<Eigen::Vector3d>* dl_dv)>;

struct SoftDesignGradient {
  std::vector<double> mass, mu, lambda, chamber;  ///< ∂L/∂m_i, ∂L/∂μ_i, ∂L/∂λ_i, ∂L/∂w_i
  std::vector<Eigen::Vector3d> x0, v0;            ///< ∂L/∂x_0, ∂L/∂v_0
};

struct SoftRolloutResult {
  double loss = 0.0;
  SoftDesignGradient gradient;  ///< empty unless requested
  std::size_t peak_states = 0;  ///< most (x, v) states held at once (checkpoints + one segment)
  /// Their bytes at that peak: 48 per particle and state; an explicit rollout's recomputed segment
  /// also keeps each state's forces (72 per particle and state there).
  std::size_t peak_state_bytes = 0;
  double forward_s = 0.0, backward_s = 0.0;
};

class SoftRollout {
 public:
  /// The simulator's current state (x, v, t) is the initial state; its design (masses, material,
  /// chamber, pressure schedule, contact, clamps) is used as is. Throws TopoError for dt ≤ 0,
  /// steps < 1, or an explicit dt above the stability limit.
  SoftRollout(SoftBodySimulator* sim, const SoftRolloutOptions& options);
  /// Runs forward (leaves the simulator at the final state) and, if asked, backward.
  SoftRolloutResult run(const SoftStepLoss& loss, bool with_gradient);

 private:
  void stepForward(int k);
  SoftBodySimulator* sim_;
  SoftRolloutOptions opt_;
};

/// Gradient of a loss L(x*) of a static equilibrium x* (the simulator's current state after
/// solveStatic(), with the pressure fully applied: pressureNow() == actuation().pressure_pa):
/// H λ = ∂L/∂x* (PCG on the stiffness at x*), then θ̄ = −λᵀ ∂g/∂θ with g = ∇Φ(x*; θ) − M g:
/// m̄_i = λ_i·g, μ̄_i = −λ·∂∇E/∂μ_i, λ̄_i likewise, w̄_i = −λ·∂∇E_a/∂w_i. x0/v0 are left empty.
/// Throws TopoError when the stiffness is indefinite (an unstable equilibrium) or the solve fails.
/// adjoint (optional): on entry a guess of λ for the solve (e.g. the last design's, for a loss gradient
/// of the same shape; empty for none), on return λ. The gradient is linear in dL_dx.
SoftDesignGradient staticEquilibriumGradient(const SoftBodySimulator& sim, const std::vector<Eigen::Vector3d>& dL_dx,
                                             double cg_tolerance = 1e-10,
                                             std::vector<Eigen::Vector3d>* adjoint = nullptr);

}  // namespace topo_gaussian
