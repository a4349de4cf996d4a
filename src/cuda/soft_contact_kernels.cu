// Penalty contact on the GPU (physics/soft_contact.h): per contact point (an embedded surface sample
// or a candidate particle) the normal force f_n = k ω_k max(δ − φ(y_k), 0) n and the smoothed
// Coulomb friction −μ f_n v_t / √(|v_t|² + ε²), scattered to the particles through the transpose
// of the embedding weights (f_i += Σ_k φ_ki f_k, one thread per particle: deterministic), and the
// contact's part of the explicit adjoint (Hessian k ω n nᵀ and the friction adjoint, as
// SoftContact::addHessianProduct and SoftContact::frictionAdjoint).
#include <cuda_runtime.h>

#include "soft_device_math.cuh"
#include "soft_step_kernels.h"

namespace topo_gaussian {
namespace cuda_detail {

namespace {

using namespace device;

inline int blocks(long long threads) { return static_cast<int>((threads + kBlock - 1) / kBlock); }

/// ContactObstacle::distance: signed distance of y and the unit normal n.
template <class T>
__device__ T obstacleDistance(const ContactDevice<T>& c, int o, const T y[3], T n[3]) {
  if (c.kind[o] == 0) {
    n[0] = c.normal[o][0];
    n[1] = c.normal[o][1];
    n[2] = c.normal[o][2];
    return n[0] * y[0] + n[1] * y[1] + n[2] * y[2] - c.offset[o];
  }
  T cc[3], d[3];
#pragma unroll
  for (int k = 0; k < 3; ++k) {
    cc[k] = T(0.5) * (c.lo[o][k] + c.hi[o][k]);
    const T half = T(0.5) * (c.hi[o][k] - c.lo[o][k]);
    d[k] = fabs(y[k] - cc[k]) - half;
  }
  int a = 0;
  if (d[1] > d[a]) a = 1;
  if (d[2] > d[a]) a = 2;
  if (d[a] <= T(0)) {
    n[0] = n[1] = n[2] = T(0);
    n[a] = y[a] >= cc[a] ? T(1) : T(-1);
    return d[a];
  }
  T out[3], dist2 = 0;
#pragma unroll
  for (int k = 0; k < 3; ++k) {
    out[k] = d[k] > T(0) ? d[k] : T(0);
    dist2 += out[k] * out[k];
  }
  const T dist = sqrt(dist2);
#pragma unroll
  for (int k = 0; k < 3; ++k) n[k] = (y[k] >= cc[k] ? T(1) : T(-1)) * out[k] / dist;
  return dist;
}

/// Whether an embedded sample is gathered at all (its anchor within the band of an obstacle).
template <class T>
__device__ bool nearAnObstacle(const SoftDeviceBody<T>& b, int k) {
  const ContactDevice<T>& c = b.contact;
  if (!c.embedded) return true;
  const int a = c.anchor[k];
  const T xa[3] = {b.x[3 * a], b.x[3 * a + 1], b.x[3 * a + 2]};
  T n[3];
  for (int o = 0; o < c.obstacles; ++o)
    if (obstacleDistance(c, o, xa, n) - c.margin < c.band) return true;
  return false;
}

/// Σ_i φ_ki u_i of point k.
template <class T>
__device__ void atPoint(const ContactDevice<T>& c, int k, const T* u, T out[3]) {
  out[0] = out[1] = out[2] = T(0);
  for (int q = c.off[k]; q < c.off[k + 1]; ++q) {
    const int i = c.idx[q];
    const T p = c.phi[q];
    out[0] += p * u[3 * i];
    out[1] += p * u[3 * i + 1];
    out[2] += p * u[3 * i + 2];
  }
}

template <class T>
__global__ void contactPointKernel(SoftDeviceBody<T> b) {
  const int k = blockIdx.x * blockDim.x + threadIdx.x;
  const ContactDevice<T>& c = b.contact;
  if (k >= c.points) return;
  T fn[3] = {0, 0, 0}, fr[3] = {0, 0, 0};
  if (nearAnObstacle(b, k)) {
    T y[3], vk[3], n[3];
    atPoint(c, k, b.x, y);
    atPoint(c, k, b.v, vk);
    const T kk = c.stiffness * c.omega[k];
    const T eps2 = c.slip_velocity * c.slip_velocity;
    for (int o = 0; o < c.obstacles; ++o) {
      const T g = obstacleDistance(c, o, y, n) - c.margin;
      if (!(g < T(0))) continue;
      const T f = -kk * g;
#pragma unroll
      for (int d = 0; d < 3; ++d) fn[d] += f * n[d];
      if (c.friction > T(0)) {
        const T vn = n[0] * vk[0] + n[1] * vk[1] + n[2] * vk[2];
        const T vt[3] = {vk[0] - n[0] * vn, vk[1] - n[1] * vn, vk[2] - n[2] * vn};
        const T s = c.friction * f / sqrt(vt[0] * vt[0] + vt[1] * vt[1] + vt[2] * vt[2] + eps2);
#pragma unroll
        for (int d = 0; d < 3; ++d) fr[d] -= s * vt[d];
      }
    }
  }
#pragma unroll
  for (int d = 0; d < 3; ++d) {
    c.fn[3 * k + d] = fn[d];
    c.ffr[3 * k + d] = fr[d];
  }
}

template <class T>
__global__ void contactScatterKernel(SoftDeviceBody<T> b, bool add_normal) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= b.n) return;
  const ContactDevice<T>& c = b.contact;
  T fn[3] = {0, 0, 0}, fr[3] = {0, 0, 0};
  for (int q = c.toff[i]; q < c.toff[i + 1]; ++q) {
    const int k = c.tpt[q];
    const T p = c.tphi[q];
#pragma unroll
    for (int d = 0; d < 3; ++d) {
      fn[d] += p * c.fn[3 * k + d];
      fr[d] += p * c.ffr[3 * k + d];
    }
  }
#pragma unroll
  for (int d = 0; d < 3; ++d) {
    if (add_normal) b.f[3 * i + d] += fn[d];
    c.pfr[3 * i + d] = fr[d];
  }
}

/// Per point at (x_k, v_k): −H_c a and the friction adjoint's ȳ (adj[0..2]), v̄ (adj[3..5]), and the
/// friction force (ffr) for the mass gradient.
template <class T>
__global__ void contactAdjointPointKernel(SoftDeviceBody<T> b, const T* a) {
  const int k = blockIdx.x * blockDim.x + threadIdx.x;
  const ContactDevice<T>& c = b.contact;
  if (k >= c.points) return;
  T yb[3] = {0, 0, 0}, vb[3] = {0, 0, 0}, fr[3] = {0, 0, 0};
  if (nearAnObstacle(b, k)) {
    T y[3], vk[3], ak[3], n[3];
    atPoint(c, k, b.x, y);
    atPoint(c, k, b.v, vk);
    atPoint(c, k, a, ak);
    const T kk = c.stiffness * c.omega[k];
    const T eps2 = c.slip_velocity * c.slip_velocity;
    for (int o = 0; o < c.obstacles; ++o) {
      const T g = obstacleDistance(c, o, y, n) - c.margin;
      if (!(g < T(0))) continue;
      const T f = -kk * g;
      const T na = n[0] * ak[0] + n[1] * ak[1] + n[2] * ak[2];
#pragma unroll
      for (int d = 0; d < 3; ++d) yb[d] -= kk * n[d] * na;  // x̄ −= H_c a
      if (c.friction > T(0)) {
        const T vn = n[0] * vk[0] + n[1] * vk[1] + n[2] * vk[2];
        const T vt[3] = {vk[0] - n[0] * vn, vk[1] - n[1] * vn, vk[2] - n[2] * vn};
        const T s = sqrt(vt[0] * vt[0] + vt[1] * vt[1] + vt[2] * vt[2] + eps2);
        const T ta = (vt[0] * ak[0] + vt[1] * ak[1] + vt[2] * ak[2]) / s;  // t·a
        // (∂f/∂v)ᵀ a = −μ f_n T (a/s − v_t (v_t·a)/s³);  ∂f/∂x contributes (μ k t·a) n.
        T u[3];
#pragma unroll
        for (int d = 0; d < 3; ++d) u[d] = ak[d] / s - vt[d] * (ta / (s * s));
        const T un = n[0] * u[0] + n[1] * u[1] + n[2] * u[2];
#pragma unroll
        for (int d = 0; d < 3; ++d) {
          vb[d] += -c.friction * f * (u[d] - n[d] * un);
          yb[d] += c.friction * kk * ta * n[d];
          fr[d] -= (c.friction * f / s) * vt[d];
        }
      }
    }
  }
#pragma unroll
  for (int d = 0; d < 3; ++d) {
    c.adj[6 * k + d] = yb[d];
    c.adj[6 * k + 3 + d] = vb[d];
    c.ffr[3 * k + d] = fr[d];
  }
}

template <class T>
__global__ void contactAdjointScatterKernel(SoftDeviceBody<T> b, const T* a, T* xb, T* vb, T* g_mass) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= b.n || b.clamped[i]) return;
  const ContactDevice<T>& c = b.contact;
  T x[3] = {0, 0, 0}, v[3] = {0, 0, 0}, fr[3] = {0, 0, 0};
  for (int q = c.toff[i]; q < c.toff[i + 1]; ++q) {
    const int k = c.tpt[q];
    const T p = c.tphi[q];
#pragma unroll
    for (int d = 0; d < 3; ++d) {
      x[d] += p * c.adj[6 * k + d];
      v[d] += p * c.adj[6 * k + 3 + d];
      fr[d] += p * c.ffr[3 * k + d];
    }
  }
  T dot = 0;
#pragma unroll
  for (int d = 0; d < 3; ++d) {
    xb[3 * i + d] += x[d];
    vb[3 * i + d] += v[d];
    dot += a[3 * i + d] * fr[d];
  }
  g_mass[i] -= dot / b.mass[i];
}

}  // namespace

template <class T>
void launchContact(const SoftDeviceBody<T>& b, bool add_normal, void* stream) {
  if (b.contact.points == 0) return;
  cudaStream_t s = static_cast<cudaStream_t>(stream);
  contactPointKernel<T><<<blocks(b.contact.points), kBlock, 0, s>>>(b);
  contactScatterKernel<T><<<blocks(b.n), kBlock, 0, s>>>(b, add_normal);
}

template <class T>
void launchContactAdjoint(const SoftDeviceBody<T>& b, T* xb, T* vb, T* g_mass, const T* work, void* stream) {
  if (b.contact.points == 0) return;
  cudaStream_t s = static_cast<cudaStream_t>(stream);
  contactAdjointPointKernel<T><<<blocks(b.contact.points), kBlock, 0, s>>>(b, work);
  contactAdjointScatterKernel<T><<<blocks(b.n), kBlock, 0, s>>>(b, work, xb, vb, g_mass);
}

template void launchContact<double>(const SoftDeviceBody<double>&, bool, void*);
template void launchContact<float>(const SoftDeviceBody<float>&, bool, void*);
template void launchContactAdjoint<double>(const SoftDeviceBody<double>&, double*, double*, double*, const double*,
                                           void*);
template void launchContactAdjoint<float>(const SoftDeviceBody<float>&, float*, float*, float*, const float*, void*);

}  // namespace cuda_detail
}  // namespace topo_gaussian
