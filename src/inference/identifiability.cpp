#include "topo_gaussian/inference/identifiability.h"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/number_text.h"
#include "topo_gaussian/common/stopwatch.h"
#include "topo_gaussian/inference/task_registry.h"
#include "topo_gaussian/topology/indicator.h"

namespace topo_gaussian::inference {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
const char* kNames[10] = {"m", "cx", "cy", "cz", "Ixx", "Iyy", "Izz", "Ixy", "Ixz", "Iyz"};

std::string joinWords(const std::vector<std::string>& w) {
  std::string s;
  for (std::size_t i = 0; i < w.size(); ++i) s += (i == 0 ? "" : (i + 1 == w.size() ? " and " : ", ")) + w[i];
  return s;
}

/// "the mass, the centre of mass along x and z and the inertia Ixx, Iyy" for moment indices.
std::string momentWords(const std::vector<int>& idx) {
  std::vector<std::string> axes, inertia, groups;
  bool mass = false;
  for (int j : idx) {
    if (j == 0) mass = true;
    if (j >= 1 && j <= 3) axes.push_back(std::string(1, "xyz"[j - 1]));
    if (j >= 4) inertia.push_back(kNames[j]);
  }
  if (mass) groups.push_back("the mass");
  if (!axes.empty()) groups.push_back("the centre of mass along " + joinWords(axes));
  if (!inertia.empty()) {
    std::string s = "the inertia ";
    for (std::size_t i = 0; i < inertia.size(); ++i) s += (i ? ", " : "") + inertia[i];
    groups.push_back(s);
  }
  return joinWords(groups);
}

std::string vecText(const Eigen::Vector3d& v) {
  return "(" + numberText(v.x(), 3) + ", " + numberText(v.y(), 3) + ", " + numberText(v.z(), 3) + ")";
}

/// Task defaults, the template experiment's own explicit non-target values, and the object's shared ones.
TaskConfig candidateConfig(const std::string& task, const TaskConfig& object, const TaskConfig* like) {
  TaskConfig c = TaskConfig::defaults(task);
  auto copy = [&](const TaskConfig& from, const std::string& key) {
    if (!c.spec(key) || !from.has(key)) return;
    try {
      c.set(key, from.valueText(key), "identifiability candidate");
    } catch (const TopoError&) {  // an empty list or a value this task refuses: keep the default
    }
  };
  if (like)
    for (const auto& key : like->explicitKeys())
      if (like->spec(key) && !like->spec(key)->is_target) copy(*like, key);
  for (const auto& sp : object.specs())
    if (TaskConfig::isShared(sp.name)) copy(object, sp.name);
  return c;
}

/// The tasks whose experiment rocks the object about an axis, for messages: "tumbler".
std::string rockingTaskList() {
  std::string s;
  for (const auto& t : taskDefinitions())
    if (!t.rocking_axis_parameter.empty()) s += (s.empty() ? "" : ", ") + t.name;
  return s;
}

/// Up to n points spread over the surface: farthest-point sampling from the highest one.
std::vector<Eigen::Vector3d> spreadSurfacePoints(const VolumeCloud& cloud, int n) {
  std::vector<Eigen::Vector3d> pool = cloud.contact.X;
  if (pool.empty())
    for (std::size_t i = 0; i < cloud.size(); ++i)
      if (cloud.surface[i]) pool.push_back(cloud.X[i]);
  std::vector<Eigen::Vector3d> out;
  if (pool.empty() || n <= 0) return out;
  std::size_t first = 0;
  for (std::size_t i = 1; i < pool.size(); ++i)
    if (pool[i].z() > pool[first].z()) first = i;
  std::vector<double> d(pool.size(), kInf);
  std::size_t next = first;
  for (int k = 0; k < n && k < static_cast<int>(pool.size()); ++k) {
    out.push_back(pool[next]);
    std::size_t far = next;
    double best = -1;
    for (std::size_t i = 0; i < pool.size(); ++i) {
      d[i] = std::min(d[i], (pool[i] - pool[next]).squaredNorm());
      if (d[i] > best) best = d[i], far = i;
    }
    if (best <= 0) break;
    next = far;
  }
  return out;
}

}  // namespace

MomentVector naturalMomentUnits(double solid_mass_kg, double size_m) {
  if (!(solid_mass_kg > 0) || !(size_m > 0))
    throw TopoError(
        "natural units of the mass moments",
        "need a positive solid mass and size (got " + numberText(solid_mass_kg) + " kg, " + numberText(size_m) + " m)",
        "give a volume with particles and a positive density_solid");
  MomentVector u;
  const double I = solid_mass_kg * size_m * size_m;
  u << solid_mass_kg, size_m, size_m, size_m, I, I, I, I, I, I;
  return u;
}

MomentVector ownMomentScales(const MassProperties& d, double solid_mass_kg, double size_m) {
  const Eigen::Vector3d I = d.inertia.diagonal();
  if (!(d.mass > 0) || !(I.minCoeff() > 0) || !d.inertia.allFinite())
    return naturalMomentUnits(solid_mass_kg, size_m);
  const double k = std::sqrt(I.sum() / (2.0 * d.mass));  // radius of gyration
  MomentVector u;
  u << d.mass, k, k, k, I.x(), I.y(), I.z(), std::sqrt(I.x() * I.y()), std::sqrt(I.x() * I.z()),
      std::sqrt(I.y() * I.z());
  return u;
}

// χ²_q(k) by Wilson–Hilferty: k (1 − 2/(9k) + z_q √(2/(9k)))³. At k = 1 its lower decile is 0.0053
// against the exact 0.0158: σ̂ then comes out √3 too large, on the safe side.
double chiSquareLowerDecile(int k) {
  const double a = 2.0 / (9.0 * k), z_q = -1.2815516;
  const double c = std::max(1.0 - a + z_q * std::sqrt(a), 1e-3);
  return k * c * c * c;
}

double fitNoiseScale(double chi2, int dof) {
  // An exact fit (χ² → 0) would claim exact observations: σ̂ is floored at 1 % of the tolerances.
  return dof > 0 ? std::max(0.01, std::sqrt(chi2 / chiSquareLowerDecile(dof))) : 1.0;
}

MeasuredResidual measuredResidual(const ProblemEvaluation& at) {
  MeasuredResidual out;
  std::vector<double> rows;
  for (const auto& xe : at.experiments)
    for (const auto& o : xe.eval.observations) {
      if (!o.has_target) continue;
      const double e = xe.weight > 0 ? std::sqrt(xe.weight) * (o.value - o.target) / o.noise : 0.0;
      rows.push_back(e);
      if (!(xe.weight > 0)) continue;  // a weight-0 experiment's rows are zero
      out.chi2 += e * e;
      ++out.count;
    }
  out.residual = Eigen::Map<const Eigen::VectorXd>(rows.data(), static_cast<Eigen::Index>(rows.size()));
  return out;
}

void appendObservationRows(const TaskEvaluation& evaluation, double weight, bool only_targets, MomentJacobian* J) {
  for (const auto& o : evaluation.observations) {
    if (only_targets && !o.has_target) continue;
    if (!(o.noise > 0) || !std::isfinite(o.noise))
      throw TopoError("observation " + o.name, "has noise " + numberText(o.noise) + " " + o.unit,
                      "a task must give each observation a positive noise scale (its tolerance)");
    J->conservativeResize(J->rows() + 1, Eigen::NoChange);
    J->row(J->rows() - 1) = (std::sqrt(weight) / o.noise) * o.d_dp.transpose();
  }
}

IdentifiabilityAnalysis analyseMomentJacobian(const MomentJacobian& J_si, const MomentVector& u, double threshold,
                                              double noise_scale) {
  if (!(threshold > 0)) throw TopoError("determined_threshold", "is not positive", "give e.g. 0.02 (2 %)");
  if (!(noise_scale > 0) || !std::isfinite(noise_scale))
    throw TopoError("noise scale of the identifiability analysis", "is not positive and finite",
                    "give the fit's sigma (1: the tolerances)");
  if (!((u.array() > 0).all()))
    throw TopoError("natural units of the mass moments", "are not all positive", "use naturalMomentUnits");
  if (!J_si.allFinite())
    throw TopoError("observation Jacobian", "has NaN or infinite entries",
                    "check the experiments' simulations (a diverged simulation gives no derivatives)");
  IdentifiabilityAnalysis a;
  a.available = true;
  a.threshold = threshold;
  a.noise_scale = noise_scale;
  a.natural_units = u;
  a.observations = static_cast<int>(J_si.rows());
  a.J = J_si * u.asDiagonal();
  // Pad to at least 10 rows so the SVD has ten singular values (zero rows add no information).
  Eigen::MatrixXd Jp = Eigen::MatrixXd::Zero(std::max<Eigen::Index>(10, a.J.rows()), 10);
  Jp.topRows(a.J.rows()) = a.J;
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(Jp, Eigen::ComputeFullV);
  a.singular_values = svd.singularValues().head<10>();
  a.V = svd.matrixV();
  const double smax = a.singular_values(0);
  std::vector<bool> null(10, true);
  for (int k = 0; k < 10; ++k) {
    null[k] = !(smax > 0) || a.singular_values(k) <= 1e-12 * smax;
    if (!null[k]) ++a.rank;
    if (!null[k] && noise_scale / a.singular_values(k) < threshold) ++a.determined_directions;
  }
  static const char* words[10] = {"the mass",
                                  "the centre of mass along x",
                                  "the centre of mass along y",
                                  "the centre of mass along z",
                                  "the inertia Ixx",
                                  "the inertia Iyy",
                                  "the inertia Izz",
                                  "the inertia Ixy",
                                  "the inertia Ixz",
                                  "the inertia Iyz"};
  std::vector<int> determined, free;
  for (int j = 0; j < 10; ++j) {
    MomentIdentification mi;
    mi.name = kNames[j];
    mi.words = words[j];
    mi.unit = j == 0 ? "kg" : (j <= 3 ? "m" : "kg m^2");
    mi.natural_unit = u(j);
    double var = 0, in_null = 0;
    for (int k = 0; k < 10; ++k) {
      const double v2 = a.V(j, k) * a.V(j, k);
      if (null[k])
        in_null += v2;
      else
        var += v2 / (a.singular_values(k) * a.singular_values(k));
    }
    // A part in J's null space moves the moment with no observation changing. Along a free direction one
    // natural unit long (about the object's whole extent for c, its own size for I) a part below the
    // threshold moves it by less than the threshold: that part counts as a spread, not as free (a hang whose
    // measured rest pose is pitched by a fraction of a degree couples cx to a free cz by the pitch's sine).
    const double null_part = std::sqrt(in_null);
    mi.std_relative = null_part >= threshold ? kInf : std::sqrt(noise_scale * noise_scale * var + in_null);
    mi.std = mi.std_relative * u(j);
    mi.determined = mi.std_relative < threshold;
    (mi.determined ? determined : free).push_back(j);
    a.moments.push_back(mi);
  }
  std::ostringstream s;
  if (determined.empty()) {
    s << "These experiments determine none of the ten mass moments";
  } else {
    s << "These experiments determine " << momentWords(determined) << " (std";
    for (std::size_t i = 0; i < determined.size(); ++i) {
      const auto& mi = a.moments[determined[i]];
      s << (i ? ", " : " ") << mi.name << " " << numberText(mi.std, 2) << " " << mi.unit;
    }
    s << ")";
  }
  if (free.empty())
    s << "; all ten are determined.";
  else
    s << "; " << momentWords(free) << (free.size() == 1 ? " is" : " are")
      << " not determined by these experiments (std above " << numberText(100 * threshold, 2)
      << " % of its own size).";
  if (noise_scale != 1.0)
    s << " The fit's residual puts the observations' noise at " << numberText(noise_scale, 3)
      << " x their tolerances, and these standard deviations with it.";
  if (!a.moments[0].determined)
    s << " Rigid motion alone never fixes the mass (a heavier copy with the same centre of mass and inertia per "
         "kilogram moves alike): weigh it (a mass_kg target of a hanging, balance or stand experiment).";
  a.summary = s.str();
  return a;
}

double undeterminedScore(const IdentifiabilityAnalysis& a) {
  double s = 0;
  for (const auto& m : a.moments) s += std::log(std::min(m.std_relative, 1.0));
  // Combinations count too: a moment is determined only when no free direction touches it, so an
  // experiment that pins one more combination (a new hang fixes c along one more direction while m
  // stays free) lowers no single moment's std yet is progress. −Σ_k log clamp(threshold·s_k, 1e-8, 1):
  // 0 when every direction is determined, +18.4 for each free one.
  for (int k = 0; k < a.singular_values.size(); ++k)
    s -= std::log(std::clamp(a.threshold * a.singular_values(k) / a.noise_scale, 1e-8, 1.0));
  return s;
}

Eigen::MatrixXd massPropertiesIndicatorJacobian(const Task& task, const VolumeCloud& cloud,
                                                const std::vector<double>& r) {
  std::vector<double> m, dm;
  task.masses(r, &m, &dm);
  const double s = cubeCellVariance(cloud.spacing);
  const MassMoments moments = computeMassMoments(cloud.X, m, s);
  const Eigen::Matrix<double, 10, 10> Jpm = massPropertiesJacobian(moments);
  Eigen::MatrixXd out(10, static_cast<Eigen::Index>(cloud.size()));
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3d& x = cloud.X[i];
    MomentVector d;  // ∂(raw moments)/∂m_i, MassMoments::toVector order
    d << 1, x.x(), x.y(), x.z(), x.x() * x.x() + s, x.y() * x.y() + s, x.z() * x.z() + s, x.x() * x.y(), x.x() * x.z(),
        x.y() * x.z();
    out.col(static_cast<Eigen::Index>(i)) = Jpm * d * dm[i];
  }
  return out;
}

Eigen::MatrixXd massPropertiesParameterJacobian(const InteriorProblem& problem, const Eigen::VectorXd& theta) {
  std::vector<double> r;
  problem.indicator(theta, &r);
  return massPropertiesParameterJacobian(problem, theta, r);
}

Eigen::MatrixXd massPropertiesParameterJacobian(const InteriorProblem& problem, const Eigen::VectorXd& theta,
                                                const std::vector<double>& r) {
  const Eigen::MatrixXd dp_dr = massPropertiesIndicatorJacobian(problem.task(), problem.cloud(), r);
  Eigen::MatrixXd dp_dtheta_t;  // numParameters × 10, one pass over the particles
  indicatorBackwardColumns(problem.representation(), theta, problem.indicatorOptions(), dp_dr.transpose(),
                           &dp_dtheta_t);
  return dp_dtheta_t.transpose();
}

void suggestNextExperiment(const InteriorProblem& problem, const std::vector<double>& r, const MomentJacobian& J_si,
                           const IdentifiabilityOptions& options, IdentifiabilityAnalysis* analysis) {
  const VolumeCloud& cloud = problem.cloud();
  const MomentVector& u = analysis->natural_units;
  const double sigma = analysis->noise_scale;  // a new experiment is expected to fit as the others do
  const double base = undeterminedScore(analyseMomentJacobian(J_si, u, options.determined_threshold, sigma));
  std::vector<double> m;
  problem.task().masses(r, &m, nullptr);
  const MassProperties props = computeMassProperties(cloud.X, m, cubeCellVariance(cloud.spacing));
  auto score = [&](ExperimentSuggestion& cand, const TaskEvaluation& ev) {
    MomentJacobian J = J_si;
    appendObservationRows(ev, 1.0, false, &J);
    const IdentifiabilityAnalysis a = analyseMomentJacobian(J, u, options.determined_threshold, sigma);
    cand.score_gain = base - undeterminedScore(a);
    cand.directions_after = a.determined_directions;
    for (int j = 0; j < 10; ++j)
      if (a.moments[j].determined && !analysis->moments[j].determined) cand.newly_determined.push_back(kNames[j]);
  };

  // Hang from a surface point: the design then hangs with c straight below the point; the target pose is
  // that equilibrium (roll about x, then pitch about y, taking c − q onto gravity; gravity along −z).
  const Eigen::Vector3d g = problem.config().vector3("gravity");
  const bool down_z = g.norm() > 0 && g.normalized().dot(Eigen::Vector3d(0, 0, -1)) > 1 - 1e-9;
  if (!down_z) analysis->notes.push_back("gravity is not along -z: hanging candidates are evaluated in the rest pose");
  for (const Eigen::Vector3d& q : spreadSurfacePoints(cloud, options.hanging_candidates)) {
    ExperimentSuggestion cand;
    cand.kind = "hang";
    cand.point = q;
    cand.config = candidateConfig("hanging", problem.config(), nullptr);
    cand.config.setVector("hanging_point", q);
    const Eigen::Vector3d d = props.com - q;
    if (d.norm() < 1e-9 * (u(1) + 1)) continue;
    if (down_z) {
      const Eigen::Vector3d dh = d.normalized();
      const double roll = std::atan2(-dh.y(), -dh.z());
      const double rho = std::hypot(dh.y(), dh.z());
      const double pitch = std::atan2(dh.x(), rho);
      cand.config.setNumber("target_roll_deg", roll * 180.0 / M_PI);
      cand.config.setNumber("target_pitch_deg", pitch * 180.0 / M_PI);
    }
    const TaskEvaluation hung = makeTask(cand.config, cloud)->evaluate(r, nullptr);
    score(cand, hung);
    const ExperimentSuggestion hang = cand;
    analysis->candidates.push_back(std::move(cand));  // first: a tie goes to the simpler experiment
    if (!options.swing_candidates) continue;
    // Swing it there on a horizontal axle along world x, then along y, and time both swings (hanging's
    // axle_swing_period_s and cross_axle_swing_period_s, which the hang already reports at the default
    // heading 0, set as targets to the design's own periods: only the derivatives count).
    ExperimentSuggestion swing = hang;
    swing.kind = "swing";
    swing.newly_determined.clear();
    swing.axis = Eigen::Vector3d::UnitX();
    int timed = 0;
    for (const auto& f : hung.features)
      if ((f.name == "axle_swing_period_s" || f.name == "cross_axle_swing_period_s") && f.value > 0) {
        swing.config.setNumber(f.name, f.value);
        ++timed;
      }
    if (timed == 0) continue;
    score(swing, makeTask(swing.config, cloud)->evaluate(r, nullptr));
    // The swing includes the hang. Where the hang fixes a moment and the swing no other, the simpler hang
    // is as good (the extra rows only shift the pseudo-inverse's spread among the free moments).
    if (!hang.newly_determined.empty() && swing.newly_determined == hang.newly_determined)
      swing.score_gain = std::min(swing.score_gain, hang.score_gain);
    analysis->candidates.push_back(std::move(swing));
  }

  // Rock about another horizontal axis, when an experiment of a rocking task (one that declares its
  // rocking_axis_parameter) shows the object rocks; the first such experiment is the model.
  const TaskConfig* rocking = nullptr;
  std::string axis_parameter;
  std::vector<Eigen::Vector3d> used;
  for (std::size_t e = 0; e < problem.numExperiments(); ++e) {
    const TaskConfig& config = problem.experiment(e).config;
    const TaskDefinition* definition = findTaskDefinition(config.task());
    if (!definition || definition->rocking_axis_parameter.empty()) continue;
    if (!rocking) {
      rocking = &config;
      axis_parameter = definition->rocking_axis_parameter;
    }
    used.push_back(config.vector3(definition->rocking_axis_parameter).normalized());
  }
  if (!rocking) {
    analysis->notes.push_back("rocking candidates skipped: no experiment of a rocking task (" + rockingTaskList() +
                              ") shows that the object rocks on a rounded base");
  } else {
    const auto t0 = Clock::now();
    int tried = 0;
    const double c = std::sqrt(0.5);
    for (const Eigen::Vector3d& axis :
         {Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(0, 1, 0), Eigen::Vector3d(c, c, 0), Eigen::Vector3d(c, -c, 0)}) {
      bool seen = false;
      for (const auto& a : used) seen = seen || std::abs(a.dot(axis)) > std::cos(10.0 * M_PI / 180.0);
      if (seen) continue;
      if (tried >= options.max_dynamic_candidates || secondsSince(t0) > options.max_dynamic_seconds) {
        analysis->notes.push_back("rocking about " + vecText(axis) + " not tried (candidate budget of " +
                                  std::to_string(options.max_dynamic_candidates) + " simulations or " +
                                  numberText(options.max_dynamic_seconds) + " s spent)");
        continue;
      }
      ++tried;
      ExperimentSuggestion cand;
      cand.kind = "rock";
      cand.axis = axis;
      cand.config = candidateConfig(rocking->task(), problem.config(), rocking);
      cand.config.setVector(axis_parameter, axis);
      try {
        const auto task = makeTask(cand.config, cloud);
        task->setShouldStop(problem.task().shouldStop());
        score(cand, task->evaluate(r, nullptr));
        analysis->candidates.push_back(std::move(cand));
      } catch (const TopoError& e) {
        analysis->notes.push_back("rocking about " + vecText(axis) + " not evaluated: " + e.what());
      }
    }
  }

  std::stable_sort(
      analysis->candidates.begin(), analysis->candidates.end(),
      [](const ExperimentSuggestion& a, const ExperimentSuggestion& b) { return a.score_gain > b.score_gain + 1e-9; });
  for (auto& cand : analysis->candidates) {
    std::ostringstream s;
    if (cand.kind == "hang")
      s << "hang it from " << vecText(cand.point) << " m";
    else if (cand.kind == "swing")
      s << "hang it from " << vecText(cand.point)
        << " m on a horizontal axle, along world x and then along y, and time its small swings "
           "(axle_swing_period_s, cross_axle_swing_period_s)";
    else
      s << "rock it about the body axis " << vecText(cand.axis);
    std::vector<int> idx;
    for (const auto& n : cand.newly_determined)
      for (int j = 0; j < 10; ++j)
        if (n == kNames[j]) idx.push_back(j);
    if (!idx.empty())
      s << " to fix " << momentWords(idx);
    else if (cand.directions_after > analysis->determined_directions)
      s << " to determine " << (cand.directions_after - analysis->determined_directions)
        << " more combination(s) of the moments (" << analysis->determined_directions << " -> " << cand.directions_after
        << " of 10)";
    else
      s << " to narrow the undetermined moments (score gain " << numberText(cand.score_gain, 3) << ")";
    cand.sentence = s.str();
  }
  // None fixes another moment on its own: the one that determines the most combinations (swings add one
  // inertia combination each; the inertia is fixed once six independent ones are).
  const ExperimentSuggestion* most = nullptr;
  for (const auto& cand : analysis->candidates)
    if (cand.directions_after > (most ? most->directions_after : analysis->determined_directions)) most = &cand;
  // A rock's prediction leans on the contact surface the design rocks on (the lattice's sampled bottom),
  // a hang's or a swing's on the moments alone (closed forms, exact for a rigid body): a rock is suggested
  // over the best hang or swing only when it fixes a moment or a combination that one does not.
  const ExperimentSuggestion* best = analysis->candidates.empty() ? nullptr : &analysis->candidates.front();
  if (best && best->kind == "rock") {
    for (const auto& cand : analysis->candidates) {
      if (cand.kind == "rock" || !(cand.score_gain > 1e-6)) continue;
      bool more = best->directions_after > cand.directions_after;
      for (const auto& n : best->newly_determined)
        more = more || std::find(cand.newly_determined.begin(), cand.newly_determined.end(), n) ==
                           cand.newly_determined.end();
      if (!more) best = &cand;
      break;
    }
  }
  if (best && best->score_gain > 1e-6) {
    analysis->has_suggestion = true;
    analysis->suggestion = *best;
  } else if (most) {
    analysis->has_suggestion = true;
    analysis->suggestion = *most;
  } else {
    analysis->notes.push_back("no candidate experiment improves what the experiments determine");
  }
}

namespace {

int rankOf(const Eigen::MatrixXd& M) {
  if (M.size() == 0) return 0;
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(M.rows() <= M.cols() ? Eigen::MatrixXd(M.transpose()) : M);
  const auto& s = svd.singularValues();
  int k = 0;
  for (int i = 0; i < s.size(); ++i) k += s(i) > 1e-9 * s(0) && s(0) > 0;
  return k;
}

// rank J_θ = rank(S_k V_kᵀ diag(1/u) dp/dθ) over the rank(J) directions k: one backward pass through the
// representation per direction (not one per moment), then dp/dθ's own rank (ten passes) when the time
// budget allows. A neural representation's backward pass can take a minute: the first pass is timed and
// the rest skipped (with a note) when they would exceed options.max_theta_seconds.
void thetaRanks(const InteriorProblem& problem, const Eigen::VectorXd& theta, const std::vector<double>& r,
                const IdentifiabilityOptions& options, IdentifiabilityAnalysis* a) {
  const Eigen::MatrixXd P = a->natural_units.cwiseInverse().asDiagonal() *
                            massPropertiesIndicatorJacobian(problem.task(), problem.cloud(), r);
  a->theta_parameters = problem.numParameters();
  auto backward = [&](const Eigen::VectorXd& dL_dr) {
    const std::vector<double> d(dL_dr.data(), dL_dr.data() + dL_dr.size());
    Eigen::VectorXd g;
    indicatorBackward(problem.representation(), theta, problem.indicatorOptions(), d, &g);
    return g;
  };
  const auto t0 = Clock::now();
  Eigen::MatrixXd G(a->rank, a->theta_parameters);
  for (int k = 0; k < a->rank; ++k) {
    G.row(k) = a->singular_values(k) * backward(P.transpose() * a->V.col(k)).transpose();
    if (k == 0 && secondsSince(t0) * a->rank > options.max_theta_seconds) {
      a->notes.push_back("the rank in the design parameters is not computed: one backward pass through the " +
                         problem.representation().name() + " representation takes " + numberText(secondsSince(t0)) +
                         " s (budget " + numberText(options.max_theta_seconds) + " s)");
      return;
    }
  }
  a->theta_rank = rankOf(G);
  const double per_pass = a->rank > 0 ? secondsSince(t0) / a->rank : 0.0;
  if (per_pass * 10 > options.max_theta_seconds) {
    a->notes.push_back("the rank of dp/dtheta is not computed (10 backward passes over the time budget)");
  } else {
    Eigen::MatrixXd D(10, a->theta_parameters);
    for (int j = 0; j < 10; ++j) D.row(j) = backward(P.row(j).transpose()).transpose();
    a->dp_dtheta_rank = rankOf(D);
  }
  std::ostringstream s;
  s << " Of the representation's " << a->theta_parameters << " parameters, the observations constrain " << a->theta_rank
    << " combination" << (a->theta_rank == 1 ? "" : "s");
  if (a->dp_dtheta_rank >= 0) s << " (the representation moves " << a->dp_dtheta_rank << " of the ten moments)";
  s << ".";
  a->summary += s.str();
}

}  // namespace

IdentifiabilityAnalysis analyseIdentifiability(const InteriorProblem& problem, const Eigen::VectorXd& theta,
                                               const ProblemEvaluation& at, const IdentifiabilityOptions& options) {
  const auto t0 = Clock::now();
  MomentJacobian J(0, 10);
  std::vector<std::string> notes;
  int with = 0;
  for (std::size_t e = 0; e < at.experiments.size(); ++e) {
    const auto& xe = at.experiments[e];
    const auto before = J.rows();
    appendObservationRows(xe.eval, xe.weight, true, &J);
    if (J.rows() > before) {
      ++with;
    } else {
      notes.push_back("experiment " + xe.name + " (" + problem.experiment(e).config.task() +
                      ") reports no measured observation of the mass moments: not part of this analysis");
    }
  }
  std::vector<double> r;
  problem.indicator(theta, &r);
  double solid = 0;
  for (double v : problem.cloud().V) solid += v;
  solid *= problem.task().density().value_r1;
  const MomentVector u = ownMomentScales(at.task.mass, solid, problem.task().size());
  if (with == 0) {
    IdentifiabilityAnalysis a;
    a.notes = notes;
    a.natural_units = u;
    a.summary =
        "No experiment reports observations of the mass moments (only rigid tasks do: hanging, balance, "
        "tumbler, ball), so what they determine is not analysed.";
    // Fewer observed numbers than the design has parameters: the interior is not determined (a
    // trajectory target stands for all its samples: not counted as one).
    std::vector<std::string> observed;
    bool trajectory = false;
    for (const auto& f : at.task.features)
      if (f.has_target) {
        observed.push_back(f.name);
        trajectory = trajectory || f.name.rfind("trajectory", 0) == 0;
      }
    if (!trajectory && static_cast<long>(observed.size()) < theta.size()) {
      std::string names;
      for (const auto& n : observed) names += (names.empty() ? "" : ", ") + n;
      a.summary += " " + std::to_string(observed.size()) + " observed number" + (observed.size() == 1 ? "" : "s") +
                   (names.empty() ? "" : " (" + names + ")") + " cannot determine the " + std::to_string(theta.size()) +
                   " parameters of the design: other interiors reproduce " + (observed.size() == 1 ? "it" : "them") +
                   " as well, and this one is one of them, not the interior; observe more (other experiments, e.g. "
                   "another pressure or load, or more features of each).";
    }
    a.seconds = secondsSince(t0);
    return a;
  }
  // σ̂ from the fit's residual over its redundant observations (the rank of J taken by a first analysis).
  const int rank = analyseMomentJacobian(J, u, options.determined_threshold).rank;
  const MeasuredResidual res = measuredResidual(at);
  const int dof = res.count - rank;
  const double sigma = fitNoiseScale(res.chi2, dof);
  IdentifiabilityAnalysis a = analyseMomentJacobian(J, u, options.determined_threshold, sigma);
  a.notes = notes;
  thetaRanks(problem, theta, r, options, &a);
  if (options.suggest) suggestNextExperiment(problem, r, J, options, &a);
  if (a.has_suggestion) a.summary += " Next: " + a.suggestion.sentence + ".";
  a.seconds = secondsSince(t0);
  return a;
}

}  // namespace topo_gaussian::inference
