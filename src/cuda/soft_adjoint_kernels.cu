// Kernels of the explicit rollout and its adjoint on the GPU (cuda/soft_rollout_cuda.h; the CPU's
// SoftRollout with SoftIntegrator::SymplecticEuler, physics/soft_rollout.cpp):
//   symplecticKickDriftKernel ↔ SoftRollout::stepForward's update of v and x,
//   hessianRowKernel ↔ CorotatedSph::hessianProduct's per-particle pass (dF̃_i, dM_i) with
//     CorotatedSph::materialRow (∂/∂μ_i, ∂/∂λ_i of a·∇E) and PneumaticActuation's Hessian term and
//     chamberDirectional; the product itself is the force gather applied to (a, dF̃, dM),
//   adjointPrepareKernel / adjointFinishKernel ↔ the per-particle updates of SoftRollout::run.
#include <cuda_runtime.h>

#include "soft_device_math.cuh"
#include "soft_step_kernels.h"

namespace topo_gaussian {
namespace cuda_detail {

namespace {

using namespace device;

inline int blocks(long long threads) { return static_cast<int>((threads + kBlock - 1) / kBlock); }

/// v ← v + dt (f/m + g − c v), x ← x + dt v of b's free particles into (x_out, v_out), the clock into
/// *time_out: in place when they are b's own, else out of place (clamped particles copied).
template <class T>
__global__ void symplecticKickDriftKernel(SoftDeviceBody<T> b, T* x_out, T* v_out, double* time_out, T dt,
                                          double dt_clock) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i == 0) {
    *time_out = *b.time + dt_clock;
    *b.step += 1;
  }
  if (i >= b.n) return;
  if (b.clamped[i]) {
    if (x_out != b.x)
#pragma unroll
      for (int d = 0; d < 3; ++d) {
        x_out[3 * i + d] = b.x[3 * i + d];
        v_out[3 * i + d] = b.v[3 * i + d];
      }
    return;
  }
  const T m = b.mass[i];
  bool finite = true;
#pragma unroll
  for (int d = 0; d < 3; ++d) {
    const T v = b.v[3 * i + d];
    const T f = b.contact.points ? b.f[3 * i + d] + b.contact.pfr[3 * i + d] : b.f[3 * i + d];
    const T vn = v + dt * (f / m + b.gravity[d] - b.damping * v);
    v_out[3 * i + d] = vn;
    x_out[3 * i + d] = b.x[3 * i + d] + dt * vn;
    finite = finite && isfinite(vn) && isfinite(x_out[3 * i + d]);
  }
  if (!finite) encodeFirst<T>(&b.status[1], 0, i);  // the host checks after every step and names it
}

/// corotated_sph.cpp's piolaDifferential: d P̂(F̃)[dF̃], P̂(F̃) = ∂ψ(R(F̃)ᵀF̃)/∂F̃.
template <class T>
__device__ Mat3<T> piolaDifferential(bool stvk, bool exact_rotation, const Mat3<T>& Ft, const Mat3<T>& R,
                                     const Mat3<T>& dFt, T mu, T la) {
  Mat3<T> out;
  if (stvk) {
    Mat3<T> E = mulTn(Ft, Ft), dE;
#pragma unroll
    for (int k = 0; k < 9; ++k) E.a[k] *= T(0.5);
    E(0, 0) -= T(0.5);
    E(1, 1) -= T(0.5);
    E(2, 2) -= T(0.5);
    const Mat3<T> A = mulTn(dFt, Ft), B = mulTn(Ft, dFt);
#pragma unroll
    for (int k = 0; k < 9; ++k) dE.a[k] = T(0.5) * (A.a[k] + B.a[k]);
    const T trE = E(0, 0) + E(1, 1) + E(2, 2), trdE = dE(0, 0) + dE(1, 1) + dE(2, 2);
    Mat3<T> S1, S2;
#pragma unroll
    for (int k = 0; k < 9; ++k) {
      S1.a[k] = T(2) * mu * E.a[k];
      S2.a[k] = T(2) * mu * dE.a[k];
    }
    S1(0, 0) += la * trE;
    S1(1, 1) += la * trE;
    S1(2, 2) += la * trE;
    S2(0, 0) += la * trdE;
    S2(1, 1) += la * trdE;
    S2(2, 2) += la * trdE;
    const Mat3<T> P1 = mul(dFt, S1), P2 = mul(Ft, S2);
#pragma unroll
    for (int k = 0; k < 9; ++k) out.a[k] = P1.a[k] + P2.a[k];
    return out;
  }
  // Corotated linear: P̂ = 2μ(F̃ − R) + λ tr(S − I) R, S = RᵀF̃.
  const Mat3<T> S = mulTn(R, Ft), Y = mulTn(R, dFt);
  Mat3<T> dR = zero3<T>();
  if (exact_rotation) {
    // ((tr S) I − sym S) ω = axial(Y − Yᵀ), dR = R [ω]×.
    const T ax0 = Y(2, 1) - Y(1, 2), ax1 = Y(0, 2) - Y(2, 0), ax2 = Y(1, 0) - Y(0, 1);
    const T trS = S(0, 0) + S(1, 1) + S(2, 2);
    Mat3<T> A;
#pragma unroll
    for (int c = 0; c < 3; ++c)
#pragma unroll
      for (int r = 0; r < 3; ++r) A(r, c) = (r == c ? trS : T(0)) - T(0.5) * (S(r, c) + S(c, r));
    const Mat3<T> C = cofactor3(A);  // A⁻¹ = Cᵀ / det A
    const T det = A(0, 0) * C(0, 0) + A(0, 1) * C(0, 1) + A(0, 2) * C(0, 2);
    const T w0 = (C(0, 0) * ax0 + C(1, 0) * ax1 + C(2, 0) * ax2) / det;
    const T w1 = (C(0, 1) * ax0 + C(1, 1) * ax1 + C(2, 1) * ax2) / det;
    const T w2 = (C(0, 2) * ax0 + C(1, 2) * ax1 + C(2, 2) * ax2) / det;
    Mat3<T> Wx = zero3<T>();
    Wx(0, 1) = -w2;
    Wx(0, 2) = w1;
    Wx(1, 0) = w2;
    Wx(1, 2) = -w0;
    Wx(2, 0) = -w1;
    Wx(2, 1) = w0;
    dR = mul(R, Wx);
  }
  const T trSm = S(0, 0) + S(1, 1) + S(2, 2) - T(3);
  const T trY = Y(0, 0) + Y(1, 1) + Y(2, 2);
#pragma unroll
  for (int k = 0; k < 9; ++k) out.a[k] = T(2) * mu * (dFt.a[k] - dR.a[k]) + la * trY * R.a[k] + la * trSm * dR.a[k];
  return out;
}

/// cofactorDifferential (pneumatic_actuation.cpp): d cof(F)[dF], columns by cross products.
template <class T>
__device__ Mat3<T> cofactorDifferential(const Mat3<T>& F, const Mat3<T>& dF) {
  Mat3<T> C;
  auto cross = [](T a0, T a1, T a2, T b0, T b1, T b2, T* o) {
    o[0] = a1 * b2 - a2 * b1;
    o[1] = a2 * b0 - a0 * b2;
    o[2] = a0 * b1 - a1 * b0;
  };
  const int nxt[3][2] = {{1, 2}, {2, 0}, {0, 1}};
#pragma unroll
  for (int c = 0; c < 3; ++c) {
    const int p = nxt[c][0], q = nxt[c][1];
    T u[3], w[3];
    cross(dF(0, p), dF(1, p), dF(2, p), F(0, q), F(1, q), F(2, q), u);
    cross(F(0, p), F(1, p), F(2, p), dF(0, q), dF(1, q), dF(2, q), w);
#pragma unroll
    for (int r = 0; r < 3; ++r) C(r, c) = u[r] + w[r];
  }
  return C;
}

/// Per particle at the evaluated state (b.Ft, b.R, b.x): dF̃_i = Σ_j V_j a_ji ĝ_ijᵀ, dM_i, and the
/// material and chamber directional derivatives along a (clamped rows of a are zero).
template <class T, int L>
__global__ void __launch_bounds__(kBlock) hessianRowKernel(SoftDeviceBody<T> b, const T* a, T* dFt_out, T* dM_out,
                                                           T* d_mu, T* d_lambda, T* d_ch, T* rec_out) {
  const int tid = blockIdx.x * blockDim.x + threadIdx.x;
  const int i = tid / L, lane = tid % L;
  const bool active = i < b.n;
  const int e0 = active ? b.offsets[i] : 0, e1 = active ? b.offsets[i + 1] : 0;
  const int ii = active ? i : 0;
  const T ai0 = a[3 * ii], ai1 = a[3 * ii + 1], ai2 = a[3 * ii + 2];
  const T Xi0 = b.X[3 * ii], Xi1 = b.X[3 * ii + 1], Xi2 = b.X[3 * ii + 2];
  const T ci = b.c[ii];
  const bool hg_row = b.hourglass && ci > T(0);
  Mat3<T> dF = zero3<T>(), dD = zero3<T>();
  for (int e = e0 + lane; e < e1; e += L) {
    const int j = b.idx[e];
    const T v = b.V[j];
    const T d0 = v * (a[3 * j] - ai0), d1 = v * (a[3 * j + 1] - ai1), d2 = v * (a[3 * j + 2] - ai2);
    const T g0 = b.gh[3 * e], g1 = b.gh[3 * e + 1], g2 = b.gh[3 * e + 2];
    dF(0, 0) += d0 * g0;
    dF(1, 0) += d1 * g0;
    dF(2, 0) += d2 * g0;
    dF(0, 1) += d0 * g1;
    dF(1, 1) += d1 * g1;
    dF(2, 1) += d2 * g1;
    dF(0, 2) += d0 * g2;
    dF(1, 2) += d1 * g2;
    dF(2, 2) += d2 * g2;
    if (hg_row) {
      const T w = b.W[e];
      const T b0 = w * d0, b1 = w * d1, b2 = w * d2;
      const T X0 = b.X[3 * j] - Xi0, X1 = b.X[3 * j + 1] - Xi1, X2 = b.X[3 * j + 2] - Xi2;
      dD(0, 0) += b0 * X0;
      dD(1, 0) += b1 * X0;
      dD(2, 0) += b2 * X0;
      dD(0, 1) += b0 * X1;
      dD(1, 1) += b1 * X1;
      dD(2, 1) += b2 * X1;
      dD(0, 2) += b0 * X2;
      dD(1, 2) += b1 * X2;
      dD(2, 2) += b2 * X2;
    }
  }
#pragma unroll
  for (int k = 0; k < 9; ++k) {
    dF.a[k] = groupSum<L>(dF.a[k]);
    dD.a[k] = groupSum<L>(dD.a[k]);
  }
  Mat3<T> Ft;
#pragma unroll
  for (int k = 0; k < 9; ++k) Ft.a[k] = b.Ft[9 * ii + k];
  // Hourglass part of ∂(a·∇E)/∂μ_i: (α V_i / h²) Σ_j 2 V_j W_ij e_ij·de_ij, e_ij = F̃_i X_ji − x_ji,
  // de_ij = dF̃_i X_ji − a_ji (a second sweep of the row, now that dF̃_i is known).
  T hg = 0;
  if (d_mu && b.hourglass && b.hg_alpha_over_h2 > 0.0) {
    const T xi0 = b.x[3 * ii], xi1 = b.x[3 * ii + 1], xi2 = b.x[3 * ii + 2];
    for (int e = e0 + lane; e < e1; e += L) {
      const int j = b.idx[e];
      const T X0 = b.X[3 * j] - Xi0, X1 = b.X[3 * j + 1] - Xi1, X2 = b.X[3 * j + 2] - Xi2;
      T er[3], de[3];
      const T xj[3] = {b.x[3 * j] - xi0, b.x[3 * j + 1] - xi1, b.x[3 * j + 2] - xi2};
      const T aj[3] = {a[3 * j] - ai0, a[3 * j + 1] - ai1, a[3 * j + 2] - ai2};
#pragma unroll
      for (int r = 0; r < 3; ++r) {
        er[r] = Ft(r, 0) * X0 + Ft(r, 1) * X1 + Ft(r, 2) * X2 - xj[r];
        de[r] = dF(r, 0) * X0 + dF(r, 1) * X1 + dF(r, 2) * X2 - aj[r];
      }
      hg += T(2) * b.V[j] * b.W[e] * (er[0] * de[0] + er[1] * de[1] + er[2] * de[2]);
    }
    hg = groupSum<L>(hg);
  }
  if (!active || lane != 0) return;
  Mat3<T> R;
#pragma unroll
  for (int k = 0; k < 9; ++k) R.a[k] = b.R[9 * i + k];
  const T mu = b.mu[i], la = b.lambda[i], Vi = b.V[i];
  const Mat3<T> dP = piolaDifferential(b.stvk != 0, b.shape_matching == 0, Ft, R, dF, mu, la);
  Mat3<T> dM;
#pragma unroll
  for (int k = 0; k < 9; ++k) dM.a[k] = Vi * dP.a[k];
  if (hg_row) {
    Mat3<T> C;
#pragma unroll
    for (int k = 0; k < 9; ++k) C.a[k] = b.moment[9 * i + k];
    const Mat3<T> dFC = mul(dF, C);
#pragma unroll
    for (int k = 0; k < 9; ++k) dM.a[k] += (T(2) * ci) * (dFC.a[k] - dD.a[k]);
  }
  T dch = 0;
  if (b.chamber) {
    const double p = pressureAt(b, *b.time);
    if (p != 0.0) {
      const T wi = b.chamber[i];
      if (wi != T(0)) {
        const Mat3<T> dC = cofactorDifferential(Ft, dF);
        const T s = -static_cast<T>(p) * wi * Vi;
#pragma unroll
        for (int k = 0; k < 9; ++k) dM.a[k] += s * dC.a[k];
      }
      const Mat3<T> Cf = cofactor3(Ft);
      T dot = 0;
#pragma unroll
      for (int k = 0; k < 9; ++k) dot += Cf.a[k] * dF.a[k];
      dch = -static_cast<T>(p) * Vi * dot;
    }
  }
  if (rec_out)  // the gather's record of (a, dF̃, dM) (evaluateKernel's layout: N_i = dM_i L_i)
    writeRecord(rec_out, b.n, i, dM, b.L + 9 * i, dF, ai0, ai1, ai2, ci, Vi);
  if (dFt_out)
#pragma unroll
    for (int k = 0; k < 9; ++k) {
      dFt_out[9 * i + k] = dF.a[k];
      dM_out[9 * i + k] = dM.a[k];
    }
  if (d_mu) {
    const Mat3<T> F = mulTn(R, Ft);
    const Mat3<T> Pmu = mul(R, firstPiola(b.stvk != 0, F, T(1), T(0)));
    const Mat3<T> Pla = mul(R, firstPiola(b.stvk != 0, F, T(0), T(1)));
    T smu = 0, sla = 0;
#pragma unroll
    for (int k = 0; k < 9; ++k) {
      smu += Pmu.a[k] * dF.a[k];
      sla += Pla.a[k] * dF.a[k];
    }
    const T c = static_cast<T>(b.hg_alpha_over_h2) * Vi;
    d_mu[i] = Vi * smu + c * hg;
    d_lambda[i] = Vi * sla;
  }
  if (d_ch) d_ch[i] = dch;
}

/// w = v̄ + dt x̄, a = dt w / m, m̄ −= a·f/m on free particles; a = w = 0 on clamped ones.
template <class T>
__global__ void adjointPrepareKernel(SoftDeviceBody<T> b, const T* f, T dt, const T* xb, const T* vb, T* w, T* a,
                                     T* g_mass) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= b.n) return;
  if (b.clamped[i]) {
#pragma unroll
    for (int d = 0; d < 3; ++d) w[3 * i + d] = a[3 * i + d] = T(0);
    return;
  }
  const T m = b.mass[i];
  T dot = 0;
#pragma unroll
  for (int d = 0; d < 3; ++d) {
    const T wd = vb[3 * i + d] + dt * xb[3 * i + d];
    w[3 * i + d] = wd;
    const T ad = dt * wd / m;
    a[3 * i + d] = ad;
    dot += ad * f[3 * i + d];
  }
  g_mass[i] -= dot / m;
}

/// x̄ ← x̄ − H a (minusHa = −H a from the negated gather), v̄ ← (1 − c dt) w on free particles, zero
/// on clamped ones; the material gradients for every particle.
template <class T>
__global__ void adjointFinishKernel(SoftDeviceBody<T> b, T dt, const T* w, const T* minusHa, const T* d_mu,
                                    const T* d_la, const T* d_ch, T* xb, T* vb, T* g_mu, T* g_la, T* g_ch) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= b.n) return;
  const bool clamped = b.clamped[i];
#pragma unroll
  for (int d = 0; d < 3; ++d) {
    xb[3 * i + d] = clamped ? T(0) : xb[3 * i + d] + minusHa[3 * i + d];
    vb[3 * i + d] = clamped ? T(0) : (T(1) - b.damping * dt) * w[3 * i + d];
  }
  g_mu[i] -= d_mu[i];
  g_la[i] -= d_la[i];
  if (g_ch) g_ch[i] -= d_ch[i];
}

template <class T>
__global__ void addKernel(T* y, const T* x, int n3) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n3) y[i] += x[i];
}

__global__ void setClockKernel(double* time, double t) { *time = t; }

template <class T, int L>
void launchHessianRow(const SoftDeviceBody<T>& b, const T* a, T* dFt, T* dM, T* d_mu, T* d_la, T* d_ch, T* rec,
                      cudaStream_t s) {
  hessianRowKernel<T, L>
      <<<blocks(static_cast<long long>(b.n) * L), kBlock, 0, s>>>(b, a, dFt, dM, d_mu, d_la, d_ch, rec);
}

/// launchHessianRow with the body's lanes per particle. rec (with b.L): the row's record for the gather
/// over (a, dF̃, dM) that recomputes ĝ (launchGatherRecords); dFt and dM may then be null.
template <class T>
void launchHessianRowLanes(const SoftDeviceBody<T>& b, const T* a, T* dFt, T* dM, T* d_mu, T* d_la, T* d_ch,
                           cudaStream_t s, T* rec = nullptr) {
  withLanes(b.lanes, [&](auto L) { launchHessianRow<T, decltype(L)::value>(b, a, dFt, dM, d_mu, d_la, d_ch, rec, s); });
}

}  // namespace

template <class T>
void launchSymplecticStep(const SoftDeviceBody<T>& b, double dt, void* stream) {
  cudaStream_t s = static_cast<cudaStream_t>(stream);
  launchContact(b, false, stream);  // friction at (x_k, v_k)
  symplecticKickDriftKernel<T><<<blocks(b.n), kBlock, 0, s>>>(b, b.x, b.v, b.time, static_cast<T>(dt), dt);
  launchEvaluateForces(b, stream);
}

template <class T>
void launchSymplecticStepInto(const SoftDeviceBody<T>& in, const SoftDeviceBody<T>& out, double dt, void* stream) {
  cudaStream_t s = static_cast<cudaStream_t>(stream);
  launchContact(in, false, stream);  // friction at (x_k, v_k)
  symplecticKickDriftKernel<T><<<blocks(in.n), kBlock, 0, s>>>(in, out.x, out.v, out.time, static_cast<T>(dt), dt);
  launchEvaluateForces(out, stream);
}

template <class T>
void launchAdjointStep(const SoftDeviceBody<T>& b, const T* f, double dt, T* xb, T* vb, T* g_mass, T* g_mu, T* g_lambda,
                       T* g_chamber, T* work, void* stream) {
  cudaStream_t s = static_cast<cudaStream_t>(stream);
  const std::size_t n = static_cast<std::size_t>(b.n);
  T* a = work;
  T* w = a + 3 * n;
  T* mHa = w + 3 * n;
  T* dFt = mHa + 3 * n;
  T* dM = dFt + 9 * n;
  T* d_mu = dM + 9 * n;
  T* d_la = d_mu + n;
  T* d_ch = d_la + n;
  adjointPrepareKernel<T><<<blocks(b.n), kBlock, 0, s>>>(b, f, static_cast<T>(dt), xb, vb, w, a, g_mass);
  // −H a: the force gather over (a, dF̃, dM), written to mHa. With b.L as the step's: the row pass
  // writes the gather's record and the gather recomputes ĝ (faster than streaming ĝ, which reads 11
  // values a neighbour entry; bench/gpu/README.md).
  SoftDeviceBody<T> lin = b;
  lin.x = a;
  lin.f = mHa;
  if (b.L) {
    T* rec = work + (30 * n + 3) / 4 * 4;  // kRecord n values after the 30 n above, 16-byte aligned
    launchHessianRowLanes(b, a, static_cast<T*>(nullptr), static_cast<T*>(nullptr), d_mu, d_la, d_ch, s, rec);
    lin.rec = rec;
    launchGatherRecords(lin, stream);
  } else {
    launchHessianRowLanes(b, a, dFt, dM, d_mu, d_la, d_ch, s);
    lin.Ft = dFt;
    lin.M = dM;
    launchGatherForces(lin, stream);
  }
  adjointFinishKernel<T><<<blocks(b.n), kBlock, 0, s>>>(b, static_cast<T>(dt), w, mHa, d_mu, d_la, d_ch, xb, vb, g_mu,
                                                        g_lambda, b.chamber ? g_chamber : nullptr);
}

template <class T>
void launchStiffnessProduct(const SoftDeviceBody<T>& b, const T* a, T* out, T* work, void* stream) {
  cudaStream_t s = static_cast<cudaStream_t>(stream);
  const std::size_t n = static_cast<std::size_t>(b.n);
  T* dFt = work;
  T* dM = dFt + 9 * n;
  launchHessianRowLanes(b, a, dFt, dM, static_cast<T*>(nullptr), static_cast<T*>(nullptr), static_cast<T*>(nullptr), s);
  SoftDeviceBody<T> lin = b;
  lin.x = const_cast<T*>(a);
  lin.Ft = dFt;
  lin.M = dM;
  lin.f = out;
  launchGatherForces(lin, stream);
}

void launchSetClock(double* time, double t, void* stream) {
  setClockKernel<<<1, 1, 0, static_cast<cudaStream_t>(stream)>>>(time, t);
}

template <class T>
void launchAdd(T* y, const T* x, int n3, void* stream) {
  addKernel<T><<<blocks(n3), kBlock, 0, static_cast<cudaStream_t>(stream)>>>(y, x, n3);
}

template void launchSymplecticStep<double>(const SoftDeviceBody<double>&, double, void*);
template void launchSymplecticStep<float>(const SoftDeviceBody<float>&, double, void*);
template void launchSymplecticStepInto<double>(const SoftDeviceBody<double>&, const SoftDeviceBody<double>&, double,
                                               void*);
template void launchSymplecticStepInto<float>(const SoftDeviceBody<float>&, const SoftDeviceBody<float>&, double,
                                              void*);
template void launchAdjointStep<double>(const SoftDeviceBody<double>&, const double*, double, double*, double*, double*,
                                        double*, double*, double*, double*, void*);
template void launchAdjointStep<float>(const SoftDeviceBody<float>&, const float*, double, float*, float*, float*,
                                       float*, float*, float*, float*, void*);
template void launchStiffnessProduct<double>(const SoftDeviceBody<double>&, const double*, double*, double*, void*);
template void launchStiffnessProduct<float>(const SoftDeviceBody<float>&, const float*, float*, float*, void*);
template void launchAdd<double>(double*, const double*, int, void*);
template void launchAdd<float>(float*, const float*, int, void*);

}  // namespace cuda_detail
}  // namespace topo_gaussian
