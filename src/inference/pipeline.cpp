#include "topo_gaussian/inference/pipeline.h"

#include "topo_gaussian/cuda/backend.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/number_text.h"
#include "topo_gaussian/common/stopwatch.h"
#include "topo_gaussian/inference/task_registry.h"

namespace topo_gaussian::inference {

ProblemEvaluation simulateInterior(const TaskConfig& config, const VolumeCloud& cloud,
                                   const std::vector<double>& r_in) {
  InteriorProblem problem(config, cloud);
  std::vector<double> r = r_in.empty() ? std::vector<double>(cloud.size(), 1.0) : r_in;
  if (r.size() != cloud.size())
    throw TopoError("interior",
                    "has " + std::to_string(r.size()) + " values for " + std::to_string(cloud.size()) + " particles",
                    "use the interior written for this volume");
  return problem.evaluateIndicator(r, nullptr);
}

std::string defaultShapeForTask(const std::string& t) {
  const TaskDefinition* task = findTaskDefinition(t);
  return task ? task->default_shape : std::string();
}

std::vector<double> particleStiffness(const TaskConfig& config, const std::vector<double>& r) {
  if (!config.has("youngs_modulus_solid") || !config.has("youngs_modulus_hollow")) return {};
  MaterialInterpolation e;  // the soft tasks' interpolation of the modulus (see soft_task.cpp)
  e.value_r0 = config.number("youngs_modulus_hollow");
  e.value_r1 = config.number("youngs_modulus_solid");
  e.power = config.has("stiffness_power") ? config.number("stiffness_power") : 1.0;
  e.continuous = config.has("continuous_material") && config.boolean("continuous_material");
  e.floor = 1e-6 * e.value_r1;
  std::vector<double> out;
  e.apply(r, &out, nullptr);
  return out;
}

namespace {
/// The designs that fit as well as the best (restarts > 0): res.spread, res.solid_confidence and a
/// sentence in the message. A cancelled run skips it.
void exploreSpread(const TaskConfig& config, const VolumeCloud& cloud, const ProgressCallback& progress,
                   const StopCheck& should_stop, InferenceResult* res, std::ostringstream* message) {
  const int restarts = config.integer("restarts");
  if (restarts <= 0) {
    *message << " Other designs that fit as well were not searched (restarts = 0; set restarts=2 to search): the "
                "interior's confidence comes from the linearised region uncertainty below, where it is analysed.";
    return;
  }
  if (res->cancelled) {
    *message << " The design spread (restarts = " << restarts << ") was skipped: the run was cancelled.";
    return;
  }
  DesignSpreadOptions so;
  so.restarts = restarts;
  so.max_evaluations = std::min(config.integer("max_evaluations"), std::max(1, res->optimizer.evaluations));
  so.should_stop = should_stop;
  so.progress = progress;
  so.first_iteration = res->optimizer.iterations;
  so.optimizer = config.text("optimizer");
  so.learning_rate = config.number("learning_rate");
  res->spread = exploreDesignSpread(config, cloud, res->theta, res->final, so);
  res->solid_confidence = res->spread.confidence;
  if (res->spread.found_better) {  // the best design evaluated is the result, wherever it was found
    const double before = res->final.loss;
    InteriorProblem problem(config, cloud);
    res->theta = res->spread.better_theta;
    res->final = res->spread.better_evaluation;
    problem.indicator(res->theta, &res->r);
    problem.task().density().apply(res->r, &res->density, nullptr);
    *message << " A search from another solid fraction found a design with a lower loss (" << res->final.loss << " < "
             << before << "): it is the result.";
  }
}
/// One statement of how uncertain the interior is: the region analysis's (designs that fit the observations
/// perturbed by their noise), with the design spread's designs from other solid fractions folded in as
/// one share of the volume that changes label; the spread's own sentence when there is no region analysis.
std::string uncertaintyStatement(const DesignSpread& spread, const RegionUncertainty& region,
                                 const std::vector<double>& V, const std::vector<double>& confidence) {
  if (!region.available) return spread.computed ? " " + spread.sentence : std::string();
  std::string out = " " + region.sentence;
  if (spread.computed && spread.accepted > 1 && spread.undetermined_fraction > 0 && confidence.size() == V.size()) {
    // a particle either set of designs disagrees on (solid_confidence below 0.95)
    out += " With the " + std::to_string(spread.accepted) +
           " designs the searches from other solid fractions found fitting as well, " +
           numberText(100.0 * uncertainVolumeFraction(V, confidence), 3) + " % of the volume is uncertain in all.";
  }
  return out;
}

/// What the design spread says about a local minimum, for the message of a run that misses its targets.
std::string localMinimumHint(const DesignSpread& spread, int restarts, bool cancelled) {
  if (!spread.computed && cancelled)
    return " (the searches from other solid fractions were skipped: the run was cancelled)";
  if (!spread.computed || restarts <= 0)
    return " (searches from other solid fractions were not run: set restarts=2 or more to look for a better fit)";
  return " (what the searches from other solid fractions found follows; more restarts, or a start from another "
         "design, may find a better fit)";
}
/// Grey designs: the drawn interior (solid where r ≥ 0.5) against the simulated one (grey r).
void checkBinarised(const TaskConfig& config, const VolumeCloud& cloud, const InteriorProblem& problem,
                    InferenceResult* res, std::ostringstream* message) {
  if (res->cancelled || res->r.size() != cloud.size() || config.boolean("continuous_material")) return;
  double grey = 0;
  std::vector<double> binary(res->r.size());
  for (std::size_t i = 0; i < res->r.size(); ++i) {
    if (res->r[i] > 0.1 && res->r[i] < 0.9) grey += cloud.V[i];
    binary[i] = res->r[i] >= 0.5 ? 1.0 : 0.0;
  }
  res->grey_fraction = grey / cloud.totalVolume();
  if (!(res->grey_fraction > 0.01)) return;
  try {
    res->binarised = problem.evaluateIndicator(binary, nullptr);
    res->has_binarised = true;
  } catch (const SimulationCancelled&) {
    return;
  } catch (const TopoError& e) {
    res->warnings.push_back("the binarised design (solid where r >= 0.5, as drawn) could not be simulated: " +
                            std::string(e.what()));
    return;
  }
  std::ostringstream differ;
  const auto& a = res->final.task.features;
  const auto& b = res->binarised.task.features;
  for (std::size_t k = 0; k < a.size() && k < b.size(); ++k) {
    if (!a[k].has_target) continue;
    const double tol = a[k].tolerance * std::max(std::abs(a[k].target), a[k].scale);
    if (std::abs(b[k].value - a[k].value) > tol)
      differ << (differ.tellp() > 0 ? ", " : "") << a[k].name << " " << b[k].value << " " << a[k].unit << " (result "
             << a[k].value << ", target " << a[k].target << ")";
  }
  if (differ.tellp() == 0) return;
  std::ostringstream w;
  w << numberText(100.0 * res->grey_fraction, 3) << " % of the volume is grey (0.1 < r < 0.9, a density between the "
    << "materials): the drawn interior (solid where r >= 0.5, solid fraction "
    << numberText(res->binarised.solid_fraction, 3) << ") is not the simulated one (solid fraction "
    << numberText(res->final.solid_fraction, 3) << ") and simulates " << differ.str()
    << "; read the result as a density field, or sharpen it (smaller epsilon, weight_smoothness)";
  res->warnings.push_back(w.str());
  *message << " Warning: " << w.str() << ".";
}

}  // namespace

InferenceResult runInference(const TaskConfig& config, const VolumeCloud& cloud, const ProgressCallback& progress,
                             const EvaluationCallback& on_evaluation, const StopCheck& should_stop) {
  const auto t0 = Clock::now();
  InteriorProblem problem(config, cloud);
  problem.requireTargets();
  problem.setShouldStop(should_stop);
  InferenceResult res;
  resolveBackend(parseComputeBackend(config.text("backend"), "task parameter backend"), "task parameter backend",
                 &res.backend);
  res.task = config.task();
  res.representation = problem.representation().name();
  res.geometry = problem.task().geometry();
  const std::string outside = pointOutsideObjectNote(res.geometry, cloud);
  if (!outside.empty()) res.warnings.push_back(outside);
  for (const auto& note : problem.notes()) res.warnings.push_back(note);
  const Eigen::VectorXd theta0 = problem.initialParameters(&res.start);
  Eigen::VectorXd lo, hi, g;
  problem.bounds(&lo, &hi);
  const auto te = Clock::now();
  try {
    problem.evaluate(theta0, &g, &res.initial);
  } catch (const SimulationCancelled&) {  // before any design was evaluated: the start design
    res.cancelled = true;
    res.theta = theta0;
    res.optimizer.theta = theta0;
    res.optimizer.cancelled = true;
    res.optimizer.message = "cancelled: returning the best design so far";
    problem.indicator(res.theta, &res.r);
    problem.task().density().apply(res.r, &res.density, nullptr);
    res.setup_s = secondsSince(t0);
    res.message = "task " + res.task + " (" + res.representation +
                  "): cancelled during the first simulation, before any design was evaluated; the start design "
                  "is returned unevaluated.";
    return res;
  }
  res.evaluation_s = secondsSince(te);
  res.setup_s = secondsSince(t0) - res.evaluation_s;
  OptimizerOptions oo;
  oo.should_stop = should_stop;
  oo.method = config.text("optimizer");
  oo.max_evaluations = config.integer("max_evaluations");
  oo.learning_rate = config.number("learning_rate");
  oo.loss_tolerance = config.number("loss_tolerance");
  oo.relative_tolerance = config.number("relative_tolerance");
  oo.gradient_tolerance = config.number("gradient_tolerance");
  oo.stall_evaluations = config.integer("stall_evaluations");
  const auto to = Clock::now();
  // The best evaluation's details are kept, so a cancelled run need not simulate the best design again.
  ProblemEvaluation best = res.initial;
  double best_loss = res.initial.loss;
  Eigen::VectorXd best_theta = theta0;
  bool first_call = true, reused_start = false;
  const auto objective = [&](const Eigen::VectorXd& th, Eigen::VectorXd* gr) {
    ProblemEvaluation details;
    double loss;
    if (first_call && th == theta0) {  // the start design, evaluated with its gradient above: not again
      loss = res.initial.loss;
      if (gr) *gr = g;
      details = res.initial;
      reused_start = true;
    } else {
      loss = problem.evaluate(th, gr, &details);
    }
    first_call = false;
    if (on_evaluation) on_evaluation(details);
    if (loss < best_loss) {
      best_loss = loss;
      best_theta = th;
      best = std::move(details);
    }
    return loss;
  };
  res.optimizer = minimize(objective, theta0, lo, hi, oo, progress);
  res.optimize_s = secondsSince(to);
  // per simulated evaluation: the start design's, handed over from above, took no time here
  const int simulated = res.optimizer.iterations - (reused_start ? 1 : 0);
  if (simulated > 0) res.evaluation_s = res.optimize_s / simulated;
  res.cancelled = res.optimizer.cancelled;
  if (res.cancelled && !(res.optimizer.loss < best_loss)) {  // the start design was the best one
    res.optimizer.theta = best_theta;
    res.optimizer.loss = best_loss;
  }
  res.theta = res.optimizer.theta;
  if (res.cancelled) {
    res.final = res.theta == best_theta ? best : res.initial;
  } else {
    try {
      problem.evaluate(res.theta, nullptr, &res.final);
    } catch (const SimulationCancelled&) {  // cancelled while re-simulating the best design
      res.cancelled = res.optimizer.cancelled = true;
      res.final = res.theta == best_theta ? best : res.initial;
    }
  }
  problem.indicator(res.theta, &res.r);
  problem.task().density().apply(res.r, &res.density, nullptr);

  // The designs that fit as well (a restart that ends lower becomes the result), before the verdict.
  std::ostringstream spread_message;
  for (const auto& note : problem.notes())  // notes the evaluations added (e.g. a GPU fallback)
    if (std::find(res.warnings.begin(), res.warnings.end(), note) == res.warnings.end()) res.warnings.push_back(note);
  exploreSpread(config, cloud, progress, should_stop, &res, &spread_message);

  // How close are the features to their targets?
  res.targets_reached = true;
  std::ostringstream msg;
  for (const auto& f : res.final.task.features) {
    if (!f.has_target || f.reached()) continue;
    res.targets_reached = false;
    msg << "target " << f.name << " = " << f.target << " " << f.unit << " not reached: nearest value found " << f.value
        << " " << f.unit << ". ";
  }
  res.converged = res.optimizer.converged && res.targets_reached;
  std::ostringstream head;
  head << "task " << res.task << " (" << res.representation << "): loss " << res.initial.loss << " -> "
       << res.final.loss << " in " << res.optimizer.iterations << " evaluations; " << res.optimizer.message << ". ";
  if (res.targets_reached) {
    head << "All targets reached.";
  } else if (res.optimizer.converged && res.final.experiments.size() > 1) {
    // A gradient search that stops has found a local minimum, not proved that nothing fits better.
    head << msg.str() << "The optimiser stopped at a minimum that misses them: either the observations are "
         << "noisier than their tolerances (a tracker, scale or timing off by more than stated: then no interior "
         << "meets them all), or no single interior of this representation fits all " << res.final.experiments.size()
         << " experiments together (they may contradict each other: another object, material, hanging point or "
         << "release; or they need more material contrast), or the search is caught in a local minimum"
         << localMinimumHint(res.spread, config.integer("restarts"), res.cancelled)
         << "; the per-experiment losses below show which one disagrees (lower its "
         << "weight or check its targets).";
  } else if (res.optimizer.converged) {
    head << msg.str() << "The optimiser stopped at a minimum that misses the target: either the observation is "
         << "noisier than its tolerance, or no interior of this representation within the material bounds reaches "
         << "it (check the target, the hanging/support point, or allow more material contrast), or one does and the "
         << "search is caught in a local minimum"
         << localMinimumHint(res.spread, config.integer("restarts"), res.cancelled) << ".";
  } else {
    head << msg.str() << "Not converged: raise max_evaluations or try another optimizer/representation.";
  }
  if (config.hasExperiments()) {
    head << " Per experiment (weight, loss):";
    for (const auto& xe : res.final.experiments)
      head << " " << xe.name << " (" << xe.weight << ", " << xe.eval.loss << ")";
    head << ".";
  }
  if (!res.targets_reached && !outside.empty())
    head << " The target may be unreachable because the " << res.geometry.point_name << " lies outside the object ("
         << outside << ").";
  head << spread_message.str();
  checkBinarised(config, cloud, problem, &res, &head);
  res.message = head.str();
  // What the experiments determine (rigid observations), at the final design: no optimiser work.
  if (res.cancelled) {
    res.identifiability.notes.push_back("not analysed: the run was cancelled");
  } else {
    try {
      res.identifiability = analyseIdentifiability(problem, res.theta, res.final);
      if (!res.targets_reached && res.identifiability.available && res.identifiability.noise_scale > 1.0)
        res.message += " The misfit is what observation noise of " +
                       numberText(res.identifiability.noise_scale, 3) +
                       " x the stated tolerances would give: if the observations are that noisy, this design fits "
                       "them as well as any, and its moments are known that much less well.";
      if (res.identifiability.available) {
        const MomentJacobian J_si =
            res.identifiability.J * res.identifiability.natural_units.cwiseInverse().asDiagonal();
        res.region = analyseRegionUncertainty(problem, res.theta, res.final, J_si);
        if (res.region.available) {
          if (res.solid_confidence.size() != res.region.confidence.size())
            res.solid_confidence = res.region.confidence;
          else
            for (std::size_t i = 0; i < res.solid_confidence.size(); ++i)
              res.solid_confidence[i] = std::min(res.solid_confidence[i], res.region.confidence[i]);
        } else {
          res.identifiability.notes.push_back("region uncertainty: " + res.region.note);
        }
      }
    } catch (const TopoError& e) {
      res.identifiability.notes.push_back(std::string("not analysed: ") + e.what());
    } catch (const SimulationCancelled&) {
      res.identifiability.notes.push_back("not analysed: cancelled while simulating a candidate experiment");
    }
  }
  res.message += uncertaintyStatement(res.spread, res.region, cloud.V, res.solid_confidence);
  // No mass moments observed (the soft tasks): what is known of the region is the count of observed numbers
  // against the design's parameters, and the message says it; "All targets reached" alone reads as the
  // interior found.
  if (!res.cancelled && !res.identifiability.available && !res.region.available &&
      !res.identifiability.summary.empty())
    res.message += " " + res.identifiability.summary;
  return res;
}

}  // namespace topo_gaussian::inference
