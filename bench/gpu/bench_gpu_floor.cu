// What the explicit step's two neighbour passes cost at the least (issue 20 §2): the passes alone, on
// idealised input, without the work the package's step does around them. One JSON line per case.
//
// The package's step (src/cuda/soft_step_kernels.cu) is two kernels over the CSR neighbour lists:
//   evaluation  F̃_i = Σ_j V_j (x_j − x_i) ⊗ ĝ_ij,  D_i = Σ_j W_ij V_j (x_j − x_i) ⊗ X_ji   (A_pq, hourglass)
//               then the polar rotation, P, M_i and a 24-value record (N_i = M_i L_i, F̃_i, x_i, c_i, V_i);
//   gather      f_k = −Σ_j N_j ∇W(X_kj) V_k − hourglass (Σ_j W c_j F̃_j X_jk, Σ_j W (c_k V_j + c_j V_k)(x_j − x_k))
//               then the kicks and the drift.
// Here both passes keep their loads, sums and stores (the same 16-byte record chunks, lattice order,
// the same lanes a particle) and drop everything else: ĝ_ij = L_i g(o), W and X_ji come from a
// 27-entry table by lattice offset o held in shared memory (the package recomputes them in float64
// from the rest positions, which a `topo fill` body's off-lattice boundary particles need), there is
// no polar rotation, stress or pneumatic term (the record holds F̃ − D where the package has M L), and
// the gather's epilogue is one kick and drift. So a case's time is what the two passes cost once
// everything else is taken away: `model_*` for the package's model (F̃ and D, the hourglass sums, the
// 24-value record), `plain_*` for the issue's reference (F̃ only, a 9-value record, the gather's
// N ∇W sum only), the baseline each other case is divided by (over_plain).
// `rest_*` is `model_*` with ĝ_ij, W_ij and X_ji computed per neighbour as the package does (from the
// rest positions and volumes in float64, X_ji and the spline in float64 in the evaluation and in T in
// the gather, L_i in float64), so rest − model is what that costs.
//
// Usage: bench_gpu_floor [--reps N] [CASE_SUBSTRING] (--reps: timed launches a kernel, default 500 at 100k and 100
// at 1M; 1 for profiling). Without a CUDA device it prints one skip line and exits 0.
#include <cuda_runtime.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "../../src/cuda/soft_device_math.cuh"  // the package's spline, group sums, rest loads

namespace {

namespace device = topo_gaussian::cuda_detail::device;
using device::groupSum;
using device::kBlock;

#define CK(x)                                                                                                       \
  do {                                                                                                              \
    const cudaError_t e_ = (x);                                                                                     \
    if (e_ != cudaSuccess) {                                                                                        \
      std::printf("{\"case\": \"gpu\", \"error\": \"%s at %s:%d\"}\n", cudaGetErrorString(e_), __FILE__, __LINE__); \
      std::exit(1);                                                                                                 \
    }                                                                                                               \
  } while (0)

constexpr int kOffsets = 27;  // the 3 × 3 × 3 lattice offsets, the particle itself included (h = 1.0 Δx)

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

/// The offset table: g(o) (3), W(o) (1), X(o) (3) for each of the 27 offsets.
template <class T>
struct OffsetTable {
  T g[kOffsets][3], w[kOffsets], X[kOffsets][3];
};

template <class T>
__device__ __forceinline__ void loadTable(const OffsetTable<T>* src, OffsetTable<T>* dst) {
  const T* s = reinterpret_cast<const T*>(src);
  T* d = reinterpret_cast<T*>(dst);
  for (int k = threadIdx.x; k < static_cast<int>(sizeof(OffsetTable<T>) / sizeof(T)); k += blockDim.x) d[k] = s[k];
  __syncthreads();
}

/// Record values: model 24 (F̃ − D, F̃, x, c, V), plain 12 (F̃, 3 unused: whole chunks).
template <bool Model>
constexpr int kRecord = Model ? 24 : 12;

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
  T r[kRecord<Model>] = {};
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
  for (int q = 0; q < kRecord<Model> / kPer<T>; ++q) putChunk<T>(b.rec + q * b.n + i, r + q * kPer<T>);
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
    T r[kRecord<Model>];
#pragma unroll
    for (int q = 0; q < kRecord<Model> / kPer<T>; ++q) getChunk<T>(b.rec + q * b.n + j, r + q * kPer<T>);
    T g0, g1, g2, w, X0, X1, X2;
    if (Rest) {  // as the package: X_jk from the rest positions in float64, the spline in T
      double Xj[4];
      device::loadRest(b.Xr, b.n, j, Xj);
      X0 = static_cast<T>(Xj[0] - Xk[0]), X1 = static_cast<T>(Xj[1] - Xk[1]), X2 = static_cast<T>(Xj[2] - Xk[2]);
      T sT;
      device::cubicSpline(b.spline, X0, X1, X2, &w, &sT);
      g0 = -sT * X0, g1 = -sT * X1, g2 = -sT * X2;
      X0 = -X0, X1 = -X1, X2 = -X2;
    } else {
      g0 = -tab.g[o][0], g1 = -tab.g[o][1], g2 = -tab.g[o][2];
      w = tab.w[o], X0 = -tab.X[o][0], X1 = -tab.X[o][1], X2 = -tab.X[o][2];
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

/// A full box of nx × ny × nz lattice nodes (x fastest, as the package's boxes), spacing dx, its CSR
/// lists over the 27 offsets and the offset codes.
struct Lattice {
  int n = 0;
  std::vector<int> off, idx;
  std::vector<std::uint8_t> code;
};

Lattice makeLattice(int nx, int ny, int nz) {
  Lattice l;
  l.n = nx * ny * nz;
  l.off.resize(l.n + 1);
  auto node = [&](int i, int j, int k) { return (k * ny + j) * nx + i; };
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        l.off[node(i, j, k)] = static_cast<int>(l.idx.size());
        for (int o = 0; o < kOffsets; ++o) {
          const int a = i + o % 3 - 1, bb = j + (o / 3) % 3 - 1, c = k + o / 9 - 1;
          if (a < 0 || a >= nx || bb < 0 || bb >= ny || c < 0 || c >= nz) continue;
          l.idx.push_back(node(a, bb, c));
          l.code.push_back(static_cast<std::uint8_t>(o));
        }
      }
  l.off[l.n] = static_cast<int>(l.idx.size());
  return l;
}

template <class T>
T* upload(const std::vector<T>& v) {
  T* d = nullptr;
  CK(cudaMalloc(&d, sizeof(T) * std::max<std::size_t>(v.size(), 1)));
  CK(cudaMemcpy(d, v.data(), sizeof(T) * v.size(), cudaMemcpyHostToDevice));
  return d;
}

struct Timing {
  double evaluate_us = 0, gather_us = 0, step_us = 0, checksum = 0;
};

template <class T, int L, bool Model, bool Rest>
Timing timeCase(const Lattice& l, int nx, int ny, int reps) {
  const int n = l.n;
  const double dx = 0.005;
  std::vector<T> x(3 * n), V(n, T(dx * dx * dx)), c(n, T(0.1)), m(n, T(1e3 * dx * dx * dx)), Lm(9 * n),
      zero(3 * n, T(0));
  for (int p = 0; p < n; ++p) {
    const int i = p % nx, j = (p / nx) % ny, k = p / (nx * ny);
    x[3 * p] = T(dx * i * (1.0 + 1e-3 * std::sin(0.3 * j)));
    x[3 * p + 1] = T(dx * j * (1.0 + 1e-3 * std::cos(0.2 * k)));
    x[3 * p + 2] = T(dx * k);
    for (int q = 0; q < 9; ++q) Lm[9 * p + q] = T(q % 4 == 0 ? 1.0 : 1e-2 * q);
  }
  // The rest data of `rest_*`: X on the lattice, V, L_i in float64.
  std::vector<double> Xr(4 * static_cast<std::size_t>(n)), Ld(9 * static_cast<std::size_t>(n));
  for (int p = 0; p < n; ++p) {
    const int i = p % nx, j = (p / nx) % ny, k = p / (nx * ny);
    Xr[2 * p] = dx * i, Xr[2 * p + 1] = dx * j;
    Xr[2 * (n + p)] = dx * k, Xr[2 * (n + p) + 1] = dx * dx * dx;
    for (int q = 0; q < 9; ++q) Ld[9 * p + q] = q % 4 == 0 ? 1.0 : 1e-2 * q;
  }
  OffsetTable<T> table{};
  for (int o = 0; o < kOffsets; ++o) {
    const double a[3] = {double(o % 3 - 1), double((o / 3) % 3 - 1), double(o / 9 - 1)};
    const double r = std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
    for (int d = 0; d < 3; ++d) {
      table.g[o][d] = T(a[d] * (r > 0 ? -0.75 * (2 - r) * (2 - r) / (r * dx * dx * dx * dx) : 0.0));
      table.X[o][d] = T(a[d] * dx);
    }
    table.w[o] = T((r < 1 ? 1 - 1.5 * r * r + 0.75 * r * r * r : 0.25 * (2 - r) * (2 - r) * (2 - r)) / (dx * dx * dx));
  }
  Body<T> b;
  b.n = n;
  b.off = upload(l.off);
  b.idx = upload(l.idx);
  b.code = upload(l.code);
  b.x = upload(x);
  b.V = upload(V);
  b.c = upload(c);
  b.m = upload(m);
  b.L = upload(Lm);
  OffsetTable<T>* dtab = nullptr;
  CK(cudaMalloc(&dtab, sizeof table));
  CK(cudaMemcpy(dtab, &table, sizeof table, cudaMemcpyHostToDevice));
  b.table = dtab;
  b.Xr = upload(Xr);
  b.Ld = upload(Ld);
  b.spline.inv_h = 1.0 / dx;
  b.spline.w_scale = 1.0 / (M_PI * dx * dx * dx);
  b.spline.dw_scale = b.spline.w_scale / dx;
  CK(cudaMalloc(&b.rec, 16 * (kRecord<Model> / kPer<T>)*static_cast<std::size_t>(n)));
  CK(cudaMalloc(&b.Ft, sizeof(T) * 9 * n));
  b.v = upload(zero);
  b.f = upload(zero);
  b.xn = upload(zero);
  b.h = T(1e-6);
  b.dt = T(2e-6);
  const int blocks = (L * n + kBlock - 1) / kBlock;
  cudaEvent_t e0, e1;
  CK(cudaEventCreate(&e0));
  CK(cudaEventCreate(&e1));
  auto timeIt = [&](auto launch) {
    for (int r = 0; r < 10; ++r) launch();
    CK(cudaEventRecord(e0));
    for (int r = 0; r < reps; ++r) launch();
    CK(cudaEventRecord(e1));
    CK(cudaEventSynchronize(e1));
    float ms = 0;
    CK(cudaEventElapsedTime(&ms, e0, e1));
    CK(cudaGetLastError());
    return 1000.0 * ms / reps;
  };
  // Kernels launched back to back on one stream: a kernel's launch overlaps the one before, as the
  // package's graphs do (it adds ~1 µs a kernel there).
  Timing t;
  t.evaluate_us = timeIt([&] { evaluateFloor<T, L, Model, Rest><<<blocks, kBlock>>>(b); });
  t.gather_us = timeIt([&] { gatherFloor<T, L, Model, Rest><<<blocks, kBlock>>>(b); });
  t.step_us = timeIt([&] {
    evaluateFloor<T, L, Model, Rest><<<blocks, kBlock>>>(b);
    gatherFloor<T, L, Model, Rest><<<blocks, kBlock>>>(b);
  });
  std::vector<T> f(3 * n);
  CK(cudaMemcpy(f.data(), b.f, sizeof(T) * f.size(), cudaMemcpyDeviceToHost));
  for (T v : f) t.checksum += std::abs(double(v));
  CK(cudaEventDestroy(e0));
  CK(cudaEventDestroy(e1));
  for (const void* p : {static_cast<const void*>(b.off), static_cast<const void*>(b.idx),
                        static_cast<const void*>(b.code), static_cast<const void*>(b.x), static_cast<const void*>(b.V),
                        static_cast<const void*>(b.c), static_cast<const void*>(b.m), static_cast<const void*>(b.L),
                        static_cast<const void*>(dtab), static_cast<const void*>(b.rec), static_cast<const void*>(b.Ft),
                        static_cast<const void*>(b.v), static_cast<const void*>(b.f), static_cast<const void*>(b.xn),
                        static_cast<const void*>(b.Xr), static_cast<const void*>(b.Ld)})
    CK(cudaFree(const_cast<void*>(p)));
  return t;
}

enum class Variant { kPlain, kModel, kRest };
constexpr const char* kVariantName[] = {"plain_", "model_", "rest_"};

template <class T, bool Model, bool Rest>
Timing timeLanes(int lanes, const Lattice& l, int nx, int ny, int reps) {
  switch (lanes) {
    case 1:
      return timeCase<T, 1, Model, Rest>(l, nx, ny, reps);
    case 2:
      return timeCase<T, 2, Model, Rest>(l, nx, ny, reps);
    default:
      return timeCase<T, 4, Model, Rest>(l, nx, ny, reps);
  }
}

template <class T>
Timing timeVariant(Variant v, int lanes, const Lattice& l, int nx, int ny, int reps) {
  switch (v) {
    case Variant::kPlain:
      return timeLanes<T, false, false>(lanes, l, nx, ny, reps);
    case Variant::kModel:
      return timeLanes<T, true, false>(lanes, l, nx, ny, reps);
    default:
      return timeLanes<T, true, true>(lanes, l, nx, ny, reps);
  }
}

void runSize(const char* size, int nx, int ny, int nz, int reps, const char* only) {
  const Lattice l = makeLattice(nx, ny, nz);
  const double neighbours = double(l.idx.size()) / l.n;
  for (int precision : {32, 64}) {
    for (int lanes : {1, 2, 4}) {
      const std::string tail =
          std::string(size) + (precision == 32 ? "_f32" : "_f64") + "_lanes" + std::to_string(lanes);
      bool any = !only;  // the other variants run beside their plain baseline
      for (const char* v : kVariantName) any = any || (v + tail).find(only) != std::string::npos;
      if (!any) continue;
      Timing plain;
      for (Variant v : {Variant::kPlain, Variant::kModel, Variant::kRest}) {
        const std::string name = kVariantName[static_cast<int>(v)] + tail;
        const Timing t = precision == 32 ? timeVariant<float>(v, lanes, l, nx, ny, reps)
                                         : timeVariant<double>(v, lanes, l, nx, ny, reps);
        if (v == Variant::kPlain) plain = t;
        std::printf(
            "{\"case\": \"%s\", \"particles\": %d, \"neighbours_mean\": %.2f, \"lanes\": %d, \"evaluate_us\": %.2f, "
            "\"gather_us\": %.2f, \"us_per_step\": %.2f, \"particle_steps_per_s\": %.3e",
            name.c_str(), l.n, neighbours, lanes, t.evaluate_us, t.gather_us, t.step_us, l.n / (1e-6 * t.step_us));
        if (v != Variant::kPlain && plain.step_us > 0) std::printf(", \"over_plain\": %.3f", t.step_us / plain.step_us);
        std::printf(", \"checksum\": %.6e}\n", t.checksum);
        std::fflush(stdout);
      }
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  const char* only = nullptr;
  int reps = 0;
  for (int a = 1; a < argc; ++a) {
    if (std::strcmp(argv[a], "--reps") == 0 && a + 1 < argc)
      reps = std::max(1, std::atoi(argv[++a]));
    else
      only = argv[a];
  }
  int devices = 0;
  if (cudaGetDeviceCount(&devices) != cudaSuccess || devices == 0) {
    std::printf("{\"case\": \"gpu\", \"skipped\": \"the CUDA runtime found no usable device\"}\n");
    return 0;
  }
  cudaDeviceProp prop{};
  CK(cudaGetDeviceProperties(&prop, 0));
  std::printf("{\"case\": \"device\", \"name\": \"%s\", \"sms\": %d}\n", prop.name, prop.multiProcessorCount);
  runSize("100k", 80, 50, 25, reps ? reps : 500,
          only);  // the boxes of bench_gpu_soft's explicit_100k_h1.0 and _1m_h1.0
  runSize("1m", 160, 100, 63, reps ? reps : 100, only);
  return 0;
}
