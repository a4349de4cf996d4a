// Kernels of the explicit soft-body step (see include/topo_gaussian/cuda/soft_body_cuda.h for the
// formulas). Each mirrors a CPU loop of physics/corotated_sph.cpp or physics/soft_body.cpp in the
// same arithmetic order: evaluateKernel ↔ CorotatedSph::evaluate (EvalMode::Forces),
// gatherKickKernel ↔ CorotatedSph::gather + the second half kick of SoftBodySimulator::step,
// kickDriftKernel ↔ its first half kick and drift. Each particle's outputs are written by one
// thread (deterministic: the same input gives the same bits, batch or single steps).
#include <cuda_runtime.h>

#include <algorithm>
#include <climits>
#include <cstdint>
#include <type_traits>

#include "soft_device_math.cuh"
#include "soft_step_kernels.h"

namespace topo_gaussian {
namespace cuda_detail {

namespace {

using namespace device;

/// v + h (f/m + g − c v): one half kick of a free particle's velocity component.
template <class T>
__device__ inline T halfKick(T v, T f, T m, T g, T damping, T h) {
  return v + h * (f / m + g - damping * v);
}

/// Where a step's drift writes: x, the clock and the step counter of the next state (the same
/// buffers as the input for a single step; the other half of SoftDeviceBody's double buffer when the
/// drift is fused into the gather, which still reads the neighbours' x at the current state).
template <class T>
struct DriftTarget {
  T* x = nullptr;  // null: no drift
  double* time = nullptr;
  long long* step = nullptr;
  T dt = 0;
  double dt_clock = 0.0;
};

/// First half kick and drift of free particles (SoftBodySimulator::step's kick(½dt, true)) into
/// out (clamped particles copied when out is the other buffer); thread 0 advances the clock and
/// the step counter (read by the step's later kernels).
template <class T>
__global__ void kickDriftKernel(SoftDeviceBody<T> b, T h, DriftTarget<T> out) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i == 0) {
    *out.time = *b.time + out.dt_clock;
    *out.step = *b.step + 1;
  }
  if (i >= b.n) return;
  if (b.clamped[i]) {
    if (out.x != b.x)
#pragma unroll
      for (int d = 0; d < 3; ++d) out.x[3 * i + d] = b.x[3 * i + d];
    return;
  }
  const T m = b.mass[i];
#pragma unroll
  for (int d = 0; d < 3; ++d) {
    const T f = b.contact.points ? b.f[3 * i + d] + b.contact.pfr[3 * i + d] : b.f[3 * i + d];
    const T vn = halfKick(b.v[3 * i + d], f, m, b.gravity[d], b.damping, h);
    b.v[3 * i + d] = vn;
    out.x[3 * i + d] = b.x[3 * i + d] + out.dt * vn;
  }
}

/// The second half kick with friction (contact): v ← v + ½dt ((f + f_fr)/m + g − c v), free particles.
template <class T>
__global__ void kickKernel(SoftDeviceBody<T> b, T h) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= b.n || b.clamped[i]) return;
  const T m = b.mass[i];
  bool finite = true;
#pragma unroll
  for (int d = 0; d < 3; ++d) {
    const T v = b.v[3 * i + d];
    const T vn = halfKick(v, b.f[3 * i + d] + b.contact.pfr[3 * i + d], m, b.gravity[d], b.damping, h);
    b.v[3 * i + d] = vn;
    finite = finite && isfinite(vn);
  }
  if (!finite) encodeFirst<T>(&b.status[1], *b.step, i);
}

/// Blocks of kBlock threads an SM of the capped evaluation (registers capped to fit them: float32 80
/// instead of 106, float64 128 instead of 150, a few bytes spilled), against the 4 and 3 that the
/// uncapped one fits. Measured faster once the grid outgrows what the SMs hold at once uncapped (float32
/// with its own data loaded late) and slower where it fits, so it is chosen by the grid's size
/// (launchEvaluateOnly; timings in bench/gpu/README.md).
template <class T>
constexpr int kEvaluationBlocksCapped = sizeof(T) == 4 ? 6 : 4;
/// Lanes with a capped variant (the automatic choices at large sizes: float32 4, float64 2).
template <int L>
constexpr bool kCappable = L == 2 || L == 4;

/// The particle's own data for the work after the neighbour sums (evaluationEpilogue), loaded before
/// the sums when `early` (their latency overlaps the loop), else where they are used.
template <class T>
struct EvaluationOwnData {
  T mu = 0, la = 0, V = 0, w = 0;
  double p = 0.0;
  Mat3<T> C{};
};

template <class T>
__device__ __forceinline__ EvaluationOwnData<T> loadEvaluationOwnData(const SoftDeviceBody<T>& b, int i, bool hg_row) {
  EvaluationOwnData<T> o;
  o.mu = b.mu[i];
  o.la = b.lambda[i];
  o.V = b.V[i];
  o.w = b.chamber ? b.chamber[i] : T(0);
  o.p = b.chamber ? pressureAt(b, *b.time) : 0.0;
  if (hg_row)
#pragma unroll
    for (int k = 0; k < 9; ++k) o.C.a[k] = b.moment[9 * i + k];
  return o;
}

/// What the evaluation reads of particle i before its neighbour sums (i = 0's when inactive: an
/// empty range): its CSR range, x_i, X_i, c_i, and with G L_i and X_i, V_i in float64.
template <class T>
struct EvaluationRow {
  int e0 = 0, e1 = 0;
  T x[3], X[3], c;
  bool hg_row, need_D;
  Mat3<double> Li;
  double Xr[4] = {0, 0, 0, 0};
};

template <class T, bool G>
__device__ __forceinline__ EvaluationRow<T> loadEvaluationRow(const SoftDeviceBody<T>& b, int i, bool active) {
  EvaluationRow<T> r;
  if (active) r.e0 = b.offsets[i], r.e1 = b.offsets[i + 1];
  const int ii = active ? i : 0;
#pragma unroll
  for (int d = 0; d < 3; ++d) r.x[d] = b.x[3 * ii + d];
#pragma unroll
  for (int d = 0; d < 3; ++d) r.X[d] = b.X[3 * ii + d];
  r.c = b.c[ii];
  r.hg_row = b.hourglass && r.c > T(0);
  r.need_D = r.hg_row || b.shape_matching;
  if (G) {
#pragma unroll
    for (int k = 0; k < 9; ++k) r.Li.a[k] = b.L[9 * ii + k];
    loadRest(b.Xr, b.n, ii, r.Xr);
  }
  return r;
}

/// F̃_i = Σ_j V_j (x_j − x_i) ⊗ ĝ_ij and (need_D) D_i = Σ_j W_ij V_j (x_j − x_i) ⊗ X_ji over the neighbours
/// e ∈ [e0, e1) of particle i, lane `lane` of its L taking every L-th; every lane of the group gets
/// the sums. G: ĝ_ij = L_i ∇W(X_ji) and W_ij recomputed in float64 from X_i, V (Xr) and L_i.
template <class T, int L, bool G>
__device__ __forceinline__ void evaluationSums(const SoftDeviceBody<T>& b, const EvaluationRow<T>& row, int lane,
                                               Mat3<T>* Ft_out, Mat3<T>* D_out) {
  const int e0 = row.e0, e1 = row.e1;
  const T xi0 = row.x[0], xi1 = row.x[1], xi2 = row.x[2], Xi0 = row.X[0], Xi1 = row.X[1], Xi2 = row.X[2];
  const bool need_D = row.need_D;
  const Mat3<double>& Li = row.Li;
  const double* Xr = row.Xr;
  Mat3<T> Ft = zero3<T>(), D = zero3<T>();
  for (int e = e0 + lane; e < e1; e += L) {
    const int j = b.idx[e];
    double Xj[4];  // X_j and V_j
    if (G) loadRest(b.Xr, b.n, j, Xj);
    const T v = G ? static_cast<T>(Xj[3]) : b.V[j];
    const T d0 = v * (b.x[3 * j] - xi0), d1 = v * (b.x[3 * j + 1] - xi1), d2 = v * (b.x[3 * j + 2] - xi2);
    T g0, g1, g2, w = 0, X0 = 0, X1 = 0, X2 = 0;
    if (G) {  // ĝ_ij = L_i ∇W(X_ji), in float64
      const double Y0 = Xj[0] - Xr[0], Y1 = Xj[1] - Xr[1], Y2 = Xj[2] - Xr[2];
      double wd, s;
      cubicSpline(b, Y0, Y1, Y2, &wd, &s);
      const double r0 = s * Y0, r1 = s * Y1, r2 = s * Y2;
      g0 = static_cast<T>(Li(0, 0) * r0 + Li(0, 1) * r1 + Li(0, 2) * r2);
      g1 = static_cast<T>(Li(1, 0) * r0 + Li(1, 1) * r1 + Li(1, 2) * r2);
      g2 = static_cast<T>(Li(2, 0) * r0 + Li(2, 1) * r1 + Li(2, 2) * r2);
      w = static_cast<T>(wd);
      X0 = static_cast<T>(Y0);
      X1 = static_cast<T>(Y1);
      X2 = static_cast<T>(Y2);
    } else {
      g0 = b.gh[3 * e];
      g1 = b.gh[3 * e + 1];
      g2 = b.gh[3 * e + 2];
    }
    Ft(0, 0) += d0 * g0;
    Ft(1, 0) += d1 * g0;
    Ft(2, 0) += d2 * g0;
    Ft(0, 1) += d0 * g1;
    Ft(1, 1) += d1 * g1;
    Ft(2, 1) += d2 * g1;
    Ft(0, 2) += d0 * g2;
    Ft(1, 2) += d1 * g2;
    Ft(2, 2) += d2 * g2;
    if (need_D) {
      if (!G) {
        w = b.W[e];
        X0 = b.X[3 * j] - Xi0;
        X1 = b.X[3 * j + 1] - Xi1;
        X2 = b.X[3 * j + 2] - Xi2;
      }
      const T b0 = w * d0, b1 = w * d1, b2 = w * d2;
      D(0, 0) += b0 * X0;
      D(1, 0) += b1 * X0;
      D(2, 0) += b2 * X0;
      D(0, 1) += b0 * X1;
      D(1, 1) += b1 * X1;
      D(2, 1) += b2 * X1;
      D(0, 2) += b0 * X2;
      D(1, 2) += b1 * X2;
      D(2, 2) += b2 * X2;
    }
  }
#pragma unroll
  for (int k = 0; k < 9; ++k) {
    Ft.a[k] = groupSum<L>(Ft.a[k]);
    D.a[k] = groupSum<L>(D.a[k]);
  }
  *Ft_out = Ft;
  *D_out = D;
}

/// What the evaluation does with particle i's sums: the polar rotation, P, M_i = V_i R_i P_i + c_i H_i
/// (+ the pneumatic term), F̃_i and M_i (G: the gather's record) written. own: the particle's own
/// data when `early`, else loaded here.
template <class T, bool G, bool early>
__device__ __forceinline__ void evaluationEpilogue(const SoftDeviceBody<T>& b, int i, const Mat3<T>& Ft,
                                                   const Mat3<T>& D, T ci, bool hg_row, T xi0, T xi1, T xi2,
                                                   const Mat3<double>& Li, const EvaluationOwnData<T>& own) {
  bool fell_back = false;
  // The matrix to decompose, chosen element by element: a reference chosen at run time (`cond ? D : Ft`)
  // took both matrices' addresses and kept them in local memory (an 84-byte stack frame).
  Mat3<T> A;
#pragma unroll
  for (int k = 0; k < 9; ++k) A.a[k] = b.shape_matching ? D.a[k] : Ft.a[k];
  const Mat3<T> R = polarRotation(A, &fell_back);
  if (fell_back) atomicAdd(&b.status[2], 1ull);
  if (b.R)
#pragma unroll
    for (int k = 0; k < 9; ++k) b.R[9 * i + k] = R.a[k];
  const Mat3<T> F = mulTn(R, Ft);
  if (!(det3(F) > T(0))) encodeFirst<T>(&b.status[0], *b.step, i);
  // P = ∂ψ/∂F (piolaAndEnergy).
  const T mu = early ? own.mu : b.mu[i], la = early ? own.la : b.lambda[i];
  const Mat3<T> P = firstPiola(b.stvk != 0, F, mu, la);
  // M_i = V_i R_i P_i + c_i H_i, H_i = 2(F̃_i C_i − D_i).
  const Mat3<T> RP = mul(R, P);
  const T Vi = early ? own.V : b.V[i];
  Mat3<T> M;
#pragma unroll
  for (int k = 0; k < 9; ++k) M.a[k] = Vi * RP.a[k];
  if (hg_row) {
    Mat3<T> C = own.C;
    if (!early)
#pragma unroll
      for (int k = 0; k < 9; ++k) C.a[k] = b.moment[9 * i + k];
    const Mat3<T> FC = mul(Ft, C);
#pragma unroll
    for (int k = 0; k < 9; ++k) M.a[k] += ci * (T(2) * (FC.a[k] - D.a[k]));
  }
  // Pneumatic chamber: ∂E_a/∂F̃_i = −p w_i V_i cof F̃_i.
  if (b.chamber) {
    const double p = early ? own.p : pressureAt(b, *b.time);
    const T wi = early ? own.w : b.chamber[i];
    if (p != 0.0 && wi != T(0)) {
      const Mat3<T> Cf = cofactor3(Ft);
      const T s = -static_cast<T>(p) * wi * Vi;
#pragma unroll
      for (int k = 0; k < 9; ++k) M.a[k] += s * Cf.a[k];
    }
  }
#pragma unroll
  for (int k = 0; k < 9; ++k) b.Ft[9 * i + k] = Ft.a[k];
  if (G) {  // the gather's record: N_i = M_i L_i, F̃_i, x_i, c_i, V_i
    writeRecord(b.rec, b.n, i, M, Li.a, Ft, xi0, xi1, xi2, ci, Vi);
  } else {
#pragma unroll
    for (int k = 0; k < 9; ++k) b.M[9 * i + k] = M.a[k];
  }
}

/// CorotatedSph::evaluate (Forces) at x, plus the pneumatic term in M, at time *time. G: ĝ_ij and
/// W_ij recomputed from X and L_i (b.L), and the gather's record written in place of M. Capped: the
/// registers capped (kEvaluationBlocksCapped); the same arithmetic. L threads a particle; the first
/// of them does the work after the sums (evaluateWarpKernel: one thread a particle there).
template <class T, int L, bool G, bool Capped = false>
__global__ void __launch_bounds__(kBlock, Capped ? kEvaluationBlocksCapped<T> : 1) evaluateKernel(SoftDeviceBody<T> b) {
  waitForPreviousKernel();
  const int tid = blockIdx.x * blockDim.x + threadIdx.x;
  const int i = tid / L, lane = tid % L;
  const bool active = i < b.n;
  const EvaluationRow<T> row = loadEvaluationRow<T, G>(b, i, active);
  // float32 loads the particle's own data for the work after the sums before the loop (every lane of
  // the group, the same addresses), so that their latency overlaps the loop; float64 loads them where
  // they are used (loaded early they hold registers through the loop, which measured slower), and so
  // does the capped kernel (its capped registers would spill the early loads). See bench/gpu/README.md.
  constexpr bool early = sizeof(T) == 4 && !Capped;
  EvaluationOwnData<T> own;
  if (early) own = loadEvaluationOwnData(b, active ? i : 0, row.hg_row);
  Mat3<T> Ft, D;
  evaluationSums<T, L, G>(b, row, lane, &Ft, &D);
  if (!active || lane != 0) return;
  evaluationEpilogue<T, G, early>(b, i, Ft, D, row.c, row.hg_row, row.x[0], row.x[1], row.x[2], row.Li, own);
}

/// evaluateKernel with the work after the sums done one thread a particle: a warp sums its 32
/// particles' neighbours in L rounds (32 / L particles a round, L lanes each, as evaluateKernel),
/// passes the sums through shared memory, and each of its threads then finishes one particle (the
/// polar rotation, P, M, the record) instead of one thread in L while the others wait. The same
/// arithmetic as evaluateKernel; a grid of n threads instead of L n.
template <class T, int L, bool G, bool Capped = false>
__global__ void __launch_bounds__(kBlock, Capped ? kEvaluationBlocksCapped<T> : 1)
    evaluateWarpKernel(SoftDeviceBody<T> b) {
  waitForPreviousKernel();
  constexpr int kWarps = kBlock / 32, P = 32 / L;
  __shared__ T sums[kWarps][18][32];  // F̃ then D of the warp's 32 particles, value-major (no bank conflicts)
  const int warp = threadIdx.x / 32, lane32 = threadIdx.x % 32;
  const int base = (blockIdx.x * kWarps + warp) * 32;
  if (base >= b.n) return;  // the whole warp
  for (int round = 0; round < L; ++round) {
    const int slot = round * P + lane32 / L, lane = lane32 % L;
    const int i = base + slot;
    Mat3<T> Ft, D;
    evaluationSums<T, L, G>(b, loadEvaluationRow<T, G>(b, i, i < b.n), lane, &Ft, &D);
    if (lane == 0)
#pragma unroll
      for (int k = 0; k < 9; ++k) {
        sums[warp][k][slot] = Ft.a[k];
        sums[warp][9 + k][slot] = D.a[k];
      }
  }
  __syncwarp();
  const int i = base + lane32;
  if (i >= b.n) return;
  Mat3<T> Ft, D;
#pragma unroll
  for (int k = 0; k < 9; ++k) {
    Ft.a[k] = sums[warp][k][lane32];
    D.a[k] = sums[warp][9 + k][lane32];
  }
  const T xi0 = b.x[3 * i], xi1 = b.x[3 * i + 1], xi2 = b.x[3 * i + 2];
  const T ci = b.c[i];
  const bool hg_row = b.hourglass && ci > T(0);
  Mat3<double> Li;
  if (G)
#pragma unroll
    for (int k = 0; k < 9; ++k) Li.a[k] = b.L[9 * i + k];
  evaluationEpilogue<T, G, false>(b, i, Ft, D, ci, hg_row, xi0, xi1, xi2, Li, EvaluationOwnData<T>());
}

/// CorotatedSph::gather (negated: f = −∂E/∂x) and, with kick, the second half kick of free particles.
/// G: ĝ_jk and the hourglass weights recomputed from X, V, c, the neighbours read from their records
/// (b.rec, N_j = M_j L_j in place of M_j). With drift.x set (and kick), the next step's first half
/// kick and drift follow the second half kick (kickDriftKernel's arithmetic), into the other state
/// buffer.
template <class T, int L, bool G>
__global__ void __launch_bounds__(kBlock) gatherKickKernel(SoftDeviceBody<T> b, T h, bool kick, DriftTarget<T> drift) {
  waitForPreviousKernel();
  const int tid = blockIdx.x * blockDim.x + threadIdx.x;
  const int k = tid / L, lane = tid % L;
  const bool active = k < b.n;
  const int e0 = active ? b.offsets[k] : 0, e1 = active ? b.offsets[k + 1] : 0;
  const int kk = active ? k : 0;
  // As in evaluateKernel: float32 loads the particle's own data for the work after the sums now.
  constexpr bool early = sizeof(T) == 4;
  const T* gsum = G ? b.gsum_raw : b.gsum;
  T gs_e[3] = {0, 0, 0}, hs_e[3] = {0, 0, 0}, v_e[3] = {0, 0, 0}, x_e[3] = {0, 0, 0}, m_e = 0, V_e = 0;
  bool free_e = false;
  if (early) {
#pragma unroll
    for (int r = 0; r < 3; ++r) gs_e[r] = gsum[3 * kk + r];
    if (b.hourglass)
#pragma unroll
      for (int r = 0; r < 3; ++r) hs_e[r] = b.hgsum[3 * kk + r];
    m_e = b.mass[kk];
    V_e = b.V[kk];
    free_e = !b.clamped[kk];
    if (kick && free_e)
#pragma unroll
      for (int r = 0; r < 3; ++r) v_e[r] = b.v[3 * kk + r];
    if (drift.x)
#pragma unroll
      for (int r = 0; r < 3; ++r) x_e[r] = b.x[3 * kk + r];
  }
  T a0 = 0, a1 = 0, a2 = 0, t0 = 0, t1 = 0, t2 = 0, u0 = 0, u1 = 0, u2 = 0;
  if (G) {
    double Xk[4];
    loadRest(b.Xr, b.n, kk, Xk);
    const T ck = b.c[kk], Vk = b.V[kk];
    const T xk0 = b.x[3 * kk], xk1 = b.x[3 * kk + 1], xk2 = b.x[3 * kk + 2];
    for (int e = e0 + lane; e < e1; e += L) {
      const int j = b.idx[e];
      T r[kRecord];  // N_j, F̃_j, x_j, c_j, V_j
      loadRecord(b.rec, b.n, j, r);
      double Xj[4];
      loadRest(b.Xr, b.n, j, Xj);
      const T X0 = static_cast<T>(Xj[0] - Xk[0]), X1 = static_cast<T>(Xj[1] - Xk[1]),
              X2 = static_cast<T>(Xj[2] - Xk[2]);  // X_jk
      T w, s;
      cubicSpline(b, X0, X1, X2, &w, &s);
      const T g0 = -s * X0, g1 = -s * X1, g2 = -s * X2;  // ∇W(X_kj)
      a0 += r[0] * g0 + r[3] * g1 + r[6] * g2;
      a1 += r[1] * g0 + r[4] * g1 + r[7] * g2;
      a2 += r[2] * g0 + r[5] * g1 + r[8] * g2;
      if (b.hourglass) {
        const T cj = r[21];
        const T wc = w * cj, y3 = w * (ck * r[22] + cj * Vk);
        const T* f = r + 9;
        t0 += wc * (f[0] * X0 + f[3] * X1 + f[6] * X2);
        t1 += wc * (f[1] * X0 + f[4] * X1 + f[7] * X2);
        t2 += wc * (f[2] * X0 + f[5] * X1 + f[8] * X2);
        u0 += y3 * (r[18] - xk0);
        u1 += y3 * (r[19] - xk1);
        u2 += y3 * (r[20] - xk2);
      }
    }
  } else if (b.hourglass) {
    const T xk0 = b.x[3 * kk], xk1 = b.x[3 * kk + 1], xk2 = b.x[3 * kk + 2];
    for (int e = e0 + lane; e < e1; e += L) {
      const int j = b.idx[e];
      const T* m = b.M + 9 * j;
      const T r0 = b.ghr[3 * e], r1 = b.ghr[3 * e + 1], r2 = b.ghr[3 * e + 2];
      a0 += m[0] * r0 + m[3] * r1 + m[6] * r2;
      a1 += m[1] * r0 + m[4] * r1 + m[7] * r2;
      a2 += m[2] * r0 + m[5] * r1 + m[8] * r2;
      const T* y = b.hgw + 4 * e;
      const T* f = b.Ft + 9 * j;
      t0 += f[0] * y[0] + f[3] * y[1] + f[6] * y[2];
      t1 += f[1] * y[0] + f[4] * y[1] + f[7] * y[2];
      t2 += f[2] * y[0] + f[5] * y[1] + f[8] * y[2];
      u0 += y[3] * (b.x[3 * j] - xk0);
      u1 += y[3] * (b.x[3 * j + 1] - xk1);
      u2 += y[3] * (b.x[3 * j + 2] - xk2);
    }
  } else {
    for (int e = e0 + lane; e < e1; e += L) {
      const T* m = b.M + 9 * b.idx[e];
      const T r0 = b.ghr[3 * e], r1 = b.ghr[3 * e + 1], r2 = b.ghr[3 * e + 2];
      a0 += m[0] * r0 + m[3] * r1 + m[6] * r2;
      a1 += m[1] * r0 + m[4] * r1 + m[7] * r2;
      a2 += m[2] * r0 + m[5] * r1 + m[8] * r2;
    }
  }
  a0 = groupSum<L>(a0);
  a1 = groupSum<L>(a1);
  a2 = groupSum<L>(a2);
  if (b.hourglass) {
    t0 = groupSum<L>(t0);
    t1 = groupSum<L>(t1);
    t2 = groupSum<L>(t2);
    u0 = groupSum<L>(u0);
    u1 = groupSum<L>(u1);
    u2 = groupSum<L>(u2);
  }
  if (drift.x && tid == 0) {
    *drift.time = *b.time + drift.dt_clock;
    *drift.step = *b.step + 1;
  }
  if (!active || lane != 0) return;
  const T Vk = early ? V_e : b.V[k];
  T rk[G ? kRecord : 1];
  if (G) loadRecord(b.rec, b.n, k, rk);
  const T* Mk_src = G ? rk : b.M + 9 * k;  // N_k with G
  const T* Fk_src = G ? rk + 9 : b.Ft + 9 * k;
  Mat3<T> Mk;
#pragma unroll
  for (int q = 0; q < 9; ++q) Mk.a[q] = Mk_src[q];
  const T gs0 = early ? gs_e[0] : gsum[3 * k], gs1 = early ? gs_e[1] : gsum[3 * k + 1],
          gs2 = early ? gs_e[2] : gsum[3 * k + 2];
  const T a[3] = {a0, a1, a2};
  T g[3];
  if (b.hourglass) {
    Mat3<T> Fk;
#pragma unroll
    for (int q = 0; q < 9; ++q) Fk.a[q] = Fk_src[q];
    const T hs0 = early ? hs_e[0] : b.hgsum[3 * k], hs1 = early ? hs_e[1] : b.hgsum[3 * k + 1],
            hs2 = early ? hs_e[2] : b.hgsum[3 * k + 2];
    const T t[3] = {t0, t1, t2}, u[3] = {u0, u1, u2};
#pragma unroll
    for (int r = 0; r < 3; ++r)
      g[r] = Vk * a[r] - (Mk(r, 0) * gs0 + Mk(r, 1) * gs1 + Mk(r, 2) * gs2) +
             (Fk(r, 0) * hs0 + Fk(r, 1) * hs1 + Fk(r, 2) * hs2) + (T(2) * Vk) * t[r] - T(2) * u[r];
  } else {
#pragma unroll
    for (int r = 0; r < 3; ++r) g[r] = Vk * a[r] - (Mk(r, 0) * gs0 + Mk(r, 1) * gs1 + Mk(r, 2) * gs2);
  }
  const bool free = early ? free_e : !b.clamped[k];
  const T m = early ? m_e : b.mass[k];
  bool finite = true;
#pragma unroll
  for (int r = 0; r < 3; ++r) {
    const T f = -g[r];
    b.f[3 * k + r] = f;
    if (kick && free) {
      const T vn = halfKick(early ? v_e[r] : b.v[3 * k + r], f, m, b.gravity[r], b.damping, h);
      finite = finite && isfinite(vn);
      if (drift.x) {
        const T vh = halfKick(vn, f, m, b.gravity[r], b.damping, h);
        b.v[3 * k + r] = vh;
        drift.x[3 * k + r] = (early ? x_e[r] : b.x[3 * k + r]) + drift.dt * vh;
      } else {
        b.v[3 * k + r] = vn;
      }
    } else if (drift.x) {
      drift.x[3 * k + r] = early ? x_e[r] : b.x[3 * k + r];
    }
  }
  if (!finite) encodeFirst<T>(&b.status[1], *b.step, k);
}

template <class T>
__global__ void polarKernel(const T* A, T* R, int count, unsigned long long* fallbacks) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= count) return;
  Mat3<T> a;
#pragma unroll
  for (int k = 0; k < 9; ++k) a.a[k] = A[9 * i + k];
  bool fb = false;
  const Mat3<T> r = polarRotation(a, &fb);
  if (fb) atomicAdd(fallbacks, 1ull);
#pragma unroll
  for (int k = 0; k < 9; ++k) R[9 * i + k] = r.a[k];
}

inline int blocks(long long threads) { return static_cast<int>((threads + kBlock - 1) / kBlock); }

/// kernel<<<blocks(threads), kBlock, 0, s>>>(args…), as a programmatic dependent of the stream's
/// previous kernel when b.dependent_launch is set.
template <class T, class... P, class... A>
void launchStep(const SoftDeviceBody<T>& b, void (*kernel)(P...), long long threads, cudaStream_t s, A... args) {
  cudaLaunchConfig_t cfg = {};
  cfg.gridDim = dim3(static_cast<unsigned>(blocks(threads)));
  cfg.blockDim = dim3(kBlock);
  cfg.stream = s;
  cudaLaunchAttribute attr[1];
  attr[0].id = cudaLaunchAttributeProgrammaticStreamSerialization;
  attr[0].val.programmaticStreamSerializationAllowed = 1;
  cfg.attrs = attr;
  cfg.numAttrs = b.dependent_launch ? 1 : 0;
  cudaLaunchKernelEx(&cfg, kernel, args...);  // errors: cudaGetLastError() after the batch
}

/// Blocks of kBlock threads of `kernel` that the current device holds at once (blocks an SM × SMs).
template <class K>
long long residentBlocks(K kernel) {
  int device = 0, sms = 0, per_sm = 0;
  cudaGetDevice(&device);
  cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, device);
  cudaOccupancyMaxActiveBlocksPerMultiprocessor(&per_sm, kernel, kBlock, 0);
  return std::max<long long>(1, static_cast<long long>(sms) * per_sm);
}

/// residentBlocks of the uncapped evaluation (the device current at the first call), computed once.
template <class T, int L, bool G>
long long residentEvaluationBlocks() {
  static const long long resident = residentBlocks(evaluateKernel<T, L, G, false>);
  return resident;
}

/// evaluationCapped for L lanes and G.
template <class T, int L, bool G>
bool evaluationCappedFor(const SoftDeviceBody<T>& b) {
  if constexpr (kCappable<L>)
    return b.capped_evaluation < 0 ? blocks(static_cast<long long>(b.n) * L) > residentEvaluationBlocks<T, L, G>()
                                   : b.capped_evaluation > 0;
  else
    return false;
}

/// Whether the float32 evaluation with recomputed ĝ and 2 or 4 lanes runs evaluateWarpKernel
/// (warp_evaluation; -1: by the grid's size, evaluationWarpFor; on small grids, e.g. 9k particles in 68
/// blocks of 128, it leaves most SMs idle and is several times slower). float64 never: with 2 lanes (its
/// choice at large sizes) it measured slower (bench/gpu/README.md).
template <class T, int L, bool G>
constexpr bool kWarpEvaluation = sizeof(T) == 4 && G&& kCappable<L>;

/// residentBlocks of evaluateWarpKernel (capped or not; the device current at the first call), computed
/// once per kernel.
template <class T, int L, bool G, bool Capped>
long long residentWarpEvaluationBlocks() {
  static const long long resident = residentBlocks(evaluateWarpKernel<T, L, G, Capped>);
  return resident;
}

template <class T, int L, bool G>
bool evaluationWarpFor(const SoftDeviceBody<T>& b) {
  if constexpr (kWarpEvaluation<T, L, G>) {
    if (b.warp_evaluation >= 0) return b.warp_evaluation > 0;
    // Its grid of n threads must fill at least three quarters of what the device holds at once (a
    // conservative line between 0.69 of a wave, where it measured about even, and 0.99, where it
    // measured faster): below, its fewer, longer warps leave SMs idle (bench/gpu/README.md).
    const long long resident = evaluationCappedFor<T, L, G>(b) ? residentWarpEvaluationBlocks<T, L, G, true>()
                                                               : residentWarpEvaluationBlocks<T, L, G, false>();
    return 4 * static_cast<long long>(blocks(b.n)) >= 3 * resident;
  } else {
    return false;
  }
}

template <class T, int L>
void launchEvaluateOnly(const SoftDeviceBody<T>& b, cudaStream_t s) {
  const long long threads = static_cast<long long>(b.n) * L;
  const auto launch = [&](auto recompute) {
    constexpr bool G = decltype(recompute)::value;
    if constexpr (kCappable<L>) {
      const bool capped = evaluationCappedFor<T, L, G>(b);
      if constexpr (kWarpEvaluation<T, L, G>) {
        if (evaluationWarpFor<T, L, G>(b)) {  // a grid of n threads
          if (capped)
            launchStep(b, evaluateWarpKernel<T, L, G, true>, static_cast<long long>(b.n), s, b);
          else
            launchStep(b, evaluateWarpKernel<T, L, G, false>, static_cast<long long>(b.n), s, b);
          return;
        }
      }
      if (capped) {
        launchStep(b, evaluateKernel<T, L, G, true>, threads, s, b);
        return;
      }
    }
    launchStep(b, evaluateKernel<T, L, G, false>, threads, s, b);
  };
  if (b.L)
    launch(std::true_type());
  else
    launch(std::false_type());
}

template <class T, int L>
void launchGatherKick(const SoftDeviceBody<T>& b, T h, bool kick, cudaStream_t s,
                      const DriftTarget<T>& drift = DriftTarget<T>()) {
  const long long threads = static_cast<long long>(b.n) * L;
  if (b.L)
    launchStep(b, gatherKickKernel<T, L, true>, threads, s, b, h, kick, drift);
  else
    launchStep(b, gatherKickKernel<T, L, false>, threads, s, b, h, kick, drift);
}

/// The adjoint's gather (linear in x, F̃, M: the body's arrays, streamed ĝ_jk and weights).
template <class T, int L>
void launchGatherOnly(const SoftDeviceBody<T>& b, cudaStream_t s) {
  gatherKickKernel<T, L, false>
      <<<blocks(static_cast<long long>(b.n) * L), kBlock, 0, s>>>(b, T(0), false, DriftTarget<T>());
}

/// Evaluation, then gather + kick, with b.lanes lanes a particle.
template <class T>
void launchForcesLanes(const SoftDeviceBody<T>& b, T h, bool kick, cudaStream_t s,
                       const DriftTarget<T>& drift = DriftTarget<T>()) {
  withLanes(b.lanes, [&](auto L) {
    launchEvaluateOnly<T, decltype(L)::value>(b, s);
    launchGatherKick<T, decltype(L)::value>(b, h, kick, s, drift);
  });
}

/// The drift target of body b: its own state (in place) or the other half of the double buffer.
template <class T>
DriftTarget<T> driftInto(const SoftDeviceBody<T>& b, double dt, bool other) {
  DriftTarget<T> d;
  d.x = other ? b.x_alt : b.x;
  d.time = other ? b.time_alt : b.time;
  d.step = other ? b.step_alt : b.step;
  d.dt = static_cast<T>(dt);
  d.dt_clock = dt;
  return d;
}

/// b with the halves of its double-buffered state (x, clock, step counter) exchanged.
template <class T>
SoftDeviceBody<T> swapped(const SoftDeviceBody<T>& b) {
  SoftDeviceBody<T> o = b;
  o.x = b.x_alt;
  o.x_alt = b.x;
  o.time = b.time_alt;
  o.time_alt = b.time;
  o.step = b.step_alt;
  o.step_alt = b.step;
  return o;
}

}  // namespace

template <class T>
void launchLeapfrogStep(const SoftDeviceBody<T>& b, double dt, void* stream) {
  cudaStream_t s = static_cast<cudaStream_t>(stream);
  const T h = static_cast<T>(0.5 * dt);
  if (b.contact.points == 0) {
    kickDriftKernel<T><<<blocks(b.n), kBlock, 0, s>>>(b, h, driftInto(b, dt, false));
    launchForcesLanes(b, h, true, s);  // forces at t + dt, second half kick
    return;
  }
  // With contact: friction at (x_n, v_n) for the first kick; the normal force joins the forces at
  // x_{n+1}, and the second kick takes friction at (x_{n+1}, v_{n+½}) (SoftBodySimulator::step).
  launchContact(b, false, stream);
  kickDriftKernel<T><<<blocks(b.n), kBlock, 0, s>>>(b, h, driftInto(b, dt, false));
  launchForcesLanes(b, T(0), false, s);
  launchContact(b, true, stream);
  kickKernel<T><<<blocks(b.n), kBlock, 0, s>>>(b, h);
}

template <class T>
void launchLeapfrogSteps(const SoftDeviceBody<T>& b, double dt, long steps, void* stream) {
  if (steps <= 0) return;
  if (b.contact.points != 0 || b.x_alt == nullptr || steps == 1) {
    for (long k = 0; k < steps; ++k) launchLeapfrogStep(b, dt, stream);
    return;
  }
  // kick + drift, then per step evaluate and gather + kick, the gather of every step but the last
  // also kicking and drifting into the other buffer; the first drift picks the buffer so that the
  // last state lands in b's own (x, time, step).
  cudaStream_t s = static_cast<cudaStream_t>(stream);
  const T h = static_cast<T>(0.5 * dt);
  const SoftDeviceBody<T> half[2] = {b, swapped(b)};
  int p = static_cast<int>((steps - 1) % 2);
  kickDriftKernel<T><<<blocks(b.n), kBlock, 0, s>>>(b, h, driftInto(b, dt, p == 1));
  for (long k = 0; k + 1 < steps; ++k) {
    launchForcesLanes(half[p], h, true, s, driftInto(half[p], dt, true));
    p = 1 - p;
  }
  launchForcesLanes(half[p], h, true, s);  // p == 0: b's own buffers
}

template <class T>
bool evaluationCapped(const SoftDeviceBody<T>& b) {
  bool capped = false;
  withLanes(b.lanes, [&](auto lanes) {
    constexpr int L = decltype(lanes)::value;
    capped = b.L ? evaluationCappedFor<T, L, true>(b) : evaluationCappedFor<T, L, false>(b);
  });
  return capped;
}

template <class T>
bool evaluationWarp(const SoftDeviceBody<T>& b) {
  bool warp = false;
  withLanes(b.lanes, [&](auto lanes) {
    constexpr int L = decltype(lanes)::value;
    warp = b.L ? evaluationWarpFor<T, L, true>(b) : evaluationWarpFor<T, L, false>(b);
  });
  return warp;
}

template <class T>
void launchEvaluateForces(const SoftDeviceBody<T>& b, void* stream) {
  launchForcesLanes(b, T(0), false, static_cast<cudaStream_t>(stream));
  launchContact(b, true, stream);  // + the contact's normal force (none without contact)
}

template <class T>
void launchEvaluateState(const SoftDeviceBody<T>& b, void* stream) {
  withLanes(b.lanes, [&](auto L) { launchEvaluateOnly<T, decltype(L)::value>(b, static_cast<cudaStream_t>(stream)); });
}

template <class T>
void launchGatherForces(const SoftDeviceBody<T>& b, void* stream) {
  withLanes(b.lanes, [&](auto L) { launchGatherOnly<T, decltype(L)::value>(b, static_cast<cudaStream_t>(stream)); });
}

template <class T>
void launchGatherRecords(const SoftDeviceBody<T>& b, void* stream) {
  cudaStream_t s = static_cast<cudaStream_t>(stream);
  withLanes(b.lanes, [&](auto L) {
    gatherKickKernel<T, decltype(L)::value, true>
        <<<blocks(static_cast<long long>(b.n) * decltype(L)::value), kBlock, 0, s>>>(b, T(0), false, DriftTarget<T>());
  });
}

template <class T>
void launchPolarRotations(const T* A, T* R, int count, unsigned long long* fallbacks, void* stream) {
  polarKernel<T><<<blocks(count), kBlock, 0, static_cast<cudaStream_t>(stream)>>>(A, R, count, fallbacks);
}

template void launchLeapfrogStep<double>(const SoftDeviceBody<double>&, double, void*);
template void launchLeapfrogStep<float>(const SoftDeviceBody<float>&, double, void*);
template void launchLeapfrogSteps<double>(const SoftDeviceBody<double>&, double, long, void*);
template void launchLeapfrogSteps<float>(const SoftDeviceBody<float>&, double, long, void*);
template void launchEvaluateForces<double>(const SoftDeviceBody<double>&, void*);
template void launchEvaluateForces<float>(const SoftDeviceBody<float>&, void*);
template bool evaluationCapped<double>(const SoftDeviceBody<double>&);
template bool evaluationCapped<float>(const SoftDeviceBody<float>&);
template bool evaluationWarp<double>(const SoftDeviceBody<double>&);
template bool evaluationWarp<float>(const SoftDeviceBody<float>&);
template void launchEvaluateState<double>(const SoftDeviceBody<double>&, void*);
template void launchEvaluateState<float>(const SoftDeviceBody<float>&, void*);
template void launchGatherForces<double>(const SoftDeviceBody<double>&, void*);
template void launchGatherForces<float>(const SoftDeviceBody<float>&, void*);
template void launchGatherRecords<double>(const SoftDeviceBody<double>&, void*);
template void launchGatherRecords<float>(const SoftDeviceBody<float>&, void*);
template void launchPolarRotations<double>(const double*, double*, int, unsigned long long*, void*);
template void launchPolarRotations<float>(const float*, float*, int, unsigned long long*, void*);

}  // namespace cuda_detail
}  // namespace topo_gaussian
