// Kernels of bench_gpu_floor (bench_gpu_floor.cpp says what they measure): the explicit step's two
// neighbour passes as src/cuda/soft_step_kernels.cu runs them (evaluationSums + the record,
// gatherKickKernel's sums), without the work around them. Variant model: ĝ_ij = L_i ∇W(o Δx), W and
// X_ji from a table by lattice offset code in shared memory; rest: as the package, from the rest
// positions (float64 in the evaluation, T in the gather); plain: a plain reference, F̃ alone.
#include <cuda_runtime.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

#include "../../src/cuda/soft_device_math.cuh"  // the package's spline, group sums, rest loads
#include "bench_gpu_floor.h"

namespace topo_gaussian {
namespace bench_floor {
namespace {

namespace device = topo_gaussian::cuda_detail::device;
using device::groupSum;
using device::kBlock;

void check(cudaError_t e, const char* what) {
  if (e != cudaSuccess) throw std::runtime_error(std::string(what) + ": " + cudaGetErrorString(e));
}
#define CK(x) check((x), #x)

template <class T>
using Chunk = typename device::Vector16<T>::type;
template <class T>
constexpr int kPer = 16 / sizeof(T);

template <class T>
__device__ __forceinline__ void putChunk(Chunk<T>* dst, const T* v) {
  Chunk<T> c;
  std::memcpy(&c, v, 16);
  *dst = c;
}
template <class T>
__device__ __forceinline__ void getChunk(const Chunk<T>* src, T* v) {
  const Chunk<T> c = __ldg(src);
  std::memcpy(v, &c, 16);
}

/// The offset table (Input::g, w, Xo in T): ∇W(o Δx), W(o Δx), o Δx for each lattice offset code.
template <class T>
struct OffsetTable {
  T g[kCodes][3], w[kCodes], X[kCodes][3];
};

template <class T>
__device__ __forceinline__ void loadTable(const OffsetTable<T>* src, OffsetTable<T>* dst) {
  const T* s = reinterpret_cast<const T*>(src);
  T* d = reinterpret_cast<T*>(dst);
  for (int k = threadIdx.x; k < static_cast<int>(sizeof(OffsetTable<T>) / sizeof(T)); k += blockDim.x) d[k] = s[k];
  __syncthreads();
}

/// Record values: model 24 (F̃ − D, F̃, x, c, V, 0), plain F̃'s 9 in whole 16-byte chunks (12 float32, 10
/// float64).
template <class T, bool Model>
constexpr int kRecord = Model ? 24 : (9 + kPer<T> - 1) / kPer<T>* kPer<T>;

template <class T>
struct Body {
  int n = 0;
  const int *off = nullptr, *idx = nullptr;
  const std::uint8_t* code = nullptr;
  const T *x = nullptr, *V = nullptr, *c = nullptr, *m = nullptr, *L = nullptr;
  const OffsetTable<T>* table = nullptr;
  /// rest: (X_0, X_1) of every particle, then (X_2, V), as the package's SoftDeviceBody::Xr
  const double* Xr = nullptr;
  const double* Ld = nullptr;                            ///< rest: L_i in float64
  topo_gaussian::cuda_detail::SoftDeviceBody<T> spline;  ///< rest: the spline's inv_h, w_scale, dw_scale
  Chunk<T>* rec = nullptr;
  T *Ft = nullptr, *v = nullptr, *f = nullptr, *xn = nullptr;
  T h = 0, dt = 0;
};

template <class T, int L, bool Model, bool Rest>
__global__ void __launch_bounds__(kBlock) evaluateFloor(Body<T> b) {
  __shared__ OffsetTable<T> tab;
  loadTable(b.table, &tab);
  const int tid = blockIdx.x * blockDim.x + threadIdx.x, i = tid / L, lane = tid % L;
  const bool active = i < b.n;
  const int ii = active ? i : 0;
  const int e0 = active ? b.off[i] : 0, e1 = active ? b.off[i + 1] : 0;
  const T xi0 = b.x[3 * ii], xi1 = b.x[3 * ii + 1], xi2 = b.x[3 * ii + 2];
  T Li[9];
  double Ld[9], Xi[4];
#pragma unroll
  for (int k = 0; k < 9; ++k) {
    if (Rest)
      Ld[k] = b.Ld[9 * ii + k];
    else
      Li[k] = b.L[9 * ii + k];
  }
  if (Rest) device::loadRest(b.Xr, b.n, ii, Xi);
  T F[9] = {}, D[9] = {};
  for (int e = e0 + lane; e < e1; e += L) {
    const int j = b.idx[e], o = b.code[e];
    T vj, g0, g1, g2, w, X0, X1, X2;
    if (Rest) {      // as the package: ĝ_ij = L_i ∇W(X_ji) in float64 from the rest positions, rounded once
      double Xj[4];  // X_j, V_j
      device::loadRest(b.Xr, b.n, j, Xj);
      const double Y0 = Xj[0] - Xi[0], Y1 = Xj[1] - Xi[1], Y2 = Xj[2] - Xi[2];
      double wd, sd;
      device::cubicSpline(b.spline, Y0, Y1, Y2, &wd, &sd);
      const double r0 = sd * Y0, r1 = sd * Y1, r2 = sd * Y2;
      g0 = static_cast<T>(Ld[0] * r0 + Ld[3] * r1 + Ld[6] * r2);
      g1 = static_cast<T>(Ld[1] * r0 + Ld[4] * r1 + Ld[7] * r2);
      g2 = static_cast<T>(Ld[2] * r0 + Ld[5] * r1 + Ld[8] * r2);
      vj = static_cast<T>(Xj[3]);
      w = static_cast<T>(wd), X0 = static_cast<T>(Y0), X1 = static_cast<T>(Y1), X2 = static_cast<T>(Y2);
    } else {
      vj = b.V[j];
      const T r0 = tab.g[o][0], r1 = tab.g[o][1], r2 = tab.g[o][2];
      g0 = Li[0] * r0 + Li[3] * r1 + Li[6] * r2, g1 = Li[1] * r0 + Li[4] * r1 + Li[7] * r2;
      g2 = Li[2] * r0 + Li[5] * r1 + Li[8] * r2;
      w = tab.w[o], X0 = tab.X[o][0], X1 = tab.X[o][1], X2 = tab.X[o][2];
    }
    const T d0 = vj * (b.x[3 * j] - xi0), d1 = vj * (b.x[3 * j + 1] - xi1), d2 = vj * (b.x[3 * j + 2] - xi2);
    F[0] += d0 * g0, F[1] += d1 * g0, F[2] += d2 * g0;
    F[3] += d0 * g1, F[4] += d1 * g1, F[5] += d2 * g1;
    F[6] += d0 * g2, F[7] += d1 * g2, F[8] += d2 * g2;
    if (Model) {
      const T b0 = w * d0, b1 = w * d1, b2 = w * d2;
      D[0] += b0 * X0, D[1] += b1 * X0, D[2] += b2 * X0;
      D[3] += b0 * X1, D[4] += b1 * X1, D[5] += b2 * X1;
      D[6] += b0 * X2, D[7] += b1 * X2, D[8] += b2 * X2;
    }
  }
#pragma unroll
  for (int k = 0; k < 9; ++k) {
    F[k] = groupSum<L>(F[k]);
    if (Model) D[k] = groupSum<L>(D[k]);
  }
  if (!active || lane != 0) return;
  T r[kRecord<T, Model>] = {};
#pragma unroll
  for (int k = 0; k < 9; ++k) r[k] = Model ? F[k] - D[k] : F[k];
  if (Model) {
#pragma unroll
    for (int k = 0; k < 9; ++k) r[9 + k] = F[k];
    r[18] = xi0, r[19] = xi1, r[20] = xi2, r[21] = b.c[i], r[22] = b.V[i];
#pragma unroll
    for (int k = 0; k < 9; ++k) b.Ft[9 * i + k] = F[k];
  }
#pragma unroll
  for (int q = 0; q < kRecord<T, Model> / kPer<T>; ++q) putChunk<T>(b.rec + q * b.n + i, r + q * kPer<T>);
}

template <class T, int L, bool Model, bool Rest>
__global__ void __launch_bounds__(kBlock) gatherFloor(Body<T> b) {
  __shared__ OffsetTable<T> tab;
  loadTable(b.table, &tab);
  const int tid = blockIdx.x * blockDim.x + threadIdx.x, k = tid / L, lane = tid % L;
  const bool active = k < b.n;
  const int kk = active ? k : 0;
  const int e0 = active ? b.off[k] : 0, e1 = active ? b.off[k + 1] : 0;
  const T xk0 = b.x[3 * kk], xk1 = b.x[3 * kk + 1], xk2 = b.x[3 * kk + 2], ck = b.c[kk], Vk = b.V[kk];
  double Xk[4] = {0, 0, 0, 0};
  if (Rest) device::loadRest(b.Xr, b.n, kk, Xk);
  T a0 = 0, a1 = 0, a2 = 0, t0 = 0, t1 = 0, t2 = 0, u0 = 0, u1 = 0, u2 = 0;
  for (int e = e0 + lane; e < e1; e += L) {
    const int j = b.idx[e], o = b.code[e];
    T r[kRecord<T, Model>];
#pragma unroll
    for (int q = 0; q < kRecord<T, Model> / kPer<T>; ++q) getChunk<T>(b.rec + q * b.n + j, r + q * kPer<T>);
    T g0, g1, g2, w, X0, X1, X2;
    if (Rest) {  // as the package: X_jk from the rest positions in float64, the spline in T
      double Xj[4];
      device::loadRest(b.Xr, b.n, j, Xj);
      X0 = static_cast<T>(Xj[0] - Xk[0]), X1 = static_cast<T>(Xj[1] - Xk[1]), X2 = static_cast<T>(Xj[2] - Xk[2]);
      T sT;
      device::cubicSpline(b.spline, X0, X1, X2, &w, &sT);
      g0 = -sT * X0, g1 = -sT * X1, g2 = -sT * X2;  // ∇W(X_kj)
    } else {
      g0 = -tab.g[o][0], g1 = -tab.g[o][1], g2 = -tab.g[o][2];
      w = tab.w[o], X0 = tab.X[o][0], X1 = tab.X[o][1], X2 = tab.X[o][2];  // X_jk
    }
    a0 += r[0] * g0 + r[3] * g1 + r[6] * g2;
    a1 += r[1] * g0 + r[4] * g1 + r[7] * g2;
    a2 += r[2] * g0 + r[5] * g1 + r[8] * g2;
    if (Model) {
      const T cj = r[21], wc = w * cj, y3 = w * (ck * r[22] + cj * Vk);
      const T* F = r + 9;
      t0 += wc * (F[0] * X0 + F[3] * X1 + F[6] * X2);
      t1 += wc * (F[1] * X0 + F[4] * X1 + F[7] * X2);
      t2 += wc * (F[2] * X0 + F[5] * X1 + F[8] * X2);
      u0 += y3 * (r[18] - xk0);
      u1 += y3 * (r[19] - xk1);
      u2 += y3 * (r[20] - xk2);
    }
  }
  a0 = groupSum<L>(a0), a1 = groupSum<L>(a1), a2 = groupSum<L>(a2);
  if (Model) {
    t0 = groupSum<L>(t0), t1 = groupSum<L>(t1), t2 = groupSum<L>(t2);
    u0 = groupSum<L>(u0), u1 = groupSum<L>(u1), u2 = groupSum<L>(u2);
  }
  if (!active || lane != 0) return;
  const T a[3] = {a0, a1, a2}, t[3] = {t0, t1, t2}, u[3] = {u0, u1, u2};
  const T mk = b.m[k];
#pragma unroll
  for (int d = 0; d < 3; ++d) {
    const T f = -(Vk * a[d] + (Model ? T(2) * Vk * t[d] - T(2) * u[d] : T(0)));
    const T vn = b.v[3 * k + d] + b.h * f / mk;
    b.f[3 * k + d] = f;
    b.v[3 * k + d] = vn;
    b.xn[3 * k + d] = b.x[3 * k + d] + b.dt * vn;
  }
}

/// Device memory freed at scope exit, also when a CUDA call throws.
struct Buffers {
  std::vector<void*> p;
  template <class T>
  T* alloc(std::size_t count) {
    T* d = nullptr;
    CK(cudaMalloc(&d, sizeof(T) * std::max<std::size_t>(count, 1)));
    p.push_back(d);
    return d;
  }
  /// v converted to T, on the device.
  template <class T, class S>
  T* upload(const std::vector<S>& v) {
    const std::vector<T> t(v.begin(), v.end());
    T* d = alloc<T>(t.size());
    CK(cudaMemcpy(d, t.data(), sizeof(T) * t.size(), cudaMemcpyHostToDevice));
    return d;
  }
  ~Buffers() {
    for (void* q : p) cudaFree(q);
  }
};

/// Two CUDA events, destroyed at scope exit.
struct EventPair {
  cudaEvent_t start = nullptr, stop = nullptr;
  EventPair() {
    CK(cudaEventCreate(&start));
    CK(cudaEventCreate(&stop));
  }
  ~EventPair() {
    if (start) cudaEventDestroy(start);
    if (stop) cudaEventDestroy(stop);
  }
};

template <class T, int L, bool Model, bool Rest>
Timing timeCase(const Input& in, int reps) {
  const int n = in.n;
  Buffers keep;
  Body<T> b;
  b.n = n;
  b.off = keep.upload<int>(in.offsets);
  b.idx = keep.upload<int>(in.indices);
  b.code = keep.upload<std::uint8_t>(in.codes);
  b.x = keep.upload<T>(in.x);
  b.V = keep.upload<T>(in.V);
  b.c = keep.upload<T>(in.c);
  b.m = keep.upload<T>(in.m);
  b.L = keep.upload<T>(in.L);
  OffsetTable<T> table;
  for (int o = 0; o < kCodes; ++o) {
    table.w[o] = static_cast<T>(in.w[o]);
    for (int d = 0; d < 3; ++d) {
      table.g[o][d] = static_cast<T>(in.g[o][d]);
      table.X[o][d] = static_cast<T>(in.Xo[o][d]);
    }
  }
  OffsetTable<T>* dtab = keep.alloc<OffsetTable<T>>(1);
  CK(cudaMemcpy(dtab, &table, sizeof table, cudaMemcpyHostToDevice));
  b.table = dtab;
  // The rest data as the package's SoftDeviceBody::Xr: (X_0, X_1) of every particle, then (X_2, V).
  std::vector<double> Xr(4 * static_cast<std::size_t>(n));
  for (int p = 0; p < n; ++p) {
    Xr[2 * p] = in.X[3 * p], Xr[2 * p + 1] = in.X[3 * p + 1];
    Xr[2 * (static_cast<std::size_t>(n) + p)] = in.X[3 * p + 2];
    Xr[2 * (static_cast<std::size_t>(n) + p) + 1] = in.V[p];
  }
  b.Xr = keep.upload<double>(Xr);
  b.Ld = keep.upload<double>(in.L);
  b.spline.inv_h = in.inv_h;
  b.spline.w_scale = in.w_scale;
  b.spline.dw_scale = in.dw_scale;
  b.rec = keep.alloc<Chunk<T>>((kRecord<T, Model> / kPer<T>)*static_cast<std::size_t>(n));
  b.Ft = keep.alloc<T>(9 * static_cast<std::size_t>(n));
  const std::vector<double> zero(3 * static_cast<std::size_t>(n), 0.0);
  b.v = keep.upload<T>(zero);
  b.f = keep.upload<T>(zero);
  b.xn = keep.upload<T>(zero);
  b.h = T(1e-6);
  b.dt = T(2e-6);
  const int blocks = static_cast<int>((static_cast<long long>(L) * n + kBlock - 1) / kBlock);
  EventPair ev;
  auto timeIt = [&](auto launch) {
    for (int r = 0; r < 10; ++r) launch();
    CK(cudaEventRecord(ev.start));
    for (int r = 0; r < reps; ++r) launch();
    CK(cudaEventRecord(ev.stop));
    CK(cudaEventSynchronize(ev.stop));
    float ms = 0;
    CK(cudaEventElapsedTime(&ms, ev.start, ev.stop));
    CK(cudaGetLastError());
    return 1000.0 * ms / reps;
  };
  // Kernels launched back to back on one stream: a kernel's launch overlaps the one before (the
  // package's graphs add ~1 µs a kernel to chain them).
  Timing t;
  t.evaluate_us = timeIt([&] { evaluateFloor<T, L, Model, Rest><<<blocks, kBlock>>>(b); });
  t.gather_us = timeIt([&] { gatherFloor<T, L, Model, Rest><<<blocks, kBlock>>>(b); });
  t.step_us = timeIt([&] {
    evaluateFloor<T, L, Model, Rest><<<blocks, kBlock>>>(b);
    gatherFloor<T, L, Model, Rest><<<blocks, kBlock>>>(b);
  });
  std::vector<T> f(3 * static_cast<std::size_t>(n));
  CK(cudaMemcpy(f.data(), b.f, sizeof(T) * f.size(), cudaMemcpyDeviceToHost));
  for (T v : f) t.force_checksum += std::abs(static_cast<double>(v));
  if (Model) {
    std::vector<T> Ft(9 * static_cast<std::size_t>(n));
    CK(cudaMemcpy(Ft.data(), b.Ft, sizeof(T) * Ft.size(), cudaMemcpyDeviceToHost));
    t.Ft.assign(Ft.begin(), Ft.end());
  }
  return t;
}

template <class T, bool Model, bool Rest>
Timing timeLanes(const Input& in, int lanes, int reps) {
  switch (lanes) {
    case 1:
      return timeCase<T, 1, Model, Rest>(in, reps);
    case 2:
      return timeCase<T, 2, Model, Rest>(in, reps);
    case 4:
      return timeCase<T, 4, Model, Rest>(in, reps);
    default:
      throw std::runtime_error("lanes " + std::to_string(lanes) + ": use 1, 2 or 4");
  }
}

template <class T>
Timing timeVariant(const Input& in, Variant v, int lanes, int reps) {
  switch (v) {
    case Variant::kPlain:
      return timeLanes<T, false, false>(in, lanes, reps);
    case Variant::kModel:
      return timeLanes<T, true, false>(in, lanes, reps);
    default:
      return timeLanes<T, true, true>(in, lanes, reps);
  }
}

}  // namespace

std::string deviceName(int* sms) {
  int devices = 0;
  if (cudaGetDeviceCount(&devices) != cudaSuccess || devices == 0) return "";
  cudaDeviceProp prop{};
  if (cudaGetDeviceProperties(&prop, 0) != cudaSuccess) return "";
  if (sms) *sms = prop.multiProcessorCount;
  return prop.name;
}

Timing timeFloor(const Input& in, Variant v, int lanes, bool float64, int reps) {
  return float64 ? timeVariant<double>(in, v, lanes, reps) : timeVariant<float>(in, v, lanes, reps);
}

}  // namespace bench_floor
}  // namespace topo_gaussian
