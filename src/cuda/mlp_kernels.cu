// Elementwise kernels of the MLP on the GPU (cuda/mlp_cuda.h); the GEMMs are cuBLAS's.
#include <cuda_runtime.h>

#include "mlp_kernels.h"

namespace topo_gaussian {
namespace cuda_detail {

namespace {

constexpr int kThreads = 256;

/// Z (rows × cols, column-major) += b per row; with relu, Z = max(Z, 0).
template <class T>
__global__ void biasReluKernel(T* Z, const T* b, int rows, long long count, bool relu) {
  const long long k = static_cast<long long>(blockIdx.x) * blockDim.x + threadIdx.x;
  if (k >= count) return;
  const T z = Z[k] + b[k % rows];
  Z[k] = relu && z < T(0) ? T(0) : z;
}

/// delta = back where H > 0, else 0.
template <class T>
__global__ void reluMaskKernel(T* delta, const T* back, const T* H, long long count) {
  const long long k = static_cast<long long>(blockIdx.x) * blockDim.x + threadIdx.x;
  if (k >= count) return;
  delta[k] = H[k] > T(0) ? back[k] : T(0);
}

template <class T>
__global__ void fillKernel(T* x, T v, long long count) {
  const long long k = static_cast<long long>(blockIdx.x) * blockDim.x + threadIdx.x;
  if (k < count) x[k] = v;
}

inline unsigned blocksFor(long long count) { return static_cast<unsigned>((count + kThreads - 1) / kThreads); }

}  // namespace

template <class T>
void launchBiasRelu(T* Z, const T* b, int rows, long long count, bool relu, void* stream) {
  if (count > 0)
    biasReluKernel<T><<<blocksFor(count), kThreads, 0, static_cast<cudaStream_t>(stream)>>>(Z, b, rows, count, relu);
}

template <class T>
void launchReluMask(T* delta, const T* back, const T* H, long long count, void* stream) {
  if (count > 0)
    reluMaskKernel<T><<<blocksFor(count), kThreads, 0, static_cast<cudaStream_t>(stream)>>>(delta, back, H, count);
}

template <class T>
void launchFill(T* x, T v, long long count, void* stream) {
  if (count > 0) fillKernel<T><<<blocksFor(count), kThreads, 0, static_cast<cudaStream_t>(stream)>>>(x, v, count);
}

template void launchBiasRelu<double>(double*, const double*, int, long long, bool, void*);
template void launchBiasRelu<float>(float*, const float*, int, long long, bool, void*);
template void launchReluMask<double>(double*, const double*, const double*, long long, void*);
template void launchReluMask<float>(float*, const float*, const float*, long long, void*);
template void launchFill<double>(double*, double, long long, void*);
template void launchFill<float>(float*, float, long long, void*);

}  // namespace cuda_detail
}  // namespace topo_gaussian
