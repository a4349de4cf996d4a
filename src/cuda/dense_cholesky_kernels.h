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

/// The inverse factor in float32 (DenseCholeskyApply::InverseFactorFloat32): rows of
/// inverseFactorLeadingDimension(n) floats (n rounded up to 32), row j = column j of L⁻¹.
long long inverseFactorLeadingDimension(long long n);

/// The row chunks of the transposed product: its work space P holds chunks × leading dimension doubles.
long long inverseFactorChunks(long long n);

/// F = L⁻ᵀ in float32 from L⁻¹ (A: n × n, column-major, lower triangle), zeros elsewhere.
void launchInverseFactorToFloat(long long n, const double* A, float* F, cudaStream_t stream);

/// z = F (Fᵀ r) = L⁻ᵀ L⁻¹ r with F's float32 entries and float64 sums: y = Fᵀ r by row chunks into P
/// then summed in a fixed order, z = F y by rows. r: n doubles; y: leading-dimension doubles (its
/// padding is written zero); z: n doubles.
void launchInverseFactorApply(long long n, const float* F, const double* r, double* P, double* y, double* z,
                              cudaStream_t stream);

}  // namespace topo_gaussian::cuda_detail
