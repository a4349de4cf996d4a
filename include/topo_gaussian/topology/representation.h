// Topology representations (paper §5): parameters θ → a signed field s_i at every particle, and
// through a sigmoid the indicator r_i = sigmoid(s_i / ε) ∈ [0, 1] (r = 1: material B, e.g. solid;
// r = 0: material A, e.g. hollow). Each representation gives the field and the vector–Jacobian
// product dL/dθ = (ds/dθ)ᵀ dL/ds, so every task and optimiser works with all of them.
//
//  point   : one variable per particle, s_i = t_i.
//  quadric : s(x) = xᵀAx + bᵀx + c with A symmetric: 10 parameters (Hafner et al. 2024).
//  neural  : an MLP SDF f_θ(x) (paper: 8 layers × 512, ReLU, weight normalisation), forward and
//            backward written here on Eigen.
// Quadric and neural evaluate at normalised coordinates u = (x − centre) / scale (centre and scale
// from the particle bounds, scale = half the largest extent), so their parameters do not depend on
// the object's size or units.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "topo_gaussian/cuda/backend.h"

namespace topo_gaussian {

class Representation {
 public:
  virtual ~Representation() = default;
  virtual std::string name() const = 0;  ///< "point", "quadric", "neural"
  virtual int numParameters() const = 0;
  /// Parameters of a fully material-B ("solid") design: s_i ≈ +initial_field everywhere.
  virtual Eigen::VectorXd initialParameters() const = 0;
  /// Box bounds for bounded optimisers (±inf where unbounded).
  virtual void bounds(Eigen::VectorXd* lower, Eigen::VectorXd* upper) const;
  /// s_i for every particle (resizes s). Throws TopoError if θ has the wrong size or is not finite.
  virtual void field(const Eigen::VectorXd& theta, std::vector<double>* s) const = 0;
  /// dL/dθ = (ds/dθ)ᵀ dL/ds. Overwrites dL_dtheta (size numParameters()).
  virtual void fieldBackward(const Eigen::VectorXd& theta, const std::vector<double>& dL_ds,
                             Eigen::VectorXd* dL_dtheta) const = 0;
  /// K gradients at once: column k of *dL_dtheta (numParameters() × K) is fieldBackward of column k of dL_ds
  /// (N × K), e.g. the ten mass moments' dp/dθ in one pass over the particles. The default calls
  /// fieldBackward K times; a representation with a cheap per-particle ds/dθ overrides it.
  virtual void fieldBackwardColumns(const Eigen::VectorXd& theta, const Eigen::MatrixXd& dL_ds,
                                    Eigen::MatrixXd* dL_dtheta) const;
  std::size_t numParticles() const { return n_; }

 protected:
  /// Throws TopoError naming name() if θ has the wrong size or a non-finite entry.
  void checkParameters(const Eigen::VectorXd& theta) const;
  /// Throws TopoError if dL/ds does not have one finite entry per particle.
  void checkFieldGradient(const std::vector<double>& dL_ds) const;

  std::size_t n_ = 0;
};

/// Normalisation used by quadric and neural: u = (x − centre) / scale.
struct NormalisedFrame {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  double scale = 1.0;
  static NormalisedFrame fromPoints(const std::vector<Eigen::Vector3d>& X);
};

struct NeuralOptions {
  int depth = 8;               ///< number of linear layers (hidden layers = depth − 1), paper: 8
  int width = 512;             ///< hidden width, paper: 512
  unsigned seed = 1;           ///< weight initialisation seed (deterministic)
  double initial_field = 0.3;  ///< the initial output bias: s ≈ +initial_field (solid) everywhere
  /// Where field() and fieldBackward() run (cuda/mlp_cuda.h: cuBLAS, float64). The task parameter
  /// `backend` sets it (default auto there); the library default is the CPU.
  ComputeBackend backend = ComputeBackend::Cpu;
};

struct RepresentationOptions {
  std::string kind = "quadric";  ///< point | quadric | neural
  double initial_field = 0.3;    ///< s at the start (fully solid): point t_i, quadric c, neural bias
  double point_bound = 1.0;      ///< point: t_i ∈ [−point_bound, point_bound]
  NeuralOptions neural;
};

/// Factory. Throws TopoError naming `kind` when it is unknown or an option is invalid
/// (depth < 2, width < 1, point_bound ≤ 0, empty particle set).
std::unique_ptr<Representation> makeRepresentation(const RepresentationOptions& options,
                                                   const std::vector<Eigen::Vector3d>& X);

}  // namespace topo_gaussian
