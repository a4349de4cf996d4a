// Quadric representation (paper §5, Hafner et al. 2024): s(u) = uᵀAu + bᵀu + c on normalised
// coordinates u, A symmetric. θ = [a_xx, a_yy, a_zz, a_xy, a_xz, a_yz, b_x, b_y, b_z, c]; each
// off-diagonal entry appears twice in uᵀAu (s contains 2 a_xy u_x u_y). Unbounded.
//
// Distance field (setDistanceUnit): the algebraic s can be made small everywhere by shrinking θ,
// and σ(s/ε) is then grey over the whole body: a grey spread of a heavy insert has the same mass and
// centre as a small dense ball. The distance field is s's first-order distance to its zero set (Taubin
// 1991), in units of `unit` [u]:
//     s_d(u) = s(u) / (√(|∇s(u)|² + κ² |θ_{A,b}|²) · unit),   ∇s = 2Au + b,  κ = 1e-3,
// homogeneous of degree 0 in θ (θ's scale no longer matters), so r = σ(s_d/ε) changes from 0.12 to
// 0.88 across 4 ε · unit of normalised distance around the surface and is binary beyond it.
#pragma once

#include "topo_gaussian/topology/representation.h"

namespace topo_gaussian {

class QuadricRepresentation : public Representation {
 public:
  static constexpr int kNumParameters = 10;

  /// Throws TopoError for an empty or non-finite particle set.
  QuadricRepresentation(const std::vector<Eigen::Vector3d>& X, double initial_field);

  std::string name() const override { return "quadric"; }
  int numParameters() const override { return kNumParameters; }
  /// Zeros except c = initial_field.
  Eigen::VectorXd initialParameters() const override;
  void field(const Eigen::VectorXd& theta, std::vector<double>* s) const override;
  void fieldBackward(const Eigen::VectorXd& theta, const std::vector<double>& dL_ds,
                     Eigen::VectorXd* dL_dtheta) const override;
  /// One pass: ds_i/dθ once per particle (skipped where its row of dL_ds is zero).
  void fieldBackwardColumns(const Eigen::VectorXd& theta, const Eigen::MatrixXd& dL_ds,
                            Eigen::MatrixXd* dL_dtheta) const override;

  /// s at arbitrary positions (same frame as the particles), e.g. to mesh the solid region.
  void fieldAt(const Eigen::VectorXd& theta, const std::vector<Eigen::Vector3d>& points, std::vector<double>* s) const;
  const NormalisedFrame& frame() const { return frame_; }
  /// unit > 0: the distance field in units of `unit` [normalised length u]; 0: the algebraic field (default).
  /// Throws TopoError for a negative or non-finite unit.
  void setDistanceUnit(double unit);
  double distanceUnit() const { return distance_unit_; }
  /// ds/dθ at normalised coordinates u (the 10 monomials).
  static Eigen::Matrix<double, 10, 1> basis(const Eigen::Vector3d& u);
  /// ds/dθ at normalised coordinates u for this field (algebraic: the basis; distance: its quotient rule).
  Eigen::Matrix<double, 10, 1> fieldGradient(const Eigen::VectorXd& theta, const Eigen::Vector3d& u) const;

 private:
  NormalisedFrame frame_;
  std::vector<Eigen::Vector3d> U_;  ///< normalised particle coordinates
  double initial_field_;
  double distance_unit_ = 0.0;
};

}  // namespace topo_gaussian
