// The rig performs the next experiment (issue 47 §3): the ROS-free loop that closes the
// identifiability analysis's suggestion. Given the object's particle cloud, its first experiments
// (a TaskConfig, one experiment or several, with their observed targets) and a performer (a callback
// that carries out an ExperimentSuggestion and returns the performed experiment's TaskConfig with its
// observed targets set), repeatedly:
//   1. infer the interior from all experiments so far (inference::runInference on the joint config,
//      one interior, loss Σ_e w_e L_e);
//   2. read what they determine (IdentifiabilityAnalysis: determined / free moments, the suggestion)
//      and how much of the volume is uncertain (uncertainVolumeFraction of the result's
//      solid_confidence: the region analysis, with the design spread when restarts > 0);
//   3. decideNextStep (below): stop, or perform the suggestion and add it as one more experiment.
// The stopping rule, in this order:
//   goal reached    all ten moments determined AND uncertain fraction ≤ max_uncertain_fraction;
//   max experiments the object has max_experiments experiments (default 5);
//   not analysed    the analysis is not available (no experiment reports moment observations);
//   no suggestion   no candidate experiment improves what is determined;
//   no gain         the suggestion's score gain < min_score_gain and it fixes no further moment or
//                   combination of the moments;
//   otherwise       continue: perform the suggestion.
// An uncertain fraction that is not known (NaN: the region analysis did not run) is not small.
// suggestionOverrides turns a suggestion into what a ROS goal carries: the task name and the
// "KEY=VALUE" parameters that differ from the task's defaults (configFromOverrides is its inverse).
// TwinPerformer performs a suggestion on a RigTwin: the twin's true interior evaluates the suggested
// experiment on the twin's own cloud and its features, with a stated measurement noise, become the
// targets.
#pragma once

#include <functional>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "topo_gaussian/inference/identifiability.h"
#include "topo_gaussian/inference/pipeline.h"
#include "topo_gaussian/inference/task_config.h"
#include "topo_gaussian/physics/volume_cloud.h"
#include "topo_gaussian/workflow/rig_twin.h"

namespace topo_gaussian::workflow {

struct ExperimentLoopOptions {
  int max_experiments = 5;  ///< experiments of the object in all (the first ones included)
  /// "small": the goal needs at most this share of the volume uncertain. A cavity of 13 % of the volume
  /// (the tumbler's default) recovered with IoU 0.85 has about 2 % of the volume on the wrong side.
  double max_uncertain_fraction = 0.02;
  double min_score_gain = 1e-6;  ///< a suggestion gaining less (and fixing nothing new) ends the loop
  /// Set: after each inference the analysis is made again with these options (the candidates a lab
  /// offers: swing_candidates = false without an axle, max_dynamic_candidates = 0 to never rock it);
  /// unset: runInference's own analysis (the defaults).
  std::optional<inference::IdentifiabilityOptions> identifiability;
};

/// What decideNextStep concludes.
enum class LoopVerdict { Continue, GoalReached, MaxExperiments, NotAnalysed, NoSuggestion, NoGain };

struct LoopDecision {
  LoopVerdict verdict = LoopVerdict::Continue;
  std::string reason;  ///< words for a person ("all ten moments determined and 1.2 % of the volume uncertain")
  bool continues() const { return verdict == LoopVerdict::Continue; }
};

/// "continue", "goal_reached", "max_experiments", "not_analysed", "no_suggestion", "no_gain".
std::string verdictName(LoopVerdict verdict);

/// What the rule reads of an analysis, in the plain form an action result carries (a front end that has
/// only the result's moment names and suggestion fills it itself).
struct LoopEvidence {
  bool analysed = false;              ///< IdentifiabilityAnalysis::available
  std::vector<std::string> free;      ///< names of the moments not determined (all ten when not analysed)
  bool has_suggestion = false;
  std::string suggestion;             ///< its sentence
  double score_gain = 0.0;            ///< ExperimentSuggestion::score_gain
  bool fixes_more = false;            ///< it determines a further moment or combination of the moments
  std::string note;                   ///< why not analysed (the analysis's first note)
};
LoopEvidence loopEvidence(const inference::IdentifiabilityAnalysis& analysis);

/// The stopping rule (header comment) on an inference's analysis, its uncertain volume fraction
/// (NaN: unknown) and the object's experiment count. Throws TopoError for max_experiments < 1 or a
/// negative max_uncertain_fraction.
LoopDecision decideNextStep(const inference::IdentifiabilityAnalysis& analysis, double uncertain_fraction,
                            int experiments_so_far, const ExperimentLoopOptions& options = {});
LoopDecision decideNextStep(const LoopEvidence& evidence, double uncertain_fraction, int experiments_so_far,
                            const ExperimentLoopOptions& options = {});

/// The share of the volume an inference leaves uncertain: uncertainVolumeFraction of its solid_confidence
/// (cloud.V), NaN when it has none (the region analysis did not run).
double uncertainFraction(const inference::InferenceResult& result, const VolumeCloud& cloud);

/// A suggestion in the form a ROS goal carries.
struct SuggestedExperiment {
  std::string kind;                    ///< "hang", "swing", "rock"
  std::string task;                    ///< e.g. "hanging"
  std::vector<std::string> overrides;  ///< "KEY=VALUE" of every parameter that differs from the task's defaults
  std::string sentence;                ///< the suggestion's sentence
};

/// The task and the "KEY=VALUE" overrides of suggestion.config against TaskConfig::defaults(task), in
/// the order of the task's parameters (numbers written so that they read back exactly). A parameter
/// the suggestion leaves unset while the defaults set it cannot be written and is left out.
SuggestedExperiment suggestionOverrides(const inference::ExperimentSuggestion& suggestion);
/// TaskConfig::defaults(task) with the overrides applied: the suggestion's config again. Throws
/// TopoError (TaskConfig's) for an unknown task or key.
inference::TaskConfig configFromOverrides(const SuggestedExperiment& suggested);

/// Carries out a suggestion: the performed experiment's TaskConfig with its observed targets set.
using ExperimentPerformer = std::function<inference::TaskConfig(const inference::ExperimentSuggestion&)>;

/// One inference of the loop and what followed it.
struct ExperimentLoopStep {
  int step = 0;                                  ///< 1, 2, ...
  std::vector<std::string> experiment_names;     ///< the experiments this inference used
  std::string added;                             ///< the experiment added before it ("" for the first step)
  std::string added_sentence;                    ///< the suggestion that experiment performed
  std::vector<std::string> determined, free;     ///< moment names
  int determined_directions = 0;                 ///< combinations of the ten moments determined
  double uncertain_fraction = NAN;               ///< uncertainFraction
  double region_iou_mean = NAN;                  ///< the region analysis's expected IoU (NaN when not run)
  bool has_suggestion = false;
  inference::ExperimentSuggestion suggestion;    ///< the next experiment (when has_suggestion)
  SuggestedExperiment suggested;                 ///< its overrides (when has_suggestion)
  LoopDecision decision;
  double truth_iou = NAN;                        ///< ExperimentLoopCallbacks::truth_iou, NaN without it
  MassProperties mass;                           ///< the recovered design's mass properties
  bool targets_reached = false;
  double inference_s = 0.0, perform_s = 0.0;     ///< this inference; performing the experiment it added
};

struct ExperimentLoopCallbacks {
  /// The IoU of the inferred region against a known truth (benches, tests); optional.
  std::function<double(const inference::InferenceResult&)> truth_iou;
  /// After every step (its record and the inference), e.g. to print a table line; optional.
  std::function<void(const ExperimentLoopStep&, const inference::InferenceResult&)> on_step;
  inference::ProgressCallback progress;  ///< passed to every runInference; false cancels the loop
  StopCheck should_stop;                ///< passed to every runInference
};

struct ExperimentLoopResult {
  std::vector<ExperimentLoopStep> steps;
  inference::TaskConfig experiments;  ///< the joint config of every experiment, targets set
  inference::InferenceResult last;    ///< the last inference
  LoopDecision decision;              ///< why the loop ended (a cancelled inference: NotAnalysed, "cancelled")
  double seconds = 0.0;
};

/// The loop (header comment). `first` holds the first experiments (a single-experiment config becomes
/// the experiment named after its task). A performed experiment is added as "<kind>_<n>" (n: the
/// experiment count after adding it). Throws TopoError for an empty cloud, a `first` without targets
/// the inference refuses, a performer's config that disagrees with the object's shared parameters,
/// and whatever runInference throws; a performer's TopoError ends the loop with that reason
/// (LoopVerdict::NoSuggestion, "the performer could not ...").
ExperimentLoopResult runExperimentLoop(const VolumeCloud& cloud, const inference::TaskConfig& first,
                                       const ExperimentPerformer& performer, const ExperimentLoopOptions& options = {},
                                       const ExperimentLoopCallbacks& callbacks = {});

/// Measurement noise of a performer: each observation × (1 + N(0, relative)) or + N(0, deg), seeded.
struct MeasurementNoise {
  double angle_deg = 0.1;         ///< hanging roll / pitch, rocking max tilt [deg]
  double period_relative = 0.001; ///< rocking and axle-swing periods
  double mass_relative = 0.001;   ///< the scale
  unsigned seed = 1;
};

/// A rocking experiment's measured largest tilt by the rule of inference/motion_targets.h: a value that does
/// not exceed the release tilt (initial_tilt_deg) by 1 % is the release tilt (a doll released at rest always
/// reaches it); others as given.
double measuredMaxTilt(const inference::TaskConfig& config, double tilt_deg);

/// Performs experiments on a RigTwin (its cloud with surface on the true boundary, its true interior):
///   hanging   the rest pose of the true centre of mass below hanging_point (hangingRestPose) as
///             target_roll_deg / target_pitch_deg (+ angle noise); a swing (the config asks for
///             axle_swing_period_s or cross_axle_swing_period_s, or the suggestion's kind is "swing")
///             also both axle periods simulated in that true pose (× period noise); weighed: mass_kg;
///   rocking   (a task with a rocking axis, tumbler) the simulated period_s (× period noise) and
///             max_tilt_deg (+ angle noise, then measuredMaxTilt) of the true interior released as configured.
/// Other tasks are refused (TopoError naming the task).
class TwinPerformer {
 public:
  /// The twin must outlive the performer.
  explicit TwinPerformer(const RigTwin& twin, const MeasurementNoise& noise = {});
  /// The experiment `config` performed on the twin: a copy with its observed targets set.
  inference::TaskConfig perform(const inference::TaskConfig& config, bool weigh = false, bool swing = false);
  inference::TaskConfig operator()(const inference::ExperimentSuggestion& suggestion) {
    return perform(suggestion.config, false, suggestion.kind == "swing");
  }

 private:
  const RigTwin* twin_;
  MeasurementNoise noise_;
  std::mt19937 rng_;
};

/// Per particle of `cloud`, the mean of `values` over the particles of `from` inside its cell (cube of
/// side cloud.spacing), or the nearest one's value when none is: a field moved onto another lattice of
/// the same object (a twin's true indicator onto the inference's cloud).
std::vector<double> transferField(const VolumeCloud& from, const std::vector<double>& values, const VolumeCloud& cloud);

}  // namespace topo_gaussian::workflow
