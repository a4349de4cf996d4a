#include "topo_gaussian/inference/region_uncertainty.h"

#include <Eigen/Householder>
#include <Eigen/QR>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <sstream>
#include <utility>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/number_text.h"
#include "topo_gaussian/physics/mass_properties.h"
#include "topo_gaussian/topology/quadric_representation.h"

namespace topo_gaussian::inference {

namespace {

constexpr double kRegionProposalCap = 0.5;
/// The smallest noise σ̂ the fit may estimate, in units of the tolerances.
constexpr double kRegionNoiseFloor = 0.01;
/// Below this expected IoU the sentence calls the region not determined (issue 16's IoU goal).
constexpr double kRegionDeterminedIou = 0.9;
/// The random walk: steps adapting the step size, steps between two kept designs, and the smallest
/// share of steps accepted after the burn-in for the spread to be reported.
constexpr int kRegionBurnInSteps = 256;
constexpr int kRegionThinning = 16;
constexpr double kRegionMinAcceptance = 0.05;

/// χ²_q(k) by Wilson–Hilferty: k (1 − 2/(9k) + z_q √(2/(9k)))³. At k = 1 its lower decile is 0.0053
/// against the exact 0.0158: σ̂ then comes out √3 too large, on the safe side.
double chiSquareQuantile(int k, double z_q) {
  const double a = 2.0 / (9.0 * k);
  const double c = std::max(1.0 - a + z_q * std::sqrt(a), 1e-3);
  return k * c * c * c;
}
double chiSquareLowerDecile(int k) { return chiSquareQuantile(k, -1.2815516); }

}  // namespace

double volumeIou(const std::vector<double>& V, const std::vector<double>& a, const std::vector<double>& b) {
  if (a.size() != V.size() || b.size() != V.size())
    throw TopoError("volume IoU",
                    "has fields of " + std::to_string(a.size()) + " and " + std::to_string(b.size()) + " values for " +
                        std::to_string(V.size()) + " particles",
                    "give one indicator value per particle");
  double inter = 0, uni = 0;
  for (std::size_t i = 0; i < V.size(); ++i) {
    inter += V[i] * std::min(a[i], b[i]);
    uni += V[i] * std::max(a[i], b[i]);
  }
  return uni > 0 ? inter / uni : 1.0;
}

RegionUncertainty analyseRegionUncertainty(const InteriorProblem& problem, const Eigen::VectorXd& theta,
                                           const ProblemEvaluation& at, const MomentJacobian& J_si,
                                           const RegionUncertaintyOptions& options) {
  RegionUncertainty out;
  const int P = problem.numParameters();
  if (P > options.max_parameters) {
    out.note = "the " + problem.representation().name() + " representation has " + std::to_string(P) +
               " parameters (more than " + std::to_string(options.max_parameters) +
               "): its region's uncertainty is not analysed; use the design spread (restarts)";
    return out;
  }
  if (J_si.rows() == 0) {
    out.note = "no experiment reports observations of the mass moments";
    return out;
  }
  if (theta.size() != P || !theta.allFinite())
    throw TopoError("region uncertainty design", "has " + std::to_string(theta.size()) + " parameters",
                    "give the representation's " + std::to_string(P));
  // χ² of the measured observations, in the rows' order (identifiability: experiments, then observations).
  double chi2 = 0;
  int n = 0;
  for (const auto& xe : at.experiments)
    for (const auto& o : xe.eval.observations) {
      if (!o.has_target || !(xe.weight > 0)) continue;  // a weight-0 experiment's rows are zero
      const double e = (o.value - o.target) / o.noise;
      chi2 += xe.weight * e * e;
      ++n;
    }
  out.observations = static_cast<int>(J_si.rows());
  out.chi2 = chi2;
  const Eigen::MatrixXd dp_dtheta = massPropertiesParameterJacobian(problem, theta);
  Eigen::MatrixXd J_theta = J_si * dp_dtheta;  // rows × P
  // The directions that change the design: θ*'s own is removed for a scale-free (distance) field.
  Eigen::MatrixXd Q = Eigen::MatrixXd::Identity(P, P);
  const auto* quadric = dynamic_cast<const QuadricRepresentation*>(&problem.representation());
  if (quadric && quadric->distanceUnit() > 0 && theta.norm() > 0) {
    Eigen::HouseholderQR<Eigen::MatrixXd> qr(theta.normalized());
    const Eigen::MatrixXd full = qr.householderQ() * Eigen::MatrixXd::Identity(P, P);
    Q = full.rightCols(P - 1);
  }
  const Eigen::MatrixXd Jr = J_theta * Q;
  // At least as many rows as columns, so the SVD has a singular value (zero when free) per direction.
  Eigen::MatrixXd Jp = Eigen::MatrixXd::Zero(std::max<Eigen::Index>(Jr.cols(), Jr.rows()), Jr.cols());
  Jp.topRows(Jr.rows()) = Jr;
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(Jp, Eigen::ComputeFullV);
  const Eigen::VectorXd s = svd.singularValues();
  const Eigen::MatrixXd V = svd.matrixV();
  out.directions = static_cast<int>(Q.cols());
  const double s_max = s.size() > 0 ? s[0] : 0.0;
  for (Eigen::Index k = 0; k < s.size(); ++k) {
    if (s_max > 0 && s[k] > 1e-9 * s_max)
      ++out.determined_directions;
    else
      ++out.free_directions;
  }
  const int dof = n - out.determined_directions;
  // An exact fit (χ² → 0) would claim exact observations: σ̂ is floored at 1 % of the tolerances.
  out.noise_scale = dof > 0 ? std::max(kRegionNoiseFloor, std::sqrt(chi2 / chiSquareLowerDecile(dof))) : 1.0;

  // The best design's labels and region (the other material: the smaller label by volume).
  const auto& V_i = problem.cloud().V;
  std::vector<double> r;
  problem.indicator(theta, &r);
  const std::size_t N = r.size();
  std::vector<char> best(N);
  double solid = 0, total = 0;
  for (std::size_t i = 0; i < N; ++i) {
    best[i] = r[i] >= 0.5;
    solid += best[i] ? V_i[i] : 0.0;
    total += V_i[i];
  }
  const bool region_is_solid = solid <= 0.5 * total;
  std::vector<double> best_region(N);
  for (std::size_t i = 0; i < N; ++i) best_region[i] = best[i] == region_is_solid ? 1.0 : 0.0;
  out.region_fraction = (region_is_solid ? solid : total - solid) / total;

  // The designs that fit, sampled by a random walk (Metropolis) in the coordinates z of the directions
  // Q V: target density exp(−½ Δχ²(θ)/σ̂² − ½ |z|²/cap²), Δχ² = |J (p(θ) − p*)|² with the exact moments
  // p(θ) of the design θ = θ* + Q V z (not the linearised ones), within the representation's bounds.
  // The walk follows the fitting designs where the moments are not linear in θ (a curved valley). The
  // method before it (until 2026-11-28), a Gaussian proposal filtered by the fit and halved whenever it
  // overshot, kept designs nearer θ* than the fit allows: on bench/interiors the found region's IoU with
  // the truth lay below the reported 10 % quantile in 3 of the 7 representable cases (the tumbler's cavity:
  // 0.678 expected, 10 % below 0.583, found 0.508), with the walk in none (0.438, 0.354). Steps: σ̂/s_j
  // along a determined direction, at most cap, scaled during a burn-in towards a quarter to a half accepted.
  std::vector<double> masses;
  const auto momentsOf = [&](const std::vector<double>& rr) {
    problem.task().masses(rr, &masses, nullptr);
    return computeMassProperties(problem.cloud().X, masses, cubeCellVariance(problem.cloud().spacing)).toVector();
  };
  const Eigen::Matrix<double, 10, 1> p_best = momentsOf(r);
  Eigen::VectorXd lower, upper;
  problem.bounds(&lower, &upper);
  std::mt19937 rng(options.seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::vector<int> agree(N, 0);
  std::vector<double> ious;
  std::vector<double> region(N);
  // A direction the observations barely fix (its 1σ step above half the design's own parameter norm)
  // is explored within about that half norm (the prior's width): the designs near this one, not any
  // quadric at all.
  const double cap = kRegionProposalCap * theta.norm();
  if (!(cap > 0) || options.samples < 1) {  // no step to take: a walk that cannot move would claim certainty
    out.note = options.samples < 1
                   ? "no designs were asked for (samples < 1): the region's uncertainty is not analysed"
                   : "the design has no parameters set (|θ| = 0): the region's uncertainty could not be "
                     "measured (use the design spread, restarts)";
    return out;
  }
  const double inv_noise2 = 1.0 / (out.noise_scale * out.noise_scale);
  const Eigen::Index D = V.cols();
  Eigen::VectorXd sd(D);
  for (Eigen::Index j = 0; j < D; ++j)
    sd[j] = j < out.determined_directions ? std::min(out.noise_scale / s[j], cap) : cap;
  const auto logTarget = [&](const Eigen::VectorXd& zz, std::vector<double>* rr) {
    const Eigen::VectorXd th = theta + Q * (V * zz);
    for (Eigen::Index k = 0; k < th.size(); ++k)
      if (!(th[k] >= lower[k] && th[k] <= upper[k])) return -std::numeric_limits<double>::infinity();
    problem.indicator(th, rr);
    const Eigen::VectorXd dy = J_si * (momentsOf(*rr) - p_best);
    return -0.5 * (dy.squaredNorm() * inv_noise2 + zz.squaredNorm() / (cap * cap));
  };
  Eigen::VectorXd z = Eigen::VectorXd::Zero(D);
  std::vector<double> r_cur = std::move(r), r_try;  // the walk starts at θ*: its own moments, so Δχ² = 0
  double log_cur = 0.0;
  double step = 1.0;
  const int burn_in = kRegionBurnInSteps, thin = kRegionThinning;
  const int steps = burn_in + thin * options.samples;
  int accepted_window = 0, accepted_sampling = 0, kept = 0;
  for (int it = 0; it < steps; ++it) {
    Eigen::VectorXd z_try = z;
    for (Eigen::Index j = 0; j < D; ++j) z_try[j] += step * sd[j] * normal(rng);
    const double log_try = logTarget(z_try, &r_try);
    if (std::isfinite(log_try) && std::log(std::max(uniform(rng), 1e-300)) < log_try - log_cur) {
      z = z_try, log_cur = log_try;
      r_cur.swap(r_try);
      ++accepted_window;
      if (it >= burn_in) ++accepted_sampling;
    }
    if (it < burn_in && (it + 1) % 32 == 0) {  // towards a quarter to a half accepted
      const double rate = accepted_window / 32.0;
      if (rate < 0.25) step *= rate < 0.1 ? 0.5 : 0.75;
      if (rate > 0.5) step *= 1.5;
      accepted_window = 0;
    }
    if (it < burn_in || (it - burn_in + 1) % thin != 0) continue;
    ++kept;
    for (std::size_t i = 0; i < N; ++i) {
      const bool label = r_cur[i] >= 0.5;
      agree[i] += label == static_cast<bool>(best[i]);
      region[i] = label == region_is_solid ? 1.0 : 0.0;
    }
    ious.push_back(volumeIou(V_i, best_region, region));
  }
  out.proposal_scale = step;
  out.drawn = steps;
  out.samples = kept;
  out.acceptance = double(accepted_sampling) / double(std::max(1, steps - burn_in));
  if (out.acceptance < kRegionMinAcceptance) {  // the walk stayed at θ*: its IoU 1 would claim a certainty
    out.note = "a random walk over the designs that fit accepted " + numberText(100 * out.acceptance, 2) + " % of " +
               std::to_string(steps - burn_in) +
               " steps near the result: the region's uncertainty could not be measured (use the design spread, "
               "restarts)";
    return out;
  }
  out.confidence.resize(N);
  double undetermined = 0;
  for (std::size_t i = 0; i < N; ++i) {
    out.confidence[i] = kept > 0 ? double(agree[i]) / kept : 1.0;
    if (out.confidence[i] < options.confident_level) undetermined += V_i[i];
  }
  out.undetermined_fraction = undetermined / total;
  std::sort(ious.begin(), ious.end());
  double sum = 0;
  for (double v : ious) sum += v;
  out.iou_mean = sum / static_cast<double>(ious.size());
  out.iou_p10 = ious[static_cast<std::size_t>(0.1 * static_cast<double>(ious.size() - 1))];
  if (out.free_directions > 0) out.iou_mean = out.iou_p10 = NAN;
  out.available = true;

  std::ostringstream os;
  const std::string what = region_is_solid ? "the solid (insert) region" : "the hollow region";
  if (out.free_directions > 0) {
    os << "The observations do not fix " << what << " along " << out.free_directions << " of its " << out.directions
       << " directions: it is not determined, whatever its moments; this design is one of many.";
  } else {
    os << "Designs that fit the observations to their noise (" << out.samples << " taken from a random walk of "
       << out.drawn << " steps, " << numberText(100 * out.acceptance, 2) << " % accepted; noise "
       << numberText(out.noise_scale, 3) << " x the tolerances" << (dof > 0 ? ", from the fit" : "") << ") give "
       << what << " (" << numberText(100 * out.region_fraction, 3) << " % of the volume) an IoU of "
       << numberText(out.iou_mean, 3) << " on average with this design (10 % below " << numberText(out.iou_p10, 3)
       << "); " << numberText(100 * out.undetermined_fraction, 3) << " % of the volume changes label in more than "
       << numberText(100 * (1 - options.confident_level), 2) << " % of them.";
    if (out.iou_mean < kRegionDeterminedIou)
      os << " The region is not determined: read it as one of the designs that fit.";
  }
  out.sentence = os.str();
  return out;
}

}  // namespace topo_gaussian::inference
