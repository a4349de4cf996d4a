// Design spread: how sure is the interior? (paper §7 "multiple videos" ablation: one
// observation rarely determines an interior). After the main optimisation, further optimisations
// look for other designs that fit the observations as well as the best one, each pulled towards
// another solid fraction f* by the material-volume regulariser of InteriorProblem,
//     L_pull(θ) = L_task(θ) + w_pull (f(θ) − f*)²,   f = Σ V_i r_i / Σ V_i,
// then polished on the unpulled loss from where the pull left it. A design is ACCEPTED when it fits
// as well as the best (acceptedByFit): every target reached when the best reached them all,
// otherwise a task loss within kSpreadLossFactor × the best's, or every targeted feature within its
// tolerance of the best design's value (indistinguishable at the tolerance that calls it matched). From the accepted
// designs (the best included), per particle i with solid_i = r_i ≥ 0.5:
//     p_solid_i    = (designs in which i is solid) / (accepted designs)
//     confidence_i = (designs whose label of i is the best design's label) / (accepted designs)
// (1 = every design that fits agrees; ≤ 0.5 = at least as many designs that fit disagree), and the
// range (min/max) of solid fraction, mass, centre of mass and inertia over them. This samples the
// designs that fit; it cannot prove that no other fits (a few restarts, local optimisers).
// Deterministic: the restarts' starts come from a seeded generator.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "topo_gaussian/inference/interior_problem.h"
#include "topo_gaussian/inference/optimizer.h"
#include "topo_gaussian/inference/task_config.h"
#include "topo_gaussian/physics/volume_cloud.h"

namespace topo_gaussian::inference {

/// Without reached targets, a design is accepted when its task loss ≤ this × the best's (+1e-15).
constexpr double kSpreadLossFactor = 1.01;
/// Fewest evaluations of a restart's pull and of its polish.
constexpr int kSpreadMinStageEvaluations = 10;
/// Weight w_pull of the pull towards another solid fraction (the task losses are dimensionless).
constexpr double kSpreadPullWeight = 0.1;

struct DesignSpreadOptions {
  int restarts = 0;  ///< further designs to look for (0: only the best, nothing explored)
  /// Evaluations of one restart, split between its pull (half) and its polish (the rest), at least
  /// kSpreadMinStageEvaluations each. runInference gives the main run's count (what one fit costs), so
  /// the search costs about restarts × the main run.
  int max_evaluations = 200;
  unsigned seed = 1;                ///< of the starts' perturbations
  StopCheck should_stop;            ///< polled like runInference's; true ends the search (partial spread)
  ProgressCallback progress;        ///< every iteration of every restart; false cancels
  int first_iteration = 0;          ///< progress numbers iterations after this (the main run's count)
  std::string optimizer = "lbfgs";  ///< the main run's optimiser settings
  double learning_rate = 0.02;
};

/// One design of the search (the best is the first).
struct SpreadDesign {
  double target_fraction = -1;  ///< f* it was pulled to (−1: the best design, not pulled)
  double solid_fraction = 0, task_loss = 0;
  MassProperties mass;
  bool accepted = false;
  int evaluations = 0;
  std::string note;  ///< why it ended early, if it did
};

struct DesignSpread {
  bool computed = false;  ///< false: not run (restarts = 0, or the main run was cancelled)
  bool cancelled = false;
  int restarts = 0;           ///< asked for
  int tried = 0;              ///< restarts finished
  int accepted = 0;           ///< accepted designs, the best included
  bool best_reached = false;  ///< the best design reached every target (acceptance: reach them too)
  std::vector<SpreadDesign> designs;
  std::vector<double> p_solid, confidence;  ///< per particle (empty when not computed)
  double undetermined_fraction = 0;         ///< Σ V_i over confidence_i < 1, / Σ V_i
  double solid_fraction_min = 0, solid_fraction_max = 0, mass_min_kg = 0, mass_max_kg = 0;
  Eigen::Vector3d com_min_m = Eigen::Vector3d::Zero(), com_max_m = Eigen::Vector3d::Zero();
  /// Diagonal of the inertia about the centre of mass, body axes [kg m²].
  Eigen::Vector3d inertia_min = Eigen::Vector3d::Zero(), inertia_max = Eigen::Vector3d::Zero();
  /// A restart ended at a lower task loss than the best design it started from: that design is the
  /// reference instead (acceptance and confidence are judged against it), and runInference returns it.
  bool found_better = false;
  Eigen::VectorXd better_theta;
  ProblemEvaluation better_evaluation;
  std::string rule;      ///< the acceptance rule, in words
  std::string sentence;  ///< for a person: how much of the volume is undetermined
  double seconds = 0;
};

/// True when `candidate` fits as well as `best` (the rule at the top). best_reached: the best design
/// reached every target.
bool acceptedByFit(const ProblemEvaluation& candidate, const ProblemEvaluation& best, bool best_reached);

/// True when every feature with a target is reached.
bool allTargetsReached(const ProblemEvaluation& evaluation);

/// Runs the search around the best design θ_best (with its evaluation). Throws nothing for a restart
/// that fails (its note says why); a cancel returns the spread of the designs found so far.
/// accepted_indicators (optional): r of every accepted design, the best first.
DesignSpread exploreDesignSpread(const TaskConfig& config, const VolumeCloud& cloud, const Eigen::VectorXd& best_theta,
                                 const ProblemEvaluation& best, const DesignSpreadOptions& options,
                                 std::vector<std::vector<double>>* accepted_indicators = nullptr);

/// The per-particle part alone: p_solid, confidence and the undetermined volume fraction of the
/// accepted designs' indicators (designs[0] is the best). Throws TopoError for no design or sizes
/// that differ from the cloud's.
void summarizeDesigns(const std::vector<std::vector<double>>& designs, const VolumeCloud& cloud, DesignSpread* spread);

/// "12 % of the volume is undetermined: 5 designs with solid fraction 0.83–1.00 fit the targets equally well ...".
std::string spreadSentence(const DesignSpread& spread);

}  // namespace topo_gaussian::inference
