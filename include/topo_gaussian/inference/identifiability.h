// What the observations determine (paper §6.1: a rigid motion depends on the interior only
// through the ten mass properties p = (m, cx, cy, cz, Ixx, Iyy, Izz, Ixy, Ixz, Iyz)).
//
// Every rigid experiment e reports observations y_k with noise σ_k and dy_k/dp (task.h Observation).
// Linearised at the design r, the stacked, whitened Jacobian
//   J_kj = √w_e · (∂y_k/∂p_j) / σ_k · u_j       (n × 10, dimensionless)
// in units of each moment's own size at the design (m, c, I): u = (m, k, k, k, Ixx, Iyy, Izz, √(Ixx Iyy),
// √(Ixx Izz), √(Iyy Izz)) with k = √(tr I / 2m) the radius of gyration — gives the Gauss–Newton
// covariance of p/u, scaled by the fit's own residual:
//   Cov = σ̂² (JᵀJ)⁺,   std_j = u_j √Cov_jj,   σ̂ = fitNoiseScale(χ², n − rank)
// (χ² = Σ whitened residuals² of the n measured observations; √(χ² / its lower decile) with n − rank
// degrees of freedom, the region analysis's σ̂; 1 without redundant observations), with a moment
// FREE (std = ∞) when its component in the null space of J, √Σ_null V_jk², reaches the threshold; a
// smaller one (a free direction one natural unit long moves it by less than the threshold: a hang's
// noisy rest pitch couples cx to a free cz by its sine) adds to the variance,
//   std_j/u_j = √(σ̂² Σ_pinned V_jk²/s_k² + Σ_null V_jk²).   A moment is DETERMINED when
// std_j < threshold · u_j (default 2 % of its own size: an inertia known to 2 % of itself, not of
// m L², which for a box is about a third of its principal moments). The singular values s_k of J say how well each
// direction V_k of p/u is pinned: its std is 1/s_k natural units. Through the representation,
// J_θ = J · diag(1/u) · dp/dθ (dp/dθ: the indicator chain's backward pass, one per moment) has the rank
// the observations give the design parameters θ.
// Next experiment: candidates the object admits (hang from ~40 surface points; rock about other
// horizontal axes when a tumbler experiment is present; swing on a horizontal axle along world x and then
// y through each of those hanging points: hanging's axle_swing_period_s and cross_axle_swing_period_s),
// each built as a TaskConfig (task defaults + the experiment's and the object's shared
// parameters) and evaluated at r; the best one most lowers Σ_j log min(std_j/u_j, 1). A rock (its
// prediction leans on the contact surface the design rocks on, a hang's or swing's on the moments alone)
// is suggested over the best hang or swing only when it fixes a moment or a combination that one does not.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "topo_gaussian/inference/interior_problem.h"
#include "topo_gaussian/inference/task.h"
#include "topo_gaussian/inference/task_config.h"
#include "topo_gaussian/physics/volume_cloud.h"

namespace topo_gaussian::inference {

using MomentJacobian = Eigen::Matrix<double, Eigen::Dynamic, 10>;  ///< rows: observations, columns: p
using MomentVector = Eigen::Matrix<double, 10, 1>;

struct MomentIdentification {
  std::string name;   ///< "m", "cx", ..., "Iyz"
  std::string words;  ///< "the mass", "the centre of mass along x", "the inertia Ixx"
  std::string unit;   ///< "kg", "m", "kg m^2"
  double natural_unit = 1.0;
  double std = 0.0;           ///< linearised standard deviation [unit]; +inf when free (header)
  double std_relative = 0.0;  ///< std / natural_unit
  bool determined = false;    ///< std_relative < threshold
};

struct ExperimentSuggestion {
  std::string kind;  ///< "hang", "swing" (hang there on an axle and time the swing) or "rock"
  TaskConfig config;
  Eigen::Vector3d point = Eigen::Vector3d::Zero();  ///< hanging point, body frame [m] (hang, swing)
  Eigen::Vector3d axis = Eigen::Vector3d::Zero();   ///< rocking axis, body frame (rock); the first axle, world (swing)
  double score_gain = 0.0;                          ///< decrease of Σ_j log min(std_j/u_j, 1)
  std::vector<std::string> newly_determined;        ///< moment names that become determined
  int directions_after = 0;                         ///< determined directions with this experiment added
  std::string sentence;                             ///< "hang it from (x, y, z) m to fix ..."
};

struct IdentifiabilityOptions {
  double determined_threshold = 0.02;  ///< std below this fraction of the natural unit: determined
  int hanging_candidates = 40;         ///< surface points tried as hanging points
  bool swing_candidates = true;        ///< also swinging on an axle there (false: a lab without an axle)
  int max_dynamic_candidates = 3;      ///< rocking axes tried (each one simulation)
  double max_dynamic_seconds = 20.0;   ///< no further dynamic candidate once this much time is spent
  double max_theta_seconds = 10.0;     ///< budget of the backward passes for the θ ranks
  bool suggest = true;
};

struct IdentifiabilityAnalysis {
  bool available = false;          ///< false: no experiment reports observations (notes say why)
  std::vector<std::string> notes;  ///< for a person (experiments without observations, skipped candidates)
  int observations = 0;            ///< rows of J
  double threshold = 0.02;         ///< determined: std below threshold · natural unit
  /// σ̂: the moments' stds are this many times what the tolerances alone give (see the header)
  double noise_scale = 1.0;
  MomentVector natural_units = MomentVector::Ones();
  MomentJacobian J;                              ///< whitened, in natural units (see the header comment)
  MomentVector singular_values;                  ///< of J, descending [1 / natural unit]
  Eigen::Matrix<double, 10, 10> V;               ///< right singular vectors (columns), in natural units
  int rank = 0;                                  ///< numerical rank of J (s > 1e-12 s_max)
  int determined_directions = 0;                 ///< directions with 1/s_k < threshold
  std::vector<MomentIdentification> moments;     ///< ten, in p order
  int theta_parameters = 0;                      ///< size of θ (0 when not analysed)
  int dp_dtheta_rank = -1;                       ///< rank of dp/dθ: moments the representation can move
  int theta_rank = -1;                           ///< rank of J_θ
  std::vector<ExperimentSuggestion> candidates;  ///< evaluated, best first
  bool has_suggestion = false;
  ExperimentSuggestion suggestion;
  std::string summary;  ///< words: what is determined, what is free, what to do
  double seconds = 0.0;
};

/// u = (M, L, L, L, M L² ×6) for the fully solid mass M [kg] and size L [m]: the units of a design
/// without mass or inertia of its own.
MomentVector naturalMomentUnits(double solid_mass_kg, double size_m);
/// Each moment's own size at the design (the header's u); naturalMomentUnits(solid_mass_kg, size_m)
/// when the design has no positive mass or inertia.
MomentVector ownMomentScales(const MassProperties& design, double solid_mass_kg, double size_m);

/// χ² of the evaluation's measured observations (whitened: √w (y − y*)/σ per row, in the rows' order of
/// appendObservationRows) and their count n (weight-0 experiments' rows left out).
struct MeasuredResidual {
  Eigen::VectorXd residual;  ///< one per measured observation row (0 for a weight-0 experiment's)
  double chi2 = 0.0;
  int count = 0;
};
MeasuredResidual measuredResidual(const ProblemEvaluation& at);
/// The lower decile of χ² with k degrees of freedom (Wilson–Hilferty; k ≥ 1).
double chiSquareLowerDecile(int k);
/// σ̂ = √(χ² / χ²₀.₁(dof)), the observations' noise in units of their tolerances estimated from a fit's
/// residual (the lower decile: on the large side for few degrees of freedom), floored at 0.01; 1 without
/// redundant observations (dof ≤ 0).
double fitNoiseScale(double chi2, int dof);

/// Appends one row √weight · d_dp / noise per observation (only the measured ones when only_targets).
void appendObservationRows(const TaskEvaluation& evaluation, double weight, bool only_targets, MomentJacobian* J);

/// Analysis of a whitened Jacobian in SI (rows √w dy/dp / σ): singular values, moments' stds (× noise_scale,
/// the fit's σ̂), words. Throws TopoError for a non-positive unit, threshold or noise scale.
IdentifiabilityAnalysis analyseMomentJacobian(const MomentJacobian& J_si, const MomentVector& natural_units,
                                              double threshold = 0.02, double noise_scale = 1.0);

/// Σ_j log min(std_j / u_j, 1) − Σ_k log clamp(threshold · s_k, 1e-8, 1): lower is better determined (a
/// free moment counts 0; each free direction of J counts +18.4, a determined one 0).
double undeterminedScore(const IdentifiabilityAnalysis& analysis);

/// dp/dr (10 × N): how the ten mass properties move with each particle's indicator (task's density).
Eigen::MatrixXd massPropertiesIndicatorJacobian(const Task& task, const VolumeCloud& cloud,
                                                const std::vector<double>& r);

/// dp/dθ (10 × numParameters): dp/dr chained through the indicator and representation (backward pass).
Eigen::MatrixXd massPropertiesParameterJacobian(const InteriorProblem& problem, const Eigen::VectorXd& theta);
/// The same with the indicator r at θ already evaluated (problem.indicator(θ, &r)).
Eigen::MatrixXd massPropertiesParameterJacobian(const InteriorProblem& problem, const Eigen::VectorXd& theta,
                                                const std::vector<double>& r);

/// The whole analysis at design θ whose evaluation is `at` (problem.evaluate(θ, ...)): measured
/// observations of every experiment, θ rank, and (options.suggest) the next experiment.
IdentifiabilityAnalysis analyseIdentifiability(const InteriorProblem& problem, const Eigen::VectorXd& theta,
                                               const ProblemEvaluation& at, const IdentifiabilityOptions& options = {});

/// The next experiment among the candidates the object admits (header comment), given the measured J_si.
/// Fills analysis->candidates, suggestion, has_suggestion and notes.
void suggestNextExperiment(const InteriorProblem& problem, const std::vector<double>& r, const MomentJacobian& J_si,
                           const IdentifiabilityOptions& options, IdentifiabilityAnalysis* analysis);

}  // namespace topo_gaussian::inference
