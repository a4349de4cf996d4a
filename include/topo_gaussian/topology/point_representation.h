// Point representation (paper §5): one decision variable per particle, s_i = t_i, θ = t ∈ [−b, b]ᴺ.
#pragma once

#include "topo_gaussian/topology/representation.h"

namespace topo_gaussian {

class PointRepresentation : public Representation {
 public:
  /// n particles; every t_i starts at initial_field and is bounded by ±point_bound (> 0).
  PointRepresentation(std::size_t n, double initial_field, double point_bound);

  std::string name() const override { return "point"; }
  int numParameters() const override { return static_cast<int>(n_); }
  Eigen::VectorXd initialParameters() const override;
  void bounds(Eigen::VectorXd* lower, Eigen::VectorXd* upper) const override;
  void field(const Eigen::VectorXd& theta, std::vector<double>* s) const override;
  void fieldBackward(const Eigen::VectorXd& theta, const std::vector<double>& dL_ds,
                     Eigen::VectorXd* dL_dtheta) const override;

 private:
  double initial_field_;
  double bound_;
};

}  // namespace topo_gaussian
