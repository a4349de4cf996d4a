#include "topo_gaussian/inference/interior_problem.h"

#include <algorithm>
#include <cmath>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/number_text.h"
#include "topo_gaussian/topology/quadric_representation.h"

namespace topo_gaussian::inference {

namespace {
/// A TopoError from experiment e, prefixed with its name when there are several.
TopoError inExperiment(const std::vector<Experiment>& experiments, std::size_t e, const TopoError& error, bool named) {
  if (!named) return error;
  return TopoError("experiment '" + experiments[e].name + "' (" + experiments[e].config.task() + "): " + error.what());
}
}  // namespace

InteriorProblem::InteriorProblem(const TaskConfig& config, const VolumeCloud& cloud) : config_(config), cloud_(cloud) {
  experiments_ = config_.experimentList();
  for (std::size_t e = 0; e < experiments_.size(); ++e) {
    try {
      tasks_.push_back(makeTask(experiments_[e].config, cloud_));
    } catch (const TopoError& error) {
      throw inExperiment(experiments_, e, error, config_.hasExperiments());
    }
  }
  RepresentationOptions ro;
  ro.kind = config_.text("representation");
  ro.initial_field = config_.number("initial_field");
  ro.point_bound = config_.number("point_bound");
  ro.neural.depth = config_.integer("neural_depth");
  ro.neural.width = config_.integer("neural_width");
  ro.neural.seed = static_cast<unsigned>(config_.integer("neural_seed"));
  ro.neural.initial_field = ro.initial_field;
  ro.neural.backend = parseComputeBackend(config_.text("backend"), "task parameter backend");
  representation_ = makeRepresentation(ro, cloud_.X);
  indicator_.epsilon = config_.number("epsilon");
  if (config_.boolean("pin_shell"))
    indicator_.pinned = boundaryShell(cloud_.X, cloud_.surface, config_.number("shell_thickness_m"));
  w_volume_ = config_.number("weight_volume");
  target_fraction_ = config_.number("target_solid_fraction");
  w_smooth_ = config_.number("weight_smoothness");
  total_volume_ = cloud_.totalVolume();
  if (w_smooth_ > 0) {
    double radius = config_.number("smoothness_radius_m");
    if (radius <= 0) radius = 1.5 * cloud_.spacing;  // carried by the volume (the task validated it)
    neighbors_ = buildNeighborList(cloud_.X, radius);
  }
  // After the pinned shell: the weighed start's bisection uses the indicator.
  if (auto* quadric = dynamic_cast<QuadricRepresentation*>(representation_.get())) {
    const std::string field = config_.text("quadric_field");
    if (field == "distance" || (field == "auto" && weighedMassKg() > 0)) {
      double w = config_.number("quadric_boundary_m");
      if (!(w > 0)) w = 0.5 * cloud_.spacing;
      quadric->setDistanceUnit(w / (indicator_.epsilon * quadric->frame().scale));
      // The distance field of a constant design (A = b = 0: no surface) has no gradient: the start must
      // have a surface. auto keeps the paper's field when the weighed start is not made.
      const std::vector<double>& given = config_.list("initial_parameters");
      Eigen::VectorXd start;
      if (given.size() == QuadricRepresentation::kNumParameters)
        start = Eigen::Map<const Eigen::VectorXd>(given.data(), static_cast<Eigen::Index>(given.size()));
      else if (given.empty())
        start = weighed_start_ = weighedCavityStart(&weighed_start_mass_kg_, &weighed_start_radius_);
      if (start.size() == QuadricRepresentation::kNumParameters && start.head<9>().norm() > 0) {
        // the distance field stands
      } else if (field == "auto") {
        quadric->setDistanceUnit(0.0);
        weighed_start_.resize(0);
      } else if (given.empty() || given.size() == QuadricRepresentation::kNumParameters) {
        throw TopoError("quadric_field distance",
                        "the start design has no surface (A = b = 0, a constant field), where the distance field "
                        "has no gradient",
                        "weigh the object (a mass_kg target) for the weighed start, give initial_parameters of a "
                        "design with a surface (e.g. the sphere 1,1,1,0,0,0,0,0,0,-0.25), or use quadric_field "
                        "algebraic");
      }
    }
  }
}

void InteriorProblem::indicator(const Eigen::VectorXd& theta, std::vector<double>* r) const {
  ::topo_gaussian::evaluateIndicator(*representation_, theta, indicator_, r);
}

ProblemEvaluation InteriorProblem::evaluateIndicator(const std::vector<double>& r, std::vector<double>* dL_dr) const {
  ProblemEvaluation ev;
  std::vector<double> dLe;
  for (std::size_t e = 0; e < tasks_.size(); ++e) {
    ExperimentEvaluation xe{experiments_[e].name, experiments_[e].weight, {}};
    try {
      xe.eval = tasks_[e]->evaluate(r, dL_dr ? (e == 0 ? dL_dr : &dLe) : nullptr);
    } catch (const TopoError& error) {
      throw inExperiment(experiments_, e, error, config_.hasExperiments());
    }
    if (dL_dr) {
      if (e == 0) {
        if (xe.weight != 1.0)
          for (double& d : *dL_dr) d *= xe.weight;
      } else {
        for (std::size_t i = 0; i < r.size(); ++i) (*dL_dr)[i] += xe.weight * dLe[i];
      }
    }
    ev.task_loss += xe.weight * xe.eval.loss;
    ev.experiments.push_back(std::move(xe));
  }
  if (!config_.hasExperiments()) {
    ev.task = ev.experiments.front().eval;
  } else {
    ev.task = ev.experiments.front().eval;
    ev.task.features.clear();
    for (const auto& xe : ev.experiments)
      for (Feature f : xe.eval.features) {
        f.name = xe.name + kExperimentKeySeparator + f.name;
        ev.task.features.push_back(std::move(f));
      }
  }
  ev.task.loss = ev.task_loss;
  double solid = 0;
  for (std::size_t i = 0; i < r.size(); ++i) solid += cloud_.V[i] * r[i];
  ev.solid_fraction = solid / total_volume_;
  if (w_volume_ > 0) {
    // Minimise material (fraction), or pull it to the target fraction.
    double dterm;
    if (target_fraction_ < 0) {
      ev.volume_term = w_volume_ * ev.solid_fraction;
      dterm = w_volume_;
    } else {
      const double e = ev.solid_fraction - target_fraction_;
      ev.volume_term = w_volume_ * e * e;
      dterm = 2 * w_volume_ * e;
    }
    if (dL_dr)
      for (std::size_t i = 0; i < r.size(); ++i) (*dL_dr)[i] += dterm * cloud_.V[i] / total_volume_;
  }
  if (w_smooth_ > 0 && neighbors_.size() == r.size()) {
    double sum = 0;
    long pairs = 0;
    for (std::size_t i = 0; i < r.size(); ++i)
      for (int k = neighbors_.offsets[i]; k < neighbors_.offsets[i + 1]; ++k) {
        const double d = r[i] - r[neighbors_.indices[k]];
        sum += d * d;
        ++pairs;
      }
    if (pairs > 0) {
      ev.smoothness_term = w_smooth_ * sum / pairs;
      if (dL_dr)
        for (std::size_t i = 0; i < r.size(); ++i)
          for (int k = neighbors_.offsets[i]; k < neighbors_.offsets[i + 1]; ++k) {
            // each unordered pair appears twice (i→j and j→i): d/dr_i of both terms is 4 (r_i − r_j)
            (*dL_dr)[i] += w_smooth_ * 4.0 * (r[i] - r[neighbors_.indices[k]]) / pairs;
          }
    }
  }
  ev.loss = ev.task_loss + ev.volume_term + ev.smoothness_term;
  return ev;
}

void InteriorProblem::requireTargets() const {
  for (std::size_t e = 0; e < tasks_.size(); ++e) {
    try {
      tasks_[e]->requireTargets();
    } catch (const TopoError& error) {
      throw inExperiment(experiments_, e, error, config_.hasExperiments());
    }
  }
}

std::vector<std::string> InteriorProblem::notes() const {
  std::vector<std::string> out;
  for (std::size_t e = 0; e < tasks_.size(); ++e)
    for (const auto& n : tasks_[e]->notes())
      out.push_back(config_.hasExperiments() ? "experiment " + experiments_[e].name + ": " + n : n);
  return out;
}

Eigen::VectorXd InteriorProblem::initialParameters(std::string* note) const {
  const std::vector<double>& given = config_.list("initial_parameters");
  if (given.empty()) {
    double mass = weighed_start_mass_kg_, radius = weighed_start_radius_;
    Eigen::VectorXd theta = weighed_start_.size() > 0 ? weighed_start_ : weighedCavityStart(&mass, &radius);
    if (theta.size() > 0) {
      if (note)
        *note = "start: the weighed mass " + numberText(weighedMassKg(), 6) + " kg from " +
                (config_.text("weighed_start") == "ellipsoid"
                     ? "the volume's equivalent ellipsoid of the other material, centred on its centroid, scaled by " +
                           numberText(radius, 4)
                     : "a sphere of the other material centred on the volume's centroid, radius " +
                           numberText(radius, 4) + " m") +
                " (design mass " + numberText(mass, 6) + " kg; initial_parameters overrides it)";
      return theta;
    }
    if (note) *note = "start: " + representation_->name() + " fully solid (initial_field)";
    return representation_->initialParameters();
  }
  if (static_cast<int>(given.size()) != representation_->numParameters())
    throw TopoError("initial_parameters",
                    "has " + std::to_string(given.size()) + " values but the " + representation_->name() +
                        " representation has " + std::to_string(representation_->numParameters()) + " parameters",
                    "give one value per parameter, or leave it empty to start from initial_field");
  if (note) *note = "start: initial_parameters";
  return Eigen::Map<const Eigen::VectorXd>(given.data(), static_cast<Eigen::Index>(given.size()));
}

double InteriorProblem::weighedMassKg() const {
  double m = 0.0;
  for (const auto& x : experiments_)
    if (x.config.has("mass_kg")) m = std::max(m, x.config.number("mass_kg"));
  return m;
}

Eigen::VectorXd InteriorProblem::weighedCavityStart(double* mass_kg, double* radius_m) const {
  const double target = weighedMassKg();
  const auto* quadric = dynamic_cast<const QuadricRepresentation*>(representation_.get());
  if (!(target > 0) || !quadric || cloud_.X.empty()) return {};
  const NormalisedFrame& f = quadric->frame();
  const Eigen::Vector3d uc = (cloud_.centroid() - f.centre) / f.scale;
  // The region's shape: A = 1 (a sphere), or the volume's equivalent ellipsoid A = C⁻¹/5 (C the volume's
  // covariance in u; a solid ellipsoid of semi-axes a_k has C = diag(a_k²)/5, so ρ = 1 is the body's own).
  Eigen::Matrix3d A = Eigen::Matrix3d::Identity();
  if (config_.text("weighed_start") == "ellipsoid") {
    Eigen::Matrix3d C = Eigen::Matrix3d::Zero();
    double volume = 0;
    for (std::size_t i = 0; i < cloud_.size(); ++i) {
      const Eigen::Vector3d d = (cloud_.X[i] - f.centre) / f.scale - uc;
      C += cloud_.V[i] * d * d.transpose();
      volume += cloud_.V[i];
    }
    C /= volume;
    if (C.determinant() > 0) A = C.inverse() / 5.0;
  }
  double reach = 0;
  for (const auto& x : cloud_.X) {
    const Eigen::Vector3d d = (x - f.centre) / f.scale - uc;
    reach = std::max(reach, std::sqrt(d.dot(A * d)));
  }
  std::vector<double> r, m;
  // The other material than the configured start's: hollow in a solid start (initial_field ≥ 0), the
  // solid (e.g. a heavy insert) in a start of the other material (initial_field < 0).
  const double sign = config_.number("initial_field") >= 0 ? 1.0 : -1.0;
  const Eigen::Vector3d b = -2.0 * A * uc;
  const auto design = [&](double rho) {  // s(u) = ±((u − u_c)ᵀ A (u − u_c) − ρ²)
    Eigen::VectorXd theta(10);
    theta << A(0, 0), A(1, 1), A(2, 2), A(0, 1), A(0, 2), A(1, 2), b.x(), b.y(), b.z(), uc.dot(A * uc) - rho * rho;
    return Eigen::VectorXd(sign * theta);
  };
  const auto mass = [&](double rho) {
    indicator(design(rho), &r);
    task().masses(r, &m, nullptr);
    double sum = 0;
    for (double v : m) sum += v;
    return sum;
  };
  // The mass is monotone in ρ (the sphere of the other material grows); bisect on its sign change.
  double lo = 0.0, hi = reach + 1.0;
  const double m_lo = mass(lo), m_hi = mass(hi);
  if (!((m_lo - target) * (m_hi - target) < 0)) return {};
  for (int k = 0; k < 100 && hi - lo > 1e-12; ++k) {
    const double mid = 0.5 * (lo + hi), m_mid = mass(mid);
    if (std::abs(m_mid - target) <= 1e-6 * target) {
      lo = hi = mid;
      break;
    }
    ((m_mid - target) * (m_lo - target) > 0 ? lo : hi) = mid;
  }
  const double rho = 0.5 * (lo + hi);
  if (mass_kg) *mass_kg = mass(rho);
  if (radius_m) *radius_m = config_.text("weighed_start") == "ellipsoid" ? rho : rho * f.scale;
  return design(rho);
}

double InteriorProblem::evaluate(const Eigen::VectorXd& theta, Eigen::VectorXd* grad,
                                 ProblemEvaluation* details) const {
  if (!theta.allFinite())
    throw TopoError("design parameters", "contain NaN or infinity",
                    "restart from the initial design (the optimiser diverged)");
  std::vector<double> r;
  indicator(theta, &r);
  std::vector<double> dL_dr;
  ProblemEvaluation ev = evaluateIndicator(r, grad ? &dL_dr : nullptr);
  if (!std::isfinite(ev.loss))
    throw TopoError("loss of task '" + task().name() + "'", "is not finite", "check the task parameters and targets");
  if (grad) indicatorBackward(*representation_, theta, indicator_, dL_dr, grad);
  if (details) *details = std::move(ev);
  return ev.loss;
}

}  // namespace topo_gaussian::inference
