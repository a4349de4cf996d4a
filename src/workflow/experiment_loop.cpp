#include "topo_gaussian/workflow/experiment_loop.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <map>
#include <tuple>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/number_text.h"
#include "topo_gaussian/common/stopwatch.h"
#include "topo_gaussian/inference/interior_problem.h"
#include "topo_gaussian/inference/region_uncertainty.h"
#include "topo_gaussian/inference/task.h"
#include "topo_gaussian/inference/task_registry.h"

namespace topo_gaussian::workflow {

using inference::ExperimentSuggestion;
using inference::IdentifiabilityAnalysis;
using inference::TaskConfig;

namespace {

/// A number as text that reads back to the same double: 10 significant digits when they do, else 17.
std::string exactNumber(double v) {
  char b[40];
  std::snprintf(b, sizeof b, "%.10g", v);
  if (std::strtod(b, nullptr) != v) std::snprintf(b, sizeof b, "%.17g", v);
  return b;
}

/// The value of `key` in `c` as set() reads it, exactly.
std::string exactValueText(const TaskConfig& c, const inference::ParamSpec& s) {
  switch (s.type) {
    case inference::ParamType::Number:
    case inference::ParamType::Integer:
      return exactNumber(c.number(s.name));
    case inference::ParamType::Boolean:
      return c.boolean(s.name) ? "true" : "false";
    case inference::ParamType::Text:
      return c.text(s.name);
    case inference::ParamType::Vector3: {
      const Eigen::Vector3d v = c.vector3(s.name);
      return exactNumber(v.x()) + "," + exactNumber(v.y()) + "," + exactNumber(v.z());
    }
    case inference::ParamType::List: {
      std::string out;
      for (double v : c.list(s.name)) out += (out.empty() ? "" : ",") + exactNumber(v);
      return out;
    }
  }
  return "";
}

std::string joined(const std::vector<std::string>& names) {
  std::string s;
  for (const auto& n : names) s += (s.empty() ? "" : " ") + n;
  return s.empty() ? "none" : s;
}

/// The joint config of `first`: itself when it has experiments, else the experiment named after its task.
TaskConfig asJoint(const TaskConfig& first) {
  if (first.hasExperiments()) return first;
  TaskConfig joint = TaskConfig::common();
  for (const auto& key : first.explicitKeys())
    if (TaskConfig::isShared(key) && first.has(key)) joint.set(key, first.valueText(key), "the first experiment");
  joint.addExperiment(first.task(), 1.0, first);
  return joint;
}

std::vector<std::string> experimentNames(const TaskConfig& joint) {
  std::vector<std::string> names;
  for (const auto& e : joint.experimentList()) names.push_back(e.name);
  return names;
}

}  // namespace

std::string verdictName(LoopVerdict v) {
  switch (v) {
    case LoopVerdict::Continue:
      return "continue";
    case LoopVerdict::GoalReached:
      return "goal_reached";
    case LoopVerdict::MaxExperiments:
      return "max_experiments";
    case LoopVerdict::NotAnalysed:
      return "not_analysed";
    case LoopVerdict::NoSuggestion:
      return "no_suggestion";
    case LoopVerdict::NoGain:
      return "no_gain";
  }
  return "unknown";
}

LoopEvidence loopEvidence(const IdentifiabilityAnalysis& a) {
  LoopEvidence e;
  e.analysed = a.available && a.moments.size() == 10;
  if (e.analysed) {
    for (const auto& m : a.moments)
      if (!m.determined) e.free.push_back(m.name);
  } else {
    e.free = {"m", "cx", "cy", "cz", "Ixx", "Iyy", "Izz", "Ixy", "Ixz", "Iyz"};
  }
  e.has_suggestion = a.has_suggestion;
  if (a.has_suggestion) {
    e.suggestion = a.suggestion.sentence;
    e.score_gain = a.suggestion.score_gain;
    e.fixes_more = !a.suggestion.newly_determined.empty() || a.suggestion.directions_after > a.determined_directions;
  }
  if (!a.notes.empty()) e.note = a.notes.front();
  return e;
}

LoopDecision decideNextStep(const IdentifiabilityAnalysis& a, double uncertain_fraction, int experiments_so_far,
                            const ExperimentLoopOptions& o) {
  return decideNextStep(loopEvidence(a), uncertain_fraction, experiments_so_far, o);
}

LoopDecision decideNextStep(const LoopEvidence& e, double uncertain_fraction, int experiments_so_far,
                            const ExperimentLoopOptions& o) {
  if (o.max_experiments < 1)
    throw TopoError("max_experiments " + std::to_string(o.max_experiments), "is below 1",
                    "give the most experiments the object may have in all, e.g. 5");
  if (!(o.max_uncertain_fraction >= 0))
    throw TopoError("max_uncertain_fraction " + numberText(o.max_uncertain_fraction), "is negative or not a number",
                    "give the largest share of the volume that may stay uncertain, e.g. 0.02");
  LoopDecision d;
  const bool all = e.analysed && e.free.empty();
  const bool small = uncertain_fraction <= o.max_uncertain_fraction;  // false for NaN
  const std::string region =
      std::isfinite(uncertain_fraction)
          ? numberText(100.0 * uncertain_fraction, 3) + " % of the volume uncertain (goal at most " +
                numberText(100.0 * o.max_uncertain_fraction, 3) + " %)"
          : "the uncertain volume not known (no region analysis)";
  const std::string moments =
      e.analysed ? (all ? std::string("all ten moments determined")
                        : std::to_string(10 - static_cast<int>(e.free.size())) + " of ten moments determined (free: " +
                              joined(e.free) + ")")
                 : std::string("the moments not analysed");
  if (all && small) {
    d.verdict = LoopVerdict::GoalReached;
    d.reason = "goal reached: " + moments + " and " + region;
    return d;
  }
  if (experiments_so_far >= o.max_experiments) {
    d.verdict = LoopVerdict::MaxExperiments;
    d.reason = "stopped at " + std::to_string(experiments_so_far) + " experiments (at most " +
               std::to_string(o.max_experiments) + "): " + moments + ", " + region;
    return d;
  }
  if (!e.analysed) {
    d.verdict = LoopVerdict::NotAnalysed;
    d.reason = "stopped: what the experiments determine was not analysed" + (e.note.empty() ? "" : " (" + e.note + ")");
    return d;
  }
  if (!e.has_suggestion) {
    d.verdict = LoopVerdict::NoSuggestion;
    d.reason = "stopped: no candidate experiment improves what is determined; " + moments + ", " + region;
    return d;
  }
  if (e.score_gain < o.min_score_gain && !e.fixes_more) {
    d.verdict = LoopVerdict::NoGain;
    d.reason = "stopped: the best suggestion (" + e.suggestion + ") gains nothing (score gain " +
               numberText(e.score_gain, 3) + "); " + moments + ", " + region;
    return d;
  }
  d.verdict = LoopVerdict::Continue;
  d.reason = "continue: " + moments + ", " + region + "; next: " + e.suggestion;
  return d;
}

double uncertainFraction(const inference::InferenceResult& result, const VolumeCloud& cloud) {
  if (cloud.size() == 0 || result.solid_confidence.size() != cloud.size())
    return std::numeric_limits<double>::quiet_NaN();
  return inference::uncertainVolumeFraction(cloud.V, result.solid_confidence);
}

SuggestedExperiment suggestionOverrides(const ExperimentSuggestion& s) {
  if (s.config.hasExperiments())
    throw TopoError("experiment suggestion (" + s.kind + ")", "has several experiments",
                    "a suggestion is one experiment of one task");
  SuggestedExperiment out;
  out.kind = s.kind;
  out.task = s.config.task();
  out.sentence = s.sentence;
  const TaskConfig defaults = TaskConfig::defaults(out.task);
  for (const auto& spec : s.config.specs()) {
    if (!s.config.has(spec.name)) continue;
    const std::string value = exactValueText(s.config, spec);
    if (defaults.has(spec.name) && exactValueText(defaults, spec) == value) continue;
    out.overrides.push_back(spec.name + "=" + value);
  }
  return out;
}

TaskConfig configFromOverrides(const SuggestedExperiment& suggested) {
  TaskConfig c = TaskConfig::defaults(suggested.task);
  for (const auto& a : suggested.overrides) c.setAssignment(a, "suggested experiment overrides");
  return c;
}

ExperimentLoopResult runExperimentLoop(const VolumeCloud& cloud, const TaskConfig& first,
                                       const ExperimentPerformer& performer, const ExperimentLoopOptions& options,
                                       const ExperimentLoopCallbacks& callbacks) {
  if (cloud.size() == 0)
    throw TopoError("experiment loop", "the object's particle cloud is empty", "give the filled volume of the object");
  if (!performer)
    throw TopoError("experiment loop", "has no performer", "give a callback that performs a suggested experiment");
  const auto t_loop = Clock::now();
  ExperimentLoopResult out;
  out.experiments = asJoint(first);
  std::string added, added_sentence;
  double perform_s = 0.0;
  for (int step = 1;; ++step) {
    ExperimentLoopStep rec;
    rec.step = step;
    rec.experiment_names = experimentNames(out.experiments);
    rec.added = added;
    rec.added_sentence = added_sentence;
    rec.perform_s = perform_s;
    const auto t0 = Clock::now();
    inference::InferenceResult res =
        inference::runInference(out.experiments, cloud, callbacks.progress, nullptr, callbacks.should_stop);
    if (options.identifiability && !res.cancelled && res.identifiability.available) {
      inference::InteriorProblem problem(out.experiments, cloud);
      problem.setShouldStop(callbacks.should_stop);
      res.identifiability = inference::analyseIdentifiability(problem, res.theta, res.final, *options.identifiability);
    }
    rec.inference_s = secondsSince(t0);
    const IdentifiabilityAnalysis& id = res.identifiability;
    for (const auto& m : id.moments) (m.determined ? rec.determined : rec.free).push_back(m.name);
    if (id.moments.empty())
      rec.free = {"m", "cx", "cy", "cz", "Ixx", "Iyy", "Izz", "Ixy", "Ixz", "Iyz"};
    rec.determined_directions = id.determined_directions;
    rec.uncertain_fraction = uncertainFraction(res, cloud);
    rec.region_iou_mean = res.region.available ? res.region.iou_mean : std::numeric_limits<double>::quiet_NaN();
    rec.has_suggestion = id.has_suggestion;
    if (id.has_suggestion) {
      rec.suggestion = id.suggestion;
      rec.suggested = suggestionOverrides(id.suggestion);
    }
    rec.mass = res.final.task.mass;
    rec.targets_reached = res.targets_reached;
    if (res.cancelled) {
      rec.decision.verdict = LoopVerdict::NotAnalysed;
      rec.decision.reason = "cancelled: the inference was stopped";
    } else {
      rec.decision = decideNextStep(id, rec.uncertain_fraction, static_cast<int>(rec.experiment_names.size()), options);
    }
    if (callbacks.truth_iou) rec.truth_iou = callbacks.truth_iou(res);
    out.steps.push_back(rec);
    if (callbacks.on_step) callbacks.on_step(out.steps.back(), res);
    out.last = std::move(res);
    out.decision = rec.decision;
    if (!rec.decision.continues()) break;

    const auto t1 = Clock::now();
    TaskConfig performed;
    try {
      performed = performer(rec.suggestion);
    } catch (const TopoError& e) {
      out.decision.verdict = LoopVerdict::NoSuggestion;
      out.decision.reason = "stopped: the performer could not " + rec.suggestion.sentence + ": " + e.what();
      out.steps.back().decision = out.decision;
      break;
    }
    perform_s = secondsSince(t1);
    const int n = static_cast<int>(rec.experiment_names.size()) + 1;
    std::string name = rec.suggestion.kind + "_" + std::to_string(n);
    for (int k = 2; std::find(rec.experiment_names.begin(), rec.experiment_names.end(), name) !=
                    rec.experiment_names.end();
         ++k)
      name = rec.suggestion.kind + "_" + std::to_string(n) + "_" + std::to_string(k);
    out.experiments.addExperiment(name, 1.0, performed);
    added = name;
    added_sentence = rec.suggestion.sentence;
  }
  out.seconds = secondsSince(t_loop);
  return out;
}

double measuredMaxTilt(const TaskConfig& config, double tilt_deg) {
  if (!config.has("initial_tilt_deg")) return tilt_deg;
  const double release = std::abs(config.number("initial_tilt_deg"));
  return tilt_deg <= 1.01 * release ? release : tilt_deg;
}

TwinPerformer::TwinPerformer(const RigTwin& twin, const MeasurementNoise& noise)
    : twin_(&twin), noise_(noise), rng_(noise.seed) {
  if (!(noise.angle_deg >= 0) || !(noise.period_relative >= 0) || !(noise.mass_relative >= 0))
    throw TopoError("twin performer's measurement noise", "has a negative or NaN standard deviation",
                    "give noise levels >= 0 (0: exact observations)");
}

TaskConfig TwinPerformer::perform(const TaskConfig& config, bool weigh, bool swing) {
  if (config.hasExperiments())
    throw TopoError("twin performer", "was given several experiments at once", "perform one experiment at a time");
  std::normal_distribution<double> N(0.0, 1.0);
  TaskConfig c = config;
  const VolumeCloud& cloud = twin_->cloud();
  const std::vector<double>& r = twin_->indicator();
  const inference::TaskDefinition* def = inference::findTaskDefinition(c.task());
  if (c.task() == "hanging") {
    if (!c.has("hanging_point"))
      throw TopoError("twin performer: hanging experiment", "has no hanging_point", "set hanging_point=x,y,z");
    const inference::ProblemEvaluation ev = inference::simulateInterior(c, cloud, r);
    const MassProperties& m = ev.task.mass;
    const inference::RollPitch rest = inference::hangingRestPose(m.com, c.vector3("hanging_point"));
    if (swing || c.has("axle_swing_period_s") || c.has("cross_axle_swing_period_s")) {
      TaskConfig timed = c;  // the axles in the pose the true interior rests in
      timed.setNumber("target_roll_deg", rest.roll_deg);
      timed.setNumber("target_pitch_deg", rest.pitch_deg);
      const inference::ProblemEvaluation t = inference::simulateInterior(timed, cloud, r);
      for (const char* name : {"axle_swing_period_s", "cross_axle_swing_period_s"}) {
        double value = NAN;
        for (const auto& f : t.task.features)
          if (f.name == name) value = f.value;
        if (!(value > 0))
          throw TopoError("twin performer: hanging experiment", std::string("gives no ") + name,
                          "hang it where the centre of mass is off the axle");
        c.setNumber(name, value * (1.0 + noise_.period_relative * N(rng_)));
      }
    }
    c.setNumber("target_roll_deg", rest.roll_deg + noise_.angle_deg * N(rng_));
    c.setNumber("target_pitch_deg", rest.pitch_deg + noise_.angle_deg * N(rng_));
    if (weigh) c.setNumber("mass_kg", m.mass * (1.0 + noise_.mass_relative * N(rng_)));
    return c;
  }
  if (def && !def->rocking_axis_parameter.empty()) {
    const inference::ProblemEvaluation ev = inference::simulateInterior(c, cloud, r);
    double period = NAN, tilt = NAN;
    for (const auto& f : ev.task.features) {
      if (f.name == "period_s") period = f.value;
      if (f.name == "max_tilt_deg") tilt = f.value;
    }
    if (!(period > 0) || !(tilt > 0))
      throw TopoError("twin performer: " + c.task() + " experiment", "the true interior shows no rocking period",
                      "release it further from rest (initial_tilt_deg) or simulate longer (duration_s)");
    c.setNumber("period_s", period * (1.0 + noise_.period_relative * N(rng_)));
    c.setNumber("max_tilt_deg", measuredMaxTilt(c, tilt + noise_.angle_deg * N(rng_)));
    return c;
  }
  throw TopoError("twin performer: experiment of task " + c.task(), "is not one the twin can perform",
                  "the twin hangs (hanging), swings (hanging with axle periods) and rocks (tumbler)");
}

std::vector<double> transferField(const VolumeCloud& from, const std::vector<double>& values,
                                  const VolumeCloud& cloud) {
  if (values.size() != from.size())
    throw TopoError("transferred field", "has " + std::to_string(values.size()) + " values for " +
                                             std::to_string(from.size()) + " particles",
                    "give one value per particle of the source cloud");
  std::vector<double> out(cloud.size(), 0.0);
  if (cloud.size() == 0 || from.size() == 0) return out;
  const double h = cloud.spacing > 0 ? cloud.spacing : 1.0;
  const Eigen::Vector3d o = cloud.X.front();
  using Key = std::tuple<long, long, long>;
  auto key = [&](const Eigen::Vector3d& x) {
    const Eigen::Vector3d u = (x - o) / h;
    return Key{std::lround(u.x()), std::lround(u.y()), std::lround(u.z())};
  };
  std::map<Key, std::pair<double, int>> cells;
  for (std::size_t j = 0; j < from.size(); ++j) {
    auto& c = cells[key(from.X[j])];
    c.first += values[j];
    ++c.second;
  }
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const auto it = cells.find(key(cloud.X[i]));
    if (it != cells.end()) {
      out[i] = it->second.first / it->second.second;
      continue;
    }
    std::size_t best = 0;
    double d = std::numeric_limits<double>::infinity();
    for (std::size_t j = 0; j < from.size(); ++j) {
      const double e = (from.X[j] - cloud.X[i]).squaredNorm();
      if (e < d) d = e, best = j;
    }
    out[i] = values[best];
  }
  return out;
}

}  // namespace topo_gaussian::workflow
