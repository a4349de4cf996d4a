// FingerTwin: the default finger with a true chamber, solved at a ladder of pressures.
#include "topo_gaussian/workflow/finger_twin.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/number_text.h"
#include "topo_gaussian/inference/task_registry.h"
#include "topo_gaussian/workflow/shape_surface.h"

namespace topo_gaussian::workflow {

using namespace inference;  // the twin runs the finger task
namespace {

double featureValue(const ProblemEvaluation& ev, const std::string& name) {
  for (const auto& f : ev.task.features)
    if (f.name == name) return f.value;
  throw TopoError("finger twin: the finger task", "returned no feature " + name,
                  "the task must be the finger task (task: finger)");
}

/// Index k and weight w with p = (1 − w) p_k + w p_{k+1} (p clamped to the ladder).
void bracket(const std::vector<double>& levels, double p, std::size_t* k, double* w) {
  const double q = std::isfinite(p) ? std::min(std::max(p, levels.front()), levels.back()) : 0.0;
  std::size_t j = 0;
  while (j + 2 < levels.size() && q > levels[j + 1]) ++j;
  *k = j;
  *w = (q - levels[j]) / (levels[j + 1] - levels[j]);
}

}  // namespace

Eigen::VectorXd FingerTwin::defaultChamberQuadric() {
  // the ellipsoid Σ (u_i − c_i)² / a_i² < 1, c = (−0.2, 0, −0.04), a = (0.5, 0.12, 0.05), scaled by a_z²
  const Eigen::Vector3d c(-0.2, 0.0, -0.04), a(0.5, 0.12, 0.05);
  const double k = a.z() * a.z();
  Eigen::VectorXd theta = Eigen::VectorXd::Zero(10);
  double constant = -k;
  for (int i = 0; i < 3; ++i) {
    const double A = k / (a[i] * a[i]);
    theta[i] = A;
    theta[6 + i] = -2.0 * A * c[i];
    constant += A * c[i] * c[i];
  }
  theta[9] = constant;
  return theta;
}

FingerTwin::FingerTwin(const FingerTwinOptions& options) : options_(options) {
  const auto t0 = std::chrono::steady_clock::now();
  if (options_.pressure_levels < 2 || options_.pressure_levels > 100)
    throw TopoError("finger twin pressure levels " + std::to_string(options_.pressure_levels), "must be 2..100",
                    "use about 6 (the shape between levels is interpolated)");
  config_ = TaskConfig::load(options_.task, options_.task_dir);
  const TaskDefinition& definition = taskDefinition(config_.task());
  if (!definition.pressure_twin)  // a task this twin replays (TaskDefinition::pressure_twin)
    throw TopoError("finger twin task '" + options_.task + "'", "is the " + config_.task() + " task",
                    "give the finger task (or a YAML file with task: finger)");
  for (const auto& a : options_.overrides) config_.setAssignment(a, "finger twin set");
  config_.set("mode", "static", "finger twin");
  config_.set("representation", "quadric", "finger twin");
  if (options_.max_pressure_pa == 0.0) options_.max_pressure_pa = config_.number("pressure_pa");
  if (!(options_.max_pressure_pa > 0 && options_.max_pressure_pa < 1e8))
    throw TopoError("finger twin pressure " + numberText(options_.max_pressure_pa) + " Pa",
                    "must be a gauge pressure in (0, 1e8) Pa", "e.g. 5e5 (the paper's finger)");
  config_.setNumber("pressure_pa", options_.max_pressure_pa);

  shape_ = defaultShape(definition.default_shape);
  cloud_ = defaultShapeCloud(shape_, options_.spacing_m);  // throws naming the spacing
  std::vector<Eigen::Vector3d> points;
  projectSurfaceOntoShape(shape_, &cloud_, &points, &surface_normals_);
  for (std::size_t i = 0; i < cloud_.size(); ++i)
    if (cloud_.surface[i]) surface_index_.push_back(i);

  Eigen::VectorXd theta = options_.interior_quadric;
  if (theta.size() == 0) theta = defaultChamberQuadric();
  if (theta.size() != 10 || !theta.allFinite())
    throw TopoError("finger twin chamber quadric",
                    "must be 10 finite numbers [a_xx a_yy a_zz a_xy a_xz a_yz b_x b_y b_z c] (got " +
                        std::to_string(theta.size()) + ")",
                    "give θ of s(u) = uᵀAu + bᵀu + c (chamber where s < 0), or leave it empty for the default");
  options_.interior_quadric = theta;
  const InteriorProblem problem(config_, cloud_);
  problem.indicator(theta, &r_);
  std::size_t chamber = 0;
  for (double& v : r_) {
    v = v < 0.5 ? 0.0 : 1.0;  // a real chamber: air or wall, nothing between
    chamber += v == 0.0 ? 1 : 0;
  }
  if (chamber == 0 || chamber == r_.size())
    throw TopoError("finger twin chamber quadric",
                    chamber == 0 ? "holds no particle at spacing " + numberText(options_.spacing_m) + " m"
                                 : "holds every particle (no wall)",
                    "give a chamber inside the finger, larger than a spacing (or the default)");
  std::vector<double> m;
  problem.task().masses(r_, &m, nullptr);
  density_.resize(m.size());
  for (std::size_t i = 0; i < m.size(); ++i) density_[i] = m[i] / cloud_.V[i];

  for (int k = 0; k < options_.pressure_levels; ++k)
    levels_pa_.push_back(options_.max_pressure_pa * k / (options_.pressure_levels - 1));
  shapes_.push_back(cloud_.X);
  bend_deg_.push_back(0.0);
  for (std::size_t k = 1; k < levels_pa_.size(); ++k) {
    TaskConfig at = config_;
    at.setNumber("pressure_pa", levels_pa_[k]);
    try {
      const ProblemEvaluation ev = InteriorProblem(at, cloud_).evaluateIndicator(r_, nullptr);
      if (ev.task.shapes.size() < 2)
        throw TopoError("the finger task", "returned no deformed shape", "report this: finger_task.cpp sets shapes");
      shapes_.push_back(ev.task.shapes.back());
      bend_deg_.push_back(featureValue(ev, "bend_angle_deg"));
      if (k + 1 == levels_pa_.size()) truth_ = ev;
    } catch (const TopoError& e) {
      throw TopoError("finger twin: the equilibrium at " + numberText(levels_pa_[k]) + " Pa failed: " + e.what());
    }
  }
  setup_s_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

double FingerTwin::solidFraction() const {
  double solid = 0, total = 0;
  for (std::size_t i = 0; i < r_.size(); ++i) solid += r_[i] * cloud_.V[i], total += cloud_.V[i];
  return solid / total;
}

double FingerTwin::chamberVolumeM3() const {
  double v = 0;
  for (std::size_t i = 0; i < r_.size(); ++i) v += (1.0 - r_[i]) * cloud_.V[i];
  return v;
}

double FingerTwin::bendDeg(double pressure_pa) const {
  std::size_t k;
  double w;
  bracket(levels_pa_, pressure_pa, &k, &w);
  return (1.0 - w) * bend_deg_[k] + w * bend_deg_[k + 1];
}

std::vector<Eigen::Vector3d> FingerTwin::positionsAt(double pressure_pa) const {
  std::size_t k;
  double w;
  bracket(levels_pa_, pressure_pa, &k, &w);
  std::vector<Eigen::Vector3d> x(cloud_.size());
  for (std::size_t i = 0; i < x.size(); ++i) x[i] = (1.0 - w) * shapes_[k][i] + w * shapes_[k + 1][i];
  return x;
}

}  // namespace topo_gaussian::workflow
