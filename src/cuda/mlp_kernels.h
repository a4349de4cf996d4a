// Launchers of the MLP's elementwise kernels (mlp_kernels.cu); plain device pointers, no CUDA headers.
#pragma once

namespace topo_gaussian {
namespace cuda_detail {

/// Z (rows × count/rows, column-major) += b per row; with relu, then max(Z, 0).
template <class T>
void launchBiasRelu(T* Z, const T* b, int rows, long long count, bool relu, void* stream);

/// delta = back ⊙ [H > 0] (count values).
template <class T>
void launchReluMask(T* delta, const T* back, const T* H, long long count, void* stream);

/// x[0 … count) = v.
template <class T>
void launchFill(T* x, T v, long long count, void* stream);

}  // namespace cuda_detail
}  // namespace topo_gaussian
