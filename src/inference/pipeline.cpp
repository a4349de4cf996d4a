#include "topo_gaussian/inference/pipeline.h"

#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <sstream>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/json.h"
#include "topo_gaussian/common/stopwatch.h"
#include "topo_gaussian/inference/task_registry.h"

namespace topo_gaussian::inference {
namespace {

using topo_gaussian::Clock;
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

std::string targetsJson(const TaskConfig& c) {
  std::string s = "{";
  bool first = true;
  for (const auto& sp : c.specs())
    if (sp.is_target && c.has(sp.name)) {
      s += (first ? "" : ", ") + quote(sp.name) + ": ";
      if (sp.type == ParamType::Text) s += quote(c.text(sp.name));
      else if (sp.type == ParamType::List) {
        s += "[";
        const auto& l = c.list(sp.name);
        for (std::size_t i = 0; i < l.size(); ++i) s += (i ? ", " : "") + num(l[i]);
        s += "]";
      } else s += num(c.number(sp.name));
      first = false;
    }
  return s + "}";
}

}  // namespace

ProblemEvaluation simulateInterior(const TaskConfig& config, const VolumeCloud& cloud, const std::vector<double>& r_in) {
  InteriorProblem problem(config, cloud);
  std::vector<double> r = r_in.empty() ? std::vector<double>(cloud.size(), 1.0) : r_in;
  if (r.size() != cloud.size())
    throw TopoError("interior", "has " + std::to_string(r.size()) + " values for " + std::to_string(cloud.size()) + " particles",
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

InferenceResult runInference(const TaskConfig& config, const VolumeCloud& cloud, const ProgressCallback& progress,
                             const EvaluationCallback& on_evaluation) {
  const auto t0 = Clock::now();
  InteriorProblem problem(config, cloud);
  problem.task().requireTargets();
  InferenceResult res;
  res.task = config.task();
  res.representation = problem.representation().name();
  res.geometry = problem.task().geometry();
  const Eigen::VectorXd theta0 = problem.initialParameters();
  Eigen::VectorXd lo, hi, g;
  problem.bounds(&lo, &hi);
  const auto te = Clock::now();
  problem.evaluate(theta0, &g, &res.initial);
  res.evaluation_s = secondsSince(te);
  res.setup_s = secondsSince(t0) - res.evaluation_s;
  OptimizerOptions oo;
  oo.method = config.text("optimizer");
  oo.max_iterations = config.integer("max_iterations");
  oo.learning_rate = config.number("learning_rate");
  oo.loss_tolerance = config.number("loss_tolerance");
  oo.relative_tolerance = config.number("relative_tolerance");
  oo.gradient_tolerance = config.number("gradient_tolerance");
  const auto to = Clock::now();
  const auto objective = [&](const Eigen::VectorXd& th, Eigen::VectorXd* gr) {
    if (!on_evaluation) return problem.evaluate(th, gr);
    ProblemEvaluation details;
    const double loss = problem.evaluate(th, gr, &details);
    on_evaluation(details);
    return loss;
  };
  res.optimizer = minimize(objective, theta0, lo, hi, oo, progress);
  res.optimize_s = secondsSince(to);
  if (res.optimizer.iterations > 0) res.evaluation_s = res.optimize_s / res.optimizer.iterations;
  res.theta = res.optimizer.theta;
  problem.evaluate(res.theta, nullptr, &res.final);
  problem.indicator(res.theta, &res.r);
  problem.task().density().apply(res.r, &res.density, nullptr);

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
  head << "task " << res.task << " (" << res.representation << "): loss " << res.initial.loss << " -> " << res.final.loss
       << " in " << res.optimizer.iterations << " evaluations; " << res.optimizer.message << ". ";
  if (res.targets_reached) {
    head << "All targets reached.";
  } else if (res.optimizer.converged) {
    head << msg.str() << "The optimiser converged, so no interior of this representation within the material bounds "
         << "reaches the target: the value above is the nearest reachable one (check the target, the hanging/support "
         << "point, or allow more material contrast).";
  } else {
    head << msg.str() << "Not converged: raise max_iterations or try another optimizer/representation.";
  }
  res.message = head.str();
  return res;
}

void writeInteriorPly(const std::string& path, const VolumeCloud& cloud, const std::vector<double>& r,
                      const std::vector<double>& density, bool continuous) {
  std::ofstream out(path, std::ios::binary);
  if (!out) throw TopoError(path, "cannot be written", "check the directory exists and is writable");
  out << "ply\nformat binary_little_endian 1.0\ncomment topo_gaussian interior: solid = r >= 0.5"
      << (continuous ? " (continuous material: r is the density fraction)" : "") << "\nelement vertex " << cloud.size()
      << "\nproperty float x\nproperty float y\nproperty float z\nproperty float r\nproperty uchar solid\n"
         "property float density\nend_header\n";
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const float v[4] = {float(cloud.X[i].x()), float(cloud.X[i].y()), float(cloud.X[i].z()), float(r[i])};
    const unsigned char s = r[i] >= 0.5 ? 1 : 0;
    const float d = float(density[i]);
    out.write(reinterpret_cast<const char*>(v), sizeof v);
    out.write(reinterpret_cast<const char*>(&s), 1);
    out.write(reinterpret_cast<const char*>(&d), sizeof d);
  }
  if (!out) throw TopoError(path, "write failed", "check the free disk space");
}

InteriorPly readInteriorPlyData(const std::string& path, std::size_t expected) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw TopoError(path, "cannot open the interior file", "check the path (an interior.ply written by topo infer)");
  std::string line;
  std::size_t count = 0;
  bool header_ok = false;
  InteriorPly out;
  std::getline(in, line);
  if (line.rfind("ply", 0) != 0) throw TopoError(path, "is not a PLY file", "give an interior.ply written by topo infer");
  std::vector<std::string> props;
  while (std::getline(in, line)) {
    if (line.rfind("element vertex", 0) == 0) {
      try {
        count = std::stoul(line.substr(15));
      } catch (const std::exception&) {
        throw TopoError(path, "has a malformed line '" + line.substr(0, 60) + "'", "write it with topo infer");
      }
    } else if (line.rfind("property", 0) == 0) props.push_back(line);
    else if (line.rfind("comment", 0) == 0 && line.find("continuous material") != std::string::npos) out.continuous = true;
    else if (line == "end_header") { header_ok = true; break; }
  }
  const std::vector<std::string> want = {"property float x", "property float y", "property float z", "property float r",
                                         "property uchar solid", "property float density"};
  if (!header_ok || props != want)
    throw TopoError(path, "does not have the interior layout (x y z r solid density)", "write it with topo infer");
  if (count != expected)
    throw TopoError(path, "has " + std::to_string(count) + " particles, the volume has " + std::to_string(expected),
                    "use the interior computed on this volume");
  out.X.resize(count);
  out.r.resize(count);
  out.density.resize(count);
  for (std::size_t i = 0; i < count; ++i) {
    char buf[21];
    in.read(buf, sizeof buf);
    if (!in) throw TopoError(path, "ends early at particle " + std::to_string(i), "the file is truncated: write it again");
    float v[4], d;
    std::memcpy(v, buf, 16);
    std::memcpy(&d, buf + 17, 4);
    out.X[i] = Eigen::Vector3d(v[0], v[1], v[2]);
    out.r[i] = v[3];
    out.density[i] = d;
  }
  return out;
}

std::vector<double> readInteriorPly(const std::string& path, std::size_t expected) {
  return readInteriorPlyData(path, expected).r;
}

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
  s << "},\n  \"targets\": " << targetsJson(config) << ",\n  \"initial_features\": " << featuresJson(r.initial.task.features)
    << ",\n  \"achieved_features\": " << featuresJson(r.final.task.features) << ",\n  \"initial_loss\": " << num(r.initial.loss)
    << ",\n  \"final_loss\": " << num(r.final.loss) << ",\n  \"converged\": " << (r.converged ? "true" : "false")
    << ",\n  \"optimizer_converged\": " << (r.optimizer.converged ? "true" : "false")
    << ",\n  \"targets_reached\": " << (r.targets_reached ? "true" : "false")
    << ",\n  \"cancelled\": " << (r.optimizer.cancelled ? "true" : "false") << ",\n  \"message\": " << quote(r.message)
    << ",\n  " << geometryJson(r.final, r.geometry) << ",\n  \"initial_center_of_mass\": " << vec3(r.initial.task.mass.com)
    << ",\n  \"particles\": " << r.r.size() << ",\n  \"parameters_count\": " << r.theta.size()
    << ",\n  \"timings_s\": {\"setup\": " << num(r.setup_s) << ", \"optimize\": " << num(r.optimize_s)
    << ", \"per_evaluation\": " << num(r.evaluation_s) << "},\n  \"loss_history\": [";
  for (std::size_t i = 0; i < r.optimizer.history.size(); ++i) {
    const auto& h = r.optimizer.history[i];
    s << (i ? ", " : "") << "{\"iteration\": " << h.iteration << ", \"loss\": " << num(h.loss)
      << ", \"gradient_norm\": " << num(h.gradient_norm) << ", \"elapsed_s\": " << num(h.elapsed_s) << "}";
  }
  s << "]\n}\n";
  return s.str();
}

}  // namespace topo_gaussian::inference
