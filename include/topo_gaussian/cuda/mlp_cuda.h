// The neural representation's MLP on a CUDA GPU (paper §5: an MLP SDF, 8 linear layers
// of width 512, ReLU between them): for inputs U (3 × N, the normalised particle coordinates, kept
// on the device) and effective weights W_l (out × in) and biases b_l,
//   forward   H_0 = U,  Z_l = W_l H_l + b_l,  H_{l+1} = max(Z_l, 0),  s = Z_{depth−1}
//   backward  δ = dL/ds;  for l = depth−1 … 0:  dL/dW_l += δ H_lᵀ,  dL/db_l += δ 1,
//             δ ← (W_lᵀ δ) ⊙ [H_l > 0]
// with cuBLAS GEMMs (column-major, the layouts of Eigen's matrices) over blocks of up to 65 536
// points. The forward keeps every point's activations (width × (depth − 1) values a point) when
// they fit in half of the free memory, so a backward at the same weights needs no forward
// (backwardAfterForward); else each block recomputes its own.
// The weight normalisation W = diag(g/‖v‖) v and its backward stay on the host
// (topology/neural_representation.cpp: O(parameters), not O(points × parameters)).
// float64 (agrees with the CPU to round-off) or float32; float32 may run its GEMMs on the tensor
// cores in TF32 (MlpMath::Tf32: 10-bit mantissas in the products, float32 sums; several times the
// float32 GEMM rate, at ~1e-3 relative error: the stated tolerance is in
// test/unit/core_cuda_neural.cpp). Weights go up and gradients come down through pinned host
// memory, one synchronisation per call.
#pragma once

#include <Eigen/Core>
#include <memory>
#include <vector>

#include "topo_gaussian/cuda/soft_body_cuda.h"

namespace topo_gaussian {

/// How float32 GEMMs multiply: Exact (IEEE float32 FMA) or Tf32 (tensor cores, inputs rounded to
/// TF32). float64 is always exact.
enum class MlpMath { Exact, Tf32 };

class MlpCuda {
 public:
  /// sizes: layer widths, e.g. {3, 512, …, 512, 1}. Uploads U. Throws TopoError without a device,
  /// for bad sizes, for Tf32 with Float64, or (GpuMemoryError) when a block's activations do not fit.
  MlpCuda(const std::vector<int>& sizes, const Eigen::Matrix3Xd& U, CudaPrecision precision = CudaPrecision::Float64,
          MlpMath math = MlpMath::Exact);
  ~MlpCuda();
  MlpCuda(const MlpCuda&) = delete;
  MlpCuda& operator=(const MlpCuda&) = delete;

  std::size_t points() const;
  CudaPrecision precision() const;
  MlpMath math() const;
  /// s (N values) for the weights W[l] (sizes[l+1] × sizes[l]) and biases b[l] (sizes[l+1]).
  void forward(const std::vector<Eigen::MatrixXd>& W, const std::vector<Eigen::VectorXd>& b, std::vector<double>* s);
  /// dL/dW and dL/db for dL/ds (N values); overwrites dW and db.
  void backward(const std::vector<Eigen::MatrixXd>& W, const std::vector<Eigen::VectorXd>& b,
                const std::vector<double>& dL_ds, std::vector<Eigen::MatrixXd>* dW, std::vector<Eigen::VectorXd>* db);

  /// As backward() at the weights of the last forward(), from the activations that forward kept
  /// (every point's, when they take less than half of the free memory): no forward pass. Returns
  /// false, computing nothing, when they were not kept.
  bool backwardAfterForward(const std::vector<double>& dL_ds, std::vector<Eigen::MatrixXd>* dW,
                            std::vector<Eigen::VectorXd>* db);

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace topo_gaussian
