// Static rigid tasks (paper §7 rigid experiments, appendix "Hawk"): the object must hang from a
// point (hanging), balance on a point (balance) or stand on its base (stand) in a target
// orientation. Equilibrium needs the centre of mass on the vertical through the point, so the loss
// is the squared offset of c from that vertical, perpendicular to gravity, over the object size².
// No time stepping: the loss depends on c alone. Observations (TaskEvaluation::observations): the two
// horizontal components of that offset, linear in c.
//
// hanging also takes the period of the object swinging on a horizontal axle through the hanging point (a
// knife edge, the compound-pendulum method of measuring a moment of inertia): with s = c − q, a the axle
// (world heading axle_heading_deg from x towards y, in the body frame Rᵀ a), s⊥ = s − (a·s) a, d = |s⊥|,
//   I_a = aᵀ I_c a + m d²,   T = 2π √(I_a / (m g d)) · (2/π) K(sin(A/2))
// for amplitude A (axle_swing_amplitude_deg; the complete elliptic integral K is the exact amplitude
// correction of a rigid pendulum). T does not depend on the pose about a, so the target pose need not be
// the axle's rest. cross_axle_swing_period_s: the same with the axle turned 90° about the vertical (a lab
// times both at one hanging point). Loss ((T − T*)/T*)² each; observations of the same names, with
//   ∂ln T/∂m = d²/(2 I_a) − 1/(2m),  ∂ln T/∂c = m s⊥/I_a − s⊥/(2d²),  ∂ln T/∂I_jk = a_j a_k (2 − δ_jk)/(2 I_a).
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <optional>

#include "task_factories.h"
#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/number_text.h"
#include "topo_gaussian/inference/oscillation.h"
#include "topo_gaussian/inference/task_options.h"
#include "topo_gaussian/physics/rigid_body.h"

namespace topo_gaussian::inference {
namespace {

// Convex hull (monotone chain) of 2D points, counter-clockwise.
std::vector<Eigen::Vector2d> convexHull(std::vector<Eigen::Vector2d> p) {
  std::sort(p.begin(), p.end(), [](const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y());
  });
  if (p.size() < 3) return p;
  std::vector<Eigen::Vector2d> h(2 * p.size());
  auto cross = [](const Eigen::Vector2d& o, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    return (a - o).x() * (b - o).y() - (a - o).y() * (b - o).x();
  };
  std::size_t k = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    while (k >= 2 && cross(h[k - 2], h[k - 1], p[i]) <= 0) --k;
    h[k++] = p[i];
  }
  for (std::size_t i = p.size() - 1, t = k + 1; i > 0; --i) {
    while (k >= t && cross(h[k - 2], h[k - 1], p[i - 1]) <= 0) --k;
    h[k++] = p[i - 1];
  }
  h.resize(k - 1);
  return h;
}

// Signed distance of q inside a CCW convex polygon (> 0 inside).
double insideMargin(const std::vector<Eigen::Vector2d>& hull, const Eigen::Vector2d& q) {
  if (hull.size() < 3) return -1e300;
  double m = 1e300;
  for (std::size_t i = 0; i < hull.size(); ++i) {
    const Eigen::Vector2d a = hull[i], b = hull[(i + 1) % hull.size()];
    const Eigen::Vector2d e = (b - a).normalized();
    m = std::min(m, e.x() * (q - a).y() - e.y() * (q - a).x());
  }
  return m;
}

/// The parameters of each static task, typed, and their declaration and reading (inference/task_options.h), in
/// the order `topo tasks` lists them: the task's own, then the target pose every static task has.
struct HangingOptions {
  std::optional<Eigen::Vector3d> hanging_point;
  double swing_duration_s = 0, swing_tilt_deg = 3, axle_heading_deg = 0, axle_swing_amplitude_deg = 3;
  std::optional<double> axle_swing_period_s, cross_axle_swing_period_s;
  double axle_period_tolerance = 0.01;
};

constexpr auto kHangingFields = [](auto& f) {
  using O = HangingOptions;
  f.vector3("hanging_point", &O::hanging_point, "m",
            "hanging point in the body frame [m]; default: top centre of the bounds");
  f.number("swing_duration_s", &O::swing_duration_s, 0.0, "s",
           "also simulate the design swinging on the hanging point for this long [s] (0 = off)", 0);
  f.number("swing_tilt_deg", &O::swing_tilt_deg, 3.0, "deg", "release angle of that swing about world x [deg]", -80,
           80);
  f.number("axle_heading_deg", &O::axle_heading_deg, 0.0, "deg",
           "axle_swing_period_s: the horizontal axle through hanging_point points this far from world x "
           "towards world y [deg] (0: along x; 90: along y); cross_axle_swing_period_s's axle 90 more",
           -360, 360);
  f.number("axle_swing_amplitude_deg", &O::axle_swing_amplitude_deg, 3.0, "deg",
           "the measured axle swings' amplitude [deg] (the period grows with it, +0.02 % at 3)", 0, 80);
  f.target("axle_swing_period_s", &O::axle_swing_period_s, "s",
           "period of small swings on a horizontal axle (knife edge) through hanging_point [s]: fixes the inertia "
           "about that axle (T = 2 pi sqrt(I_a / (m g d)))",
           0, 1e300, true);
  f.target("cross_axle_swing_period_s", &O::cross_axle_swing_period_s, "s",
           "the same with the axle turned 90 deg about the vertical (heading axle_heading_deg + 90) [s]", 0, 1e300,
           true);
  f.number("axle_period_tolerance", &O::axle_period_tolerance, 0.01, "unitless",
           "how well the timed axle periods are known, relative, unitless (reached within it; their "
           "observations' noise): e.g. a 1 ms timer on a 0.5 s swing, 0.002",
           1e-6, 1, true);
};

struct BalanceOptions {
  std::optional<Eigen::Vector3d> support_point;
  bool require_stable = true;
  double stability_margin_m = 0;
};

constexpr auto kBalanceFields = [](auto& f) {
  using O = BalanceOptions;
  f.vector3("support_point", &O::support_point, "m",
            "support point in the body frame [m]; default: top centre of the bounds");
  f.flag("require_stable", &O::require_stable, true, "the centre of mass must lie below the support point");
  f.number("stability_margin_m", &O::stability_margin_m, 0.0, "m",
           "required depth of the centre of mass below the support point [m]", 0);
};

struct StandOptions {
  double base_tolerance_m = 0;
};

constexpr auto kStandFields = [](auto& f) {
  f.number("base_tolerance_m", &StandOptions::base_tolerance_m, 0.0, "m",
           "particles this close to the lowest point form the base [m]; 0 = 1.5 x spacing", 0);
};

struct TargetPoseOptions {
  std::optional<double> target_roll_deg, target_pitch_deg, mass_kg;
};

constexpr auto kTargetPoseFields = [](auto& f) {
  using O = TargetPoseOptions;
  f.target("target_roll_deg", &O::target_roll_deg, "deg",
           "target orientation: roll about world x [deg] (default 0: the rest pose)");
  f.target("target_pitch_deg", &O::target_pitch_deg, "deg",
           "target orientation: pitch about world y [deg] (default 0)");
  f.target("mass_kg", &O::mass_kg, "kg",
           "the object weighed on a scale [kg]: the one number rigid motion never fixes (loss ((m - m*)/m*)^2)", 0,
           1e300, true);
};

class StaticTask : public Task {
 public:
  StaticTask(const TaskConfig& c, const VolumeCloud& cloud) : Task(c, cloud) {
    const TargetPoseOptions pose = readOptions<TargetPoseOptions>(c, kTargetPoseFields);
    roll_ = pose.target_roll_deg.value_or(0.0);
    pitch_ = pose.target_pitch_deg.value_or(0.0);
    R_ = targetRotation(roll_, pitch_);
    if (pose.mass_kg) mass_target_ = *pose.mass_kg;
    g_hat_ = geometry_.gravity.normalized();
    const Eigen::Vector3d top((lo_.x() + hi_.x()) / 2, (lo_.y() + hi_.y()) / 2, hi_.z());
    if (name_ == "hanging") {
      const HangingOptions o = readOptions<HangingOptions>(c, kHangingFields);
      point_ = o.hanging_point.value_or(top);
      geometry_.point_name = "hanging_point";
      swing_duration_ = o.swing_duration_s;
      swing_tilt_ = o.swing_tilt_deg;
      const double heading = o.axle_heading_deg * M_PI / 180.0;
      axle_amplitude_ = o.axle_swing_amplitude_deg * M_PI / 180.0;
      axle_tolerance_ = o.axle_period_tolerance;
      Eigen::Vector3d h1, h2;
      horizontalAxes(&h1, &h2);
      const char* names[2] = {"axle_swing_period_s", "cross_axle_swing_period_s"};
      const std::optional<double> targets[2] = {o.axle_swing_period_s, o.cross_axle_swing_period_s};
      for (int k = 0; k < 2; ++k) {
        const double psi = heading + k * M_PI / 2;
        axles_[k].name = names[k];
        axles_[k].axis_body = R_.transpose() * (std::cos(psi) * h1 + std::sin(psi) * h2);
        if (targets[k]) axles_[k].target = *targets[k];
      }
    } else if (name_ == "balance") {
      const BalanceOptions o = readOptions<BalanceOptions>(c, kBalanceFields);
      point_ = o.support_point.value_or(top);
      geometry_.point_name = "support_point";
      require_stable_ = o.require_stable;
      margin_ = o.stability_margin_m;
    } else {
      // stand: the base is the set of particles within tolerance of the lowest point in the target pose.
      double tol = readOptions<StandOptions>(c, kStandFields).base_tolerance_m;
      if (tol <= 0) tol = 1.5 * cloud.spacing;
      if (tol <= 0) tol = 0.01 * size_;
      const Eigen::Vector3d up = -g_hat_;
      double zmin = 1e300;
      for (const auto& x : cloud.X) zmin = std::min(zmin, up.dot(R_ * x));
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      int n = 0;
      // Plane coordinates perpendicular to gravity.
      e1_ = up.unitOrthogonal();
      e2_ = up.cross(e1_);
      std::vector<Eigen::Vector2d> base;
      for (const auto& x : cloud.X) {
        const Eigen::Vector3d w = R_ * x;
        if (up.dot(w) <= zmin + tol) {
          sum += w;
          ++n;
          base.emplace_back(e1_.dot(w), e2_.dot(w));
        }
      }
      hull_ = convexHull(base);
      point_ = R_.transpose() * (sum / n);  // base centre, body frame
      geometry_.point_name = "support_point";
      base_count_ = n;
    }
    geometry_.has_point = true;
    geometry_.point = point_;
  }

  TaskEvaluation evaluate(const std::vector<double>& r, std::vector<double>* dL_dr) const override {
    const RigidMass rm = rigidMass(r, dL_dr != nullptr);
    TaskEvaluation ev;
    ev.mass = rm.props;
    const Eigen::Matrix3d P = Eigen::Matrix3d::Identity() - g_hat_ * g_hat_.transpose();
    const Eigen::Vector3d d = R_ * (ev.mass.com - point_);  // world offset of c from the point
    const Eigen::Vector3d e = P * d;
    const double L2 = size_ * size_;
    ev.loss = e.squaredNorm() / L2;
    Eigen::Vector3d dL_dc = 2.0 * R_.transpose() * e / L2;
    const double depth = g_hat_.dot(d);  // > 0: c below the point
    if (require_stable_ && depth < margin_) {
      const double v = margin_ - depth;
      ev.loss += v * v / L2;
      dL_dc += -2.0 * v * R_.transpose() * g_hat_ / L2;
    }
    // Weighed on a scale: ((m − m*)/m*)², the relative error as the rocking period's.
    double dL_dm = 0.0;
    if (mass_target_ > 0) {
      const double e = (ev.mass.mass - mass_target_) / mass_target_;
      ev.loss += e * e;
      dL_dm = 2.0 * e / mass_target_;
    }
    // stand succeeds once the centre of mass is over the base (the loss keeps pulling it to the
    // base centre); hanging and balance need it on the vertical through the point.
    Feature off{"com_offset_m", e.norm(), "m", name_ != "stand", 0.0, 1e-3 * size_, 1.0};
    ev.features.push_back(off);
    ev.features.push_back(Feature{"tilt_deg", std::atan2(e.norm(), std::abs(depth)) * 180.0 / M_PI, "deg"});
    if (name_ == "balance") ev.features.push_back(Feature{"com_depth_below_support_m", depth, "m"});
    if (name_ == "stand") {
      const Eigen::Vector3d cw = R_ * ev.mass.com;
      const double mg = insideMargin(hull_, Eigen::Vector2d(e1_.dot(cw), e2_.dot(cw)));
      ev.features.push_back(Feature{"support_margin_m", mg, "m"});
      ev.features.push_back(Feature{"stands", mg > 0 ? 1.0 : 0.0, "", true, 1.0, 1.0, 0.0});
    }
    ev.features.push_back(Feature{"mass_kg", ev.mass.mass, "kg", mass_target_ > 0, mass_target_, 1e-9, 0.01});
    if (name_ != "stand") addOffsetObservations(d, off, &ev);
    if (mass_target_ > 0) {  // the scale's reading, noise its 1 % tolerance; dm/dp = (1, 0, ...)
      Observation o{"mass_kg", ev.mass.mass, "kg", true, mass_target_, 0.01 * mass_target_};
      o.d_dp[0] = 1.0;
      ev.observations.push_back(o);
    }
    if (swing_duration_ > 0) swing(ev);
    Eigen::Matrix<double, 10, 1> dL_daxle = Eigen::Matrix<double, 10, 1>::Zero();
    if (name_ == "hanging")
      for (const Axle& a : axles_) axleSwing(a, ev, &dL_daxle);
    if (dL_dr) {
      Eigen::Matrix<double, 10, 1> g = dL_daxle;
      g[0] += dL_dm;
      g.segment<3>(1) += dL_dc;
      chainToIndicator(rm, g, dL_dr);
    }
    return ev;
  }

 private:
  // Observations (hanging, balance): the two components of the world offset d = R (c − point) along the
  // horizontal directions h1 (world x made perpendicular to gravity; world y when gravity is along x) and
  // h2 = up × h1; target 0, noise the com_offset_m tolerance; d/dc = Rᵀ h_k. stand has none: standing
  // only bounds c (an inequality), which determines no moment.
  void horizontalAxes(Eigen::Vector3d* h1, Eigen::Vector3d* h2) const {
    const Eigen::Vector3d up = -g_hat_;
    *h1 = std::abs(up.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
    *h1 = (*h1 - h1->dot(up) * up).normalized();
    *h2 = up.cross(*h1);
  }

  void addOffsetObservations(const Eigen::Vector3d& d, const Feature& off, TaskEvaluation* ev) const {
    Eigen::Vector3d h1, h2;
    horizontalAxes(&h1, &h2);
    const Eigen::Vector3d h[2] = {h1, h2};
    const char* names[2] = {"com_offset_h1_m", "com_offset_h2_m"};
    for (int k = 0; k < 2; ++k) {
      Observation o{names[k], h[k].dot(d), "m", true, 0.0, off.tolerance * off.scale};
      o.d_dp.segment<3>(1) = R_.transpose() * h[k];
      ev->observations.push_back(o);
    }
  }

  // The design hung from the point (ball joint) and released swing_tilt_deg off the target pose about
  // world x: it swings as a physical pendulum. Reports the simulated period and the closed form of that
  // swing (swingClosedForm), for comparison.
  void swing(TaskEvaluation& ev) const {
    RigidSimOptions o;
    o.duration_s = swing_duration_;
    o.gravity = geometry_.gravity;
    o.ground.enabled = false;
    o.pivot = true;
    o.pivot_body = point_;
    o.pivot_world = R_ * point_;
    o.should_stop = should_stop_;
    const RigidInertia<double> I = toInertia(ev.mass);
    const Eigen::Quaterniond q0(Eigen::AngleAxisd(swing_tilt_ * M_PI / 180.0, Eigen::Vector3d::UnitX()) *
                                Eigen::Quaterniond(R_));
    const RigidTrajectory<double> traj = simulateRigid(I, pivotState(I, q0, o), {}, o);
    std::vector<double> angle;
    for (std::size_t k = 0; k < traj.states.size(); ++k) {
      const auto& st = traj.states[k];
      ev.motion.push_back(bodyPoseOf(traj.time_s[k], st, ev.mass.com));
      const Eigen::Vector3d d = st.position - o.pivot_world;  // pivot → centre of mass
      angle.push_back(std::atan2(d.y(), -d.z()) * 180.0 / M_PI);
    }
    const double dt = traj.time_s.size() > 1 ? traj.time_s[1] - traj.time_s[0] : o.output_dt_s;
    const OscillationFeatures<double> f = analyseOscillation(angle, 0.0, dt, 0, true);
    ev.signal_name = "swing_angle_deg";
    ev.signal_time_s = traj.time_s;
    ev.signal = angle;
    if (f.valid) ev.features.push_back(Feature{"swing_period_s", f.period, "s"});
    swingClosedForm(ev, q0.toRotationMatrix());
  }

  // The closed form of the swing released at rest in pose R0: the centre of mass, a distance d from the
  // pivot, starts θ0 from straight below it, and gravity's torque turns the body about n, the normal of
  // the vertical plane through the pivot and c. When n is a principal axis of the inertia about the pivot
  // the swing stays in that plane, a compound pendulum about the rest pose (c below the pivot):
  //   I_n = nᵀ (R0 I_c R0ᵀ) n + m d²,   T = 2π √(I_n / (m g d)) · (2/π) K(sin(θ0/2))
  // (the complete elliptic integral K is the exact amplitude correction), whatever the target pose: a
  // design released off its rest pose swings about the rest pose with the whole offset as amplitude.
  // When the inertia couples the plane to the other axes by more than kPlanarCoupling (|I_p n − I_n n| /
  // I_n) the swing leaves the plane and no closed form describes it: the feature is left out, with a
  // note saying why.
  void swingClosedForm(TaskEvaluation& ev, const Eigen::Matrix3d& R0) const {
    constexpr double kPlanarCoupling = 0.01;
    const MassProperties& p = ev.mass;
    const Eigen::Vector3d r = R0 * (p.com - point_);  // pivot → c at the release, world
    const double d = r.norm(), g = geometry_.gravity.norm();
    if (!(d > 1e-9 * size_) || !(p.mass > 0) || !(g > 0)) return;
    const Eigen::Vector3d side = r.cross(g_hat_);
    const double theta0 = std::atan2(side.norm(), r.dot(g_hat_));
    Eigen::Vector3d n = side.normalized();
    if (!(side.norm() > 1e-9 * d)) {  // released in the rest pose: small swings about world x (made horizontal)
      Eigen::Vector3d h1, h2;
      horizontalAxes(&h1, &h2);
      n = h1;
    }
    const Eigen::Matrix3d Ip =
        R0 * p.inertia * R0.transpose() + p.mass * (r.squaredNorm() * Eigen::Matrix3d::Identity() - r * r.transpose());
    const double I_n = n.dot(Ip * n);
    const double coupling = (Ip * n - I_n * n).norm() / I_n;
    if (coupling > kPlanarCoupling) {
      const std::string note =
          "hanging: swing_period_closed_form_s is left out: released " + numberText(theta0 * 180.0 / M_PI, 3) +
          " deg from its rest pose the design's inertia about the hanging point couples the "
          "swing's plane to the other axes (by " +
          numberText(100 * coupling, 2) + " %), so it swings out of that plane and no pendulum closed form applies";
      for (const std::string& said : notes_)  // once: the text before the numbers
        if (said.compare(0, 40, note, 0, 40) == 0) return;
      notes_.push_back(note);
      return;
    }
    const double T =
        2 * M_PI * std::sqrt(I_n / (p.mass * g * d)) * (2 / M_PI) * std::comp_ellint_1(std::sin(theta0 / 2));
    ev.features.push_back(Feature{"swing_period_closed_form_s", T, "s"});
  }

  struct Axle {
    std::string name;                                      ///< its feature, observation and target
    Eigen::Vector3d axis_body = Eigen::Vector3d::UnitX();  ///< the axle's direction, body frame
    double target = -1;                                    ///< measured period [s]; ≤ 0: none
  };

  // The swing on an axle (formula at the top): its feature; with a target, its loss term (gradient added
  // to *dL_dp, [m, c, I] order) and its observation. Nothing when c lies on the axle.
  void axleSwing(const Axle& axle, TaskEvaluation& ev, Eigen::Matrix<double, 10, 1>* dL_dp) const {
    const MassProperties& p = ev.mass;
    const Eigen::Vector3d& a = axle.axis_body;
    const double target = axle.target;
    const Eigen::Vector3d s = p.com - point_;
    const Eigen::Vector3d s_perp = s - a.dot(s) * a;
    const double d2 = s_perp.squaredNorm(), d = std::sqrt(d2), g = geometry_.gravity.norm();
    if (!(d > 1e-9 * size_) || !(p.mass > 0) || !(g > 0)) return;
    const double I_a = a.dot(p.inertia * a) + p.mass * d2;
    const double K = std::comp_ellint_1(std::sin(axle_amplitude_ / 2));
    const double T = 2 * M_PI * std::sqrt(I_a / (p.mass * g * d)) * (2 / M_PI) * K;
    Eigen::Matrix<double, 10, 1> dlnT = Eigen::Matrix<double, 10, 1>::Zero();
    dlnT[0] = d2 / (2 * I_a) - 1 / (2 * p.mass);
    dlnT.segment<3>(1) = p.mass * s_perp / I_a - s_perp / (2 * d2);
    const int row[6] = {0, 1, 2, 0, 0, 1}, col[6] = {0, 1, 2, 1, 2, 2};
    for (int k = 0; k < 6; ++k) dlnT[4 + k] = a[row[k]] * a[col[k]] * (row[k] == col[k] ? 1.0 : 2.0) / (2 * I_a);
    ev.features.push_back(Feature{axle.name, T, "s", target > 0, target, 1e-9, axle_tolerance_});
    if (!(target > 0)) return;
    const double e = (T - target) / target;
    ev.loss += e * e;
    *dL_dp += (2 * e * T / target) * dlnT;
    Observation o{axle.name, T, "s", true, target, axle_tolerance_ * target};
    o.d_dp = T * dlnT;
    ev.observations.push_back(o);
  }

  double swing_duration_ = 0, swing_tilt_ = 3;
  Axle axles_[2];
  double axle_amplitude_ = 0, axle_tolerance_ = 0.01;
  double roll_ = 0, pitch_ = 0, mass_target_ = -1;
  Eigen::Matrix3d R_;
  Eigen::Vector3d g_hat_, point_, e1_, e2_;
  bool require_stable_ = false;
  double margin_ = 0.0;
  std::vector<Eigen::Vector2d> hull_;
  int base_count_ = 0;
};

}  // namespace

namespace {

std::unique_ptr<Task> makeStaticTask(const TaskConfig& config, const VolumeCloud& cloud) {
  return std::make_unique<StaticTask>(config, cloud);
}

/// The camera looks along world x, so the observed equilibrium angle is the roll of the target pose.
MotionTargets equilibriumTargets(const TaskConfig&, const motion::MotionFeatures& f) {
  MotionTargets out;
  if (f.equilibrium_confidence > 0)
    out.targets.emplace_back("target_roll_deg", f.equilibrium_deg);
  else
    out.note = motionFeaturesOrigin(f) + " hold no measured equilibrium angle";
  return out;
}

}  // namespace

void registerStaticTasks(TaskList* tasks) {
  TaskDefinition hanging;
  hanging.name = "hanging";
  hanging.summary = "hangs from a point in a target orientation (centre of mass below the point); optionally swings";
  hanging.declare_parameters = [](TaskParameters& p) {
    declareOptions<HangingOptions>(p, kHangingFields);
    declareOptions<TargetPoseOptions>(p, kTargetPoseFields);
  };
  hanging.make = makeStaticTask;
  hanging.motion_targets = equilibriumTargets;
  RigTwinMotion swing;  // the twin of a hanging object: it swings from its hanging point
  swing.duration_parameter = "swing_duration_s";
  swing.period_feature = "swing_period_s";
  swing.fallback_duration_s = 3.0;
  swing.cavity_centre = Eigen::Vector3d(0.0, 0.0, 0.3);
  swing.cavity_radius = 0.4;
  swing.default_for_shapes = {"*"};
  swing.hangs = true;
  hanging.twin = swing;
  tasks->push_back(hanging);

  TaskDefinition balance;
  balance.name = "balance";
  balance.summary = "balances on a support point in a target orientation (centre of mass on its vertical, below it)";
  balance.declare_parameters = [](TaskParameters& p) {
    declareOptions<BalanceOptions>(p, kBalanceFields);
    declareOptions<TargetPoseOptions>(p, kTargetPoseFields);
  };
  balance.make = makeStaticTask;
  balance.motion_targets = equilibriumTargets;
  tasks->push_back(balance);

  TaskDefinition stand;
  stand.name = "stand";
  stand.summary = "stands on its base in a target orientation (centre of mass over the base)";
  stand.declare_parameters = [](TaskParameters& p) {
    declareOptions<StandOptions>(p, kStandFields);
    declareOptions<TargetPoseOptions>(p, kTargetPoseFields);
  };
  stand.make = makeStaticTask;
  stand.motion_targets = equilibriumTargets;
  tasks->push_back(stand);
}

}  // namespace topo_gaussian::inference
