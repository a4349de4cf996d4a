// One inference run, end to end: the single library call behind `topo infer`, the
// interior_inference node (action goal and ~infer) and bench/infer.
//   request (task config, volume or the task's default shape, observed motion features, targets,
//   output folder, callbacks)
//   → targets from the observed motion (inference/motion_targets.h), then the explicit ones
//   → every target the task needs present (checked before any work, like the folder)
//   → inference::runInference (paper §5–7), cancellable from the progress callback
//   → the run folder (io/run_folder.h): volume.ply, interior.ply, report.json (+ "interface"),
//     signal.csv, and the export (interior.stl, slices.png, loss.png, signal.png, export.json);
//     when the export fails, the run's own files are still written and the failure is a note.
// A run folder written here loads with io::loadRunFolder, whichever front end wrote it.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "topo_gaussian/common/motion_features.h"
#include "topo_gaussian/inference/pipeline.h"
#include "topo_gaussian/io/run_files.h"
#include "topo_gaussian/io/run_folder.h"
#include "topo_gaussian/physics/volume_cloud.h"

namespace topo_gaussian::workflow {

struct InferenceRunRequest {
  inference::TaskConfig config;                            ///< task, representation and overrides already applied
  std::shared_ptr<const VolumeCloud> volume;               ///< null: the task's default shape, else an error
  std::shared_ptr<const motion::MotionFeatures> observed;  ///< optional: targets and the observed signal
  /// More observed windows for a multi-experiment config, each tagged with its experiment
  /// (MotionFeatures::experiment); `observed` (untagged) belongs to the first experiment.
  std::vector<std::shared_ptr<const motion::MotionFeatures>> observed_experiments;
  std::vector<std::string> targets;             ///< "NAME=VALUE", applied after (over) the observed ones
  std::string targets_origin = "targets";       ///< names them in messages ("--target", "goal targets")
  std::string parameters_origin = "--set";      ///< where parameters go instead ("--set", "goal overrides")
  std::string missing_targets_hint;             ///< appended to the error when a needed target is missing
  std::string output_dir;                       ///< this folder (created when missing; must be empty), or else
  std::string output_parent;                    ///< a new folder <output_parent>/<task>_<YYYYmmdd_HHMMSS>[_N]
  bool export_files = true;                     ///< also the STL and the pictures
  /// output_dir may hold an earlier run: its files are removed first, other files kept (topo infer
  /// --force; io::prepareRunFolder). Otherwise a non-empty output_dir is refused before any work.
  bool replace_output = false;
  inference::ProgressCallback progress;         ///< per iteration; false cancels (best design so far)
  inference::EvaluationCallback on_evaluation;  ///< every evaluated design
  /// Polled inside every simulation's time loop and between evaluations (a cancelled goal, Ctrl-C):
  /// true stops the run within a few ms of work with the best design so far (cancelled = true).
  std::function<bool()> should_stop;
};

struct InferenceRunOutcome {
  inference::TaskConfig config;               ///< as run: with the targets set
  std::shared_ptr<const VolumeCloud> volume;  ///< as run (the default shape when none was given)
  inference::InferenceResult result;
  bool cancelled = false;  ///< stopped by the progress callback or should_stop: best design so far
  std::string output_dir;
  std::vector<std::string> files;  ///< written, full paths
  std::string report_json;
  std::vector<io::SignalSeries> signals;  ///< observed (aligned) and simulated, as drawn in signal.png
  std::vector<std::string> notes;         ///< for a person: where volume and targets came from, what failed
  std::string message;                    ///< result.message with the notes (the front end says "cancelled")
};

/// Runs the request. Throws TopoError before any optimisation for a missing volume, a missing
/// target, an invalid override, a simulation over its step or memory budget (physics/run_limits.h)
/// or an output folder that cannot be created; afterwards the files are written even when the run
/// was cancelled. Memory that runs out anyway (std::bad_alloc) becomes a TopoError that names the
/// task, the particles and the parameters that set the size (dt_s, duration_s, the spacing).
InferenceRunOutcome runInference(InferenceRunRequest request);

/// The series a person compares: the observed signal of `observed` (started at its first turning point
/// on the release side when the simulation starts at a release, so both start alike) and the
/// simulated signal of `simulated`.
std::vector<io::SignalSeries> comparisonSignals(const motion::MotionFeatures* observed,
                                                const inference::TaskEvaluation& simulated);

struct RestorableRun {
  io::LatestRun latest;         ///< found: the run to show again; skipped: the newer folders passed over, why
  inference::TaskConfig config;  ///< latest.run's task as `task_dir` resolves it (its default parameters)
};

/// The run a restarted front end shows again: the newest complete run under `parent`
/// (io::findLatestRun: it loads and was not interrupted) whose task resolves in `task_dir`. A newer
/// folder whose report names a task that does not resolve (an unknown name, a task file gone) is
/// passed over like a torn one, with the folder and the task in `latest.skipped`.
RestorableRun findRestorableRun(const std::string& parent, const std::string& task_dir);

}  // namespace topo_gaussian::workflow
