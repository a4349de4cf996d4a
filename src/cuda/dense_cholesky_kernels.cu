// The scatter of a sparse lower triangle into the dense matrix cuSOLVER factorises; see
// dense_cholesky_cuda.h.
#include "dense_cholesky_kernels.h"

#include <algorithm>

namespace topo_gaussian::cuda_detail {

namespace {

constexpr int kApplyThreads = 256;  // threads of the inverse factor's product kernels
constexpr int kRowsPerChunk = 128;  // rows a block of the transposed product sums
constexpr int kRowsPerBlock = 8;    // rows a block of the row product takes

/// One warp per column: its lanes stride over the column's entries.
__global__ void scatterLowerCsc(long long n, const int* __restrict__ outer, const int* __restrict__ inner,
                                const double* __restrict__ values, double* __restrict__ A) {
  const long long warp = (static_cast<long long>(blockIdx.x) * blockDim.x + threadIdx.x) / 32;
  const int lane = threadIdx.x % 32;
  if (warp >= n) return;
  const long long col = warp;
  for (int e = outer[col] + lane; e < outer[col + 1]; e += 32)
    A[static_cast<long long>(inner[e]) + col * n] = values[e];
}

/// 32 × 32 tiles of the strict upper triangle, read from the lower one through shared memory.
__global__ void mirrorLower(long long n, double* __restrict__ A) {
  __shared__ double tile[32][33];
  const long long bi = blockIdx.y, bj = blockIdx.x;  // tile row, tile column (upper: bj >= bi)
  if (bj < bi) return;
  // read the lower tile (rows bj, columns bi) coalesced along its columns
  const long long r = bj * 32 + threadIdx.x;
  for (int k = threadIdx.y; k < 32; k += blockDim.y) {
    const long long c = bi * 32 + k;
    if (r < n && c < n) tile[k][threadIdx.x] = A[r + c * n];
  }
  __syncthreads();
  const long long row = bi * 32 + threadIdx.x;
  for (int k = threadIdx.y; k < 32; k += blockDim.y) {
    const long long col = bj * 32 + k;
    if (row < n && col < n && col > row) A[row + col * n] = tile[threadIdx.x][k];
  }
}

/// F (rows of ld floats) = L⁻ᵀ rounded once: row j holds column j of L⁻¹ (A, column-major, lower),
/// zero left of the diagonal and in the padding.
__global__ void inverseFactorToFloat(long long n, long long ld, const double* __restrict__ A, float* __restrict__ F) {
  for (long long j = blockIdx.y; j < n; j += gridDim.y)
    for (long long i = static_cast<long long>(blockIdx.x) * blockDim.x + threadIdx.x; i < ld;
         i += static_cast<long long>(gridDim.x) * blockDim.x)
      F[j * ld + i] = (i >= j && i < n) ? static_cast<float>(A[j * n + i]) : 0.0f;
}

/// y = Fᵀ r (= L⁻¹ r), pass 1: block (column tile, row chunk) sums its kRowsPerChunk rows of four
/// columns a thread into P[chunk][column]; chunks entirely below the tile's last column are empty.
__global__ void __launch_bounds__(kApplyThreads)
    inverseFactorTransposedPartial(long long n, long long ld, const float* __restrict__ F, const double* __restrict__ r,
                                   double* __restrict__ P) {
  const long long c0 = static_cast<long long>(blockIdx.x) * kApplyThreads * 4;
  const long long j0 = static_cast<long long>(blockIdx.y) * kRowsPerChunk;
  const long long c = c0 + 4 * threadIdx.x;
  if (j0 >= n || j0 > c0 + kApplyThreads * 4 - 1) return;  // no row of this chunk reaches the tile
  __shared__ double rs[kRowsPerChunk];
  for (int k = threadIdx.x; k < kRowsPerChunk; k += kApplyThreads) rs[k] = j0 + k < n ? r[j0 + k] : 0.0;
  __syncthreads();
  if (c >= ld) return;
  const int rows = static_cast<int>(std::min<long long>(kRowsPerChunk, n - j0));
  double a0 = 0.0, a1 = 0.0, a2 = 0.0, a3 = 0.0;
  const float* f = F + j0 * ld + c;
#pragma unroll 8
  for (int k = 0; k < rows; ++k) {
    const float4 v = __ldcs(reinterpret_cast<const float4*>(f + k * ld));
    const double rk = rs[k];
    a0 += static_cast<double>(v.x) * rk;
    a1 += static_cast<double>(v.y) * rk;
    a2 += static_cast<double>(v.z) * rk;
    a3 += static_cast<double>(v.w) * rk;
  }
  double* p = P + static_cast<long long>(blockIdx.y) * ld + c;
  p[0] = a0;
  p[1] = a1;
  p[2] = a2;
  p[3] = a3;
}

/// y = Fᵀ r, pass 2: y_i = the chunks' partial sums in chunk order (only chunks starting at rows ≤ i
/// were written); y's padding is zero.
__global__ void inverseFactorTransposedSum(long long n, long long ld, const double* __restrict__ P,
                                           double* __restrict__ y) {
  const long long i = static_cast<long long>(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i >= ld) return;
  double s = 0.0;
  if (i < n)
    for (long long k = 0; k * kRowsPerChunk <= i; ++k) s += P[k * ld + i];
  y[i] = s;
}

/// z = F y (= L⁻ᵀ y): a block takes kRowsPerBlock rows, its threads four columns at a time from the
/// first row's diagonal (rounded down to four: the entries left of a diagonal are zero), each y loaded
/// once for the block's rows; the row sums are reduced in a fixed order.
__global__ void __launch_bounds__(kApplyThreads)
    inverseFactorRows(long long n, long long ld, const float* __restrict__ F, const double* __restrict__ y,
                      double* __restrict__ z) {
  const long long j0 = static_cast<long long>(blockIdx.x) * kRowsPerBlock;
  const int rows = static_cast<int>(std::min<long long>(kRowsPerBlock, n - j0));
  double acc[kRowsPerBlock];
#pragma unroll
  for (int q = 0; q < kRowsPerBlock; ++q) acc[q] = 0.0;
  for (long long c = (j0 & ~3LL) + 4 * threadIdx.x; c < ld; c += 4 * kApplyThreads) {
    const double2 y01 = *reinterpret_cast<const double2*>(y + c);
    const double2 y23 = *reinterpret_cast<const double2*>(y + c + 2);
#pragma unroll
    for (int q = 0; q < kRowsPerBlock; ++q) {
      if (q < rows) {
        const float4 v = __ldcs(reinterpret_cast<const float4*>(F + (j0 + q) * ld + c));
        acc[q] += static_cast<double>(v.x) * y01.x + static_cast<double>(v.y) * y01.y +
                  static_cast<double>(v.z) * y23.x + static_cast<double>(v.w) * y23.y;
      }
    }
  }
  __shared__ double part[kApplyThreads / 32][kRowsPerBlock];
  const int lane = threadIdx.x % 32, warp = threadIdx.x / 32;
#pragma unroll
  for (int q = 0; q < kRowsPerBlock; ++q) {
    double v = acc[q];
    for (int o = 16; o > 0; o /= 2) v += __shfl_down_sync(0xffffffffu, v, o);
    if (lane == 0) part[warp][q] = v;
  }
  __syncthreads();
  if (threadIdx.x < rows) {
    double s = 0.0;
    for (int w = 0; w < kApplyThreads / 32; ++w) s += part[w][threadIdx.x];
    z[j0 + threadIdx.x] = s;
  }
}

}  // namespace

long long inverseFactorLeadingDimension(long long n) { return (n + 31) / 32 * 32; }

long long inverseFactorChunks(long long n) { return (n + kRowsPerChunk - 1) / kRowsPerChunk; }

void launchInverseFactorToFloat(long long n, const double* A, float* F, cudaStream_t stream) {
  const long long ld = inverseFactorLeadingDimension(n);
  const unsigned rows = static_cast<unsigned>(std::min<long long>(n, 65535));
  const unsigned cols = static_cast<unsigned>(std::min<long long>((ld + 255) / 256, 64));
  inverseFactorToFloat<<<dim3(cols, rows), 256, 0, stream>>>(n, ld, A, F);
}

void launchInverseFactorApply(long long n, const float* F, const double* r, double* P, double* y, double* z,
                              cudaStream_t stream) {
  const long long ld = inverseFactorLeadingDimension(n);
  const unsigned tiles = static_cast<unsigned>((ld + 4 * kApplyThreads - 1) / (4 * kApplyThreads));
  const unsigned chunks = static_cast<unsigned>(inverseFactorChunks(n));
  inverseFactorTransposedPartial<<<dim3(tiles, chunks), kApplyThreads, 0, stream>>>(n, ld, F, r, P);
  inverseFactorTransposedSum<<<static_cast<unsigned>((ld + 255) / 256), 256, 0, stream>>>(n, ld, P, y);
  inverseFactorRows<<<static_cast<unsigned>((n + kRowsPerBlock - 1) / kRowsPerBlock), kApplyThreads, 0, stream>>>(
      n, ld, F, y, z);
}

void launchMirrorLower(long long n, double* A, cudaStream_t stream) {
  const unsigned tiles = static_cast<unsigned>((n + 31) / 32);
  mirrorLower<<<dim3(tiles, tiles), dim3(32, 8), 0, stream>>>(n, A);
}

void launchScatterLowerCsc(long long n, const int* outer, const int* inner, const double* values, double* A,
                           cudaStream_t stream) {
  const int threads = 256;
  const long long blocks = (n * 32 + threads - 1) / threads;
  scatterLowerCsc<<<static_cast<unsigned>(blocks), threads, 0, stream>>>(n, outer, inner, values, A);
}

}  // namespace topo_gaussian::cuda_detail
