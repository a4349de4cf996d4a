// Optimisers (paper §7): NLopt LD_LBFGS with box bounds, and Adam (written here). Both report
// progress every iteration (iteration, loss, gradient norm, elapsed), can be cancelled from the
// progress callback (returning false) or from should_stop (polled before every evaluation; a
// simulation polling it too throws SimulationCancelled, which ends the run), and always return the
// best design seen.
//
// max_evaluations counts evaluations of the loss and its gradient (each simulates one design once),
// for both methods, failed evaluations included: an L-BFGS iteration may evaluate several trial
// designs in its line search, an Adam iteration evaluates one. OptimizerResult::iterations is that
// count of the evaluations that succeeded; it never exceeds max_evaluations.
#pragma once

#include <Eigen/Core>
#include <functional>
#include <string>
#include <vector>

#include "topo_gaussian/physics/run_limits.h"

namespace topo_gaussian::inference {

struct OptimizerOptions {
  std::string method = "lbfgs";  ///< lbfgs | adam
  int max_evaluations = 200;     ///< evaluations of loss and gradient (see the header comment)
  double learning_rate = 0.02;   ///< Adam
  double beta1 = 0.9, beta2 = 0.999, adam_eps = 1e-8;
  double loss_tolerance = 1e-12;      ///< stop when loss ≤ this
  double relative_tolerance = 1e-10;  ///< stop when the relative loss change ≤ this (L-BFGS)
  double gradient_tolerance = 1e-14;  ///< stop when ‖g‖ ≤ this
  /// L-BFGS: stop (converged: "stalled") when the best loss has fallen by less than stall_relative over the
  /// last stall_evaluations evaluations (0 = never): a line search circling a flat valley otherwise
  /// spends the whole budget on digits that no observation resolves.
  int stall_evaluations = 30;
  double stall_relative = 1e-4;
  StopCheck should_stop;  ///< polled before every evaluation; true cancels
};

struct IterationInfo {
  int iteration = 0;
  double loss = 0.0;
  double gradient_norm = 0.0;
  double elapsed_s = 0.0;
  double best_loss = 0.0;
};

struct OptimizerResult {
  Eigen::VectorXd theta;  ///< the best design seen
  double loss = 0.0;
  int iterations = 0;      ///< objective evaluations with gradient that succeeded (≤ max_evaluations)
  int evaluations = 0;     ///< every objective call, failed ones included (≤ max_evaluations)
  bool converged = false;  ///< a stopping criterion was met (not the evaluation limit)
  bool cancelled = false;
  std::string message;  ///< why it stopped
  std::vector<IterationInfo> history;
};

/// f(θ, grad) returns the loss and fills grad (same size as θ).
using Objective = std::function<double(const Eigen::VectorXd&, Eigen::VectorXd*)>;
/// Return false to cancel; the best design so far is returned.
using ProgressCallback = std::function<bool(const IterationInfo&)>;

/// Throws TopoError for an unknown method or mismatched bounds. Exceptions from the objective
/// (e.g. a diverging simulation at a trial design) end the run with the best design so far and
/// the reason in message, unless it happens at the very first evaluation (then it is rethrown).
OptimizerResult minimize(const Objective& f, const Eigen::VectorXd& theta0, const Eigen::VectorXd& lower,
                         const Eigen::VectorXd& upper, const OptimizerOptions& options,
                         const ProgressCallback& progress = nullptr);

}  // namespace topo_gaussian::inference
