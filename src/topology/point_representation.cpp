#include "topo_gaussian/topology/point_representation.h"

#include <climits>
#include <cmath>

#include "topo_gaussian/common/error.h"

namespace topo_gaussian {

PointRepresentation::PointRepresentation(std::size_t n, double initial_field, double point_bound)
    : initial_field_(initial_field), bound_(point_bound) {
  if (n == 0)
    throw TopoError("point representation", "the particle set is empty",
                    "fill the object with particles before choosing a representation");
  if (n > static_cast<std::size_t>(INT_MAX))
    throw TopoError("point representation", std::to_string(n) + " particles are more than an int indexes",
                    "use a coarser fill or the quadric/neural representation");
  if (!(point_bound > 0.0) || !std::isfinite(point_bound))
    throw TopoError("point representation point_bound", "is " + std::to_string(point_bound),
                    "use a positive finite bound, e.g. 1");
  if (!std::isfinite(initial_field) || std::abs(initial_field) > point_bound)
    throw TopoError("point representation initial_field",
                    std::to_string(initial_field) + " is outside ±point_bound = ±" + std::to_string(point_bound),
                    "choose |initial_field| ≤ point_bound");
  n_ = n;
}

Eigen::VectorXd PointRepresentation::initialParameters() const {
  return Eigen::VectorXd::Constant(numParameters(), initial_field_);
}

void PointRepresentation::bounds(Eigen::VectorXd* lower, Eigen::VectorXd* upper) const {
  if (lower) *lower = Eigen::VectorXd::Constant(numParameters(), -bound_);
  if (upper) *upper = Eigen::VectorXd::Constant(numParameters(), bound_);
}

void PointRepresentation::field(const Eigen::VectorXd& theta, std::vector<double>* s) const {
  checkParameters(theta);
  s->assign(theta.data(), theta.data() + theta.size());
}

void PointRepresentation::fieldBackward(const Eigen::VectorXd& theta, const std::vector<double>& dL_ds,
                                        Eigen::VectorXd* dL_dtheta) const {
  checkParameters(theta);
  checkFieldGradient(dL_ds);
  *dL_dtheta = Eigen::Map<const Eigen::VectorXd>(dL_ds.data(), static_cast<Eigen::Index>(dL_ds.size()));
}

}  // namespace topo_gaussian
