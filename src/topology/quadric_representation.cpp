#include "topo_gaussian/topology/quadric_representation.h"

#include <cmath>
#include <vector>

#include "topo_gaussian/common/block_sum.h"
#include "topo_gaussian/common/error.h"

namespace topo_gaussian {

namespace {

double evaluate(const Eigen::VectorXd& t, const Eigen::Vector3d& u) {
  const double x = u.x(), y = u.y(), z = u.z();
  return t[0] * x * x + t[1] * y * y + t[2] * z * z + 2.0 * (t[3] * x * y + t[4] * x * z + t[5] * y * z) + t[6] * x +
         t[7] * y + t[8] * z + t[9];
}

constexpr double kDistanceKappa = 1e-3;

/// q = |∇s|² + κ²|θ_{A,b}|² and ∇s = 2Au + b at u.
double gradientSquare(const Eigen::VectorXd& t, const Eigen::Vector3d& u, Eigen::Vector3d* g) {
  const double x = u.x(), y = u.y(), z = u.z();
  *g = Eigen::Vector3d(2.0 * (t[0] * x + t[3] * y + t[4] * z) + t[6], 2.0 * (t[3] * x + t[1] * y + t[5] * z) + t[7],
                       2.0 * (t[4] * x + t[5] * y + t[2] * z) + t[8]);
  return g->squaredNorm() + kDistanceKappa * kDistanceKappa * t.head<9>().squaredNorm();
}

/// The field at u: algebraic (unit 0) or the distance field in `unit`.
double fieldValue(const Eigen::VectorXd& t, const Eigen::Vector3d& u, double unit) {
  const double s = evaluate(t, u);
  if (unit <= 0.0) return s;
  Eigen::Vector3d g;
  const double q = gradientSquare(t, u, &g);
  if (!(q > 0.0)) return s > 0 ? 1e300 : (s < 0 ? -1e300 : 0.0);  // θ_{A,b} = 0: a constant field
  return s / (std::sqrt(q) * unit);
}

}  // namespace

void QuadricRepresentation::setDistanceUnit(double unit) {
  if (!(unit >= 0.0) || !std::isfinite(unit))
    throw TopoError("quadric distance unit", "is " + std::to_string(unit),
                    "use a positive length in normalised units, or 0 for the algebraic field");
  distance_unit_ = unit;
}

QuadricRepresentation::QuadricRepresentation(const std::vector<Eigen::Vector3d>& X, double initial_field)
    : frame_(NormalisedFrame::fromPoints(X)), initial_field_(initial_field) {
  if (!std::isfinite(initial_field))
    throw TopoError("quadric representation initial_field", "is not finite", "use e.g. 0.3");
  n_ = X.size();
  U_.resize(n_);
  const double inv = 1.0 / frame_.scale;
  for (std::size_t i = 0; i < n_; ++i) U_[i] = (X[i] - frame_.centre) * inv;
}

Eigen::VectorXd QuadricRepresentation::initialParameters() const {
  Eigen::VectorXd t = Eigen::VectorXd::Zero(kNumParameters);
  t[9] = initial_field_;
  return t;
}

Eigen::Matrix<double, 10, 1> QuadricRepresentation::basis(const Eigen::Vector3d& u) {
  const double x = u.x(), y = u.y(), z = u.z();
  Eigen::Matrix<double, 10, 1> m;
  m << x * x, y * y, z * z, 2.0 * x * y, 2.0 * x * z, 2.0 * y * z, x, y, z, 1.0;
  return m;
}

void QuadricRepresentation::field(const Eigen::VectorXd& theta, std::vector<double>* s) const {
  checkParameters(theta);
  s->resize(n_);
  const std::ptrdiff_t n = static_cast<std::ptrdiff_t>(n_);
#pragma omp parallel for schedule(static) if (n > 8192)
  for (std::ptrdiff_t i = 0; i < n; ++i) (*s)[i] = fieldValue(theta, U_[i], distance_unit_);
}

void QuadricRepresentation::fieldAt(const Eigen::VectorXd& theta, const std::vector<Eigen::Vector3d>& points,
                                    std::vector<double>* s) const {
  checkParameters(theta);
  s->resize(points.size());
  const double inv = 1.0 / frame_.scale;
  const std::ptrdiff_t n = static_cast<std::ptrdiff_t>(points.size());
#pragma omp parallel for schedule(static) if (n > 8192)
  for (std::ptrdiff_t i = 0; i < n; ++i) (*s)[i] = fieldValue(theta, (points[i] - frame_.centre) * inv, distance_unit_);
}

namespace {

/// √q · unit · ds_d/dθ's bracket: basis/√q − s ∂q/∂θ / (2 q^{3/2}), ∂q/∂θ = 2 (∂g/∂θ)ᵀ g + 2κ² θ_{A,b}
/// (zero where q = 0); ds_d/dθ is it over unit.
Eigen::Matrix<double, 10, 1> distanceGradientTimesUnit(const Eigen::VectorXd& theta, const Eigen::Vector3d& u) {
  using Vec10 = Eigen::Matrix<double, 10, 1>;
  Eigen::Vector3d g;
  const double q = gradientSquare(theta, u, &g);
  if (!(q > 0.0)) return Vec10::Zero();
  const double x = u.x(), y = u.y(), z = u.z(), sq = std::sqrt(q), s = evaluate(theta, u);
  Vec10 dq;
  dq << 4.0 * x * g.x(), 4.0 * y * g.y(), 4.0 * z * g.z(), 4.0 * (y * g.x() + x * g.y()), 4.0 * (z * g.x() + x * g.z()),
      4.0 * (z * g.y() + y * g.z()), 2.0 * g.x(), 2.0 * g.y(), 2.0 * g.z(), 0.0;
  dq.head<9>() += 2.0 * kDistanceKappa * kDistanceKappa * theta.head<9>();
  return QuadricRepresentation::basis(u) / sq - (s / (2.0 * q * sq)) * dq;
}

}  // namespace

Eigen::Matrix<double, 10, 1> QuadricRepresentation::fieldGradient(const Eigen::VectorXd& theta,
                                                                  const Eigen::Vector3d& u) const {
  return distance_unit_ > 0.0 ? Eigen::Matrix<double, 10, 1>(distanceGradientTimesUnit(theta, u) / distance_unit_)
                              : basis(u);
}

void QuadricRepresentation::fieldBackward(const Eigen::VectorXd& theta, const std::vector<double>& dL_ds,
                                          Eigen::VectorXd* dL_dtheta) const {
  checkParameters(theta);
  checkFieldGradient(dL_ds);
  // Algebraic: s is linear in θ, dL/dθ = Σ_i dL/ds_i · basis(u_i). Distance field s_d = s / (√q · unit):
  // ds_d/dθ = (basis/√q − s ∂q/∂θ / (2 q^{3/2})) / unit, ∂q/∂θ = 2 (∂g/∂θ)ᵀ g + 2κ² θ_{A,b}. Summed in
  // fixed blocks added in block order: the same bits on any number of threads (common/block_sum.h).
  using Vec10 = Eigen::Matrix<double, 10, 1>;
  *dL_dtheta = blockSum<Vec10>(static_cast<std::ptrdiff_t>(n_), Vec10::Zero(), [&](Vec10* local, std::ptrdiff_t i) {
    if (distance_unit_ <= 0.0)
      *local += dL_ds[i] * basis(U_[i]);
    else if (dL_ds[i] != 0.0)
      *local += (dL_ds[i] / distance_unit_) * distanceGradientTimesUnit(theta, U_[i]);
  });
}

void QuadricRepresentation::fieldBackwardColumns(const Eigen::VectorXd& theta, const Eigen::MatrixXd& dL_ds,
                                                 Eigen::MatrixXd* dL_dtheta) const {
  checkParameters(theta);
  if (static_cast<std::size_t>(dL_ds.rows()) != n_ || !dL_ds.allFinite())
    throw TopoError("quadric field gradients",
                    "have " + std::to_string(dL_ds.rows()) + " rows for " + std::to_string(n_) +
                        " particles, or a non-finite entry",
                    "pass one finite row per particle");
  const Eigen::MatrixXd zero = Eigen::MatrixXd::Zero(kNumParameters, dL_ds.cols());
  *dL_dtheta =
      blockSum<Eigen::MatrixXd>(static_cast<std::ptrdiff_t>(n_), zero, [&](Eigen::MatrixXd* local, std::ptrdiff_t i) {
        if (!dL_ds.row(i).isZero(0.0)) local->noalias() += fieldGradient(theta, U_[i]) * dL_ds.row(i);
      });
}

}  // namespace topo_gaussian
