// The explicit differentiable soft-body rollout on a CUDA GPU (paper §"Differentiability"):
// SoftRollout with SoftIntegrator::SymplecticEuler (physics/soft_rollout.h), forward and reverse mode
// through time, on the device:
//   forward   v' = v + dt (f(x)/m + g − c v),  x' = x + dt v'        (free particles)
//   adjoint   w = v̄' + dt x̄',  a = dt w / m,  x̄ = x̄' − H(x) a,  v̄ = (1 − c dt) w,
//             m̄_i −= a_i·f_i/m_i,  μ̄, λ̄, w̄ −= aᵀ ∂f/∂(μ, λ, w)
// Every state is kept in device memory when they fit in half of its free memory and
// checkpoint_every ≤ 0 (the default): the backward then recomputes nothing. Otherwise segments of K
// steps (K = checkpoint_every, or ⌈√steps⌉) counted back from the end: the forward runs the last one into
// the segment's slots (the backward starts there without recomputing it) and checkpoints the start of
// every earlier one, which the backward recomputes from it, so the device holds ⌈(steps − K)/K⌉ + K + 1
// states. A stored state is x, v, f and the evaluation at x that its adjoint step reads (F̃, R): 27
// values a particle, and its clock; each step of a segment runs out of place into the next state's slot
// (no copies), from its checkpoint's clock. H a is the force gather applied to (a, dF̃(a), dM(a))
// (soft_body_cuda.h): with order-1 gradients the row pass writes its record and the gather recomputes ĝ,
// as the step's gather does. The loss is the same host callback as SoftRollout's: each state is copied to the
// host for it (2 × 3N values a step, forward and backward).
//
// Contact and friction (embedded samples or particles) are included: their Hessian k ω n nᵀ and the
// friction adjoint through the embedding weights, as SoftContact's. Not on the GPU (refused by name):
// implicit steps.
#pragma once

#include "topo_gaussian/cuda/soft_body_cuda.h"
#include "topo_gaussian/physics/soft_rollout.h"

namespace topo_gaussian {

/// As SoftRollout(sim, options).run(loss, with_gradient), on the GPU: the simulator's state is the
/// initial state and its design is used as is; it is left at the final state (evaluated on the CPU
/// once; with a gradient on a host thread while the device runs the backward, so the loss callback
/// must not use the simulator, only the states it is given; after an error in the backward the
/// simulator's state is unspecified). forward_s / backward_s include the host loss calls, not the
/// device allocations (made before the forward). Throws TopoError for what
/// SoftRollout refuses, for options.integrator ImplicitEuler (not on the GPU yet), when no
/// device is available, and, naming the step and particle, for a non-finite or inverted state.
SoftRolloutResult runSoftRolloutCuda(SoftBodySimulator* sim, const SoftRolloutOptions& options,
                                     const SoftStepLoss& loss, bool with_gradient,
                                     CudaPrecision precision = CudaPrecision::Float64);

}  // namespace topo_gaussian
