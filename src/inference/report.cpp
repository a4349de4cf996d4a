#include "topo_gaussian/inference/report.h"

#include <cmath>
#include <sstream>

#include "topo_gaussian/common/json.h"

namespace topo_gaussian::inference {
namespace {

using json::num;
using json::quote;

std::string vec3(const Eigen::Vector3d& v) { return "[" + num(v[0]) + ", " + num(v[1]) + ", " + num(v[2]) + "]"; }

std::string featuresJson(const std::vector<Feature>& fs) {
  std::string s = "{";
  for (std::size_t i = 0; i < fs.size(); ++i) {
    const Feature& f = fs[i];
    s += (i ? ", " : "") + quote(f.name) + ": {\"value\": " + num(f.value) + ", \"unit\": " + quote(f.unit);
    if (f.has_target) s += ", \"target\": " + num(f.target) + ", \"reached\": " + (f.reached() ? "true" : "false");
    s += "}";
  }
  return s + "}";
}

std::string geometryJson(const ProblemEvaluation& ev, const TaskGeometry& g) {
  std::string s = "\"gravity\": " + vec3(g.gravity) + ", \"center_of_mass\": " + vec3(ev.task.mass.com) +
                  ", \"mass_kg\": " + num(ev.task.mass.mass) + ", \"inertia\": [";
  for (int a = 0; a < 3; ++a) s += std::string(a ? ", " : "") + vec3(ev.task.mass.inertia.row(a).transpose());
  s += "]";
  if (g.has_point) s += ", " + quote(g.point_name) + ": " + vec3(g.point);
  s += ", \"solid_fraction\": " + num(ev.solid_fraction);
  return s;
}

std::string targetsJson(const TaskConfig& c, const std::string& prefix = "") {
  std::string s = "{";
  bool first = true;
  for (const auto& sp : c.specs())
    if (sp.is_target && c.has(sp.name)) {
      s += (first ? "" : ", ") + quote(prefix + sp.name) + ": ";
      if (sp.type == ParamType::Text)
        s += quote(c.text(sp.name));
      else if (sp.type == ParamType::List) {
        s += "[";
        const auto& l = c.list(sp.name);
        for (std::size_t i = 0; i < l.size(); ++i) s += (i ? ", " : "") + num(l[i]);
        s += "]";
      } else
        s += num(c.number(sp.name));
      first = false;
    }
  return s + "}";
}

/// The targets of every experiment, named "EXPERIMENT.target" when there are several.
std::string allTargetsJson(const TaskConfig& c) {
  if (!c.hasExperiments()) return targetsJson(c);
  std::string s;
  for (const auto& e : c.experiments()) {
    const std::string t = targetsJson(e.config, e.name + kExperimentKeySeparator);
    if (t.size() > 2) s += (s.empty() ? "" : ", ") + t.substr(1, t.size() - 2);
  }
  return "{" + s + "}";
}

/// One entry per experiment: its task, weight, loss, targets and features.
std::string experimentsJson(const ProblemEvaluation& ev, const TaskConfig& c) {
  const std::vector<Experiment> list = c.experimentList();
  std::string s = "[";
  for (std::size_t e = 0; e < ev.experiments.size() && e < list.size(); ++e) {
    const ExperimentEvaluation& xe = ev.experiments[e];
    s += std::string(e ? ", " : "") + "{\"name\": " + quote(xe.name) + ", \"task\": " + quote(list[e].config.task()) +
         ", \"source\": " + quote(list[e].config.source()) + ", \"weight\": " + num(xe.weight) +
         ", \"loss\": " + num(xe.eval.loss) + ", \"targets\": " + targetsJson(list[e].config) +
         ", \"features\": " + featuresJson(xe.eval.features) + "}";
  }
  return s + "]";
}

std::string regionJson(const RegionUncertainty& g) {
  std::ostringstream s;
  s << "{\"available\": " << (g.available ? "true" : "false") << ", \"note\": " << quote(g.note)
    << ", \"observations\": " << g.observations << ", \"directions\": " << g.directions
    << ", \"determined_directions\": " << g.determined_directions << ", \"free_directions\": " << g.free_directions
    << ", \"chi2\": " << num(g.chi2) << ", \"noise_scale\": " << num(g.noise_scale) << ", \"samples\": " << g.samples
    << ", \"iterations\": " << g.iterations << ", \"solves_converged\": " << g.solves_converged
    << ", \"region_fraction\": " << num(g.region_fraction) << ", \"iou_mean\": " << num(g.iou_mean)
    << ", \"iou_p10\": " << num(g.iou_p10) << ", \"iou_p90\": " << num(g.iou_p90) << ", \"undetermined_fraction\": " << num(g.undetermined_fraction)
    << ", \"sentence\": " << quote(g.sentence) << "}";
  return s.str();
}

std::string identifiabilityJson(const IdentifiabilityAnalysis& a) {
  std::ostringstream s;
  s << "{\"available\": " << (a.available ? "true" : "false") << ", \"summary\": " << quote(a.summary)
    << ", \"observations\": " << a.observations << ", \"threshold\": " << num(a.threshold)
    << ", \"noise_scale\": " << num(a.noise_scale) << ", \"rank\": " << a.rank
    << ", \"determined_directions\": " << a.determined_directions << ", \"theta_parameters\": " << a.theta_parameters
    << ", \"theta_rank\": " << a.theta_rank << ", \"dp_dtheta_rank\": " << a.dp_dtheta_rank;
  if (a.available) {
    s << ", \"natural_units\": [";
    for (int j = 0; j < 10; ++j) s << (j ? ", " : "") << num(a.natural_units(j));
    s << "], \"singular_values\": [";
    for (int j = 0; j < 10; ++j) s << (j ? ", " : "") << num(a.singular_values(j));
    s << "], \"right_singular_vectors\": [";
    for (int k = 0; k < 10; ++k) {
      s << (k ? ", [" : "[");
      for (int j = 0; j < 10; ++j) s << (j ? ", " : "") << num(a.V(j, k));
      s << "]";
    }
    s << "], \"moments\": {";
    for (std::size_t j = 0; j < a.moments.size(); ++j) {
      const auto& m = a.moments[j];
      // An infinite std (a free moment) is written as null: JSON has no infinity.
      s << (j ? ", " : "") << quote(m.name) << ": {\"std\": " << (std::isfinite(m.std) ? num(m.std) : "null")
        << ", \"unit\": " << quote(m.unit) << ", \"natural_unit\": " << num(m.natural_unit)
        << ", \"std_relative\": " << (std::isfinite(m.std_relative) ? num(m.std_relative) : "null")
        << ", \"determined\": " << (m.determined ? "true" : "false") << "}";
    }
    s << "}";
  }
  s << ", \"suggestion\": ";
  if (a.has_suggestion) {
    const auto& g = a.suggestion;
    s << "{\"kind\": " << quote(g.kind) << ", \"sentence\": " << quote(g.sentence) << ", \"point\": " << vec3(g.point)
      << ", \"axis\": " << vec3(g.axis) << ", \"score_gain\": " << num(g.score_gain) << ", \"newly_determined\": [";
    for (std::size_t i = 0; i < g.newly_determined.size(); ++i) s << (i ? ", " : "") << quote(g.newly_determined[i]);
    s << "]}";
  } else {
    s << "null";
  }
  s << ", \"candidates_evaluated\": " << a.candidates.size() << ", \"notes\": [";
  for (std::size_t i = 0; i < a.notes.size(); ++i) s << (i ? ", " : "") << quote(a.notes[i]);
  s << "], \"seconds\": " << num(a.seconds) << "}";
  return s.str();
}

/// The "uncertainty" section: the designs that fit as well as the best (inference/design_spread.h).
std::string uncertaintyJson(const InferenceResult& r) {
  const DesignSpread& d = r.spread;
  if (!d.computed) return "{\"explored\": false, \"sentence\": \"not explored (restarts = 0 or cancelled)\"}";
  double low = 0;  // volume-free summary: particles whose confidence is below 1
  for (double c : d.confidence) low += c < 1.0 ? 1 : 0;
  std::ostringstream s;
  s << "{\"explored\": true, \"restarts\": " << d.restarts << ", \"tried\": " << d.tried
    << ", \"accepted_designs\": " << d.accepted << ", \"acceptance_rule\": " << quote(d.rule)
    << ", \"cancelled\": " << (d.cancelled ? "true" : "false")
    << ", \"undetermined_volume_fraction\": " << num(d.undetermined_fraction) << ", \"uncertain_particles\": " << low
    << ", \"solid_fraction\": [" << num(d.solid_fraction_min) << ", " << num(d.solid_fraction_max)
    << "], \"mass_kg\": [" << num(d.mass_min_kg) << ", " << num(d.mass_max_kg)
    << "], \"center_of_mass_min\": " << vec3(d.com_min_m) << ", \"center_of_mass_max\": " << vec3(d.com_max_m)
    << ", \"inertia_diagonal_min\": " << vec3(d.inertia_min) << ", \"inertia_diagonal_max\": " << vec3(d.inertia_max)
    << ", \"sentence\": " << quote(d.sentence) << ", \"seconds\": " << num(d.seconds) << ", \"designs\": [";
  for (std::size_t k = 0; k < d.designs.size(); ++k) {
    const SpreadDesign& x = d.designs[k];
    s << (k ? ", " : "")
      << "{\"pulled_to_solid_fraction\": " << (x.target_fraction < 0 ? "null" : num(x.target_fraction))
      << ", \"solid_fraction\": " << num(x.solid_fraction) << ", \"task_loss\": " << num(x.task_loss)
      << ", \"mass_kg\": " << num(x.mass.mass) << ", \"accepted\": " << (x.accepted ? "true" : "false")
      << ", \"evaluations\": " << x.evaluations;
    if (!x.note.empty()) s << ", \"note\": " << quote(x.note);
    s << "}";
  }
  s << "]}";
  return s.str();
}

}  // namespace

std::string simulationJson(const ProblemEvaluation& ev, const TaskConfig& config, const TaskGeometry& geometry) {
  std::ostringstream s;
  s << "{\"task\": " << quote(config.task()) << ", \"features\": " << featuresJson(ev.task.features)
    << ", \"loss\": " << num(ev.loss) << ", " << geometryJson(ev, geometry) << "}";
  return s.str();
}

std::string reportJson(const InferenceResult& r, const TaskConfig& config) {
  std::ostringstream s;
  s << "{\n  \"task\": " << quote(r.task) << ",\n  \"task_source\": " << quote(config.source())
    << ",\n  \"representation\": " << quote(r.representation) << ",\n  \"parameters\": {";
  bool first = true;
  for (const auto& sp : config.specs()) {
    if (sp.is_target || !config.has(sp.name)) continue;
    s << (first ? "" : ", ") << quote(sp.name) << ": " << quote(config.valueText(sp.name));
    first = false;
  }
  s << "},\n  \"targets\": " << allTargetsJson(config) << ",\n  \"experiments\": " << experimentsJson(r.final, config)
    << ",\n  \"initial_features\": " << featuresJson(r.initial.task.features)
    << ",\n  \"achieved_features\": " << featuresJson(r.final.task.features) << ",\n  \"start\": " << quote(r.start)
    << ",\n  \"theta\": [";
  for (Eigen::Index i = 0; i < r.theta.size(); ++i) s << (i ? ", " : "") << num(r.theta[i]);
  s << "]"
    << ",\n  \"initial_loss\": " << num(r.initial.loss) << ",\n  \"final_loss\": " << num(r.final.loss)
    << ",\n  \"converged\": " << (r.converged ? "true" : "false")
    << ",\n  \"optimizer_converged\": " << (r.optimizer.converged ? "true" : "false")
    << ",\n  \"targets_reached\": " << (r.targets_reached ? "true" : "false")
    << ",\n  \"cancelled\": " << (r.optimizer.cancelled ? "true" : "false") << ",\n  \"message\": " << quote(r.message)
    << ",\n  \"backend\": " << quote(r.backend) << ",\n  \"warnings\": [";
  for (std::size_t i = 0; i < r.warnings.size(); ++i) s << (i ? ", " : "") << quote(r.warnings[i]);
  s << "]"
    << ",\n  " << geometryJson(r.final, r.geometry)
    << ",\n  \"initial_center_of_mass\": " << vec3(r.initial.task.mass.com) << ",\n  \"particles\": " << r.r.size()
    << ",\n  \"uncertainty\": " << uncertaintyJson(r) << ",\n  \"grey_fraction\": " << num(r.grey_fraction)
    << ",\n  \"binarised\": "
    << (r.has_binarised ? "{\"solid_fraction\": " + num(r.binarised.solid_fraction) + ", \"loss\": " +
                              num(r.binarised.loss) + ", \"features\": " + featuresJson(r.binarised.task.features) + "}"
                        : std::string("null"))
    << ",\n  \"parameters_count\": " << r.theta.size() << ",\n  \"timings_s\": {\"setup\": " << num(r.setup_s)
    << ", \"optimize\": " << num(r.optimize_s) << ", \"per_evaluation\": " << num(r.evaluation_s)
    << "},\n  \"identifiability\": " << identifiabilityJson(r.identifiability)
    << ",\n  \"region_uncertainty\": " << regionJson(r.region) << ",\n  \"loss_history\": [";
  for (std::size_t i = 0; i < r.optimizer.history.size(); ++i) {
    const auto& h = r.optimizer.history[i];
    s << (i ? ", " : "") << "{\"iteration\": " << h.iteration << ", \"loss\": " << num(h.loss)
      << ", \"gradient_norm\": " << num(h.gradient_norm) << ", \"elapsed_s\": " << num(h.elapsed_s) << "}";
  }
  s << "]\n}\n";
  return s.str();
}

}  // namespace topo_gaussian::inference
