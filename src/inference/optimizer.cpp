#include "topo_gaussian/inference/optimizer.h"

#include <nlopt.hpp>

#include <chrono>
#include <cmath>
#include <limits>

#include "topo_gaussian/common/error.h"

namespace topo_gaussian::inference {
namespace {

struct Tracker {
  Tracker(const Objective& fn, const ProgressCallback& pr, const OptimizerOptions& o)
      : f(fn), progress(pr), options(o) {}
  const Objective& f;
  const ProgressCallback& progress;
  const OptimizerOptions& options;
  std::chrono::steady_clock::time_point start = std::chrono::steady_clock::now();
  OptimizerResult result;
  bool have_best = false;
  bool stop = false;
  bool stalled = false;
  double stall_reference = std::numeric_limits<double>::infinity();  ///< best loss at the last real progress
  int stall_since = 0;                                               ///< evaluations then
  std::string error;

  int failures = 0, total_failures = 0;
  Eigen::VectorXd failed_x;  ///< the last design the task could not evaluate
  double scale = 1.0;        ///< L-BFGS sees scale × loss (NLopt's L-BFGS stops when every gradient entry is tiny)

  /// A loss far above the best, so a line search steps back (cancelled or failed evaluations).
  double refusedLoss(const Eigen::VectorXd& x, Eigen::VectorXd* g) const {
    if (g) g->setZero(x.size());
    return have_best ? 1e3 * (1.0 + std::abs(result.loss)) : std::numeric_limits<double>::infinity();
  }

  void cancel() {
    result.cancelled = true;
    stop = true;
  }

  double call(const Eigen::VectorXd& x, Eigen::VectorXd* g) {
    if (options.should_stop && options.should_stop()) {
      cancel();
      return refusedLoss(x, g);
    }
    if (result.evaluations >= options.max_evaluations) {  // the limit counts every evaluation
      stop = true;
      if (result.message.empty()) result.message = "evaluation limit (max_evaluations) reached";
      return refusedLoss(x, g);
    }
    ++result.evaluations;
    double loss;
    try {
      loss = f(x, g);
      failures = 0;
    } catch (const SimulationCancelled&) {
      cancel();
      return refusedLoss(x, g);
    } catch (const std::exception& e) {
      if (!have_best) throw;
      // A trial design the task cannot evaluate (e.g. a tumbler that no longer rocks): report a loss
      // far above the best so the line search steps back; give up after several in a row.
      error = e.what();
      failed_x = x;
      ++total_failures;
      if (++failures >= 8) {
        stop = true;
        return std::numeric_limits<double>::infinity();
      }
      if (g) g->setZero(x.size());
      return 1e3 * (1.0 + std::abs(result.loss));
    }
    error.clear();
    ++result.iterations;
    if (!have_best || loss < result.loss) {
      result.loss = loss;
      result.theta = x;
      have_best = true;
    }
    if (result.loss < stall_reference * (1.0 - options.stall_relative) || !std::isfinite(stall_reference)) {
      stall_reference = result.loss;
      stall_since = result.evaluations;
    } else if (options.method == "lbfgs" && options.stall_evaluations > 0 &&
               result.evaluations - stall_since >= options.stall_evaluations) {
      stalled = stop = true;
    }
    IterationInfo info;
    info.iteration = result.iterations;
    info.loss = loss;
    info.gradient_norm = g ? g->norm() : 0.0;
    info.elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    info.best_loss = result.loss;
    result.history.push_back(info);
    if (progress && !progress(info)) {
      result.cancelled = true;
      stop = true;
    }
    if (result.loss <= options.loss_tolerance) stop = true;
    return loss;
  }
};

OptimizerResult runAdam(Tracker& t, Eigen::VectorXd x, const Eigen::VectorXd& lo, const Eigen::VectorXd& hi) {
  const OptimizerOptions& o = t.options;
  Eigen::VectorXd m = Eigen::VectorXd::Zero(x.size()), v = m, g(x.size());
  for (int k = 1; k <= o.max_evaluations && !t.stop; ++k) {
    const double loss = t.call(x, &g);
    if (t.stop) break;
    if (!std::isfinite(loss) || !g.allFinite()) {
      t.error = "the gradient is not finite at iteration " + std::to_string(k);
      break;
    }
    if (g.norm() <= o.gradient_tolerance) {
      t.result.converged = true;
      t.result.message = "gradient norm below gradient_tolerance";
      break;
    }
    m = o.beta1 * m + (1 - o.beta1) * g;
    v = o.beta2 * v + (1 - o.beta2) * g.cwiseProduct(g);
    const Eigen::VectorXd mh = m / (1 - std::pow(o.beta1, k));
    const Eigen::VectorXd vh = v / (1 - std::pow(o.beta2, k));
    x -= o.learning_rate * (mh.array() / (vh.array().sqrt() + o.adam_eps)).matrix();
    x = x.cwiseMax(lo).cwiseMin(hi);
  }
  return t.result;
}

}  // namespace

OptimizerResult minimize(const Objective& f, const Eigen::VectorXd& theta0, const Eigen::VectorXd& lower_in,
                         const Eigen::VectorXd& upper_in, const OptimizerOptions& options,
                         const ProgressCallback& progress) {
  const long n = theta0.size();
  const double inf = std::numeric_limits<double>::infinity();
  const Eigen::VectorXd lower = lower_in.size() ? lower_in : Eigen::VectorXd::Constant(n, -inf);
  const Eigen::VectorXd upper = upper_in.size() ? upper_in : Eigen::VectorXd::Constant(n, inf);
  if (lower.size() != n || upper.size() != n)
    throw TopoError("optimiser bounds", "sizes differ from the number of parameters", "give one bound per parameter");
  if (!theta0.allFinite())
    throw TopoError("initial design", "contains NaN or infinity", "start from finite parameters");
  if (options.max_evaluations < 1) throw TopoError("max_evaluations", "is below 1", "give at least 1 evaluation");
  Tracker t(f, progress, options);
  const Eigen::VectorXd x0 = theta0.cwiseMax(lower).cwiseMin(upper);
  if (options.method == "adam") {
    if (!(options.learning_rate > 0)) throw TopoError("learning_rate", "must be positive", "e.g. 0.02");
    runAdam(t, x0, lower, upper);
  } else if (options.method == "lbfgs") {
    nlopt::opt opt(nlopt::LD_LBFGS, static_cast<unsigned>(n));
    std::vector<double> lb(lower.data(), lower.data() + n), ub(upper.data(), upper.data() + n);
    opt.set_lower_bounds(lb);
    opt.set_upper_bounds(ub);
    opt.set_maxeval(options.max_evaluations);
    opt.set_ftol_rel(options.relative_tolerance);
    opt.set_stopval(options.loss_tolerance);
    auto fn = [](unsigned nn, const double* x, double* grad, void* data) -> double {
      Tracker* tr = static_cast<Tracker*>(data);
      if (tr->stop) throw nlopt::forced_stop();
      Eigen::Map<const Eigen::VectorXd> xv(x, nn);
      Eigen::VectorXd g(nn);
      const double loss = tr->call(xv, grad ? &g : nullptr);
      if (tr->result.cancelled) throw nlopt::forced_stop();
      if (grad) Eigen::Map<Eigen::VectorXd>(grad, nn) = tr->scale * g;
      // A vanishing gradient ends the run only at the best design so far: a trial step into a
      // saturated region (every r_i at 0 or 1, e.g. the chamber gone) also has a zero gradient, but
      // a higher loss; the line search must step back from it, not stop there.
      if (grad && tr->failures == 0 && g.norm() <= tr->options.gradient_tolerance) {
        if (loss <= tr->result.loss) {
          tr->stop = true;
        } else {  // for the restart's trust region, as a design that could not be evaluated
          tr->failed_x = xv;
          ++tr->total_failures;
        }
      }
      return tr->scale * loss;
    };
    // With very many parameters (the point representation: one per particle) every gradient entry
    // is tiny and NLopt's L-BFGS reports success at once: scale the loss so the largest entry at the
    // start is 1e-2. (Scaling the few-parameter representations made their line searches fail.)
    if (n > 10000) {
      Eigen::VectorXd g0(n);
      t.call(x0, &g0);
      const double gmax = g0.cwiseAbs().maxCoeff();
      if (gmax > 0 && gmax < 1e-4 && std::isfinite(gmax)) t.scale = 1e-2 / gmax;
      opt.set_stopval(options.loss_tolerance * t.scale);
    }
    opt.set_min_objective(fn, &t);
    // L-BFGS restarts from the best design (fresh curvature memory) when NLopt gives up on a rough
    // stretch of the loss (line-search failure), while evaluations remain.
    //
    // Trust region after failed evaluations: when the line search gave up because a trial design could
    // not be evaluated (e.g. no static equilibrium of a soft body at that design), the restart keeps
    // every parameter within half the distance (∞-norm) from the best design to the failed one, so
    // NLopt's first steps cannot jump there again; the box doubles after each restart that makes
    // progress without failures.
    Eigen::VectorXd start = x0;
    double best_at_start = std::numeric_limits<double>::infinity();
    double radius = inf;
    int failures_seen = 0;
    for (int attempt = 0; attempt < 50 && !t.stop; ++attempt) {
      const bool new_failure = t.total_failures > failures_seen;
      failures_seen = t.total_failures;
      if (new_failure && t.have_best && t.failed_x.size() == static_cast<Eigen::Index>(n)) {
        const double d = (t.failed_x - t.result.theta).lpNorm<Eigen::Infinity>();
        radius = std::min(radius, 0.5 * d);
      } else if (attempt > 0 && std::isfinite(radius)) {
        radius *= 2.0;
      }
      if (t.have_best && !(t.result.loss < best_at_start) && !new_failure) {
        // No progress since the last restart: try once more without the loss scaling, then give up.
        if (t.scale == 1.0) break;
        t.scale = 1.0;
        opt.set_stopval(options.loss_tolerance);
      }
      if (std::isfinite(radius)) {
        for (int k = 0; k < static_cast<int>(n); ++k) {
          lb[k] = std::max(lower[k], start[k] - radius);
          ub[k] = std::min(upper[k], start[k] + radius);
        }
        opt.set_lower_bounds(lb);
        opt.set_upper_bounds(ub);
      }
      best_at_start = t.have_best ? t.result.loss : best_at_start;
      const int left = options.max_evaluations - t.result.evaluations;
      if (left < 1) break;
      opt.set_maxeval(left);
      std::vector<double> x(start.data(), start.data() + n);
      double fx = 0;
      bool retry = false;
      try {
        const nlopt::result r = opt.optimize(x, fx);
        switch (r) {
          case nlopt::STOPVAL_REACHED:
            t.result.converged = true;
            t.result.message = "loss below loss_tolerance";
            break;
          case nlopt::FTOL_REACHED:
          case nlopt::XTOL_REACHED:
            t.result.converged = true;
            t.result.message = "relative loss change below relative_tolerance";
            break;
          case nlopt::MAXEVAL_REACHED:
            t.result.message = "evaluation limit (max_evaluations) reached";
            break;
          default:
            t.result.converged = true;
            t.result.message = "L-BFGS converged (NLopt code " + std::to_string(int(r)) + ")";
        }
      } catch (const nlopt::forced_stop&) {
      } catch (const nlopt::roundoff_limited&) {
        t.result.converged = true;
        t.result.message = "L-BFGS stopped at round-off: no further progress possible";
      } catch (const std::runtime_error& e) {
        if (!t.have_best) throw;
        retry = true;
        t.result.message = std::string("L-BFGS line search failed (") + e.what() + "), restarted from the best design";
      }
      if (!retry) break;
      start = t.result.theta;
    }
  } else {
    throw TopoError("optimizer '" + options.method + "'", "unknown", "use lbfgs or adam");
  }
  OptimizerResult& r = t.result;
  if (r.theta.size() == 0) {  // cancelled (or stopped) before any design was evaluated: the start
    r.theta = x0;
    r.loss = std::numeric_limits<double>::infinity();
  }
  if (r.cancelled)
    r.message = "cancelled: returning the best design so far";
  else if (!t.error.empty())
    r.message = "stopped early: " + t.error + " (returning the best design so far)";
  else if (t.stalled && r.loss > options.loss_tolerance) {
    r.converged = true;
    r.message = "stalled: the best loss fell by less than " + std::to_string(100 * options.stall_relative) +
                " % in the last " + std::to_string(options.stall_evaluations) + " evaluations (stall_evaluations)";
  } else if (r.loss <= options.loss_tolerance) {
    r.converged = true;
    r.message = "loss below loss_tolerance";
  } else if (r.message.empty() && !r.history.empty() && r.history.back().gradient_norm <= options.gradient_tolerance &&
             r.history.back().loss <= r.loss) {
    r.converged = true;
    r.message = "gradient norm below gradient_tolerance";
  } else if (r.message.empty())
    r.message = options.method == "adam" ? "evaluation limit (max_evaluations) reached" : "stopped";
  return r;
}

}  // namespace topo_gaussian::inference
