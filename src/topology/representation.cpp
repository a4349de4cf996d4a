// Representation base class, normalised frame and factory.
#include "topo_gaussian/topology/representation.h"

#include <cmath>
#include <limits>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/topology/neural_representation.h"
#include "topo_gaussian/topology/point_representation.h"
#include "topo_gaussian/topology/quadric_representation.h"

namespace topo_gaussian {

void Representation::fieldBackwardColumns(const Eigen::VectorXd& theta, const Eigen::MatrixXd& dL_ds,
                                          Eigen::MatrixXd* dL_dtheta) const {
  if (static_cast<std::size_t>(dL_ds.rows()) != n_)
    throw TopoError(name() + " representation field gradients",
                    "have " + std::to_string(dL_ds.rows()) + " rows for " + std::to_string(n_) + " particles",
                    "pass one row per particle");
  dL_dtheta->resize(numParameters(), dL_ds.cols());
  std::vector<double> column(n_);
  Eigen::VectorXd g;
  for (Eigen::Index k = 0; k < dL_ds.cols(); ++k) {
    Eigen::VectorXd::Map(column.data(), dL_ds.rows()) = dL_ds.col(k);
    fieldBackward(theta, column, &g);
    dL_dtheta->col(k) = g;
  }
}

void Representation::bounds(Eigen::VectorXd* lower, Eigen::VectorXd* upper) const {
  const double inf = std::numeric_limits<double>::infinity();
  if (lower) *lower = Eigen::VectorXd::Constant(numParameters(), -inf);
  if (upper) *upper = Eigen::VectorXd::Constant(numParameters(), inf);
}

void Representation::checkParameters(const Eigen::VectorXd& theta) const {
  if (theta.size() != numParameters())
    throw TopoError(name() + " representation parameters θ",
                    "has " + std::to_string(theta.size()) + " values, expected " + std::to_string(numParameters()),
                    "start from initialParameters() of the same representation and particle set");
  for (Eigen::Index k = 0; k < theta.size(); ++k)
    if (!std::isfinite(theta[k]))
      throw TopoError(name() + " representation parameters θ",
                      "entry " + std::to_string(k) + " is not finite (" + std::to_string(theta[k]) + ")",
                      "the optimiser diverged: lower the learning rate or restart from initialParameters()");
}

void Representation::checkFieldGradient(const std::vector<double>& dL_ds) const {
  if (dL_ds.size() != n_)
    throw TopoError(name() + " representation field gradient dL/ds",
                    "has " + std::to_string(dL_ds.size()) + " values for " + std::to_string(n_) + " particles",
                    "pass one derivative per particle");
  for (std::size_t i = 0; i < dL_ds.size(); ++i)
    if (!std::isfinite(dL_ds[i]))
      throw TopoError(name() + " representation field gradient dL/ds", "entry " + std::to_string(i) + " is not finite",
                      "the loss or simulation diverged: check the simulation step and the loss inputs");
}

NormalisedFrame NormalisedFrame::fromPoints(const std::vector<Eigen::Vector3d>& X) {
  if (X.empty())
    throw TopoError("particle set", "is empty", "fill the object with particles before choosing a representation");
  Eigen::Vector3d lo = X[0], hi = X[0];
  for (std::size_t i = 0; i < X.size(); ++i) {
    if (!X[i].allFinite())
      throw TopoError("particle set", "particle " + std::to_string(i) + " has a non-finite position",
                      "remove NaN/Inf points before filling");
    lo = lo.cwiseMin(X[i]);
    hi = hi.cwiseMax(X[i]);
  }
  NormalisedFrame f;
  f.centre = 0.5 * (lo + hi);
  const double half = 0.5 * (hi - lo).maxCoeff();
  f.scale = half > 0.0 ? half : 1.0;  // a single point: any scale works
  return f;
}

std::unique_ptr<Representation> makeRepresentation(const RepresentationOptions& options,
                                                   const std::vector<Eigen::Vector3d>& X) {
  const std::string& kind = options.kind;
  if (kind != "point" && kind != "quadric" && kind != "neural")
    throw TopoError("representation kind '" + kind + "'", "is unknown", "use one of: point, quadric, neural");
  if (X.empty())
    throw TopoError(kind + " representation", "the particle set is empty",
                    "fill the object with particles before choosing a representation");
  if (!std::isfinite(options.initial_field))
    throw TopoError(kind + " representation initial_field", "is not finite", "use e.g. 0.3");
  if (kind == "point") {
    if (!(options.point_bound > 0.0) || !std::isfinite(options.point_bound))
      throw TopoError("point representation point_bound", "is " + std::to_string(options.point_bound),
                      "use a positive finite bound, e.g. 1");
    return std::make_unique<PointRepresentation>(X.size(), options.initial_field, options.point_bound);
  }
  if (kind == "quadric") return std::make_unique<QuadricRepresentation>(X, options.initial_field);
  // The documented options.initial_field (the neural output bias) wins over options.neural's copy.
  NeuralOptions neural = options.neural;
  neural.initial_field = options.initial_field;
  return std::make_unique<NeuralRepresentation>(neural, X);
}

}  // namespace topo_gaussian
