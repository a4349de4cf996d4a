// Explicit soft-body step on a CUDA GPU: SoftBodySimulator::step (paper appendix
// "Soft body dynamics"; physics/soft_body.h) with the same corotated SPH forces
// (physics/corotated_sph.h) evaluated by two kernels per step (three for a batch's first step):
//
//   v ← v + ½dt (f/m + g − c v);  x ← x + dt v              (kick + drift, free particles)
//   evaluate:  F̃_i = Σ_j V_j x_ji ĝ_ijᵀ,  D_i = Σ_j V_j W_ij x_ji X_jiᵀ,  R_i = polar(D_i or F̃_i),
//              F_i = R_iᵀF̃_i,  P_i = ∂ψ/∂F,  M_i = V_i R_i P_i + c_i 2(F̃_i C_i − D_i)
//              − p(t) w_i V_i cof F̃_i   (hourglass, pneumatic chamber term)
//   gather + kick:  f_k = −Σ_{j∈N(k)} [V_k M_j ĝ_jk − V_j M_k ĝ_kj + q_kj − q_jk];
//              v ← v + ½dt (f/m + g − c v)
//
// The rest constants (neighbourhoods, L_i, the gather's sums) are the CPU body's, uploaded once. With
// order-1 gradients (the default) the kernels recompute W_ij and ĝ_ij = L_i ∇W(X_ji) per neighbour
// from X and L (float64) instead of streaming per-entry arrays, and the gather reads Σ_j M_j ĝ_jk as
// Σ_j N_j ∇W(X_kj) with N_j = M_j L_j from one 24-value record per neighbour written by the evaluation
// (soft_step_kernels.h); order-2 (MLS) gradients stream ĝ, W, the reverse ĝ and the hourglass weights
// (CorotatedSph::reverseKernelGradients() etc.). The step is the CPU's arithmetic up to the order of
// sums and products, with each neighbour sum split over a few lanes of a warp, so in float64 a step
// agrees with SoftBodySimulator::step to round-off. float32 keeps positions and the state in single
// precision (the evaluation computes ĝ in float64 and rounds it; tolerance in
// test/unit/core_cuda_soft_body.cpp).
// Batches of steps are captured once in a CUDA graph and replayed (no host synchronisation inside a
// batch); without contact the gather of each step but a batch's last also does the next step's first
// half kick and drift (x, clock and step counter double-buffered), so a step is two kernels. A batch
// ends by reading one status word: an inverted particle (det F ≤ 0) or a non-finite velocity throws
// TopoError naming the particle and the step, as the CPU does.
//
// With contact (physics/soft_contact.h: obstacles, on embedded surface samples or on the particles)
// a step is five kernels: friction at (x_n, v_n), kick + drift, evaluate, gather + the normal force
// at x_{n+1} with friction at (x_{n+1}, v_{n+½}), kick (soft_contact_kernels.cu).
// Implicit steps and static solves (SoftBodySimulator::stepImplicit, solveStatic) stay Newton on the
// host; under backend cuda their linear solves run the stiffness products (cuda/soft_stiffness_cuda.h)
// and the preconditioner (cuda/dense_cholesky_cuda.h) on the GPU.
#pragma once

#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

#include "topo_gaussian/physics/soft_body.h"

namespace topo_gaussian {

enum class CudaPrecision { Float64, Float32 };

class SoftBodyCuda {
 public:
  /// Uploads the simulator's body (rest constants, masses, materials, clamps, chamber and pressure
  /// schedule, gravity, damping) and state (x, v, conservative forces, time). Throws TopoError when
  /// this build or machine has no CUDA device (cudaDeviceInfo().reason), or the simulator uses what
  /// the GPU step cannot take (more than 8 contact obstacles).
  /// lanes_per_particle: threads that share one particle's neighbour sums (1, 2, 4, 8, 16, 32), or 0
  /// to choose: 2 from 50 000 particles; below, float64 4, float32 8 with 48 or more neighbours, else
  /// 4 (measured fastest for 26 and 86–94 neighbours at 9k, 100k and 1M particles,
  /// bench/gpu/README.md).
  explicit SoftBodyCuda(const SoftBodySimulator& sim, CudaPrecision precision = CudaPrecision::Float64,
                        int lanes_per_particle = 0);
  /// The lanes per particle in use.
  int lanesPerParticle() const;
  /// The evaluation kernel with its registers capped, so that more blocks share an SM: faster once its
  /// grid outgrows what the SMs hold at once uncapped (100k particles), slower where it fits (9k).
  /// -1 (the default): chosen by the grid's size; 0: never; 1: always (with 2 or 4 lanes; tests,
  /// benches). The arithmetic is the same either way.
  void setCappedEvaluation(int mode);
  /// Whether the step's evaluations run the capped kernel (the mode, the lanes and the grid's size).
  bool cappedEvaluation() const;
  /// float32: the evaluation's work after the neighbour sums (the polar rotation, the stress, the
  /// gather's record) done one thread a particle instead of by the first of each particle's lanes
  /// while the others wait (measured faster on large grids, bench/gpu/README.md). -1 (the
  /// default): by the grid's size, where its grid of one thread a particle fills at least three
  /// quarters of what the device holds at once (below, its fewer, longer warps are slower); 0: never;
  /// 1: always. Only with 2 or 4 lanes and
  /// order-1 gradients (ĝ recomputed); otherwise, and in float64, the group kernel runs. The same
  /// formulas; float32 rounding may differ in the last bits (the compiler fuses multiply–adds per kernel),
  /// so when the choice changes the current state is evaluated again with the kernel now chosen.
  void setWarpEvaluation(int mode);
  /// Whether the step's evaluations run the one-thread-a-particle kernel.
  bool warpEvaluation() const;
  ~SoftBodyCuda();
  SoftBodyCuda(const SoftBodyCuda&) = delete;
  SoftBodyCuda& operator=(const SoftBodyCuda&) = delete;

  std::size_t size() const;
  CudaPrecision precision() const;
  /// `steps` leapfrog steps of dt [s]; refuses dt ≤ 0 or dt > the simulator's stableTimeStep().
  /// Throws TopoError (particle, step) when a particle inverted or a velocity became non-finite; the
  /// device state is then that of the end of the batch and should not be used.
  void step(double dt, long steps = 1);
  /// Waits for the device, then copies the state back.
  void download(std::vector<Eigen::Vector3d>* x, std::vector<Eigen::Vector3d>* v) const;
  /// The conservative forces (elastic + pneumatic) of the last evaluation.
  std::vector<Eigen::Vector3d> forces() const;
  double time() const;
  long stepCount() const;
  /// Waits for the device (timing).
  void synchronize() const;
  /// Bytes allocated on the device for this body.
  std::size_t deviceBytes() const;

  /// The device state, for the backend's own code (src/cuda: the rollout and its adjoint).
  struct Impl;
  Impl& impl() { return *impl_; }

 private:
  void dropGraph();  ///< the captured step graph, made again at the next step (after a kernel choice)
  std::unique_ptr<Impl> impl_;
};

/// The device's polar rotation (the CPU's Newton iteration; a Jacobi eigen-decomposition of AᵀA for
/// the matrices it declines: reflected, nearly singular, non-finite) of each matrix; *fallbacks (if
/// given) counts those. For tests of the kernel against the CPU's. Throws without a device.
std::vector<Eigen::Matrix3d> cudaPolarRotations(const std::vector<Eigen::Matrix3d>& A, CudaPrecision precision,
                                                long* fallbacks = nullptr);

}  // namespace topo_gaussian
