#include "topo_gaussian/inference/design_spread.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <sstream>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/number_text.h"
#include "topo_gaussian/common/stopwatch.h"

namespace topo_gaussian::inference {

bool allTargetsReached(const ProblemEvaluation& ev) {
  for (const auto& f : ev.task.features)
    if (f.has_target && !f.reached()) return false;
  return true;
}

/// Every targeted feature of the candidate within its tolerance of the best design's value: the two
/// are indistinguishable at the tolerance that calls a feature matched (Feature::reached).
bool matchesBestWithinTolerance(const ProblemEvaluation& candidate, const ProblemEvaluation& best) {
  const auto& fb = best.task.features;
  const auto& fc = candidate.task.features;
  if (fb.size() != fc.size()) return false;
  bool any = false;
  for (std::size_t k = 0; k < fb.size(); ++k) {
    if (!fb[k].has_target) continue;
    any = true;
    const double tol = fb[k].tolerance * std::max(std::abs(fb[k].target), fb[k].scale);
    if (!(std::abs(fc[k].value - fb[k].value) <= tol)) return false;
  }
  return any;
}

bool acceptedByFit(const ProblemEvaluation& candidate, const ProblemEvaluation& best, bool best_reached) {
  if (!std::isfinite(candidate.task_loss)) return false;
  if (best_reached) return allTargetsReached(candidate);
  // The best leaves a residual (model error, or experiments that disagree): a design fits as well
  // when its loss is as low, or when its features cannot be told from the best's at the tolerance.
  return candidate.task_loss <= kSpreadLossFactor * best.task_loss + 1e-15 ||
         matchesBestWithinTolerance(candidate, best);
}

void summarizeDesigns(const std::vector<std::vector<double>>& designs, const VolumeCloud& cloud, DesignSpread* spread) {
  if (designs.empty()) throw TopoError("design spread", "has no design", "give at least the best design's indicator");
  const std::size_t n = cloud.size();
  for (const auto& r : designs)
    if (r.size() != n)
      throw TopoError("design spread",
                      "a design has " + std::to_string(r.size()) + " values for " + std::to_string(n) + " particles",
                      "give one indicator value per particle of the volume");
  spread->p_solid.assign(n, 0.0);
  spread->confidence.assign(n, 0.0);
  const double count = double(designs.size());
  double undetermined = 0, total = 0;
  for (std::size_t i = 0; i < n; ++i) {
    int solid = 0, agree = 0;
    const bool best_solid = designs.front()[i] >= 0.5;
    for (const auto& r : designs) {
      const bool s = r[i] >= 0.5;
      solid += s ? 1 : 0;
      agree += s == best_solid ? 1 : 0;
    }
    spread->p_solid[i] = solid / count;
    spread->confidence[i] = agree / count;
    total += cloud.V[i];
    if (agree < int(designs.size())) undetermined += cloud.V[i];
  }
  spread->undetermined_fraction = total > 0 ? undetermined / total : 0.0;
}

std::string spreadSentence(const DesignSpread& s) {
  std::ostringstream o;
  const auto range = [](double a, double b, int digits) {
    return numberText(a, digits) +
           (std::abs(b - a) > 1e-12 * std::max(1.0, std::abs(a)) ? "-" + numberText(b, digits) : std::string());
  };
  const int others = s.tried;
  if (!s.computed) return "The design spread was not explored.";
  if (s.accepted <= 1 && !s.best_reached) {
    // The best misses its targets: that no other design fits as well says nothing about how well fitting
    // observations would determine the interior.
    o << "No other design found fits the observations as well as the best (" << others << " of " << s.restarts
      << " searches from other solid fractions finished); the best misses its targets, so this does not show that "
         "the observations determine the interior.";
  } else if (s.accepted <= 1) {
    // Searches that end elsewhere without fitting are no evidence that nothing else fits (two rocking
    // features leave most of a quadric's ten parameters free): no claim either way.
    o << "No other design found fits the observations as well as the best (" << others << " of " << s.restarts
      << " searches from other solid fractions finished); that no search found a second interior does not show "
         "that there is none.";
  } else if (s.undetermined_fraction <= 0) {
    o << s.accepted << " designs fit the observations equally well (solid fraction "
      << range(s.solid_fraction_min, s.solid_fraction_max, 3)
      << ") and agree on whether every particle is solid or hollow.";
  } else {
    o << numberText(100.0 * s.undetermined_fraction, 3) << " % of the volume is undetermined: " << s.accepted
      << " designs with solid fraction " << range(s.solid_fraction_min, s.solid_fraction_max, 3) << " (mass "
      << range(s.mass_min_kg, s.mass_max_kg, 3)
      << " kg) fit the observations as well as the best design; more experiments (another "
      << "hanging point, rocking about another axis) would tell them apart.";
  }
  if (s.cancelled) o << " (Cancelled: " << s.tried << " of " << s.restarts << " searches ran.)";
  return o.str();
}

namespace {

/// The solid fractions the restarts pull to: spread over the room below and above the best's, in
/// proportion to that room, interleaved (below, above, below, ...) so that a cancelled search has
/// looked both ways.
std::vector<double> pullFractions(double best, double floor, int restarts) {
  const double below_room = std::max(0.0, best - floor), above_room = std::max(0.0, 1.0 - best);
  int n_below = int(std::lround(restarts * below_room / std::max(1e-12, below_room + above_room)));
  // Both ways when there is room (5 % of the volume) on both sides.
  if (restarts >= 2 && above_room > 0.05) n_below = std::min(n_below, restarts - 1);
  if (restarts >= 2 && below_room > 0.05) n_below = std::max(n_below, 1);
  const int n_above = restarts - n_below;
  std::vector<double> below, above, out;
  for (int j = 1; j <= n_below; ++j) below.push_back(best - below_room * j / (n_below + 1.0));
  for (int j = 1; j <= n_above; ++j) above.push_back(best + above_room * j / (n_above + 1.0));
  for (std::size_t k = 0; k < std::max(below.size(), above.size()); ++k) {
    if (k < below.size()) out.push_back(below[k]);
    if (k < above.size()) out.push_back(above[k]);
  }
  return out;
}

struct StageOutcome {
  Eigen::VectorXd theta;
  int evaluations = 0;
  bool cancelled = false;
  std::string message;
};

}  // namespace

DesignSpread exploreDesignSpread(const TaskConfig& config, const VolumeCloud& cloud, const Eigen::VectorXd& best_theta,
                                 const ProblemEvaluation& best, const DesignSpreadOptions& o,
                                 std::vector<std::vector<double>>* accepted_indicators) {
  const auto t0 = Clock::now();
  DesignSpread s;
  s.computed = true;
  s.restarts = std::max(0, o.restarts);
  const bool best_reached = allTargetsReached(best);
  s.best_reached = best_reached;
  s.rule = best_reached ? "every target reached (as by the best design)"
                        : "task loss <= " + numberText(kSpreadLossFactor) +
                              " x the best design's, or every targeted feature within its tolerance of the best "
                              "design's (the best reached not every target)";
  InteriorProblem problem(config, cloud);
  problem.setShouldStop(o.should_stop);
  Eigen::VectorXd lo, hi;
  problem.bounds(&lo, &hi);

  std::vector<std::vector<double>> accepted_r(1);
  problem.indicator(best_theta, &accepted_r.front());
  // Every evaluated design (the best first): θ and evaluation, to judge them again should a restart
  // find a lower loss than the best.
  std::vector<Eigen::VectorXd> thetas{best_theta};
  std::vector<ProblemEvaluation> evaluations{best};
  std::vector<int> design_of{0};  ///< index in s.designs
  SpreadDesign first;
  first.solid_fraction = best.solid_fraction;
  first.task_loss = best.task_loss;
  first.mass = best.task.mass;
  first.accepted = true;
  s.designs.push_back(first);

  std::mt19937 rng(o.seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  int iteration = o.first_iteration;
  const int pull_budget = std::max(kSpreadMinStageEvaluations, o.max_evaluations / 2);
  const int polish_budget = std::max(kSpreadMinStageEvaluations, o.max_evaluations - o.max_evaluations / 2);
  const auto stage = [&](const InteriorProblem& p, const Eigen::VectorXd& start, int budget) {
    OptimizerOptions oo;
    oo.method = o.optimizer;
    oo.learning_rate = o.learning_rate;
    oo.max_evaluations = budget;
    oo.should_stop = o.should_stop;
    bool stopped = false;
    const OptimizerResult r =
        minimize([&](const Eigen::VectorXd& th, Eigen::VectorXd* g) { return p.evaluate(th, g); }, start, lo, hi, oo,
                 [&](const IterationInfo& info) {
                   IterationInfo shifted = info;
                   shifted.iteration = ++iteration;
                   if (o.progress && !o.progress(shifted)) stopped = true;
                   return !stopped;
                 });
    return StageOutcome{r.theta, r.evaluations, r.cancelled || stopped, r.message};
  };

  // The pinned shell is solid in every design: no pull below its volume fraction.
  double pinned = 0;
  const auto& mask = problem.indicatorOptions().pinned;
  for (std::size_t i = 0; i < mask.size(); ++i) pinned += mask[i] ? cloud.V[i] : 0.0;
  const double floor = pinned / cloud.totalVolume();
  for (const double f_pull : pullFractions(best.solid_fraction, floor, s.restarts)) {
    SpreadDesign d;
    d.target_fraction = f_pull;
    try {
      TaskConfig pulled = config;
      pulled.setNumber("weight_volume", kSpreadPullWeight);
      pulled.setNumber("target_solid_fraction", std::clamp(f_pull, 0.0, 1.0));
      InteriorProblem pull_problem(pulled, cloud);
      pull_problem.setShouldStop(o.should_stop);
      // A start beside the best design (seeded), so that restarts aimed alike still differ.
      // (the unbounded parameters' range once: recomputed per parameter it was quadratic, 2.5e12 operations
      // for the 1.6M-parameter neural network)
      Eigen::VectorXd start = best_theta;
      const double unbounded_range =
          2.0 * std::max(1.0, best_theta.size() > 0 ? best_theta.cwiseAbs().maxCoeff() : 0.0);
      for (Eigen::Index k = 0; k < start.size(); ++k) {
        const double range = std::isfinite(hi[k] - lo[k]) ? hi[k] - lo[k] : unbounded_range;
        start[k] = std::clamp(start[k] + 0.05 * range * normal(rng), lo[k], hi[k]);
      }
      const StageOutcome a = stage(pull_problem, start, pull_budget);
      d.evaluations += a.evaluations;
      if (a.cancelled) {
        s.cancelled = true;
        break;
      }
      const StageOutcome b = stage(problem, a.theta, polish_budget);
      d.evaluations += b.evaluations;
      if (b.cancelled) {
        s.cancelled = true;
        break;
      }
      ProblemEvaluation ev;
      problem.evaluate(b.theta, nullptr, &ev);
      d.solid_fraction = ev.solid_fraction;
      d.task_loss = ev.task_loss;
      d.mass = ev.task.mass;
      d.accepted = acceptedByFit(ev, best, best_reached);
      if (!d.accepted) d.note = "the polish ended: " + b.message;
      if (d.accepted) {
        accepted_r.emplace_back();
        problem.indicator(b.theta, &accepted_r.back());
      }
      thetas.push_back(b.theta);
      evaluations.push_back(ev);
      design_of.push_back(int(s.designs.size()));
    } catch (const SimulationCancelled&) {
      s.cancelled = true;
      break;
    } catch (const std::exception& e) {  // a diverging trial design: this restart only
      d.note = e.what();
    }
    ++s.tried;
    s.designs.push_back(d);
  }

  // A restart that ends lower than the best: it becomes the reference, and every design is judged again.
  std::size_t lowest = 0;
  for (std::size_t k = 1; k < evaluations.size(); ++k)
    if (evaluations[k].task_loss < evaluations[lowest].task_loss) lowest = k;
  if (lowest != 0 && evaluations[lowest].task_loss < best.task_loss * (1.0 - 1e-9)) {
    s.found_better = true;
    s.better_theta = thetas[lowest];
    s.better_evaluation = evaluations[lowest];
    const ProblemEvaluation& ref = evaluations[lowest];
    const bool ref_reached = allTargetsReached(ref);
    s.best_reached = ref_reached;
    accepted_r.assign(1, {});
    problem.indicator(thetas[lowest], &accepted_r.front());
    for (std::size_t k = 0; k < evaluations.size(); ++k) {
      SpreadDesign& d = s.designs[design_of[k]];
      d.accepted = k == lowest || acceptedByFit(evaluations[k], ref, ref_reached);
      if (d.accepted && k != lowest) {
        accepted_r.emplace_back();
        problem.indicator(thetas[k], &accepted_r.back());
      }
    }
    s.rule += "; judged against the lowest-loss design a restart found (it is the result)";
  }
  summarizeDesigns(accepted_r, cloud, &s);
  s.accepted = int(accepted_r.size());
  bool first_accepted = true;
  for (const SpreadDesign& d : s.designs) {
    if (!d.accepted) continue;
    const Eigen::Vector3d diag = d.mass.inertia.diagonal();
    if (first_accepted) {
      s.solid_fraction_min = s.solid_fraction_max = d.solid_fraction;
      s.mass_min_kg = s.mass_max_kg = d.mass.mass;
      s.com_min_m = s.com_max_m = d.mass.com;
      s.inertia_min = s.inertia_max = diag;
      first_accepted = false;
      continue;
    }
    s.solid_fraction_min = std::min(s.solid_fraction_min, d.solid_fraction);
    s.solid_fraction_max = std::max(s.solid_fraction_max, d.solid_fraction);
    s.mass_min_kg = std::min(s.mass_min_kg, d.mass.mass);
    s.mass_max_kg = std::max(s.mass_max_kg, d.mass.mass);
    s.com_min_m = s.com_min_m.cwiseMin(d.mass.com);
    s.com_max_m = s.com_max_m.cwiseMax(d.mass.com);
    s.inertia_min = s.inertia_min.cwiseMin(diag);
    s.inertia_max = s.inertia_max.cwiseMax(diag);
  }
  s.sentence = spreadSentence(s);
  if (accepted_indicators) *accepted_indicators = std::move(accepted_r);
  s.seconds = secondsSince(t0);
  return s;
}

}  // namespace topo_gaussian::inference
