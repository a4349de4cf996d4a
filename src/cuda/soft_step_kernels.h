// Device-side layout of a soft body and the launchers of its explicit step (soft_step_kernels.cu).
// Plain pointers into device memory; no Eigen, no CUDA headers (the host side is soft_body_cuda.cpp).
// Vectors are stored as 3 consecutive values per particle (x0 y0 z0 x1 …), 3×3 matrices as 9
// column-major values, per CSR entry data in the CPU body's CSR order.
#pragma once

#include <cstdint>
#include <type_traits>

namespace topo_gaussian {
namespace cuda_detail {

/// status words written by the kernels (device memory, 4 × unsigned long long):
/// [0] first inverted particle, encoded step << 32 | particle (ULLONG_MAX: none; step counts from 1)
/// [1] first non-finite velocity, same encoding
/// [2] rotations that left the Newton iteration for the Jacobi fallback (count)
constexpr int kStatusWords = 4;

/// Values per particle of the gather's neighbour record (SoftDeviceBody::rec).
constexpr int kRecord = 24;

/// Penalty contact with rigid obstacles (physics/soft_contact.h) on contact points: embedded surface
/// samples y_k = Σ_i φ_ki x_i with weights ω_k, or the candidate particles themselves (φ = 1, ω = 1).
/// points == 0: no contact.
template <class T>
struct ContactDevice {
  static constexpr int kMaxObstacles = 8;
  int points = 0;
  int obstacles = 0;
  int kind[kMaxObstacles] = {};  // 0 half-space, 1 box
  T normal[kMaxObstacles][3] = {};
  T offset[kMaxObstacles] = {};
  T lo[kMaxObstacles][3] = {}, hi[kMaxObstacles][3] = {};
  T stiffness = 0, friction = 0, slip_velocity = 0, margin = 0;
  T band = 0;  // embedded: skip samples whose anchor is farther (nearBand())
  int embedded = 0;
  const int* off = nullptr;  // points + 1: the point's particles off[k] … off[k+1]
  const int* idx = nullptr;
  const T* phi = nullptr;
  const T* omega = nullptr;     // points
  const int* anchor = nullptr;  // points
  const int* toff = nullptr;    // n + 1: transpose, particle i's points toff[i] … toff[i+1]
  const int* tpt = nullptr;     // the point k of each transposed entry
  const T* tphi = nullptr;      // φ_ki of each transposed entry
  T* fn = nullptr;              // 3 points: normal force at each point
  T* ffr = nullptr;             // 3 points: friction force at each point
  T* pfr = nullptr;             // 3n: friction force at each particle (scattered)
  T* adj = nullptr;             // 6 points: the adjoint's −h_k + ȳ_k and v̄_k
};

template <class T>
struct SoftDeviceBody {
  int n = 0;
  int nnz = 0;
  // rest constants
  const int* offsets = nullptr;  // n + 1
  const int* idx = nullptr;      // nnz
  const T* X = nullptr;          // 3n
  const T* V = nullptr;          // n
  const T* mass = nullptr;       // n
  const T* mu = nullptr;         // n
  const T* lambda = nullptr;     // n
  const T* c = nullptr;          // n, hourglass coefficients
  const T* gh = nullptr;         // 3 nnz, ĝ_ij
  const T* W = nullptr;          // nnz
  const T* ghr = nullptr;        // 3 nnz, ĝ_jk of the reverse entry (null with L)
  const T* hgw = nullptr;        // 4 nnz (null with L)
  const T* gsum = nullptr;       // 3n
  // Order-1 gradients (ĝ_ij = L_i ∇W(X_ji)) recomputed per entry instead of streamed (set when the
  // body's gradient_order is 1): the step's kernels then read no per-entry constant but the index.
  // The evaluation also writes per particle one record of what the gather reads of a neighbour j
  // (N_j = M_j L_j, so that Σ_j M_j ĝ_jk = Σ_j N_j ∇W(X_kj) needs no L_j; F̃_j, x_j, c_j, V_j), read
  // as 16-byte vectors: a neighbour costs the gather 6 (float32) or 12 (float64) loads instead of 23.
  // In float32 too, ĝ_ij is computed in float64 from X_ji in float64 and rounded once (as the CPU's
  // streamed ĝ is): float32 errors in ĝ would show as a spurious strain Σ_j V_j X_ji δĝ_ijᵀ.
  // The adjoint's gather recomputes them too (launchGatherRecords); the stiffness product's
  // (launchGatherForces) streams ghr and hgw.
  const double* L = nullptr;              // 9n, correction matrices L_i (null: stream gh, W, ghr, hgw)
  const double* Xr = nullptr;             // 4n, X_i and V_i in float64: (X_0, X_1) of all, then (X_2, V) (loadRest)
  const T* gsum_raw = nullptr;            // 3n, Σ_j V_j ∇W(X_ji) (with L: M_k ĝsum_k = N_k gsum_raw_k)
  T* rec = nullptr;                       // kRecord n: N_i, F̃_i, x_i, c_i, V_i, 0 in 16-byte chunks (writeRecord;
                                          // with L; then M is not written)
  double inv_h = 0;                       // 1/h [1/m]
  double w_scale = 0;                     // 1/(π h³) [1/m³]: W = w_scale · w(q)
  double dw_scale = 0;                    // 1/(π h⁴) [1/m⁴]: dW/dr = dw_scale · w'(q)
  const T* hgsum = nullptr;               // 3n
  const T* moment = nullptr;              // 9n (null without hourglass)
  const std::uint8_t* clamped = nullptr;  // n
  const T* chamber = nullptr;             // n (null: no actuation)
  double pressure_pa = 0.0;
  double ramp_s = 0.0;
  int stvk = 1;            // 1 StVK, 0 corotated linear
  int shape_matching = 1;  // rotation from A_pq (D_i), else from F̃_i
  int hourglass = 1;
  T gravity[3] = {0, 0, 0};
  T damping = 0;
  double hg_alpha_over_h2 = 0.0;  // α / h² (the hourglass material derivative)
  ContactDevice<T> contact;
  int lanes = 8;  // threads per particle in the neighbour sums: 1, 2, 4, 8, 16 or 32
  // The evaluation with its registers capped (kEvaluationBlocksCapped blocks an SM): -1 when its grid
  // outgrows what the SMs hold at once uncapped (evaluationCapped), 0 never, 1 always (tests, benches);
  // 2 and 4 lanes only.
  int capped_evaluation = -1;
  // The float32 evaluation's work after the neighbour sums done one thread a particle
  // (evaluateWarpKernel; recomputed ĝ, 2 or 4 lanes): -1 by the grid's size (evaluationWarpFor), 0 never,
  // 1 always (tests, benches). Ignored in float64.
  int warp_evaluation = -1;
  // Launch the step's two neighbour kernels as programmatic dependents of the kernel before them
  // (compute capability 9.0+): their launch overlaps that kernel's end; they wait for its results.
  int dependent_launch = 0;
  // state
  T* x = nullptr;             // 3n
  T* v = nullptr;             // 3n
  T* f = nullptr;             // 3n, conservative forces at x
  T* Ft = nullptr;            // 9n
  T* M = nullptr;             // 9n
  T* R = nullptr;             // 9n rotations R_i, written by the evaluation when set
  double* time = nullptr;     // 1
  long long* step = nullptr;  // 1, steps taken
  // the other half of the double-buffered state (null: steps one at a time, in place)
  T* x_alt = nullptr;                    // 3n
  double* time_alt = nullptr;            // 1
  long long* step_alt = nullptr;         // 1
  unsigned long long* status = nullptr;  // kStatusWords
};

/// f(std::integral_constant<int, L>()) for L = lanes (1, 2, 4, 8, 16 or 32; anything else 8).
template <class F>
void withLanes(int lanes, F&& f) {
  switch (lanes) {
    case 1:
      f(std::integral_constant<int, 1>());
      break;
    case 2:
      f(std::integral_constant<int, 2>());
      break;
    case 4:
      f(std::integral_constant<int, 4>());
      break;
    case 16:
      f(std::integral_constant<int, 16>());
      break;
    case 32:
      f(std::integral_constant<int, 32>());
      break;
    default:
      f(std::integral_constant<int, 8>());
      break;
  }
}

/// One leapfrog step (three kernels) on `stream` (a cudaStream_t).
template <class T>
void launchLeapfrogStep(const SoftDeviceBody<T>& body, double dt, void* stream);

/// `steps` leapfrog steps: without contact the gather of each step but the last also does the next
/// step's first half kick and drift into the other half of the double-buffered state (x_alt,
/// time_alt, step_alt), so a step is two kernels; the last state is in b's own buffers. The same
/// arithmetic as `steps` launchLeapfrogStep calls.
template <class T>
void launchLeapfrogSteps(const SoftDeviceBody<T>& body, double dt, long steps, void* stream);

/// The state at the current x (F̃, M, f) without moving: after an upload, or to refresh f.
template <class T>
void launchEvaluateForces(const SoftDeviceBody<T>& body, void* stream);

/// Whether the body's evaluations run the kernel with capped registers (capped_evaluation, its lanes,
/// and its grid against the blocks the device holds at once uncapped): the rule the launches follow.
template <class T>
bool evaluationCapped(const SoftDeviceBody<T>& body);

/// Whether the body's evaluations run evaluateWarpKernel (warp_evaluation, precision, lanes, grid).
template <class T>
bool evaluationWarp(const SoftDeviceBody<T>& body);

/// SoftRollout's explicit step (symplectic Euler: v ← v + dt (f/m + g − c v), x ← x + dt v for free
/// particles; the clock advances), then the conservative forces at the new x (no kick).
template <class T>
void launchSymplecticStep(const SoftDeviceBody<T>& body, double dt, void* stream);

/// The same step out of place: from `in`'s x, v, f and clock into `out`'s x, v and clock (clamped
/// particles copied), then the state and forces at the new x into `out`'s f, F̃, R, M or record (the
/// adjoint's recomputed segment: each state's evaluation kept for its adjoint step, no copies).
template <class T>
void launchSymplecticStepInto(const SoftDeviceBody<T>& in, const SoftDeviceBody<T>& out, double dt, void* stream);

/// The SPH state at x and *time (F̃, M and, with body.R set, R) without the forces.
template <class T>
void launchEvaluateState(const SoftDeviceBody<T>& body, void* stream);

/// f = −Σ_j [V_k M_j ĝ_jk − V_j M_k ĝ_kj + q_kj − q_jk] with body.x, body.Ft, body.M (the gather of
/// CorotatedSph, negated; linear in (x, F̃, M), so with (dx, dF̃, dM) it gives −H dx), into body.f.
template <class T>
void launchGatherForces(const SoftDeviceBody<T>& body, void* stream);

/// The same gather with ĝ recomputed (body.L set): the neighbours' (x, F̃, M) read from body.rec in
/// evaluateKernel's record layout (N_j = M_j L_j, F̃_j, x_j, c_j, V_j), x_k from body.x.
template <class T>
void launchGatherRecords(const SoftDeviceBody<T>& body, void* stream);

/// One adjoint step of the symplectic Euler rollout at the evaluated state (soft_rollout.h):
///   w = v̄ + dt x̄,  a = dt w / m,  m̄ −= a·f/m,  x̄ ← x̄ − H a,  v̄ ← (1 − c dt) w   (free particles;
///   clamped rows zero),  μ̄ −= ∂(a·∇E)/∂μ,  λ̄ −= ∂(a·∇E)/∂λ,  w̄ −= ∂(a·∇E_a)/∂w.
/// f: the conservative forces at the state; work: 3n (a) + 3n (w) + 3n (H a) + 9n + 9n + 3n values, and
/// kRecord n + 4 more with body.L (the gather's record of (a, dF̃, dM), 16-byte aligned).
template <class T>
void launchAdjointStep(const SoftDeviceBody<T>& body, const T* f, double dt, T* xb, T* vb, T* g_mass, T* g_mu,
                       T* g_lambda, T* g_chamber, T* work, void* stream);

/// out = −K a at the evaluated state (body.Ft, body.R at body.x): the adjoint's per-particle pass
/// (dF̃, dM; no material derivatives) and the force gather over (a, dF̃, dM). a: clamped rows zero;
/// work: 18n values.
template <class T>
void launchStiffnessProduct(const SoftDeviceBody<T>& body, const T* a, T* out, T* work, void* stream);

/// Contact at x: per point the normal force and the friction force for velocities v (both at x),
/// scattered to the particles: f += normal (when add_normal), pfr = friction.
template <class T>
void launchContact(const SoftDeviceBody<T>& body, bool add_normal, void* stream);

/// The contact's part of one adjoint step at x_k, v_k (after launchAdjointStep, with its a in work):
/// x̄ −= H_c a, friction adjoint into x̄ and v̄ (free particles), m̄ −= a·f_fr / m.
template <class T>
void launchContactAdjoint(const SoftDeviceBody<T>& body, T* xb, T* vb, T* g_mass, const T* work, void* stream);

/// *time = t on the stream (no host synchronisation).
void launchSetClock(double* time, double t, void* stream);

/// y += x (n3 values).
template <class T>
void launchAdd(T* y, const T* x, int n3, void* stream);

/// Polar rotation of `count` matrices (9 column-major values each), for tests of the device
/// polar decomposition against the CPU's.
template <class T>
void launchPolarRotations(const T* A, T* R, int count, unsigned long long* fallbacks, void* stream);

}  // namespace cuda_detail
}  // namespace topo_gaussian
