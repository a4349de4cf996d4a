// Kernel launchers of the GPU dense Cholesky (dense_cholesky_cuda.cpp); no Eigen here.
#pragma once

#include <cuda_runtime_api.h>

namespace topo_gaussian::cuda_detail {

/// A (n × n, column-major, zeroed by the caller) gets the lower triangle given in compressed
/// columns (outer: n + 1 offsets, inner: row indices ≥ the column, values).
void launchScatterLowerCsc(long long n, const int* outer, const int* inner, const double* values, double* A,
                           cudaStream_t stream);

/// A (n × n, column-major): the upper triangle becomes the mirror of the lower one.
void launchMirrorLower(long long n, double* A, cudaStream_t stream);

}  // namespace topo_gaussian::cuda_detail
