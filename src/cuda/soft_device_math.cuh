// Device math of the soft-body kernels (soft_step_kernels.cu, soft_adjoint_kernels.cu): 3×3
// matrices (column-major), the polar rotation (the CPU's Newton iteration, corotated_sph.cpp, and a
// Jacobi fallback), the group sums of the lanes that share a particle, the status words.
#pragma once

#include <cuda_runtime.h>

#include "soft_step_kernels.h"

namespace topo_gaussian {
namespace cuda_detail {
namespace device {

constexpr int kBlock = 128;

template <class T>
struct Mat3 {
  T a[9];  // column-major: a[r + 3c]
  __device__ T& operator()(int r, int c) { return a[r + 3 * c]; }
  __device__ T operator()(int r, int c) const { return a[r + 3 * c]; }
};

template <class T>
__device__ inline Mat3<T> zero3() {
  Mat3<T> m;
#pragma unroll
  for (int k = 0; k < 9; ++k) m.a[k] = T(0);
  return m;
}

template <class T>
__device__ inline T sqnorm(const Mat3<T>& m) {
  T s = 0;
#pragma unroll
  for (int k = 0; k < 9; ++k) s += m.a[k] * m.a[k];
  return s;
}

/// A·B
template <class T>
__device__ inline Mat3<T> mul(const Mat3<T>& A, const Mat3<T>& B) {
  Mat3<T> C;
#pragma unroll
  for (int c = 0; c < 3; ++c)
#pragma unroll
    for (int r = 0; r < 3; ++r) C(r, c) = A(r, 0) * B(0, c) + A(r, 1) * B(1, c) + A(r, 2) * B(2, c);
  return C;
}

/// Aᵀ·B
template <class T>
__device__ inline Mat3<T> mulTn(const Mat3<T>& A, const Mat3<T>& B) {
  Mat3<T> C;
#pragma unroll
  for (int c = 0; c < 3; ++c)
#pragma unroll
    for (int r = 0; r < 3; ++r) C(r, c) = A(0, r) * B(0, c) + A(1, r) * B(1, c) + A(2, r) * B(2, c);
  return C;
}

template <class T>
__device__ inline Mat3<T> cofactor3(const Mat3<T>& X) {
  Mat3<T> C;
  C(0, 0) = X(1, 1) * X(2, 2) - X(1, 2) * X(2, 1);
  C(0, 1) = X(1, 2) * X(2, 0) - X(1, 0) * X(2, 2);
  C(0, 2) = X(1, 0) * X(2, 1) - X(1, 1) * X(2, 0);
  C(1, 0) = X(0, 2) * X(2, 1) - X(0, 1) * X(2, 2);
  C(1, 1) = X(0, 0) * X(2, 2) - X(0, 2) * X(2, 0);
  C(1, 2) = X(0, 1) * X(2, 0) - X(0, 0) * X(2, 1);
  C(2, 0) = X(0, 1) * X(1, 2) - X(0, 2) * X(1, 1);
  C(2, 1) = X(0, 2) * X(1, 0) - X(0, 0) * X(1, 2);
  C(2, 2) = X(0, 0) * X(1, 1) - X(0, 1) * X(1, 0);
  return C;
}

template <class T>
__device__ inline T det3(const Mat3<T>& X) {
  return X(0, 0) * (X(1, 1) * X(2, 2) - X(1, 2) * X(2, 1)) - X(0, 1) * (X(1, 0) * X(2, 2) - X(1, 2) * X(2, 0)) +
         X(0, 2) * (X(1, 0) * X(2, 1) - X(1, 1) * X(2, 0));
}

/// First Piola–Kirchhoff stress P(F) = ∂ψ/∂F for (μ, λ) (corotated_sph.cpp, piolaAndEnergy's P):
/// StVK P = F S(E), E = ½(FᵀF − I); corotated linear P = S(ε), ε = sym(F) − I; S(e) = 2μ e + λ tr(e) I.
/// The forward step and the adjoint both use it.
template <class T>
__device__ __forceinline__ Mat3<T> firstPiola(bool stvk, const Mat3<T>& F, T mu, T la) {
  Mat3<T> eps;
  if (stvk) {
    eps = mulTn(F, F);
#pragma unroll
    for (int k = 0; k < 9; ++k) eps.a[k] *= T(0.5);
    eps(0, 0) -= T(0.5);
    eps(1, 1) -= T(0.5);
    eps(2, 2) -= T(0.5);
  } else {
#pragma unroll
    for (int c = 0; c < 3; ++c)
#pragma unroll
      for (int r = 0; r < 3; ++r) eps(r, c) = T(0.5) * (F(r, c) + F(c, r));
    eps(0, 0) -= T(1);
    eps(1, 1) -= T(1);
    eps(2, 2) -= T(1);
  }
  const T tr = eps(0, 0) + eps(1, 1) + eps(2, 2);
  Mat3<T> S;
#pragma unroll
  for (int k = 0; k < 9; ++k) S.a[k] = T(2) * mu * eps.a[k];
  S(0, 0) += la * tr;
  S(1, 1) += la * tr;
  S(2, 2) += la * tr;
  return stvk ? mul(F, S) : S;
}

/// Newton-iteration thresholds: float64 as the CPU (corotated_sph.cpp, PolarNewton); float32 stops
/// at its own round-off.
template <class T>
struct PolarTol;
template <>
struct PolarTol<double> {
  static constexpr double converged = 1e-16, scaled = 1e-4;
};
template <>
struct PolarTol<float> {
  static constexpr float converged = 1e-11f, scaled = 1e-4f;
};

/// Symmetric 3×3 eigen-decomposition by cyclic Jacobi rotations: S = Q diag(w) Qᵀ.
template <class T>
__device__ void jacobiEigen(Mat3<T> S, Mat3<T>* Q, T w[3]) {
  Mat3<T> q = zero3<T>();
  q(0, 0) = q(1, 1) = q(2, 2) = T(1);
  for (int sweep = 0; sweep < 30; ++sweep) {
    const T off = S(0, 1) * S(0, 1) + S(0, 2) * S(0, 2) + S(1, 2) * S(1, 2);
    const T diag = S(0, 0) * S(0, 0) + S(1, 1) * S(1, 1) + S(2, 2) * S(2, 2);
    if (!(off > T(1e-30) * diag)) break;
#pragma unroll
    for (int p = 0; p < 2; ++p)
#pragma unroll
      for (int r = p + 1; r < 3; ++r) {
        const T apq = S(p, r);
        if (apq == T(0)) continue;
        const T theta = (S(r, r) - S(p, p)) / (T(2) * apq);
        const T t = (theta >= T(0) ? T(1) : T(-1)) / (fabs(theta) + sqrt(theta * theta + T(1)));
        const T c = T(1) / sqrt(t * t + T(1)), s = t * c;
        // S ← Jᵀ S J with J the rotation in the (p, r) plane.
#pragma unroll
        for (int k = 0; k < 3; ++k) {
          const T skp = S(k, p), skr = S(k, r);
          S(k, p) = c * skp - s * skr;
          S(k, r) = s * skp + c * skr;
        }
#pragma unroll
        for (int k = 0; k < 3; ++k) {
          const T spk = S(p, k), srk = S(r, k);
          S(p, k) = c * spk - s * srk;
          S(r, k) = s * spk + c * srk;
        }
#pragma unroll
        for (int k = 0; k < 3; ++k) {
          const T qkp = q(k, p), qkr = q(k, r);
          q(k, p) = c * qkp - s * qkr;
          q(k, r) = s * qkp + c * qkr;
        }
      }
  }
  w[0] = S(0, 0);
  w[1] = S(1, 1);
  w[2] = S(2, 2);
  *Q = q;
}

/// Proper rotation of the polar decomposition through AᵀA = V Σ² Vᵀ, U = A V Σ⁻¹ (the direction of
/// the smallest singular value completed by a cross product, and flipped when det A < 0, as the
/// CPU's SVD fallback does). For the matrices Newton's iteration declines: reflected, nearly
/// singular or non-finite.
template <class T>
__device__ Mat3<T> polarFallback(const Mat3<T>& A) {
  Mat3<T> Vm;
  T w[3];
  jacobiEigen(mulTn(A, A), &Vm, w);
  // Order by descending singular value.
  int o[3] = {0, 1, 2};
  if (w[o[0]] < w[o[1]]) {
    int t = o[0];
    o[0] = o[1];
    o[1] = t;
  }
  if (w[o[1]] < w[o[2]]) {
    int t = o[1];
    o[1] = o[2];
    o[2] = t;
  }
  if (w[o[0]] < w[o[1]]) {
    int t = o[0];
    o[0] = o[1];
    o[1] = t;
  }
  Mat3<T> Vs, U;
#pragma unroll
  for (int c = 0; c < 3; ++c)
#pragma unroll
    for (int r = 0; r < 3; ++r) Vs(r, c) = Vm(r, o[c]);
  if (!(w[o[0]] > T(0)) || !isfinite(w[o[0]])) {
    Mat3<T> I = zero3<T>();
    I(0, 0) = I(1, 1) = I(2, 2) = T(1);
    return I;
  }
  // Right-handed V.
  if (det3(Vs) < T(0))
#pragma unroll
    for (int r = 0; r < 3; ++r) Vs(r, 2) = -Vs(r, 2);
  for (int c = 0; c < 2; ++c) {
    T u[3], nrm = 0;
#pragma unroll
    for (int r = 0; r < 3; ++r) {
      u[r] = A(r, 0) * Vs(0, c) + A(r, 1) * Vs(1, c) + A(r, 2) * Vs(2, c);
      nrm += u[r] * u[r];
    }
    nrm = sqrt(nrm);
    if (c == 1) {  // Gram-Schmidt against column 0
      T d = 0;
#pragma unroll
      for (int r = 0; r < 3; ++r) d += u[r] * U(r, 0);
      nrm = 0;
#pragma unroll
      for (int r = 0; r < 3; ++r) {
        u[r] -= d * U(r, 0);
        nrm += u[r] * u[r];
      }
      nrm = sqrt(nrm);
    }
    if (!(nrm > T(0))) {  // rank-deficient: any unit vector orthogonal to the previous column
      const T a0 = c == 0 ? T(1) : U(0, 0), a1 = c == 0 ? T(0) : U(1, 0), a2 = c == 0 ? T(0) : U(2, 0);
      if (fabs(a0) < T(0.9)) {
        u[0] = 0;
        u[1] = a2;
        u[2] = -a1;
      } else {
        u[0] = -a2;
        u[1] = 0;
        u[2] = a0;
      }
      if (c == 0) {
        u[0] = 1;
        u[1] = 0;
        u[2] = 0;
      }
      nrm = sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    }
#pragma unroll
    for (int r = 0; r < 3; ++r) U(r, c) = u[r] / nrm;
  }
  // Third column: U₂ = U₀ × U₁ (then R = U Vᵀ is proper; for det A < 0 this flips the smallest
  // singular direction, as the CPU's SVD fallback does).
  U(0, 2) = U(1, 0) * U(2, 1) - U(2, 0) * U(1, 1);
  U(1, 2) = U(2, 0) * U(0, 1) - U(0, 0) * U(2, 1);
  U(2, 2) = U(0, 0) * U(1, 1) - U(1, 0) * U(0, 1);
  Mat3<T> R;
#pragma unroll
  for (int c = 0; c < 3; ++c)
#pragma unroll
    for (int r = 0; r < 3; ++r) R(r, c) = U(r, 0) * Vs(c, 0) + U(r, 1) * Vs(c, 1) + U(r, 2) * Vs(c, 2);
  return R;
}

/// The CPU's polarRotation (Higham's scaled Newton iteration), the same steps and thresholds.
template <class T>
__device__ Mat3<T> polarRotation(const Mat3<T>& A, bool* fallback) {
  *fallback = false;
  const T na2 = sqnorm(A);
  if (na2 > T(0) && isfinite(na2)) {
    Mat3<T> X;
    const T s = sqrt(T(3) / na2);
#pragma unroll
    for (int k = 0; k < 9; ++k) X.a[k] = s * A.a[k];
    T step2 = 1;
    for (int it = 0; it < 40; ++it) {
      const Mat3<T> C = cofactor3(X);
      const T det = X(0, 0) * C(0, 0) + X(0, 1) * C(0, 1) + X(0, 2) * C(0, 2);
      if (it == 0 ? !(det >= T(1e-3)) : !(det > T(0))) break;
      T a = T(0.5), b = T(0.5) / det;
      if (it == 0 ? det < T(0.9) : step2 > PolarTol<T>::scaled) {
        const T z = sqrt(sqrt(sqnorm(C) / (det * det * sqnorm(X))));
        a *= z;
        b /= z;
      }
      T s2 = 0;
#pragma unroll
      for (int k = 0; k < 9; ++k) {
        const T xn = a * X.a[k] + b * C.a[k];
        const T d = xn - X.a[k];
        s2 += d * d;
        X.a[k] = xn;
      }
      step2 = s2;
      if (step2 < PolarTol<T>::converged) return X;
    }
  }
  *fallback = true;
  return polarFallback(A);
}

/// The cubic spline kernel at rest offset r (sph_kernel.h: cubicSplineW and cubicSplineDW / |r|, with
/// q = |r| / h): *W = W(|r|, h), *dW_over_r = W'(|r|) / |r| (0 at r = 0), so ∇W(r) = *dW_over_r · r.
/// K: the arithmetic's precision (float64 in the evaluation, T in the gather).
template <class K, class T>
__device__ inline void cubicSpline(const SoftDeviceBody<T>& b, K r0, K r1, K r2, K* W, K* dW_over_r) {
  const K rr = r0 * r0 + r1 * r1 + r2 * r2;
  const K rinv = rr > K(0) ? rsqrt(rr) : K(0);
  const K r = rr * rinv;
  const K q = r * static_cast<K>(b.inv_h);
  K w = 0, dw = 0;
  if (q < K(1)) {
    w = K(1) - K(1.5) * q * q + K(0.75) * q * q * q;
    dw = K(-3) * q + K(2.25) * q * q;
  } else if (q < K(2)) {
    const K t = K(2) - q;
    w = K(0.25) * t * t * t;
    dw = K(-0.75) * t * t;
  }
  *W = static_cast<K>(b.w_scale) * w;
  *dW_over_r = static_cast<K>(b.dw_scale) * dw * rinv;
}

/// The 16-byte vector type of T.
template <class T>
struct Vector16;
template <>
struct Vector16<float> {
  using type = float4;
};
template <>
struct Vector16<double> {
  using type = double2;
};

/// Programmatic dependent launch: waits until the kernel before this one (when this one was launched
/// as its dependent) has finished and its writes are visible; a no-op otherwise. Nothing the previous
/// kernel writes may be read, and nothing it reads may be written, before this call. (The previous
/// kernel triggers the launch only by finishing: with an early cudaTriggerProgrammaticLaunchCompletion()
/// the waiting blocks hold the SMs' slots, which measured slower.)
__device__ inline void waitForPreviousKernel() {
#if defined(__CUDA_ARCH__) && __CUDA_ARCH__ >= 900
  cudaGridDependencySynchronize();
#endif
}

template <class T>
__device__ inline void encodeFirst(unsigned long long* word, long long step, int particle) {
  atomicMin(word, (static_cast<unsigned long long>(step) << 32) | static_cast<unsigned int>(particle));
}

template <class T>
__device__ inline double pressureAt(const SoftDeviceBody<T>& b, double t) {
  if (b.ramp_s <= 0.0) return b.pressure_pa;
  const double r = t / b.ramp_s;
  return b.pressure_pa * (r < 0.0 ? 0.0 : (r > 1.0 ? 1.0 : r));
}

// The neighbour sums of a particle are split over a group of L consecutive lanes of a warp (lane l
// takes the CSR entries e0 + l, e0 + l + L, …, so a group reads its row's per-entry constants in
// contiguous runs) and combined by a butterfly of shuffles; the group's lane 0 then does the
// per-particle work. The summation order differs from the CPU's serial sum only by round-off.

/// Sums v over the L lanes of the group (every lane gets the total).
template <int L, class T>
__device__ inline T groupSum(T v) {
#pragma unroll
  for (int off = L / 2; off > 0; off /= 2) v += __shfl_xor_sync(0xffffffffu, v, off, L);
  return v;
}

/// X_j and V_j in float64 (SoftDeviceBody::Xr: (X_0, X_1) of every particle, then (X_2, V)): two
/// 16-byte loads, each a contiguous run over a warp's consecutive particles.
__device__ inline void loadRest(const double* Xr, int n, int j, double* out) {
  const double2 a = __ldg(reinterpret_cast<const double2*>(Xr) + j);
  const double2 b = __ldg(reinterpret_cast<const double2*>(Xr) + n + j);
  out[0] = a.x;
  out[1] = a.y;
  out[2] = b.x;
  out[3] = b.y;
}

/// The gather's records, kRecord values a particle: N_i = M_i L_i (L in float64, rounded to T), F̃_i,
/// x_i, c_i, V_i, 0. They are stored in 16-byte chunks, chunk q of every particle together: value k of
/// particle i at rec[(k / w · n + i) · w + k % w], w = 16 / sizeof(T). In lattice order a warp's
/// particles read the neighbours at one offset from consecutive particles, so a warp's load of one
/// chunk reads one contiguous run (8 particles: 128 bytes) instead of a 16-byte piece of each of 8
/// records 96 bytes apart (float32), six times the L1 wavefronts. rec: 16-byte aligned, kRecord n values.
template <class T>
__device__ inline void writeRecord(T* rec, int n, int i, const Mat3<T>& M, const double* L, const Mat3<T>& Ft, T x0,
                                   T x1, T x2, T c, T V) {
  Mat3<T> Lt;
#pragma unroll
  for (int k = 0; k < 9; ++k) Lt.a[k] = static_cast<T>(L[k]);
  const Mat3<T> N = mul(M, Lt);
  T r[kRecord];
#pragma unroll
  for (int k = 0; k < 9; ++k) {
    r[k] = N.a[k];
    r[9 + k] = Ft.a[k];
  }
  r[18] = x0;
  r[19] = x1;
  r[20] = x2;
  r[21] = c;
  r[22] = V;
  r[23] = T(0);
  using V16 = typename Vector16<T>::type;
  constexpr int w = static_cast<int>(sizeof(V16) / sizeof(T));
  static_assert(kRecord % w == 0, "whole 16-byte chunks");
#pragma unroll
  for (int q = 0; q < kRecord / w; ++q) {
    V16 v;
    T* e = reinterpret_cast<T*>(&v);
#pragma unroll
    for (int p = 0; p < w; ++p) e[p] = r[w * q + p];
    reinterpret_cast<V16*>(rec)[static_cast<long long>(q) * n + i] = v;
  }
}

/// The record of particle j (writeRecord's layout) into out[kRecord], through the read-only cache (only
/// in a kernel that does not write the records).
template <class T>
__device__ inline void loadRecord(const T* rec, int n, int j, T* out) {
  using V16 = typename Vector16<T>::type;
  constexpr int w = static_cast<int>(sizeof(V16) / sizeof(T));
#pragma unroll
  for (int q = 0; q < kRecord / w; ++q) {
    const V16 v = __ldg(reinterpret_cast<const V16*>(rec) + static_cast<long long>(q) * n + j);
    const T* e = reinterpret_cast<const T*>(&v);
#pragma unroll
    for (int p = 0; p < w; ++p) out[w * q + p] = e[p];
  }
}

}  // namespace device
}  // namespace cuda_detail
}  // namespace topo_gaussian
