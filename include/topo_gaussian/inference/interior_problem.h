// InteriorProblem: θ → r (representation + pinned shell + sigmoid) → task loss + regularisers,
// and the gradient back to θ. This is the objective every optimiser minimises.
#pragma once

#include <Eigen/Core>
#include <memory>
#include <vector>

#include "topo_gaussian/inference/task.h"
#include "topo_gaussian/inference/task_config.h"
#include "topo_gaussian/physics/neighbor_list.h"
#include "topo_gaussian/physics/volume_cloud.h"
#include "topo_gaussian/topology/indicator.h"
#include "topo_gaussian/topology/representation.h"

namespace topo_gaussian::inference {

/// One experiment's part of an evaluation.
struct ExperimentEvaluation {
  std::string name;
  double weight = 1.0;
  TaskEvaluation eval;  ///< its loss (unweighted), features, signal
};

struct ProblemEvaluation {
  double loss = 0.0;       ///< task loss + regularisers
  double task_loss = 0.0;  ///< Σ_e w_e L_e over the experiments
  double volume_term = 0.0;
  double smoothness_term = 0.0;
  double solid_fraction = 0.0;  ///< Σ V_i r_i / Σ V_i
  /// The task's evaluation. With several experiments: every experiment's features, named
  /// "EXPERIMENT.feature", the weighted loss Σ_e w_e L_e, and the first experiment's signal and motion.
  TaskEvaluation task;
  std::vector<ExperimentEvaluation> experiments;  ///< one per experiment (one for a single task)
};

class InteriorProblem {
 public:
  /// The cloud must outlive the problem. Throws TopoError for invalid parameters.
  InteriorProblem(const TaskConfig& config, const VolumeCloud& cloud);

  int numParameters() const { return representation_->numParameters(); }
  /// The start design: initial_parameters when configured; else, for the quadric when an experiment
  /// is weighed (a mass_kg target) that the solid start does not match, weighedCavityStart(); else the
  /// representation's start (initial_field: fully solid). `note` (optional) says which, in words.
  Eigen::VectorXd initialParameters(std::string* note = nullptr) const;
  /// The weighed start: a sphere of the other material than the configured start's (hollow in a solid
  /// start; the solid, e.g. a heavy insert, when initial_field < 0 starts from the body material) centred
  /// on the particles' centroid, s(u) = ±(|u − u_c|² − ρ²) in the normalised frame, with ρ
  /// bisected until the design's mass Σ ρ(r_i) V_i equals the scale's reading m* to 1e-6 (relative).
  /// An unweighed solid start cannot leave its uniform density: a lower mass is reached fastest by
  /// lowering the constant c, a grey body with the solid's centre of mass and inertia per mass (on the
  /// tumbler demo 50 % of the volume grey, cavity IoU 0; from this start 0.72). Returns an empty vector
  /// when no experiment is weighed, the representation is not the quadric, or m* lies outside the
  /// masses such spheres reach (then the solid start stands). weighed_start: ellipsoid replaces the
  /// sphere by the volume's equivalent ellipsoid (s(u) = ±((u − u_c)ᵀ A (u − u_c) − ρ²), A = C⁻¹/5 with C
  /// the volume's covariance: ρ = 1 is the solid ellipsoid of the body's second moments), a shell's own
  /// shape. radius_m: the sphere's radius [m], or the ellipsoid's ρ (unitless).
  Eigen::VectorXd weighedCavityStart(double* mass_kg = nullptr, double* radius_m = nullptr) const;
  /// The largest scale reading (mass_kg target) among the experiments, 0 when none is weighed.
  double weighedMassKg() const;
  void bounds(Eigen::VectorXd* lo, Eigen::VectorXd* hi) const { representation_->bounds(lo, hi); }

  /// Loss (and gradient when grad != null) at θ.
  double evaluate(const Eigen::VectorXd& theta, Eigen::VectorXd* grad, ProblemEvaluation* details = nullptr) const;
  /// Loss and gradient w.r.t. r directly (for a given interior).
  ProblemEvaluation evaluateIndicator(const std::vector<double>& r, std::vector<double>* dL_dr) const;
  void indicator(const Eigen::VectorXd& theta, std::vector<double>* r) const;

  /// The first experiment's task (the only one for a single-experiment config).
  const Task& task() const { return *tasks_.front(); }
  std::size_t numExperiments() const { return tasks_.size(); }
  const Task& task(std::size_t e) const { return *tasks_.at(e); }
  const Experiment& experiment(std::size_t e) const { return experiments_.at(e); }
  /// Throws TopoError (naming the experiment) when a target a loss needs is missing.
  void requireTargets() const;
  /// Every task's notes, prefixed with its experiment's name when there are several.
  std::vector<std::string> notes() const;
  /// Polled by the task's simulations (Task::setShouldStop): true throws SimulationCancelled.
  void setShouldStop(const StopCheck& stop) {
    for (auto& t : tasks_) t->setShouldStop(stop);
  }
  const Representation& representation() const { return *representation_; }
  const IndicatorOptions& indicatorOptions() const { return indicator_; }
  const VolumeCloud& cloud() const { return cloud_; }
  const TaskConfig& config() const { return config_; }

 private:
  TaskConfig config_;
  const VolumeCloud& cloud_;
  std::vector<Experiment> experiments_;
  std::vector<std::unique_ptr<Task>> tasks_;
  std::unique_ptr<Representation> representation_;
  IndicatorOptions indicator_;
  NeighborList neighbors_;
  double w_volume_ = 0, target_fraction_ = -1, w_smooth_ = 0, total_volume_ = 1;
  /// The weighed start, made once in the constructor when the distance field needs to know it has a surface.
  Eigen::VectorXd weighed_start_;
  double weighed_start_mass_kg_ = 0, weighed_start_radius_ = 0;
};

}  // namespace topo_gaussian::inference
