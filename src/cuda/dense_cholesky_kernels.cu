// The scatter of a sparse lower triangle into the dense matrix cuSOLVER factorises; see
// dense_cholesky_cuda.h.
#include "dense_cholesky_kernels.h"

namespace topo_gaussian::cuda_detail {

namespace {

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

}  // namespace

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
