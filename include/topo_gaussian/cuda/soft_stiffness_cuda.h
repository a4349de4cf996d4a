// The soft body's stiffness product on the GPU (the static/implicit path): Newton's
// conjugate gradients and the adjoint solves multiply by
//   K p = (∂²(E_el + E_a)/∂x²) p    (corotated SPH with hourglass, the pneumatic chamber's term)
// at the simulator's state, as SoftBodySimulator::stiffnessProduct does on the host without contact.
// The kernels are the explicit rollout's adjoint's (soft_adjoint_kernels.cu): the per-particle pass
// dF̃_i = Σ_j V_j p_ji ĝ_ijᵀ, dM_i = V_i dP_i + hourglass + chamber terms, then the force gather over
// (p, dF̃, dM), which is −K p. The state (F̃_i, R_i at x) is evaluated on the device once per Newton
// iterate (setState); a product then uploads p and downloads K p (2 × 3N values). float64: the host's
// arithmetic up to the order of sums (test/unit/core_cuda_dense_cholesky.cpp).
#pragma once

#include <memory>

#include "topo_gaussian/physics/soft_body.h"

namespace topo_gaussian {

/// An ExternalStiffness on the first CUDA device for `sim`'s body (its masses, materials, clamps and
/// chamber as they are now). Throws TopoError without the CUDA backend or a device, and GpuMemoryError
/// when the body does not fit.
std::unique_ptr<ExternalStiffness> makeStiffnessCuda(const SoftBodySimulator& sim);

}  // namespace topo_gaussian
