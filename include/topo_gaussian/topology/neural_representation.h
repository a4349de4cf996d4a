// Neural representation (paper §5 and appendix): an MLP SDF u ∈ ℝ³ → s ∈ ℝ on normalised
// coordinates, `depth` linear layers (3 → width → … → width → 1), ReLU between them, weight
// normalisation (Salimans & Kingma 2016): row j of layer l is W_j = g_j v_j / ‖v_j‖.
//
// θ layout, layer after layer: v (out × in, column-major, i.e. v(j, k) at j + out·k), then g (out),
// then b (out). The last parameter is the output bias.
//
// With options.backend cuda (or auto and a GPU) field() and fieldBackward() run their matrix
// products on the GPU through cuBLAS (cuda/mlp_cuda.h, float64: the same results to round-off).
//
// The paper trains with dropout; here there is none, because the field must be a deterministic
// function of θ for the simulator gradients and finite-difference checks.
#pragma once

#include <Eigen/Core>

#include <memory>

#include "topo_gaussian/cuda/mlp_cuda.h"
#include "topo_gaussian/topology/representation.h"

namespace topo_gaussian {

class NeuralRepresentation : public Representation {
 public:
  /// Throws TopoError for depth < 2, width < 1, non-finite initial_field or an empty/non-finite cloud.
  NeuralRepresentation(const NeuralOptions& options, const std::vector<Eigen::Vector3d>& X);

  std::string name() const override { return "neural"; }
  int numParameters() const override { return num_parameters_; }
  /// Deterministic (seeded) He-style initialisation; the output layer has small weights and bias
  /// initial_field, so s ≈ +initial_field everywhere while every parameter receives gradient.
  Eigen::VectorXd initialParameters() const override;
  void field(const Eigen::VectorXd& theta, std::vector<double>* s) const override;
  void fieldBackward(const Eigen::VectorXd& theta, const std::vector<double>& dL_ds,
                     Eigen::VectorXd* dL_dtheta) const override;

  /// s at arbitrary positions (same frame as the particles), e.g. to mesh the solid region.
  void fieldAt(const Eigen::VectorXd& theta, const std::vector<Eigen::Vector3d>& points, std::vector<double>* s) const;
  /// Per particle, the smallest |pre-activation| over all hidden units: how far the particle is
  /// from a ReLU kink (finite differences with steps below this margin are exact to O(h²)).
  void kinkMargin(const Eigen::VectorXd& theta, std::vector<double>* margin) const;

  /// Effective weights W_l = diag(g / ‖v_j‖) v of every layer (what MlpCuda multiplies by).
  std::vector<Eigen::MatrixXd> weights(const Eigen::VectorXd& theta) const;
  /// The biases b_l of θ.
  std::vector<Eigen::VectorXd> biases(const Eigen::VectorXd& theta) const;
  /// The layer widths {3, width, …, width, 1}.
  std::vector<int> layerSizes() const;

  const NormalisedFrame& frame() const { return frame_; }
  const NeuralOptions& options() const { return options_; }
  /// Parameter count of a net: Σ over layers of in·out (v) + out (g) + out (b).
  static int parameterCount(int depth, int width);

 private:
  struct Layer {
    int in = 0, out = 0;
    int v = 0, g = 0, b = 0;  ///< offsets into θ
  };
  void forward(const Eigen::VectorXd& theta, const Eigen::Matrix3Xd& U, std::vector<double>* s,
               std::vector<double>* margin) const;

  /// The weight-normalisation backward: dL/dθ from dL/dW_l (G) and dL/db_l (gb) of every layer.
  void weightNormBackward(const Eigen::VectorXd& theta, const std::vector<Eigen::MatrixXd>& G,
                          const std::vector<Eigen::VectorXd>& gb, Eigen::VectorXd* dL_dtheta) const;
  /// The GPU MLP when options_.backend resolves to cuda (made at the first evaluation), else null.
  MlpCuda* gpu() const;

  NeuralOptions options_;
  mutable std::shared_ptr<MlpCuda> gpu_;
  mutable bool gpu_resolved_ = false;
  mutable Eigen::VectorXd gpu_theta_;  ///< θ of the GPU's last field() (its activations are kept)
  NormalisedFrame frame_;
  Eigen::Matrix3Xd U_;  ///< normalised particle coordinates, one column each
  std::vector<Layer> layers_;
  int num_parameters_ = 0;
};

}  // namespace topo_gaussian
