// Rigid-body simulator: Newton–Euler with a unit quaternion, RK2 (midpoint), penalty ground contact
// with stick–slip friction, optional ball-joint pivot. Templated on the scalar (double, Dual10).
//
// Contact model (per contact point i, plane z = height, d_i = x_i.z − height, pen_i = δ − d_i > 0):
//   normal      f_n = clamp(k w_i pen_i − c w_i (pen_i / p_rest) v_n,i , 0, 2 k w_i pen_i)
//               w_i = GroundContact::point_weights (area shares, mean 1). The damper is of
//               Hunt–Crossley type (∝ penetration): c at the resting penetration p_rest, zero where a
//               point enters or leaves contact, so a rolling body is not dragged by it.
//               The damper is a fraction damping_ratio ζ of critical for the per-point stiffness and
//               the body mass share m / n_rest (n_rest = points in contact at rest, see ContactSetup):
//               c = 2 ζ sqrt(k m / n_rest), so the whole resting contact is damped at about ζ of
//               critical. The clamp keeps the force non-negative (no glue) and caps the damper by
//               the spring term, so the force is continuous (zero) when a point enters or leaves
//               contact: the discrete map stays continuous in the parameters (it is piecewise
//               smooth: central differences with relative steps ~1e-7 agree with the forward-mode
//               derivatives to ~1e-5) and entering points cause less rolling drag.
//   tangential  a tangential spring anchored where the point came into contact (stick–slip):
//               f_t = −k_t (x_t − a_t) − c v_t,  |f_t| ≤ μ f_n  (k_t = k). At the start of every
//               step the anchor of a point that slips (|k_t (x_t − a_t)| > μ f_n) is dragged along so
//               the spring force equals μ f_n (kinetic friction); new contacts anchor where they are.
//   Why not regularised Coulomb (f_t = −μ f_n v_t / max(|v_t|, v_eps)): in rolling contact it creeps
//   and dissipates continuously and its strength depends on v_eps (the rocking period of a
//   round-bottomed body is off by percents at small amplitudes, more the larger v_eps); the anchored spring sticks (rocking periods within 0.1 % of the closed form, no
//   dependence on μ once it sticks), slides with the Coulomb force when the spring saturates (a
//   launched ball ends rolling at 5/7 v0) and is continuous, which forward-mode derivatives need.
//
// Automatic stiffness (GroundContact::stiffness_n_per_m = 0): with s the median nearest-neighbour
// spacing of the contact points and L the largest distance of a point from the centre of mass, the
// target resting penetration is p* = min(0.1 s, 0.01 L). Placing the object in its initial
// orientation on the plane with its lowest point penetrated by p*, the points of relative height
// h_j < p* would carry k Σ (p* − h_j); k is chosen so that this equals m g_n:
//   k = m g_n / Σ_{h_j < p*} (p* − h_j)
// (g_n = normal component of gravity). k is proportional to the mass (k = m κ), so it carries the
// mass derivative and the resting penetration does not depend on the interior.
//
// Automatic substep (RigidSimOptions::max_substep_s = 0): the fastest contact mode with n points in
// contact is bounded by ω_c² = k n (1/m + ℓ²/I_min) (ℓ = largest lever arm of those points about the
// centre of mass, I_min the smallest principal moment; the tangential springs have the same k), the
// explicit damper needs c n (1/m + ℓ²/I_min) dt ≤ 0.5, and the slow (gravity) motion has
// ω_g² = m |g| L / I_min (pivot: about the pivot). dt = min(output_dt, 0.2/ω_c, 0.02/ω_g, 0.02/|ω0|),
// rounded so that a whole number of substeps fills one output interval. n is chosen per output
// interval: n_near (points within 2 × the resting penetration in the initial orientation) while at most
// 2 n_near points are or may come (current vertical speed × output_dt) into contact, else the next
// n_near × 2^j: a box that lands on a face gets a smaller step, a rocking tumbler keeps one step.
// (RK2 on an undamped oscillator gains energy ~ (ω dt)^4 / 4 per step: 0.02/ω_g keeps the drift of a
// pendulum below 2e-5 of its oscillation energy per period.) The automatic stiffness is tuned to the
// initial contact: an object that starts on a corner and ends on a face has a much stiffer face
// contact and so a much smaller step; pass an explicit stiffness for such runs.
//
// Accuracy notes (measured, see test/unit/core_rigid.cpp): the penalty penetration shortens the
// rolling radius by about the resting penetration (period bias −0.05…−0.2 % at p* = 0.1 s). The
// discrete sampling makes the contact slightly bumpy: for a rocking period within ~0.3 % the spacing
// near the contact must be ≲ 0.3 R θ_amplitude (R = radius of curvature at the contact). The normal
// damper causes a rolling drag of about ζ v sqrt(2 p*/g) / R × m g (≈ 1.4 % of m g at ζ = 0.1,
// v = 1 m/s, R = 5 cm, p* = 0.2 mm): for long free rolling use a small damping_ratio.
//
// Cost: the points that can touch during a step are found in a Verlet list (the points within a skin
// of max(4 p_rest, 0.02 L) of the plane, remade when the body has moved a point by more than the skin);
// only points in contact get a force. With S = Dual10 the forces are computed in plain doubles with
// their partial derivatives, summed over the points as 3×3 matrices and 3×3×3 moments, and multiplied
// with the state's derivative parts once per evaluation (RigidSim::addContactDual): same values and
// derivatives as dual numbers point by point, several times faster (RigidSpeed.Tumbler5000Points).
// eval, advance and addContactDual are flattened (every Eigen call inlined: otherwise GCC leaves the
// 10-vector assignments as out-of-line calls) and the 3×9 · 9×10 product is coefficient-based (Eigen
// would send it to its blocked GEMM): the same values up to that product's summation order, measured
// with `bench_infer tumbler_quadric_2s`.
#include "topo_gaussian/physics/rigid_body.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <type_traits>

#include <Eigen/Eigenvalues>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/number_text.h"

namespace topo_gaussian {

// ------------------------------------------------------------------------------------ seeding

RigidInertia<double> toInertia(const MassProperties& props) {
  RigidInertia<double> out;
  out.mass = props.mass;
  out.com = props.com;
  out.inertia = props.inertia;
  return out;
}

RigidInertia<Dual10> seedInertia(const MassProperties& props) {
  RigidInertia<Dual10> out;
  out.mass = Dual10(props.mass, 10, 0);
  for (int a = 0; a < 3; ++a) out.com(a) = Dual10(props.com(a), 10, 1 + a);
  for (int a = 0; a < 3; ++a) out.inertia(a, a) = Dual10(props.inertia(a, a), 10, 4 + a);
  out.inertia(0, 1) = Dual10(props.inertia(0, 1), 10, 7);
  out.inertia(1, 0) = Dual10(props.inertia(1, 0), 10, 7);
  out.inertia(0, 2) = Dual10(props.inertia(0, 2), 10, 8);
  out.inertia(2, 0) = Dual10(props.inertia(2, 0), 10, 8);
  out.inertia(1, 2) = Dual10(props.inertia(1, 2), 10, 9);
  out.inertia(2, 1) = Dual10(props.inertia(2, 1), 10, 9);
  return out;
}

namespace {

using std::sqrt;

template <typename S>
Eigen::Vector3d val(const Vec3<S>& v) {
  return Eigen::Vector3d(valueOf(v(0)), valueOf(v(1)), valueOf(v(2)));
}
template <typename S>
Eigen::Matrix3d val(const Mat3<S>& m) {
  Eigen::Matrix3d out;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) out(r, c) = valueOf(m(r, c));
  return out;
}
template <typename S>
Eigen::Quaterniond val(const Eigen::Quaternion<S>& q) {
  return Eigen::Quaterniond(valueOf(q.w()), valueOf(q.x()), valueOf(q.y()), valueOf(q.z()));
}
template <typename S>
Vec3<S> lift(const Eigen::Vector3d& v) {
  return Vec3<S>(S(v(0)), S(v(1)), S(v(2)));
}
template <typename S>
Mat3<S> lift(const Eigen::Matrix3d& m) {
  Mat3<S> out;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) out(r, c) = S(m(r, c));
  return out;
}
template <typename S>
Eigen::Quaternion<S> lift(const Eigen::Quaterniond& q) {
  return Eigen::Quaternion<S>(S(q.w()), S(q.x()), S(q.y()), S(q.z()));
}

template <typename S>
Eigen::Quaternion<S> normalizedQ(const Eigen::Quaternion<S>& q) {
  const S n = sqrt(q.coeffs().squaredNorm());
  Eigen::Quaternion<S> out;
  out.coeffs() = q.coeffs() / n;
  return out;
}

/// Symmetric 3×3 inverse by cofactors (works for any scalar).
template <typename S>
Mat3<S> inverse3(const Mat3<S>& a) {
  Mat3<S> c;
  c(0, 0) = a(1, 1) * a(2, 2) - a(1, 2) * a(2, 1);
  c(0, 1) = a(0, 2) * a(2, 1) - a(0, 1) * a(2, 2);
  c(0, 2) = a(0, 1) * a(1, 2) - a(0, 2) * a(1, 1);
  c(1, 0) = a(1, 2) * a(2, 0) - a(1, 0) * a(2, 2);
  c(1, 1) = a(0, 0) * a(2, 2) - a(0, 2) * a(2, 0);
  c(1, 2) = a(0, 2) * a(1, 0) - a(0, 0) * a(1, 2);
  c(2, 0) = a(1, 0) * a(2, 1) - a(1, 1) * a(2, 0);
  c(2, 1) = a(0, 1) * a(2, 0) - a(0, 0) * a(2, 1);
  c(2, 2) = a(0, 0) * a(1, 1) - a(0, 1) * a(1, 0);
  const S det = a(0, 0) * c(0, 0) + a(0, 1) * c(1, 0) + a(0, 2) * c(2, 0);
  return c / det;
}

// ------------------------------------------------------------------------------------ validation

bool finite(double x) { return std::isfinite(x); }

template <typename S>
void validateInertia(const RigidInertia<S>& in) {
  const double m = valueOf(in.mass);
  if (!(finite(m) && m > 0.0))
    throw TopoError("rigid inertia: mass", "must be positive and finite, got " + numberText(m, 4),
                    "pass the MassProperties of a non-empty object (mass > 0 kg)");
  const Eigen::Vector3d c = val(in.com);
  if (!c.allFinite())
    throw TopoError("rigid inertia: centre of mass", "is not finite (NaN or inf)",
                    "check the particle positions and masses the mass properties came from");
  const Eigen::Matrix3d I = val(in.inertia);
  if (!I.allFinite())
    throw TopoError("rigid inertia: inertia tensor", "is not finite (NaN or inf)",
                    "check the particle positions and masses the mass properties came from");
  const double scale = I.cwiseAbs().maxCoeff();
  if ((I - I.transpose()).cwiseAbs().maxCoeff() > 1e-9 * std::max(scale, 1e-300))
    throw TopoError("rigid inertia: inertia tensor", "is not symmetric",
                    "pass a symmetric tensor (I_xy = I_yx, I_xz = I_zx, I_yz = I_zy)");
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(I);
  const Eigen::Vector3d ev = es.eigenvalues();
  if (!(ev(0) > 1e-12 * std::max(ev(2), 0.0)) || !(ev(0) > 0.0))
    throw TopoError("rigid inertia: inertia tensor",
                    "is not positive definite (principal moments " + numberText(ev(0), 4) + ", " +
                        numberText(ev(1), 4) + ", " + numberText(ev(2), 4) + " kg m^2)",
                    "compute it about the centre of mass from positive particle masses (every principal "
                    "moment must be > 0)");
}

void validateOptions(const RigidSimOptions& o, bool need_time) {
  if (need_time) {
    if (!(finite(o.duration_s) && o.duration_s > 0.0))
      throw TopoError("rigid options: duration_s", "must be positive and finite, got " + numberText(o.duration_s, 4),
                      "set duration_s > 0 (seconds of motion to simulate)");
    if (!(finite(o.output_dt_s) && o.output_dt_s > 0.0))
      throw TopoError("rigid options: output_dt_s", "must be positive and finite, got " + numberText(o.output_dt_s, 4),
                      "set output_dt_s > 0 (e.g. 5e-3 s)");
    if (!(finite(o.max_substep_s) && o.max_substep_s >= 0.0))
      throw TopoError("rigid options: max_substep_s", "must be >= 0 and finite, got " + numberText(o.max_substep_s, 4),
                      "use 0 for the automatic step or a positive step in seconds");
  }
  if (!o.gravity.allFinite())
    throw TopoError("rigid options: gravity", "is not finite", "set gravity to e.g. (0, 0, -9.81) m/s^2");
  if (!(finite(o.linear_damping_per_s) && o.linear_damping_per_s >= 0.0))
    throw TopoError("rigid options: linear_damping_per_s", "must be >= 0, got " + numberText(o.linear_damping_per_s, 4),
                    "use 0 for no damping");
  if (!(finite(o.angular_damping_per_s) && o.angular_damping_per_s >= 0.0))
    throw TopoError("rigid options: angular_damping_per_s",
                    "must be >= 0, got " + numberText(o.angular_damping_per_s, 4), "use 0 for no damping");
  const GroundContact& g = o.ground;
  if (!finite(g.height_m)) throw TopoError("rigid options: ground.height_m", "is not finite", "set a finite height");
  if (!(finite(g.stiffness_n_per_m) && g.stiffness_n_per_m >= 0.0))
    throw TopoError("rigid options: ground.stiffness_n_per_m",
                    "must be >= 0, got " + numberText(g.stiffness_n_per_m, 4), "use 0 for the automatic stiffness");
  if (!finite(g.offset_m)) throw TopoError("rigid options: ground.offset_m", "is not finite", "use e.g. 0");
  if (!(finite(g.damping_ratio) && g.damping_ratio >= 0.0))
    throw TopoError("rigid options: ground.damping_ratio", "must be >= 0, got " + numberText(g.damping_ratio, 4),
                    "use a fraction of critical damping such as 0.1");
  if (!(finite(g.friction_mu) && g.friction_mu >= 0.0))
    throw TopoError("rigid options: ground.friction_mu", "must be >= 0, got " + numberText(g.friction_mu, 4),
                    "use a Coulomb coefficient such as 1");
  if (o.pivot && !(o.pivot_body.allFinite() && o.pivot_world.allFinite()))
    throw TopoError("rigid options: pivot_body/pivot_world", "is not finite", "give finite pivot points");
}

template <typename S>
void validateState(const RigidState<S>& s, bool pivot) {
  const Eigen::Quaterniond q = val(s.orientation);
  if (!q.coeffs().allFinite() || !(q.coeffs().norm() > 1e-12))
    throw TopoError("rigid initial state: orientation", "is not a finite non-zero quaternion",
                    "pass a unit quaternion (e.g. Identity())");
  if (!val(s.angular_velocity).allFinite())
    throw TopoError("rigid initial state: angular_velocity", "is not finite", "pass finite values");
  if (!pivot && !(val(s.position).allFinite() && val(s.velocity).allFinite()))
    throw TopoError("rigid initial state: position/velocity", "is not finite", "pass finite values");
}

void validatePoints(const std::vector<Eigen::Vector3d>& pts, const std::vector<double>& weights) {
  for (size_t i = 0; i < pts.size(); ++i)
    if (!pts[i].allFinite())
      throw TopoError("rigid contact points", "point " + std::to_string(i) + " is not finite (NaN or inf)",
                      "remove non-finite points from the contact cloud");
  if (!weights.empty() && weights.size() != pts.size())
    throw TopoError(
        "rigid options: ground.point_weights",
        "has " + std::to_string(weights.size()) + " weights for " + std::to_string(pts.size()) + " contact points",
        "give one weight per contact point, or none");
  for (size_t i = 0; i < weights.size(); ++i)
    if (!(weights[i] > 0.0) || !std::isfinite(weights[i]))
      throw TopoError("rigid options: ground.point_weights",
                      "weight " + std::to_string(i) + " is " + numberText(weights[i], 4),
                      "give positive finite weights (a point's share of the surface area over the mean share)");
}

// ------------------------------------------------------------------------------------ contact setup

double normalGravity(const RigidSimOptions& o) {
  const double gm = o.gravity.norm();
  const double gn = -o.gravity.z();
  if (gn > 1e-3 * gm) return gn;
  return gm > 0.0 ? gm : 9.81;
}

/// Median nearest-neighbour distance over a deterministic subsample of at most 256 points.
double estimateSpacing(const std::vector<Eigen::Vector3d>& pts) {
  const size_t n = pts.size();
  if (n < 2) return 0.0;
  const size_t samples = std::min<size_t>(n, 256);
  std::vector<double> nn;
  nn.reserve(samples);
  for (size_t s = 0; s < samples; ++s) {
    const size_t i = (s * n) / samples;
    double best = std::numeric_limits<double>::infinity();
    for (size_t j = 0; j < n; ++j) {
      if (j == i) continue;
      const double d2 = (pts[j] - pts[i]).squaredNorm();
      if (d2 > 0.0 && d2 < best) best = d2;
    }
    if (std::isfinite(best)) nn.push_back(std::sqrt(best));
  }
  if (nn.empty()) return 0.0;
  std::nth_element(nn.begin(), nn.begin() + nn.size() / 2, nn.end());
  return nn[nn.size() / 2];
}

/// Everything the contact needs that is fixed for a run (computed from value parts in the reference
/// orientation: the initial one).
struct ContactSetup {
  bool active = false;
  bool auto_k = false;
  double kappa = 0.0;     ///< auto: k = m κ
  double k_value = 0.0;   ///< per-point stiffness value [N/m]
  double pen_rest = 0.0;  ///< resting penetration of the lowest point [m]
  int n_rest = 1;         ///< points in contact at rest
  int n_near = 1;         ///< points within 2 pen_rest of the lowest
  double lever = 0.0;     ///< largest distance from the com of those points
  double size = 0.0;      ///< L: largest distance of any contact point from the com
  double spacing = 0.0;
  int lowest = -1;            ///< index of the lowest point in the reference orientation
  std::vector<int> rest_set;  ///< points in contact at rest (relative height < pen_rest)
  double rest_sum_h = 0.0;    ///< Σ w_j h_j (relative heights) over rest_set
  double rest_sum_w = 0.0;    ///< Σ w_j over rest_set
};

ContactSetup makeContactSetup(double m, const Eigen::Vector3d& com, const Eigen::Matrix3d& R,
                              const std::vector<Eigen::Vector3d>& pts, const RigidSimOptions& o) {
  ContactSetup cs;
  const size_t n = pts.size();
  for (size_t i = 0; i < n; ++i) cs.size = std::max(cs.size, (pts[i] - com).norm());
  if (!o.ground.enabled || n == 0) return cs;
  cs.active = true;
  const double gn = normalGravity(o);
  std::vector<double> h(n);
  double hmin = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < n; ++i) {
    h[i] = R.row(2).dot(pts[i] - com);
    if (h[i] < hmin) {
      hmin = h[i];
      cs.lowest = static_cast<int>(i);
    }
  }
  for (size_t i = 0; i < n; ++i) h[i] -= hmin;
  const std::vector<double>& wt = o.ground.point_weights;
  auto weight = [&](size_t i) { return wt.empty() ? 1.0 : wt[i]; };
  std::vector<std::pair<double, double>> sorted(n);  // (relative height, weight)
  for (size_t i = 0; i < n; ++i) sorted[i] = {h[i], weight(i)};
  std::sort(sorted.begin(), sorted.end());

  if (o.ground.stiffness_n_per_m > 0.0) {
    cs.auto_k = false;
    cs.k_value = o.ground.stiffness_n_per_m;
    // Solve k Σ_{h_j < pen} w_j (pen − h_j) = m g_n, piecewise linear in pen.
    const double w = m * gn / cs.k_value;
    double sum = 0.0, wsum = 0.0;
    cs.pen_rest = w / sorted[0].second + sorted[0].first;
    for (size_t j = 0; j < n; ++j) {
      sum += sorted[j].second * sorted[j].first;
      wsum += sorted[j].second;
      const double pen = (w + sum) / wsum;
      cs.pen_rest = pen;
      if (j + 1 == n || pen <= sorted[j + 1].first) break;
    }
  } else {
    cs.auto_k = true;
    cs.spacing = estimateSpacing(pts);
    double target = 0.1 * cs.spacing;
    if (cs.size > 0.0) target = target > 0.0 ? std::min(target, 0.01 * cs.size) : 0.01 * cs.size;
    if (!(target > 0.0)) target = 1e-3;
    double s = 0.0;
    for (size_t j = 0; j < n && sorted[j].first < target; ++j) s += sorted[j].second * (target - sorted[j].first);
    cs.kappa = gn / s;
    cs.k_value = m * cs.kappa;
    cs.pen_rest = target;
  }
  cs.rest_sum_h = 0.0;
  cs.rest_sum_w = 0.0;
  int near = 0;
  for (size_t i = 0; i < n; ++i) {
    if (h[i] < cs.pen_rest || static_cast<int>(i) == cs.lowest) {
      cs.rest_set.push_back(static_cast<int>(i));
      cs.rest_sum_h += weight(i) * h[i];
      cs.rest_sum_w += weight(i);
    }
    if (h[i] < 2.0 * cs.pen_rest || static_cast<int>(i) == cs.lowest) {
      ++near;
      cs.lever = std::max(cs.lever, (pts[i] - com).norm());
    }
  }
  cs.n_rest = std::max<int>(1, static_cast<int>(cs.rest_set.size()));
  cs.n_near = std::max(1, near);
  return cs;
}

template <typename S>
S stiffnessOf(const ContactSetup& cs, const S& m) {
  if (cs.auto_k) return m * S(cs.kappa);
  return S(cs.k_value);
}

// ------------------------------------------------------------------------------------ simulator

template <typename S>
using Vec2 = Eigen::Matrix<S, 2, 1>;

template <typename S>
struct Deriv {
  Vec3<S> dp, dv, dw;
  Eigen::Matrix<S, 4, 1> dq;  ///< quaternion coefficient rates (x, y, z, w)
};

template <typename S>
class RigidSim {
 public:
  RigidSim(const RigidInertia<S>& in, const std::vector<Eigen::Vector3d>& pts, const RigidSimOptions& o,
           const ContactSetup& cs)
      : pts_(pts), o_(o) {
    m_ = in.mass;
    com_ = in.com;
    com_v_ = val(in.com);
    I_com_ = in.inertia;
    pivot_ = o.pivot;
    if (pivot_) {
      r_pivot_ = lift<S>(o.pivot_body) - com_;  // body frame, com → pivot
      const S r2 = r_pivot_.squaredNorm();
      I_dyn_ = I_com_ + m_ * (Mat3<S>::Identity() * r2 - r_pivot_ * r_pivot_.transpose());
    } else {
      r_pivot_ = Vec3<S>::Zero();
      I_dyn_ = I_com_;
    }
    I_dyn_inv_ = inverse3(I_dyn_);
    g_ = lift<S>(o.gravity);
    lin_c_ = o.linear_damping_per_s;
    ang_c_ = o.angular_damping_per_s;
    contact_ = cs.active;
    height_ = o.ground.height_m;
    delta_ = o.ground.offset_m;
    mu_ = o.ground.friction_mu;
    if (contact_) {
      k_ = stiffnessOf(cs, m_);
      pen_rest_ = cs.pen_rest > 0.0 ? cs.pen_rest : 1e-3;
      c_ = S(2.0 * o.ground.damping_ratio) * sqrt(k_ * m_ / S(static_cast<double>(cs.n_rest)));
      const size_t n = pts.size();
      bx_.resize(n);
      by_.resize(n);
      bz_.resize(n);
      for (size_t i = 0; i < n; ++i) {
        bx_[i] = pts[i].x() - com_v_.x();
        by_[i] = pts[i].y() - com_v_.y();
        bz_[i] = pts[i].z() - com_v_.z();
      }
      w_ = o.ground.point_weights;
      if (w_.empty()) w_.assign(n, 1.0);
      // Skin of the Verlet list: wide enough that a rocking body remakes it every few output samples,
      // narrow enough to hold a small part of the points.
      size_ = cs.size;
      skin_m_ = std::max(4.0 * pen_rest_, 0.02 * cs.size);
      anchor_.assign(n, Vec2<S>::Zero());
      flag_.assign(n, 0);
    } else {
      k_ = S(0.0);
      c_ = S(0.0);
    }
  }

  /// Applies the pivot constraint (position and velocity follow the rotation).
  void constrain(RigidState<S>* s) const {
    if (!pivot_) return;
    const Mat3<S> R = s->orientation.toRotationMatrix();
    const Vec3<S> arm = -(R * r_pivot_);  // pivot → com, world
    s->position = lift<S>(o_.pivot_world) + arm;
    s->velocity = s->angular_velocity.cross(arm);
  }

  /// Indices of points whose value height is below the contact offset (all points).
  void screenAll(const RigidState<S>& s, double margin, std::vector<int>* out) const {
    out->clear();
    if (!contact_) return;
    const Eigen::Matrix3d R = val(s.orientation).toRotationMatrix();
    const double r0 = R(2, 0), r1 = R(2, 1), r2 = R(2, 2);
    const double thr = height_ + delta_ + margin - valueOf(s.position.z());
    const size_t n = bx_.size();
    for (size_t i = 0; i < n; ++i) {
      const double z = r0 * bx_[i] + r1 * by_[i] + r2 * bz_[i];
      if (z < thr) out->push_back(static_cast<int>(i));
    }
  }

  /// The same set, searched among the points that were within a skin of width skin_m_ of the contact
  /// offset when the list was made (a Verlet list): no point moves farther than |Δp| + θ L (θ the
  /// rotation since then, L the largest distance of a point from the centre of mass), so while that
  /// stays below the skin no other point can touch; the list is remade when it does not.
  void screen(const RigidState<S>& s, std::vector<int>* out) {
    out->clear();
    if (!contact_) return;
    const Eigen::Quaterniond q = val(s.orientation);
    const Eigen::Vector3d pos = val(s.position);
    const Eigen::Quaterniond dq = skin_q_.conjugate() * q;
    const double moved = (pos - skin_p_).norm() + 2.0 * std::atan2(dq.vec().norm(), std::abs(dq.w())) * size_;
    if (!skin_valid_ || !(moved < skin_m_)) {
      screenAll(s, skin_m_, &skin_);
      skin_q_ = q, skin_p_ = pos, skin_valid_ = true;
    }
    const Eigen::Matrix3d R = q.toRotationMatrix();
    const double r0 = R(2, 0), r1 = R(2, 1), r2 = R(2, 2);
    const double thr = height_ + delta_ - pos.z();
    for (int i : skin_) {
      const double z = r0 * bx_[i] + r1 * by_[i] + r2 * bz_[i];
      if (z < thr) out->push_back(i);
    }
  }

  /// Time derivative at s. When update_anchors, first brings the friction anchors up to date
  /// (new contacts anchor where they are, lost contacts are released, slipping anchors follow).
  __attribute__((flatten)) Deriv<S> eval(const RigidState<S>& s, const std::vector<int>& cand, bool update_anchors) {
    const Mat3<S> R = s.orientation.toRotationMatrix();
    const Vec3<S>& p = s.position;
    const Vec3<S>& v = s.velocity;
    const Vec3<S>& w = s.angular_velocity;
    Vec3<S> F = m_ * g_;
    if (lin_c_ > 0.0) {
      const S cm = S(lin_c_) * m_;
      F -= cm * v;
    }
    Vec3<S> tau = Vec3<S>::Zero();  // about the com (free) or the pivot
    Vec3<S> ref = p;
    if (pivot_) {
      ref = lift<S>(o_.pivot_world);
      tau = (p - ref).cross(F);
    }

    if constexpr (std::is_same_v<S, Dual10>) {
      addContactDual(R, s, ref, cand, update_anchors, &F, &tau);
    } else {
      addContactGeneric(R, s, ref, cand, update_anchors, &F, &tau);
    }

    Deriv<S> d;
    // Euler in the body frame: I ω̇_b = τ_b − ω_b × I ω_b (− c_ang I ω_b); ω̇ = R ω̇_b.
    const Vec3<S> wb = R.transpose() * w;
    const Vec3<S> tb = R.transpose() * tau;
    Vec3<S> dwb = I_dyn_inv_ * (tb - wb.cross(I_dyn_ * wb));
    if (ang_c_ > 0.0) dwb -= S(ang_c_) * wb;
    d.dw = R * dwb;
    if (pivot_) {
      d.dp = Vec3<S>::Zero();
      d.dv = Vec3<S>::Zero();
    } else {
      d.dp = v;
      d.dv = F / m_;
    }
    // q̇ = ½ (0, ω) ⊗ q
    const Eigen::Quaternion<S>& q = s.orientation;
    const Vec3<S> qv(q.x(), q.y(), q.z());
    const Vec3<S> dqv = S(0.5) * (q.w() * w + w.cross(qv));
    d.dq << dqv(0), dqv(1), dqv(2), S(-0.5) * w.dot(qv);
    return d;
  }

  /// Normal force of a point with spring force fs = k_i pen and Hunt–Crossley damper c_i v_z, clamped
  /// to [0, 2 fs] (no glue; the damper never more than doubles the spring).
  template <typename T>
  static T clampedNormal(const T& fs, const T& ci, const T& vz) {
    T fn = fs - ci * vz;
    if (valueOf(fn) < 0.0) return T(0.0);
    if (valueOf(fn) > 2.0 * valueOf(fs)) return T(2.0) * fs;
    return fn;
  }

  /// Friction anchor of point i (in contact) at the start of a step: a new contact anchors where it is;
  /// one that slips (spring force k_i |x_t − a| above lim = μ f_n) is dragged so the spring force is lim.
  void updateAnchor(int i, const Vec2<S>& xt, const S& ki, const S& lim) {
    if (flag_[i] == 0) {
      anchor_[i] = xt;
    } else {
      const Vec2<S> dsp = xt - anchor_[i];
      const S sp2 = ki * ki * dsp.squaredNorm();
      const double limv = valueOf(lim);
      if (valueOf(sp2) > limv * limv) {
        if (limv > 0.0) {
          const S scale = lim / sqrt(sp2);
          anchor_[i] = xt - dsp * scale;
        } else {
          anchor_[i] = xt;
        }
      }
    }
    flag_[i] = 1;
  }

  /// Contact forces and torques of the candidate points, computed in S (the plain double path).
  void addContactGeneric(const Mat3<S>& R, const RigidState<S>& s, const Vec3<S>& ref, const std::vector<int>& cand,
                         bool update_anchors, Vec3<S>* F, Vec3<S>* tau) {
    const Vec3<S>& p = s.position;
    const Vec3<S>& v = s.velocity;
    const Vec3<S>& w = s.angular_velocity;
    if (update_anchors)
      for (int j : active_) flag_[j] = 2;  // stale unless still in contact
    std::vector<int> now;
    if (update_anchors) now.reserve(cand.size());
    for (int i : cand) {
      const Vec3<S> r = R * (lift<S>(pts_[i]) - com_);
      const Vec3<S> x = p + r;
      const S pen = S(height_ + delta_) - x.z();
      if (!(valueOf(pen) > 0.0)) continue;
      const Vec3<S> vel = v + w.cross(r);
      // Hunt–Crossley: the damper grows with the penetration (c pen / p_rest), so it is c at the resting
      // penetration but vanishes where points enter and leave contact, which is where a rolling body's
      // damper caused its drag (a ball rolling down 15° came out 5 % slow with a constant c).
      const S ki = k_ * w_[i], ci = c_ * w_[i] * (pen / S(pen_rest_));
      const S fn = clampedNormal<S>(ki * pen, ci, vel.z());
      const Vec2<S> xt(x.x(), x.y());
      Vec2<S> ft(S(0.0), S(0.0));
      if (mu_ > 0.0) {
        const S lim = S(mu_) * fn;
        if (update_anchors) {
          updateAnchor(i, xt, ki, lim);
          now.push_back(i);
        }
        ft = -ci * Vec2<S>(vel.x(), vel.y());
        if (flag_[i] == 1) ft -= ki * (xt - anchor_[i]);
        const S f2 = ft.squaredNorm();
        const double limv = valueOf(lim);
        if (valueOf(f2) > limv * limv) {
          if (limv > 0.0) {
            const S scale = lim / sqrt(f2);
            ft *= scale;
          } else {
            ft = Vec2<S>(S(0.0), S(0.0));
          }
        }
      }
      const Vec3<S> f(ft(0), ft(1), fn);
      *F += f;
      *tau += (x - ref).cross(f);
    }
    if (update_anchors) {
      for (int j : active_)
        if (flag_[j] == 2) flag_[j] = 0;
      active_.swap(now);
    }
  }

  /// The same forces for S = Dual10, at a fraction of the cost: each point's force f_i and its partial
  /// derivatives (∂f/∂x, ∂f/∂v_point, ∂f/∂k, ∂f/∂c, ∂f/∂anchor) in plain doubles, summed over the points
  /// as 3×3 matrices (and 3×3×3 moments Σ P_i ⊗ u_i for the rotation's derivative, u_i = b_i − c), then
  /// one product with the state's derivative parts:
  ///   dx_i = dp + dR u_i − R dc,   dv_i = dv + dω × r_i + ω × dr_i,   dτ_i = −[f_i]× dρ_i + [ρ_i]× df_i
  /// (ρ_i = x_i − reference point). Same values as addContactGeneric; derivatives to rounding.
  __attribute__((flatten)) void addContactDual(const Mat3<S>& R, const RigidState<S>& s, const Vec3<S>& ref,
                                               const std::vector<int>& cand, bool update_anchors, Vec3<S>* F_out,
                                               Vec3<S>* tau_out) {
    using M3 = Eigen::Matrix3d;
    using V3 = Eigen::Vector3d;
    using D10 = Eigen::Matrix<double, 3, 10>;
    const M3 Rv = val(R);
    const V3 pv = val(s.position), vv = val(s.velocity), wv = val(s.angular_velocity), refv = val(ref);
    const double kv = valueOf(k_), cv = valueOf(c_), H = height_ + delta_;
    auto skew = [](const V3& a) {
      M3 m;
      m << 0.0, -a.z(), a.y(), a.z(), 0.0, -a.x(), -a.y(), a.x(), 0.0;
      return m;
    };
    // Pass 1 (start of a step): friction anchors. Only points whose anchor moves (new contacts, slipping
    // points) are evaluated in dual numbers.
    if (update_anchors) {
      for (int j : active_) flag_[j] = 2;
      std::vector<int> now;
      now.reserve(cand.size());
      for (int i : cand) {
        const V3 r = Rv * V3(bx_[i], by_[i], bz_[i]);
        const V3 x = pv + r;
        const double pen = H - x.z();
        if (!(pen > 0.0) || !(mu_ > 0.0)) continue;
        bool moves = flag_[i] == 0;
        if (!moves) {
          const V3 vel = vv + wv.cross(r);
          const double ki = kv * w_[i];
          const double lim = mu_ * clampedNormal<double>(ki * pen, cv * w_[i] * pen / pen_rest_, vel.z());
          const Eigen::Vector2d dsp(x.x() - valueOf(anchor_[i](0)), x.y() - valueOf(anchor_[i](1)));
          moves = ki * ki * dsp.squaredNorm() > lim * lim;
        }
        if (moves) {
          const Vec3<S> rd = R * (lift<S>(pts_[i]) - com_);
          const Vec3<S> xd = s.position + rd;
          const S pen_d = S(H) - xd.z();
          const Vec3<S> vel_d = s.velocity + s.angular_velocity.cross(rd);
          const S ki = k_ * w_[i], ci = c_ * w_[i] * (pen_d / S(pen_rest_));
          updateAnchor(i, Vec2<S>(xd.x(), xd.y()), ki, S(mu_) * clampedNormal<S>(ki * pen_d, ci, vel_d.z()));
        } else {
          flag_[i] = 1;
        }
        now.push_back(i);
      }
      for (int j : active_)
        if (flag_[j] == 2) flag_[j] = 0;
      active_.swap(now);
    }
    // Pass 2: values and partial derivatives, summed.
    const M3 wx = skew(wv);
    V3 Fv = V3::Zero(), Tv = V3::Zero();
    M3 SA[2], SB[2], SBr[2], SP[2];
    V3 Sk[2], Sc[2];
    Eigen::Matrix<double, 3, 9> T[2];  // T[a, 3 j + k] = Σ P_i(a, j) u_i(k)
    for (int t = 0; t < 2; ++t) {
      SA[t].setZero(), SB[t].setZero(), SBr[t].setZero(), SP[t].setZero(), Sk[t].setZero(), Sc[t].setZero();
      T[t].setZero();
    }
    D10 anchor_F = D10::Zero(), anchor_T = D10::Zero();
    for (int i : cand) {
      const V3 u(bx_[i], by_[i], bz_[i]);
      const V3 r = Rv * u;
      const V3 x = pv + r;
      const double pen = H - x.z();
      if (!(pen > 0.0)) continue;
      const V3 vel = vv + wv.cross(r);
      const double wi = w_[i], ki = kv * wi, ci = cv * wi * pen / pen_rest_, fs = ki * pen;
      // normal force and its partials (rows 2 of A = ∂f/∂x, B = ∂f/∂v_point; κ = ∂f/∂k, γ = ∂f/∂c)
      M3 A = M3::Zero(), B = M3::Zero();
      V3 kap = V3::Zero(), gam = V3::Zero();
      double fn = fs - ci * vel.z();
      if (fn < 0.0) {
        fn = 0.0;
      } else if (fn > 2.0 * fs) {
        fn = 2.0 * fs;
        A(2, 2) = -2.0 * ki;
        kap(2) = 2.0 * wi * pen;
      } else {
        A(2, 2) = -(ki - cv * wi * vel.z() / pen_rest_);
        B(2, 2) = -ci;
        kap(2) = wi * pen;
        gam(2) = -wi * pen * vel.z() / pen_rest_;
      }
      Eigen::Vector2d ft = Eigen::Vector2d::Zero();
      Eigen::Matrix2d E = Eigen::Matrix2d::Zero();  // ∂f_t/∂anchor
      if (mu_ > 0.0) {
        const double lim = mu_ * fn;
        const Eigen::Vector2d vt(vel.x(), vel.y());
        ft = -ci * vt;
        A.block<2, 1>(0, 2) = (cv * wi / pen_rest_) * vt;  // ci grows with pen = H − x_z
        B(0, 0) = -ci, B(1, 1) = -ci;
        gam.head<2>() = -(wi * pen / pen_rest_) * vt;
        if (flag_[i] == 1) {
          const Eigen::Vector2d d(x.x() - valueOf(anchor_[i](0)), x.y() - valueOf(anchor_[i](1)));
          ft -= ki * d;
          A(0, 0) -= ki, A(1, 1) -= ki;
          kap.head<2>() = -wi * d;
          E = ki * Eigen::Matrix2d::Identity();
        }
        const double f2 = ft.squaredNorm();
        if (f2 > lim * lim) {
          if (lim > 0.0) {
            // f_t = lim n, n = raw / |raw|: df_t = (lim / |raw|)(I − n nᵀ) d raw + n d lim
            const double nr = std::sqrt(f2);
            const Eigen::Vector2d n = ft / nr;
            const Eigen::Matrix2d Pm = (lim / nr) * (Eigen::Matrix2d::Identity() - n * n.transpose());
            ft = lim * n;
            A.topRows<2>() = Pm * A.topRows<2>() + mu_ * n * A.row(2);
            B.topRows<2>() = Pm * B.topRows<2>() + mu_ * n * B.row(2);
            kap.head<2>() = Pm * kap.head<2>() + mu_ * kap(2) * n;
            gam.head<2>() = Pm * gam.head<2>() + mu_ * gam(2) * n;
            E = Pm * E;
          } else {
            ft.setZero();
            A.topRows<2>().setZero(), B.topRows<2>().setZero();
            kap.head<2>().setZero(), gam.head<2>().setZero();
            E.setZero();
          }
        }
      }
      const V3 f(ft(0), ft(1), fn);
      const V3 rho = x - refv;
      const M3 Mx = skew(rho);
      Fv += f;
      Tv += rho.cross(f);
      const M3 P = A + B * wx;  // ∂f/∂r_i (through x_i and the point's velocity)
      const M3 Br = B * skew(r);
      const M3 Q = Mx * P - skew(f);  // ∂τ/∂r_i
      SA[0] += A, SB[0] += B, SBr[0] += Br, SP[0] += P, Sk[0] += kap, Sc[0] += gam;
      SA[1] += Mx * A, SB[1] += Mx * B, SBr[1] += Mx * Br, SP[1] += Q, Sk[1] += Mx * kap, Sc[1] += Mx * gam;
      if (pivot_) SA[1] -= skew(f);  // ρ_i = x_i − pivot also moves with p
      for (int j = 0; j < 3; ++j)
        for (int k = 0; k < 3; ++k) {
          T[0].col(3 * j + k) += P.col(j) * u(k);
          T[1].col(3 * j + k) += Q.col(j) * u(k);
        }
      if (flag_[i] == 1 && mu_ > 0.0 && E.squaredNorm() > 0.0) {
        Eigen::Matrix<double, 2, 10> DA;
        DA.row(0) = anchor_[i](0).derivatives().transpose();
        DA.row(1) = anchor_[i](1).derivatives().transpose();
        const Eigen::Matrix<double, 2, 10> EDA = E * DA;
        anchor_F.topRows<2>() += EDA;
        anchor_T += Mx.leftCols<2>() * EDA;
      }
    }
    // One product with the state's derivative parts.
    D10 DP, DV, DW, DC;
    Eigen::Matrix<double, 9, 10> DR;
    for (int a = 0; a < 3; ++a) {
      DP.row(a) = s.position(a).derivatives().transpose();
      DV.row(a) = s.velocity(a).derivatives().transpose();
      DW.row(a) = s.angular_velocity(a).derivatives().transpose();
      DC.row(a) = com_(a).derivatives().transpose();
      for (int b = 0; b < 3; ++b) DR.row(3 * a + b) = R(a, b).derivatives().transpose();
    }
    const D10 RDC = Rv * DC;
    const Eigen::Matrix<double, 1, 10> dk = k_.derivatives().transpose(), dc = c_.derivatives().transpose();
    D10 dF = anchor_F, dT = anchor_T;
    D10* out[2] = {&dF, &dT};
    for (int t = 0; t < 2; ++t) {
      *out[t] += SA[t] * DP + SB[t] * DV - SBr[t] * DW + Sk[t] * dk + Sc[t] * dc + T[t].lazyProduct(DR) - SP[t] * RDC;
    }
    for (int a = 0; a < 3; ++a) {
      (*F_out)(a) += S(Fv(a), Eigen::Matrix<double, 10, 1>(dF.row(a).transpose()));
      (*tau_out)(a) += S(Tv(a), Eigen::Matrix<double, 10, 1>(dT.row(a).transpose()));
    }
  }

  __attribute__((flatten)) RigidState<S> advance(const RigidState<S>& s, const Deriv<S>& d, double h) const {
    RigidState<S> out;
    const S hs(h);
    out.position = s.position + hs * d.dp;
    out.velocity = s.velocity + hs * d.dv;
    out.angular_velocity = s.angular_velocity + hs * d.dw;
    Eigen::Quaternion<S> q;
    q.coeffs() = s.orientation.coeffs() + hs * d.dq;
    out.orientation = normalizedQ(q);
    constrain(&out);
    return out;
  }

  /// One RK2 (midpoint) step.
  RigidState<S> step(const RigidState<S>& s, double dt) {
    screen(s, &cand_);
    const Deriv<S> k1 = eval(s, cand_, true);
    const RigidState<S> mid = advance(s, k1, 0.5 * dt);
    screen(mid, &cand_);
    const Deriv<S> k2 = eval(mid, cand_, false);
    return advance(s, k2, dt);
  }

  S energy(const RigidState<S>& s) const {
    const Mat3<S> R = s.orientation.toRotationMatrix();
    const Vec3<S> wb = R.transpose() * s.angular_velocity;
    S e = S(0.5) * m_ * s.velocity.squaredNorm() + S(0.5) * wb.dot(I_com_ * wb) - m_ * g_.dot(s.position);
    if (contact_) {
      std::vector<int> c;
      screenAll(s, 0.0, &c);
      for (int i : c) {
        const Vec3<S> x = s.position + R * (lift<S>(pts_[i]) - com_);
        const S pen = S(height_ + delta_) - x.z();
        if (valueOf(pen) > 0.0) e += S(0.5) * k_ * w_[i] * pen * pen;
      }
    }
    return e;
  }

  /// Points that are, or may come, within `margin` of the contact offset during the next `horizon`
  /// seconds (value parts: height + min(0, vertical speed) × horizon); also their largest distance
  /// from the centre of mass.
  int nearCount(const RigidState<S>& s, double horizon, double margin, double* lever) const {
    *lever = 0.0;
    if (!contact_) return 0;
    const Eigen::Matrix3d R = val(s.orientation).toRotationMatrix();
    const Eigen::Vector3d w = val(s.angular_velocity);
    const double vz = valueOf(s.velocity.z());
    const double thr = height_ + delta_ + margin - valueOf(s.position.z());
    int n = 0;
    for (size_t i = 0; i < bx_.size(); ++i) {
      const Eigen::Vector3d b(bx_[i], by_[i], bz_[i]);
      const Eigen::Vector3d r = R * b;
      const double zdot = vz + w.x() * r.y() - w.y() * r.x();
      if (r.z() + std::min(0.0, zdot) * horizon < thr) {
        ++n;
        *lever = std::max(*lever, b.norm());
      }
    }
    return n;
  }

  const S& stiffness() const { return k_; }
  double dampingValue() const { return valueOf(c_); }
  const Mat3<S>& dynInertia() const { return I_dyn_; }

 private:
  const std::vector<Eigen::Vector3d>& pts_;
  const RigidSimOptions& o_;
  S m_;
  Vec3<S> com_;
  Eigen::Vector3d com_v_;
  Mat3<S> I_com_, I_dyn_, I_dyn_inv_;
  bool pivot_ = false;
  Vec3<S> r_pivot_;
  Vec3<S> g_;
  double lin_c_ = 0.0, ang_c_ = 0.0;
  bool contact_ = false;
  double height_ = 0.0, delta_ = 0.0, mu_ = 0.0;
  S k_, c_;
  std::vector<double> w_;   ///< GroundContact::point_weights, or all 1
  double pen_rest_ = 1e-3;  ///< resting penetration [m]: where the Hunt–Crossley damper equals c
  std::vector<double> bx_, by_, bz_;
  std::vector<Vec2<S>> anchor_;
  std::vector<char> flag_;   ///< 0 free, 1 anchored, 2 stale (during an update)
  std::vector<int> active_;  ///< anchored points
  std::vector<int> cand_;
  double size_ = 0.0;    ///< largest distance of a contact point from the centre of mass [m]
  double skin_m_ = 0.0;  ///< Verlet skin [m]
  bool skin_valid_ = false;
  std::vector<int> skin_;  ///< points within the skin when it was made
  Eigen::Quaterniond skin_q_ = Eigen::Quaterniond::Identity();
  Eigen::Vector3d skin_p_ = Eigen::Vector3d::Zero();
};

double minPrincipal(const Eigen::Matrix3d& I) {
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(0.5 * (I + I.transpose()));
  return es.eigenvalues()(0);
}

}  // namespace

// ------------------------------------------------------------------------------------ public API

template <typename S>
RigidTrajectory<S> simulateRigid(const RigidInertia<S>& inertia, const RigidState<S>& initial,
                                 const std::vector<Eigen::Vector3d>& contact_points_body,
                                 const RigidSimOptions& options) {
  validateInertia(inertia);
  validateOptions(options, true);
  validateState(initial, options.pivot);
  validatePoints(contact_points_body, options.ground.point_weights);

  const double m = valueOf(inertia.mass);
  const Eigen::Vector3d com = val(inertia.com);
  RigidState<S> state = initial;
  state.orientation = normalizedQ(initial.orientation);
  const Eigen::Matrix3d R0 = val(state.orientation).toRotationMatrix();
  const ContactSetup cs = makeContactSetup(m, com, R0, contact_points_body, options);
  RigidSim<S> sim(inertia, contact_points_body, options, cs);
  sim.constrain(&state);

  // ---- time step. Fixed when max_substep_s > 0 (the step the caller asked for). Automatic otherwise:
  // a base step from the slow motion, and per output interval a contact step from the number n_now of
  // points that are or may come into contact during the interval: n_near while n_now ≤ 2 n_near (a
  // rocking or rolling object keeps its contact size and one step size), otherwise n_near × 2^j ≥
  // n_now (a box landing on a face). The quantisation keeps a slightly different run (finite
  // differences) on the same step sequence.
  const double out_dt = options.output_dt_s;
  const bool auto_dt = !(options.max_substep_s > 0.0);
  const double Imin_dyn = minPrincipal(val(sim.dynInertia()));
  const double Imin_com = minPrincipal(val(inertia.inertia));
  double dt_base = out_dt;
  if (!auto_dt) {
    dt_base = options.max_substep_s;
  } else {
    const double gm = options.gravity.norm();
    const double Lg = options.pivot ? (options.pivot_body - com).norm() : cs.size;
    if (gm > 0.0 && Lg > 0.0) dt_base = std::min(dt_base, 0.02 / std::sqrt(m * gm * Lg / Imin_dyn));
    const double w0 = val(state.angular_velocity).norm();
    if (w0 > 0.0) dt_base = std::min(dt_base, 0.02 / w0);
    const double damp = std::max(options.linear_damping_per_s, options.angular_damping_per_s);
    if (damp > 0.0) dt_base = std::min(dt_base, 0.2 / damp);
  }
  const double c_point = cs.active ? sim.dampingValue() : 0.0;
  // Contact frequency bound for n points with lever ℓ: ω² = k n (1/m + ℓ²/I_min); the explicit
  // damper needs c n (1/m + ℓ²/I_min) dt ≤ 0.5.
  auto contactStep = [&](double n, double lever) {
    const double mob = 1.0 / m + lever * lever / Imin_com;
    double h = 0.2 / std::sqrt(cs.k_value * n * mob);
    if (c_point > 0.0) h = std::min(h, 0.5 / (c_point * n * mob));
    return h;
  };
  // n_contact: the points that are or may come into contact during the interval (0 with a fixed step).
  auto substepsFor = [&](const RigidState<S>& s, int* n_contact) -> long {
    double h = dt_base;
    *n_contact = 0;
    if (auto_dt && cs.active) {
      double lever_now = 0.0;
      const int n_now = sim.nearCount(s, out_dt, 2.0 * cs.pen_rest, &lever_now);
      *n_contact = n_now;
      double n_eff = cs.n_near;
      double lever = cs.lever;
      if (n_now > 2 * cs.n_near) {  // up to 2 n_near the base step still has ω dt ≤ 0.28
        n_eff = cs.n_near * std::pow(2.0, std::ceil(std::log2(static_cast<double>(n_now) / cs.n_near) - 1e-12));
        lever = std::max(lever, lever_now);
      }
      h = std::min(h, contactStep(n_eff, lever));
    }
    return std::max<long>(1, static_cast<long>(std::ceil(out_dt / h - 1e-9)));
  };
  // ---- budgets, before anything is allocated: substeps (the smallest step the run starts with) and
  // the stored trajectory (one state per output sample, plus what a task derives from each).
  {
    double h0 = std::min(dt_base, out_dt);
    if (auto_dt && cs.active) h0 = std::min(h0, contactStep(cs.n_near, cs.lever));
    checkStepBudget(
        "rigid simulation", h0, options.duration_s,
        static_cast<double>(std::max<std::size_t>(1, contact_points_body.size())),
        auto_dt ? "a shorter duration_s (the automatic substep is set by the contact stiffness)" : "max_substep_s");
    const double samples = std::ceil(options.duration_s / out_dt - 1e-9) + 1.0;
    const double min_dt = options.duration_s * (sizeof(RigidState<S>) + 136.0) / kMaxSimulationBytes;
    checkMemoryBudget("rigid simulation", samples, sizeof(RigidState<S>) + 136.0,
                      "use a larger dt_s (the sampling step, output_dt_s) >= " + numberText(min_dt, 3) +
                          " s or a shorter duration_s");
  }
  const long n_out = std::max<long>(1, static_cast<long>(std::ceil(options.duration_s / out_dt - 1e-9)));

  RigidTrajectory<S> traj;
  traj.substep_s = out_dt;
  traj.stiffness_used = cs.active ? valueOf(sim.stiffness()) : 0.0;
  traj.time_s.reserve(n_out + 1);
  traj.states.reserve(n_out + 1);
  traj.time_s.push_back(0.0);
  traj.states.push_back(state);

  // ---- divergence reference: the motion is passive, energy may only decrease (up to integration
  // error). Tolerance: 5 % of an energy scale made of the initial kinetic energy and the potential
  // energy the object can release (m |g| × (size + height above the plane)).
  const double e0 = valueOf(sim.energy(state));
  double e_scale = valueOf(S(0.5) * inertia.mass * state.velocity.squaredNorm());
  {
    const Mat3<S> R = state.orientation.toRotationMatrix();
    const Vec3<S> wb = R.transpose() * state.angular_velocity;
    e_scale += valueOf(S(0.5) * wb.dot(sim.dynInertia() * wb));
  }
  double drop = options.pivot ? (options.pivot_body - com).norm() : cs.size;
  if (cs.active) drop += std::max(0.0, valueOf(state.position.z()) - options.ground.height_m);
  e_scale += m * options.gravity.norm() * drop;
  e_scale = std::max(e_scale, 1e-12 + 1e-9 * std::abs(e0));
  const double e_tol = 0.05 * e_scale;

  double dt = out_dt;
  double t_now = 0.0;
  auto diverged = [&](long step, double t, const std::string& what) {
    std::ostringstream problem;
    problem << "the simulation diverged at step " << step << " (t = " << numberText(t, 4)
            << " s, substep dt = " << numberText(dt, 4) << " s): " << what;
    std::ostringstream fix;
    if (cs.active) {
      const double wc = std::sqrt(cs.k_value * cs.n_near * (1.0 / m + cs.lever * cs.lever / Imin_com));
      problem << ". Likely cause: the contact stiffness k = " << numberText(cs.k_value, 4)
              << " N/m per point is too high for the time step (contact frequency x dt = " << numberText(wc * dt, 4)
              << ", stable below about 0.2), or the time step is too large";
      fix << "use a smaller time step (options.max_substep_s <= " << numberText(0.2 / wc, 4)
          << " s, or 0 for the automatic step) or a lower ground.stiffness_n_per_m (0 = automatic)";
    } else {
      problem << ". Likely cause: the time step is too large for the motion";
      fix << "use a smaller time step (options.max_substep_s, or 0 for the automatic step)";
    }
    throw TopoError("rigid simulation", problem.str(), fix.str());
  };

  long step = 0;
  for (long k = 1; k <= n_out; ++k) {
    int n_contact = 0;
    const long n_sub = substepsFor(state, &n_contact);
    dt = out_dt / static_cast<double>(n_sub);
    // The substep follows the contact: a flat face landing brings many points at once and a much smaller
    // step; the rest of the run at that step and size is checked now, not found out hours later.
    checkContactWork("rigid simulation", (k - 1) * out_dt, options.duration_s, dt, n_contact,
                     [&] { return cs.spacing > 0.0 ? cs.spacing : estimateSpacing(contact_points_body); });
    traj.substep_s = std::min(traj.substep_s, dt);
    for (long j = 0; j < n_sub; ++j) {
      if ((step & 63) == 0) pollStop(options.should_stop);
      state = sim.step(state, dt);
      ++step;
      t_now = (k - 1) * out_dt + (j + 1) * dt;
      const bool ok = val(state.position).allFinite() && val(state.velocity).allFinite() &&
                      val(state.angular_velocity).allFinite() && val(state.orientation).coeffs().allFinite();
      if (!ok) diverged(step, t_now, "the state became NaN or infinite");
    }
    const double e = valueOf(sim.energy(state));
    if (!std::isfinite(e) || e - e0 > e_tol) {
      diverged(step, t_now,
               "the total energy grew from " + numberText(e0, 4) + " J to " + numberText(e, 4) +
                   " J although the motion is passive");
    }
    traj.time_s.push_back(k * out_dt);
    traj.states.push_back(state);
    if (options.stop_after_sample && options.stop_after_sample(k * out_dt, val(state.orientation))) break;
  }
  return traj;
}

template <typename S>
RigidState<S> restingState(const RigidInertia<S>& inertia, const Eigen::Quaterniond& orientation,
                           const std::vector<Eigen::Vector3d>& contact_points_body, const RigidSimOptions& options) {
  validateInertia(inertia);
  validateOptions(options, false);
  validatePoints(contact_points_body, options.ground.point_weights);
  if (contact_points_body.empty())
    throw TopoError("restingState: contact points", "the list is empty, nothing can rest on the ground",
                    "pass the surface particles of the object");
  if (!orientation.coeffs().allFinite() || !(orientation.coeffs().norm() > 1e-12))
    throw TopoError("restingState: orientation", "is not a finite non-zero quaternion", "pass a unit quaternion");
  const Eigen::Quaterniond qn = orientation.normalized();
  const Eigen::Matrix3d R = qn.toRotationMatrix();
  RigidSimOptions o = options;
  o.ground.enabled = true;
  const ContactSetup cs = makeContactSetup(valueOf(inertia.mass), val(inertia.com), R, contact_points_body, o);
  // Resting penetration of the lowest point with the rest contact set (piecewise linear in m):
  // k Σ_{rest} w_j (pen − h_j) = m g_n  →  pen = (m g_n / k + Σ w_j h_j) / Σ w_j.
  const S k = stiffnessOf(cs, inertia.mass);
  const double gn = normalGravity(o);
  const S pen = (inertia.mass * S(gn) / k + S(cs.rest_sum_h)) / S(cs.rest_sum_w);
  const Mat3<S> Rs = lift<S>(R);
  const Vec3<S> r_low = Rs * (lift<S>(contact_points_body[cs.lowest]) - inertia.com);
  RigidState<S> s;
  s.orientation = lift<S>(qn);
  s.position = Vec3<S>(S(0.0), S(0.0), S(o.ground.height_m + o.ground.offset_m) - pen - r_low.z());
  s.velocity = Vec3<S>::Zero();
  s.angular_velocity = Vec3<S>::Zero();
  return s;
}

template <typename S>
RigidState<S> pivotState(const RigidInertia<S>& inertia, const Eigen::Quaterniond& orientation,
                         const RigidSimOptions& options) {
  validateInertia(inertia);
  validateOptions(options, false);
  if (!orientation.coeffs().allFinite() || !(orientation.coeffs().norm() > 1e-12))
    throw TopoError("pivotState: orientation", "is not a finite non-zero quaternion", "pass a unit quaternion");
  const Eigen::Quaterniond qn = orientation.normalized();
  const Mat3<S> R = lift<S>(Eigen::Matrix3d(qn.toRotationMatrix()));
  RigidState<S> s;
  s.orientation = lift<S>(qn);
  s.position = lift<S>(options.pivot_world) - R * (lift<S>(options.pivot_body) - inertia.com);
  s.velocity = Vec3<S>::Zero();
  s.angular_velocity = Vec3<S>::Zero();
  return s;
}

template <typename S>
S rigidEnergy(const RigidInertia<S>& inertia, const RigidState<S>& state,
              const std::vector<Eigen::Vector3d>& contact_points_body, const RigidSimOptions& options) {
  validateInertia(inertia);
  validateOptions(options, false);
  validatePoints(contact_points_body, options.ground.point_weights);
  RigidState<S> s = state;
  s.orientation = normalizedQ(state.orientation);
  // The automatic stiffness is evaluated in this state's orientation (the same value a simulation
  // started from this state uses); pass options.ground.stiffness_n_per_m = trajectory.stiffness_used
  // to evaluate later states of a run with the run's stiffness.
  const Eigen::Matrix3d R = val(s.orientation).toRotationMatrix();
  const ContactSetup cs = makeContactSetup(valueOf(inertia.mass), val(inertia.com), R, contact_points_body, options);
  RigidSimOptions o = options;
  o.pivot = false;  // the energy of the given state as it is (no constraint projection)
  RigidSim<S> sim(inertia, contact_points_body, o, cs);
  return sim.energy(s);
}

// ------------------------------------------------------------------------------------ instantiations

#define TOPO_RIGID_INSTANTIATE(S)                                                                                  \
  template RigidTrajectory<S> simulateRigid<S>(const RigidInertia<S>&, const RigidState<S>&,                       \
                                               const std::vector<Eigen::Vector3d>&, const RigidSimOptions&);       \
  template RigidState<S> restingState<S>(const RigidInertia<S>&, const Eigen::Quaterniond&,                        \
                                         const std::vector<Eigen::Vector3d>&, const RigidSimOptions&);             \
  template RigidState<S> pivotState<S>(const RigidInertia<S>&, const Eigen::Quaterniond&, const RigidSimOptions&); \
  template S rigidEnergy<S>(const RigidInertia<S>&, const RigidState<S>&, const std::vector<Eigen::Vector3d>&,     \
                            const RigidSimOptions&);

TOPO_RIGID_INSTANTIATE(double)
TOPO_RIGID_INSTANTIATE(Dual10)

#undef TOPO_RIGID_INSTANTIATE

}  // namespace topo_gaussian
