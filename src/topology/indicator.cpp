#include "topo_gaussian/topology/indicator.h"

#include <cmath>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/physics/neighbor_list.h"

namespace topo_gaussian {

namespace {

// Overflow-free logistic function.
inline double sigmoid(double x) {
  if (x >= 0.0) return 1.0 / (1.0 + std::exp(-x));
  const double e = std::exp(x);
  return e / (1.0 + e);
}

void validate(const IndicatorOptions& o, std::size_t n) {
  if (!(o.epsilon > 0.0) || !std::isfinite(o.epsilon))
    throw TopoError("indicator epsilon", "is " + std::to_string(o.epsilon) + ", the sigmoid width must be positive",
                    "use a positive finite epsilon in field units, e.g. 0.05");
  if (!o.pinned.empty() && o.pinned.size() != n)
    throw TopoError("indicator pinned mask",
                    "has " + std::to_string(o.pinned.size()) + " entries for " + std::to_string(n) + " particles",
                    "pass an empty mask or one flag per particle (e.g. from boundaryShell)");
  if (!(o.pinned_value >= 0.0 && o.pinned_value <= 1.0))
    throw TopoError("indicator pinned_value", "is " + std::to_string(o.pinned_value) + ", outside [0, 1]",
                    "use 1 (material B, solid) or 0 (material A)");
}

}  // namespace

std::vector<std::uint8_t> boundaryShell(const std::vector<Eigen::Vector3d>& X, const std::vector<std::uint8_t>& surface,
                                        double thickness_m) {
  if (surface.size() != X.size())
    throw TopoError("boundary shell surface flags",
                    "has " + std::to_string(surface.size()) + " flags for " + std::to_string(X.size()) + " particles",
                    "pass the cloud's surface flags (one per particle)");
  if (std::isnan(thickness_m))
    throw TopoError("boundary shell thickness", "is NaN", "use a thickness in metres, or 0 for the surface only");
  std::vector<std::uint8_t> shell(X.size(), 0);
  for (std::size_t i = 0; i < X.size(); ++i) shell[i] = surface[i] ? 1 : 0;
  if (!(thickness_m > 0.0)) return shell;
  if (!std::isfinite(thickness_m))
    throw TopoError("boundary shell thickness", "is infinite", "use a finite thickness in metres");

  // Grid over the surface particles only; every particle asks whether one lies within thickness_m.
  std::vector<Eigen::Vector3d> S;
  for (std::size_t i = 0; i < X.size(); ++i)
    if (surface[i]) S.push_back(X[i]);
  if (S.empty()) return shell;
  const SpatialGrid grid(S, thickness_m);
  const double t2 = thickness_m * thickness_m;
  const std::ptrdiff_t n = static_cast<std::ptrdiff_t>(X.size());
#pragma omp parallel for schedule(dynamic, 1024)
  for (std::ptrdiff_t i = 0; i < n; ++i) {
    if (shell[i]) continue;
    bool near = false;
    const Eigen::Vector3d xi = X[i];
    grid.query(xi, [&](int, const Eigen::Vector3d& xj) { near = near || (xj - xi).squaredNorm() < t2; });
    shell[i] = near ? 1 : 0;
  }
  return shell;
}

void evaluateIndicator(const Representation& rep, const Eigen::VectorXd& theta, const IndicatorOptions& options,
                       std::vector<double>* r) {
  validate(options, rep.numParticles());
  rep.field(theta, r);  // s, converted in place
  const double inv_eps = 1.0 / options.epsilon;
  const bool pin = !options.pinned.empty();
  const std::ptrdiff_t n = static_cast<std::ptrdiff_t>(r->size());
#pragma omp parallel for schedule(static) if (n > 8192)
  for (std::ptrdiff_t i = 0; i < n; ++i)
    (*r)[i] = pin && options.pinned[i] ? options.pinned_value : sigmoid((*r)[i] * inv_eps);
}

void indicatorBackward(const Representation& rep, const Eigen::VectorXd& theta, const IndicatorOptions& options,
                       const std::vector<double>& dL_dr, Eigen::VectorXd* dL_dtheta) {
  validate(options, rep.numParticles());
  if (dL_dr.size() != rep.numParticles())
    throw TopoError(
        "indicator gradient dL/dr",
        "has " + std::to_string(dL_dr.size()) + " values for " + std::to_string(rep.numParticles()) + " particles",
        "pass one derivative per particle");
  std::vector<double> ds;
  rep.field(theta, &ds);
  const double inv_eps = 1.0 / options.epsilon;
  const bool pin = !options.pinned.empty();
  const std::ptrdiff_t n = static_cast<std::ptrdiff_t>(ds.size());
  // dr/ds = r (1 − r) / ε; pinned particles do not depend on θ.
#pragma omp parallel for schedule(static) if (n > 8192)
  for (std::ptrdiff_t i = 0; i < n; ++i) {
    if (pin && options.pinned[i]) {
      ds[i] = 0.0;
    } else {
      const double x = ds[i] * inv_eps;
      ds[i] = dL_dr[i] * sigmoid(x) * sigmoid(-x) * inv_eps;  // r (1 − r) without cancellation
    }
  }
  rep.fieldBackward(theta, ds, dL_dtheta);
}

void indicatorBackwardColumns(const Representation& rep, const Eigen::VectorXd& theta, const IndicatorOptions& options,
                              const Eigen::MatrixXd& dL_dr, Eigen::MatrixXd* dL_dtheta) {
  validate(options, rep.numParticles());
  if (static_cast<std::size_t>(dL_dr.rows()) != rep.numParticles())
    throw TopoError(
        "indicator gradients dL/dr",
        "have " + std::to_string(dL_dr.rows()) + " rows for " + std::to_string(rep.numParticles()) + " particles",
        "pass one row per particle");
  std::vector<double> s;
  rep.field(theta, &s);
  const double inv_eps = 1.0 / options.epsilon;
  const bool pin = !options.pinned.empty();
  Eigen::MatrixXd dL_ds(dL_dr.rows(), dL_dr.cols());
  const std::ptrdiff_t n = static_cast<std::ptrdiff_t>(s.size());
#pragma omp parallel for schedule(static) if (n > 8192)
  for (std::ptrdiff_t i = 0; i < n; ++i) {
    const double x = s[i] * inv_eps;
    // dr/ds = r (1 − r) / ε; pinned particles do not depend on θ.
    if (pin && options.pinned[i])
      dL_ds.row(i).setZero();
    else
      dL_ds.row(i) = dL_dr.row(i) * (sigmoid(x) * sigmoid(-x) * inv_eps);
  }
  rep.fieldBackwardColumns(theta, dL_ds, dL_dtheta);
}

}  // namespace topo_gaussian
