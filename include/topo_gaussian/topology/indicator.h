// Indicator r_i = sigmoid(s_i / ε) from a representation's field, with an optional pinned set
// (the paper fixes the boundary shell solid: pinned particles have r_i = pinned_value and
// dr_i/ds_i = 0), and the vector–Jacobian product back to θ.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "topo_gaussian/topology/representation.h"

namespace topo_gaussian {

struct IndicatorOptions {
  double epsilon = 0.05;             ///< sigmoid width ε (> 0), in the units of the field
  std::vector<std::uint8_t> pinned;  ///< empty or size N; 1 = pinned to pinned_value
  double pinned_value = 1.0;
};

/// Particles within `thickness_m` of the boundary: the cloud's surface flags dilated inward by
/// distance (surface flag 1 or distance to the nearest surface particle < thickness_m).
/// thickness_m ≤ 0 gives just the surface flags. Grid hashing, O(N).
std::vector<std::uint8_t> boundaryShell(const std::vector<Eigen::Vector3d>& X, const std::vector<std::uint8_t>& surface,
                                        double thickness_m);

/// Evaluates r (resized to N). Throws TopoError for ε ≤ 0 or a pinned mask of the wrong size.
void evaluateIndicator(const Representation& rep, const Eigen::VectorXd& theta, const IndicatorOptions& options,
                       std::vector<double>* r);

/// dL/dθ from dL/dr (pinned entries contribute nothing). Overwrites dL_dtheta.
void indicatorBackward(const Representation& rep, const Eigen::VectorXd& theta, const IndicatorOptions& options,
                       const std::vector<double>& dL_dr, Eigen::VectorXd* dL_dtheta);

/// K gradients at once: column k of *dL_dtheta (numParameters × K) is indicatorBackward of column k of dL_dr
/// (N × K); one field evaluation and Representation::fieldBackwardColumns.
void indicatorBackwardColumns(const Representation& rep, const Eigen::VectorXd& theta, const IndicatorOptions& options,
                              const Eigen::MatrixXd& dL_dr, Eigen::MatrixXd* dL_dtheta);

}  // namespace topo_gaussian
