#include "topo_gaussian/workflow/inference_run.h"

#include <cmath>
#include <iomanip>
#include <new>
#include <sstream>
#include <utility>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/number_text.h"
#include "topo_gaussian/inference/motion_targets.h"
#include "topo_gaussian/inference/report.h"
#include "topo_gaussian/inference/task.h"
#include "topo_gaussian/io/interior_ply.h"
#include "topo_gaussian/io/run_folder.h"
#include "topo_gaussian/io/text_file.h"
#include "topo_gaussian/io/volume_ply.h"
#include "topo_gaussian/physics/default_shapes.h"
#include "topo_gaussian/workflow/interior_export.h"

namespace topo_gaussian::workflow {

namespace {

std::string signalCsv(const inference::TaskEvaluation& ev) {
  std::ostringstream os;
  os << std::setprecision(10) << "time_s," << (ev.signal_name.empty() ? "value" : ev.signal_name) << "\n";
  for (std::size_t i = 0; i < ev.signal.size() && i < ev.signal_time_s.size(); ++i)
    os << ev.signal_time_s[i] << "," << ev.signal[i] << "\n";
  return os.str();
}

/// The volume of the request, or the task's default shape.
std::shared_ptr<const VolumeCloud> volumeFor(const InferenceRunRequest& rq, std::vector<std::string>* notes) {
  if (rq.volume) {
    rq.volume->validate("volume");
    return rq.volume;
  }
  const std::string shape = inference::defaultShapeForTask(rq.config.task());
  if (shape.empty())
    throw TopoError("task " + rq.config.task(), "needs a volume and none was given",
                    "fill the object's surface first (topo fill, or the cloud_ingest node)");
  auto cloud = std::make_shared<VolumeCloud>(defaultShapeCloud(shape, rq.config.number("default_spacing_m")));
  notes->push_back("no volume given: the default " + shape + " shape (" + std::to_string(cloud->size()) +
                   " particles at " + numberText(rq.config.number("default_spacing_m")) + " m; `topo shape " + shape +
                   "` writes it)");
  return cloud;
}

}  // namespace

std::vector<io::SignalSeries> comparisonSignals(const motion::MotionFeatures* observed,
                                                const inference::TaskEvaluation& simulated) {
  std::vector<io::SignalSeries> out;
  if (observed && !observed->time_s.empty() && observed->time_s.size() == observed->angle_deg.size()) {
    io::SignalSeries s;
    s.label = "observed " + (observed->kind.empty() ? std::string("angle") : observed->kind) + " [deg]";
    const auto& t = observed->time_s;
    const auto& y = observed->angle_deg;
    double t0 = t.front();
    // A simulation released at rest starts at a turning point; a camera window usually starts
    // mid-swing. Start the observed series at its first turning point on the release side, so the
    // two can be compared by eye and by their RMS difference.
    const auto& sim = simulated.signal;
    if (!sim.empty() && std::abs(sim.front()) > 0) {
      double peak = 0;
      for (double v : y) peak = std::max(peak, std::abs(v));
      for (std::size_t i = 1; i + 1 < y.size(); ++i) {
        const bool turning = (y[i] - y[i - 1]) * (y[i + 1] - y[i]) <= 0;
        if (turning && y[i] * sim.front() > 0 && std::abs(y[i]) >= 0.8 * peak) {
          t0 = t[i];
          s.label += ", aligned";
          break;
        }
      }
    }
    for (std::size_t i = 0; i < t.size(); ++i) {
      if (t[i] < t0) continue;
      s.t.push_back(t[i] - t0);
      s.value.push_back(y[i]);
    }
    out.push_back(std::move(s));
  }
  if (!simulated.signal.empty() && simulated.signal.size() == simulated.signal_time_s.size()) {
    io::SignalSeries s;
    s.label = "simulated " + simulated.signal_name;
    s.t = simulated.signal_time_s;
    s.value = simulated.signal;
    out.push_back(std::move(s));
  }
  return out;
}

namespace {

/// std::bad_alloc → what ran out and what to change.
[[noreturn]] void outOfMemory(const inference::TaskConfig& config, const VolumeCloud* volume, const char* stage) {
  std::string sizes;
  for (const char* key : {"duration_s", "dt_s", "max_substep_s"})
    if (config.has(key)) sizes += std::string(sizes.empty() ? "" : ", ") + key + " = " + numberText(config.number(key));
  throw TopoError("task " + config.task() + " (" + (volume ? std::to_string(volume->size()) : std::string("?")) +
                      " particles" + (sizes.empty() ? "" : ", " + sizes) + ")",
                  std::string("ran out of memory while ") + stage,
                  "use a larger dt_s, a shorter duration_s, fewer particles (topo fill --count / a larger spacing) "
                  "or a simpler representation");
}

}  // namespace

namespace {

/// The confidence under which the tracker calls a measured feature unreliable ("do not use these
/// numbers", vision/motion_tracker.cpp; docs/tracking.md: a value outside its tolerance always came
/// with less).
constexpr double kReliableConfidence = 0.3;

/// "period 0.01, equilibrium 0.2": the window's measured features (confidence > 0) that the tracker
/// rates below kReliableConfidence; "" when none.
std::string unreliableFeatures(const motion::MotionFeatures& w) {
  std::string out;
  for (const auto& [name, c] : {std::make_pair("period", w.period_confidence),
                                std::make_pair("amplitude", w.amplitude_confidence),
                                std::make_pair("equilibrium", w.equilibrium_confidence),
                                std::make_pair("bend", w.bending_confidence),
                                std::make_pair("bend profile", w.bend_profile_confidence)})
    if (c > 0 && c < kReliableConfidence) out += (out.empty() ? "" : ", ") + std::string(name) + " " + numberText(c, 2);
  return out;
}

/// The targets one observed window gives its experiment (the first one when it is untagged). Targets
/// taken from features the tracker itself calls unreliable are used, with a warning in `warnings`.
void applyObservedTargets(const motion::MotionFeatures& window, inference::TaskConfig* config,
                          std::vector<std::string>* notes, std::vector<std::string>* warnings) {
  const std::vector<inference::Experiment> experiments = config->experimentList();
  const inference::Experiment* experiment = &experiments.front();
  if (!window.experiment.empty()) {
    experiment = nullptr;
    std::string names;
    for (const auto& e : experiments) {
      if (e.name == window.experiment) experiment = &e;
      names += (names.empty() ? "" : ", ") + e.name;
    }
    if (!experiment && config->hasExperiments())
      throw TopoError(inference::motionFeaturesOrigin(window),
                      "belong to experiment '" + window.experiment + "', which the task does not have",
                      "tag the window with one of: " + names);
    if (!experiment) experiment = &experiments.front();  // a single task: the tag is only a label
  }
  const inference::MotionTargets mt = inference::targetsFromMotion(experiment->config, window);
  const std::string prefix =
      config->hasExperiments() ? experiment->name + inference::kExperimentKeySeparator : std::string();
  for (const auto& [name, value] : mt.targets) {
    config->setNumber(prefix + name, value);
    notes->push_back(prefix + name + " = " + numberText(value, 6) + " from the motion features");
  }
  for (const auto& [name, values] : mt.list_targets) {
    config->setList(prefix + name, values);
    std::string text;
    for (double v : values) text += (text.empty() ? "" : ", ") + numberText(v, 4);
    notes->push_back(prefix + name + " = [" + text + "] from the motion features");
  }
  if (!mt.note.empty()) notes->push_back(prefix + mt.note);
  const std::string weak = unreliableFeatures(window);
  if (!weak.empty() && (!mt.targets.empty() || !mt.list_targets.empty())) {
    std::string taken;
    for (const auto& t : mt.targets) taken += (taken.empty() ? "" : ", ") + prefix + t.first;
    for (const auto& t : mt.list_targets) taken += (taken.empty() ? "" : ", ") + prefix + t.first;
    warnings->push_back(inference::motionFeaturesOrigin(window) + ": the tracker rates " + weak +
                        " (confidence < " + numberText(kReliableConfidence, 2) +
                        ": unreliable, its \"do not use these numbers\"), yet " + taken +
                        " were taken from them and may be wrong; track a clearer or longer clip, or give the "
                        "targets yourself (--target, a goal's targets)");
  }
}

InferenceRunOutcome runUnguarded(const InferenceRunRequest& rq) {
  InferenceRunOutcome out;
  out.volume = volumeFor(rq, &out.notes);
  inference::TaskConfig config = rq.config;
  // The task's own rule (inference/motion_targets.h) per observed window, then the explicit targets over it.
  std::vector<std::shared_ptr<const motion::MotionFeatures>> observed = rq.observed_experiments;
  if (rq.observed) observed.insert(observed.begin(), rq.observed);
  std::vector<std::string> early_warnings;  // unreliable observations, experiments left out: ahead of the run's own
  for (const auto& window : observed) applyObservedTargets(*window, &config, &out.notes, &early_warnings);
  for (const auto& t : rq.targets) {
    const auto eq = t.find('=');
    const auto* spec = config.spec(t.substr(0, eq));
    if (spec && !spec->is_target)
      throw TopoError(rq.targets_origin + " " + t.substr(0, eq), "is a parameter, not an observed feature",
                      "use " + rq.parameters_origin + " " + t);
    config.setAssignment(t, rq.targets_origin);
    out.notes.push_back(t + " from the " + rq.targets_origin);
  }
  try {
    // An experiment without its observations is left out (with a warning) while another one remains:
    // the best design of the rest is still worth returning, and its uncertainty says what is missing.
    std::vector<std::string> skipped;
    for (const auto& e : config.experimentList()) {
      try {
        inference::makeTask(e.config, *out.volume)->requireTargets();
      } catch (const TopoError& error) {
        if (!config.hasExperiments()) throw;
        const std::string why = "experiment '" + e.name + "' (" + e.config.task() + "): " + error.what() +
                                " (name the experiment: " + e.name + ".TARGET=VALUE)";
        if (skipped.size() + 1 >= config.experiments().size())
          throw TopoError(why + "; no experiment has all its targets");
        skipped.push_back(e.name);
        early_warnings.push_back(why + ": left out, the interior fits the other experiments only");
      }
    }
    for (const auto& name : skipped) config.removeExperiment(name);
  } catch (const TopoError& e) {
    // what the observed windows said (e.g. the tracker's reason for measuring nothing)
    std::string seen;
    for (const auto& n : out.notes) seen += (seen.empty() ? " [" : "] [") + n;
    throw TopoError(std::string(e.what()) + rq.missing_targets_hint + (seen.empty() ? "" : seen + "]"));
  }
  // The folder before the work, so a bad one fails early.
  if (!rq.output_dir.empty()) {
    // An earlier run there would be overwritten in part, its other files left beside the new ones.
    const io::PreparedRunFolder prepared = io::prepareRunFolder(rq.output_dir, rq.replace_output);
    if (!prepared.removed.empty())
      out.notes.push_back("removed the earlier run's " + std::to_string(prepared.removed.size()) + " files from " +
                          rq.output_dir + (prepared.kept.empty() ? std::string()
                                                                 : " (kept " + std::to_string(prepared.kept.size()) +
                                                                       " other entries)"));
    out.output_dir = rq.output_dir;
  } else if (!rq.output_parent.empty()) {
    out.output_dir = io::createRunFolder(rq.output_parent, config.task());
  } else {
    throw TopoError("inference run", "has no output folder", "give an output directory");
  }

  out.result = inference::runInference(config, *out.volume, rq.progress, rq.on_evaluation, rq.should_stop);
  out.cancelled = out.result.cancelled || out.result.optimizer.cancelled;
  out.result.warnings.insert(out.result.warnings.begin(), early_warnings.begin(), early_warnings.end());
  if (!out.result.start.empty()) out.notes.push_back(out.result.start);
  for (const auto& w : out.result.warnings) out.notes.push_back("warning: " + w);
  const auto& res = out.result;
  const std::string dir = out.output_dir + "/";
  const bool continuous = config.boolean("continuous_material");
  out.signals = comparisonSignals(rq.observed.get(), res.final.task);
  out.report_json = inference::reportJson(res, config);
  // report.json is written last (the export writes it after interior.ply): a folder with a report holds
  // the whole run, so a run killed while it writes is never taken for a complete one (io::findLatestRun).
  if (!res.final.task.signal.empty()) {
    io::writeTextFile(dir + "signal.csv", signalCsv(res.final.task));
    out.files.push_back(dir + "signal.csv");
  }
  io::writeVolumePly(*out.volume, dir + "volume.ply");
  out.files.push_back(dir + "volume.ply");
  bool exported = false;
  if (rq.export_files) {
    try {
      ExportOptions eo;
      eo.output_dir = out.output_dir;
      eo.report_json = out.report_json;
      eo.signals = out.signals;
      eo.continuous = continuous;
      eo.title = config.task() + " interior";
      eo.confidence = res.solid_confidence;
      const ExportSummary s = exportInterior(*out.volume, res.r, res.density, eo);
      for (const auto& f : s.files) out.files.push_back(dir + f);
      out.report_json = io::readTextFile(dir + "report.json");  // with its "interface" section
      exported = true;
    } catch (const std::exception& e) {
      out.notes.push_back(std::string("export failed (the run's own files are written): ") + e.what());
    }
  }
  if (!exported) {
    try {  // the interface's numbers still go into report.json when the mesh can be made
      out.report_json = withInterfaceSection(out.report_json, measureInterface(*out.volume, res.r));
    } catch (const TopoError& e) {
      out.notes.push_back(std::string("no \"interface\" section in report.json: ") + e.what());
    }
    io::writeInteriorPly(dir + "interior.ply", *out.volume, res.r, res.density, continuous, res.solid_confidence);
    io::writeTextFile(dir + "report.json", out.report_json);
    out.files.push_back(dir + "interior.ply");
    out.files.push_back(dir + "report.json");
  }
  std::ostringstream msg;
  msg << res.message;
  for (const auto& n : out.notes) msg << " [" << n << "]";
  out.message = msg.str();
  out.config = std::move(config);
  return out;
}

}  // namespace

InferenceRunOutcome runInference(InferenceRunRequest rq) {
  try {
    return runUnguarded(rq);
  } catch (const std::bad_alloc&) {
    outOfMemory(rq.config, rq.volume.get(), "simulating and optimising");
  }
}

RestorableRun findRestorableRun(const std::string& parent, const std::string& task_dir) {
  RestorableRun out;
  out.latest = io::findLatestRun(parent, [&](const io::RunFiles& run) {
    try {
      out.config = inference::TaskConfig::load(run.task, task_dir);
    } catch (const std::exception& e) {
      throw TopoError(run.dir + "/report.json", "names the task '" + run.task + "', which does not load here (" +
                                                    e.what() + ")",
                      "restore it where its task is known, or delete the folder");
    }
  });
  return out;
}

}  // namespace topo_gaussian::workflow
