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

struct ProblemEvaluation {
  double loss = 0.0;  ///< task loss + regularisers
  double task_loss = 0.0;
  double volume_term = 0.0;
  double smoothness_term = 0.0;
  double solid_fraction = 0.0;  ///< Σ V_i r_i / Σ V_i
  TaskEvaluation task;
};

class InteriorProblem {
 public:
  /// The cloud must outlive the problem. Throws TopoError for invalid parameters.
  InteriorProblem(const TaskConfig& config, const VolumeCloud& cloud);

  int numParameters() const { return representation_->numParameters(); }
  /// The representation's start (initial_field), or initial_parameters when configured.
  Eigen::VectorXd initialParameters() const;
  void bounds(Eigen::VectorXd* lo, Eigen::VectorXd* hi) const { representation_->bounds(lo, hi); }

  /// Loss (and gradient when grad != null) at θ.
  double evaluate(const Eigen::VectorXd& theta, Eigen::VectorXd* grad, ProblemEvaluation* details = nullptr) const;
  /// Loss and gradient w.r.t. r directly (for a given interior).
  ProblemEvaluation evaluateIndicator(const std::vector<double>& r, std::vector<double>* dL_dr) const;
  void indicator(const Eigen::VectorXd& theta, std::vector<double>* r) const;

  const Task& task() const { return *task_; }
  /// Polled by the task's simulations (Task::setShouldStop): true throws SimulationCancelled.
  void setShouldStop(StopCheck stop) { task_->setShouldStop(std::move(stop)); }
  const Representation& representation() const { return *representation_; }
  const IndicatorOptions& indicatorOptions() const { return indicator_; }
  const VolumeCloud& cloud() const { return cloud_; }
  const TaskConfig& config() const { return config_; }

 private:
  TaskConfig config_;
  const VolumeCloud& cloud_;
  std::unique_ptr<Task> task_;
  std::unique_ptr<Representation> representation_;
  IndicatorOptions indicator_;
  NeighborList neighbors_;
  double w_volume_ = 0, target_fraction_ = -1, w_smooth_ = 0, total_volume_ = 1;
};

}  // namespace topo_gaussian::inference
