// Pipeline: one inference (task + volume → optimised interior, paper §5–7), plus the forward
// "simulate a given interior" used by `topo simulate`, the node's ~simulate and the tests. No files:
// the run folder around an inference is workflow/inference_run.h, the report inference/report.h.
#pragma once

#include <atomic>
#include <functional>
#include <string>
#include <vector>

#include "topo_gaussian/inference/design_spread.h"
#include "topo_gaussian/inference/identifiability.h"
#include "topo_gaussian/inference/interior_problem.h"
#include "topo_gaussian/inference/optimizer.h"
#include "topo_gaussian/inference/region_uncertainty.h"
#include "topo_gaussian/inference/task_config.h"
#include "topo_gaussian/physics/volume_cloud.h"

namespace topo_gaussian::inference {

struct InferenceResult {
  std::string task, representation;
  TaskGeometry geometry;  ///< hanging/support/pivot point and gravity of the task
  Eigen::VectorXd theta;
  std::vector<double> r;        ///< indicator of the best design
  std::vector<double> density;  ///< [kg/m³]
  ProblemEvaluation initial;    ///< the starting design (fully solid unless configured otherwise)
  std::string start;            ///< how the start design was chosen (InteriorProblem::initialParameters)
  ProblemEvaluation final;      ///< the best design
  /// The drawn interior is binary (solid where r ≥ 0.5) but the simulated one may be grey (0 < r < 1:
  /// a density between the materials). grey_fraction = Σ V_i [0.1 < r_i < 0.9] / Σ V_i; above 1 %
  /// the binarised design is simulated too (has_binarised) and a warning says when its features
  /// differ from the result's by more than their tolerance (continuous_material: not checked).
  double grey_fraction = 0.0;
  bool has_binarised = false;
  ProblemEvaluation binarised;
  OptimizerResult optimizer;
  bool converged = false;  ///< optimiser converged AND every target feature reached
  bool targets_reached = false;
  bool cancelled = false;             ///< by progress or should_stop: the best design evaluated so far
  std::vector<std::string> warnings;  ///< for a person, not errors (e.g. a hanging point outside the object)
  std::string backend;  ///< where the kernels ran, e.g. "backend auto: CUDA on NVIDIA H100 … (132 SMs, 80 GiB)"
  std::string message;  ///< one paragraph for a person: what happened, how close, what to do
  /// Per particle the agreement with the best design's solid/hollow label: of the designs that fit as
  /// well as the best (restarts > 0; inference/design_spread.h) and of the linearised region uncertainty
  /// (region below), the lower; empty when neither ran.
  std::vector<double> solid_confidence;
  DesignSpread spread;
  /// timings; evaluation_s = per loss + gradient the optimiser simulated (its first call, the start
  /// design evaluated before it, is handed over and not counted)
  double setup_s = 0, optimize_s = 0, evaluation_s = 0;
  /// What the experiments determine at the final design, and the next experiment (identifiability.h);
  /// available = false (with notes) for tasks without observations or a cancelled run.
  IdentifiabilityAnalysis identifiability;
  /// How well the observations fix the region itself (region_uncertainty.h; available = false with a note
  /// for large representations or tasks without observations). Its per-particle confidence is
  /// solid_confidence when no design spread ran, and their minimum when one did.
  RegionUncertainty region;
};

/// Called after every objective evaluation with its details (features of the design just tried).
using EvaluationCallback = std::function<void(const ProblemEvaluation&)>;

/// Runs the optimisation. progress is called once per iteration; returning false cancels (the best
/// design so far is returned). on_evaluation (optional) sees every evaluated design, before the
/// progress call of its iteration. should_stop (optional) is polled inside every simulation's time
/// loop and between evaluations: a cancel takes effect within a few ms of work and returns the best
/// design evaluated so far (the start design, unevaluated, when the first evaluation was cut short)
/// without simulating it again. max_evaluations bounds the optimiser's evaluations (optimizer.h);
/// the run also evaluates the start design before them. Throws TopoError for bad input before the
/// optimisation starts, including a simulation over its step or memory budget (run_limits.h).
InferenceResult runInference(const TaskConfig& config, const VolumeCloud& cloud,
                             const ProgressCallback& progress = nullptr,
                             const EvaluationCallback& on_evaluation = nullptr, const StopCheck& should_stop = nullptr);

/// The default shape a task brings when no volume is given (finger → finger, pear → pear,
/// cantilever → beam; "" for tasks that need a volume). Its spacing is the task's default_spacing_m.
std::string defaultShapeForTask(const std::string& task);

/// Young's modulus per particle [Pa] for tasks with an elastic model (E interpolated by r with the
/// task's stiffness_power); empty for rigid tasks.
std::vector<double> particleStiffness(const TaskConfig& config, const std::vector<double>& r);

/// Features of a given interior (r per particle; empty = fully solid).
ProblemEvaluation simulateInterior(const TaskConfig& config, const VolumeCloud& cloud, const std::vector<double>& r);

}  // namespace topo_gaussian::inference
