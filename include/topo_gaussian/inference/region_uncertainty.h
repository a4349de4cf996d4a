// Region uncertainty: how well the observations fix WHERE the other material is, not only
// its ten mass moments. The moments can be determined to 2 % of their own size while the region is
// not: a 12 mm steel ball in a 100 mm doll changes the inertia by 0.6 %, so its shape hides below a
// period's noise (bench/interiors: moments within 0.4 %, the ball's IoU 0.6).
//
// Linearised at the best design θ* (Laplace approximation, as identifiability.h for the moments):
//   J_θ = J · dp/dθ      (J: the observations' whitened moment Jacobian, rows √w_e (∂y_k/∂p)/σ_k)
// restricted to the directions that change the design (the distance-field quadric does not depend on
// θ's scale: the direction θ* is removed), J_θ = U S Vᵀ. The designs that fit the observations to their
// noise are sampled by randomised maximum likelihood (RML: Oliver, He & Reynolds 1996; "randomize-then-
// optimize", Bardsley et al. 2014) in the coordinates z of θ = θ* + Q V z: each sample is the fit
//   z_k = argmin_z |r* + J (p(θ) − p*) − σ̂ ε_k|²/σ̂² + |z − z0_k|²/σ_p²,   ε_k ~ N(0, I), z0_k ~ N(0, I σ_p²)
// (the observations perturbed by their noise, the prior's centre by its width), by Levenberg–Marquardt
// from θ* within the representation's bounds (geodesic acceleration, Transtrum & Sethna 2012: the valley is
// narrow and curved), with the EXACT moments p(θ) of each design (a small cavity's
// moments are not linear in its shape, and the fitting designs can lie along a curved valley that a random
// walk with one step scale does not follow), r* the whitened residual at θ* (rows √w_e (y*_k − y_k)/σ_k).
// The rows are whitened by the tolerances σ_k (at which a feature is called matched); the observations'
// own noise is estimated from the fit's residual,
//   χ² = Σ_k w_e ((y_k − y*_k)/σ_k)²,   σ̂² = χ² / χ²_0.10(n − p)
// (its 90 % upper bound; n observations of experiments with weight > 0, p directions; Wilson–Hilferty
// quantile; at least 0.01), and σ̂ = 1 (the tolerances) when n ≤ p, where the residual cannot tell the noise.
// The prior: E|z|² = (½ |θ*|)², σ_p = ½ |θ*|/√D along each of the D directions: directions the observations
// barely fix are explored near this design, not over every quadric (the spread reported along them is the
// prior's). Fewer than half of the fits converged within 20 iterations (no direction free): not available. Each design
// is labelled (r ≥ 0.5); per particle, confidence_i = the fraction of kept designs whose label is the best's; the
// region (the other material: the smaller of the two labels by volume) is compared by IoU. A direction with s_k < 1e-9
// s_max is FREE: the observations do not fix the region along it at all (reported; drawn from the prior like the barely
// fixed ones, and iou_mean is NaN). Only for representations of few parameters (the quadric); the point and neural ones
// are not analysed.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "topo_gaussian/inference/identifiability.h"
#include "topo_gaussian/inference/interior_problem.h"

namespace topo_gaussian::inference {

struct RegionUncertaintyOptions {
  int samples = 64;               ///< designs to keep
  unsigned seed = 1;              ///< of the draws (deterministic)
  int max_parameters = 64;        ///< larger representations are not analysed
  double confident_level = 0.95;  ///< a particle is determined when this fraction of draws agree
};

struct RegionUncertainty {
  bool available = false;
  std::string note;  ///< why not, when not available
  int observations = 0, directions = 0, determined_directions = 0, free_directions = 0;
  double chi2 = 0.0;                     ///< Σ w ((y − y*)/σ)² at the best design, σ the tolerances
  double noise_scale = 1.0;              ///< σ̂ (see the header comment)
  int samples = 0;                       ///< designs drawn (perturbed fits)
  int iterations = 0;                    ///< Levenberg–Marquardt iterations over all the fits
  int solves_converged = 0;              ///< fits that reached their minimum (fewer than half: not available)
  double region_fraction = 0.0;          ///< volume of the region (the other material) / total volume
  /// IoU of the drawn designs' region with the best's: mean, 10th and 90th percentiles (NaN when free); the
  /// band the true region's IoU with this design is expected in
  double iou_mean = 0.0, iou_p10 = 0.0, iou_p90 = 0.0;
  double undetermined_fraction = 0.0;    ///< volume with confidence below confident_level / total volume
  std::vector<double> confidence;        ///< per particle (1 = every drawn design agrees with the best)
  std::string sentence;                  ///< for a person
};

/// The share of the volume whose label is uncertain: Σ V_i [confidence_i < level] / Σ V_i (0 for an empty
/// cloud); confidence as RegionUncertainty::confidence or InferenceResult::solid_confidence.
double uncertainVolumeFraction(const std::vector<double>& V, const std::vector<double>& confidence,
                               double level = 0.95);

/// Volume IoU Σ V_i min(a_i, b_i) / Σ V_i max(a_i, b_i) of two indicator fields (labels 0/1 or fractions
/// in [0, 1]); 1 when both are empty. Throws TopoError for sizes that differ from V's.
double volumeIou(const std::vector<double>& V, const std::vector<double>& a, const std::vector<double>& b);

/// The analysis at design θ (see the header comment); J_si the whitened moment Jacobian of the measured
/// observations (identifiability: analysis.J · diag(1/natural_units)), `at` the evaluation at θ whose
/// observations gave it (for χ²). Throws TopoError for a Jacobian of the wrong shape.
RegionUncertainty analyseRegionUncertainty(const InteriorProblem& problem, const Eigen::VectorXd& theta,
                                           const ProblemEvaluation& at, const MomentJacobian& J_si,
                                           const RegionUncertaintyOptions& options = {});

}  // namespace topo_gaussian::inference
