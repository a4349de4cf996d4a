// Tumbler (wobbly doll, paper §7 "Wobbly Doll"): the object rests on the ground, is released at a
// tilt (or pushed), and rocks. Features: rocking period and maximum tilt from the simulated tilt
// signal; loss w_T ((T − T*)/T*)² + w_θ ((θ − θ*)/θ*)² [+ w_A ((A − A*)/A*)² with an observed
// amplitude A*, the mean half peak-to-peak swing: released at rest at θ0 about its rest tilt φe the doll
// swings |θ0 − φe|, so A* tells where it rests, which period and max tilt do not]. The rigid simulation runs in forward
// mode (Dual10), so the features carry d/d(m, c, I); the chain to r goes through the mass moments. The observations
// (TaskEvaluation::observations) are period_s and max_tilt_deg with those derivatives.
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <memory>
#include <optional>
#include <sstream>

#include "rigid_options.h"
#include "task_factories.h"
#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/number_text.h"
#include "topo_gaussian/inference/oscillation.h"
#include "topo_gaussian/inference/task_options.h"
#include "topo_gaussian/physics/rigid_body.h"

namespace topo_gaussian::inference {
namespace {

constexpr double kDeg = 180.0 / M_PI;

/// The tumbler's own parameters, typed (the rigid motion's are RigidSimOptions, rigid_options.h).
struct TumblerOptions {
  double initial_tilt_deg = 0, initial_angular_velocity_rad_s = 0;
  Eigen::Vector3d rocking_axis = Eigen::Vector3d::UnitX(), up_axis = Eigen::Vector3d::UnitZ();
  int measured_cycles = 2;
  double weight_period = 1, weight_tilt = 1, weight_amplitude = 1, weight_equilibrium = 1;
  std::optional<double> period_s, max_tilt_deg, amplitude_deg, equilibrium_tilt_deg, equilibrium_from_release_deg;
};

/// Its declaration and reading (task_options.h), in the order `topo tasks` lists them.
constexpr auto kTumblerFields = [](auto& f) {
  using O = TumblerOptions;
  f.number("initial_tilt_deg", &O::initial_tilt_deg, 10.0, "deg", "release tilt about rocking_axis [deg]", -89, 89);
  f.number("initial_angular_velocity_rad_s", &O::initial_angular_velocity_rad_s, 0.0, "rad/s",
           "initial angular velocity about rocking_axis [rad/s]");
  f.vector3("rocking_axis", &O::rocking_axis, Eigen::Vector3d(1, 0, 0), "unitless",
            "rocking axis in the body frame (horizontal at rest), a unitless direction");
  f.vector3("up_axis", &O::up_axis, Eigen::Vector3d(0, 0, 1), "unitless",
            "the body's up direction (the tilt is measured from it), a unitless direction");
  f.integer("measured_cycles", &O::measured_cycles, 2, "unitless",
            "period and equilibrium from the first N full cycles, unitless (0 = all in duration_s)", 0, 1000);
  f.number("weight_period", &O::weight_period, 1.0, "unitless", "loss weight of ((T - T*)/T*)^2, unitless", 0);
  f.number("weight_tilt", &O::weight_tilt, 1.0, "unitless", "loss weight of ((tilt - tilt*)/tilt*)^2, unitless", 0);
  f.target("period_s", &O::period_s, "s", "observed rocking period [s]", 0, 1e300, true);
  f.target("max_tilt_deg", &O::max_tilt_deg, "deg", "observed maximum tilt [deg]", 0, 90, true);
  f.number("weight_amplitude", &O::weight_amplitude, 1.0, "unitless", "loss weight of ((A - A*)/A*)^2, unitless", 0);
  f.target("amplitude_deg", &O::amplitude_deg, "deg",
           "observed rocking amplitude, the mean half peak-to-peak swing over the measured cycles [deg]: with "
           "the release tilt it fixes the tilt the doll rests at",
           0, 90, true);
  f.number("weight_equilibrium", &O::weight_equilibrium, 1.0, "unitless",
           "loss weight of ((eq - eq*)/max(1 deg, release tilt))^2, unitless", 0);
  f.target("equilibrium_tilt_deg", &O::equilibrium_tilt_deg, "deg",
           "observed tilt the doll rocks about, the mean of its turning points [deg] (0: it rests upright): it "
           "fixes the centre of mass across the rocking axis (its magnitude is compared: a camera on the other "
           "side sees the sign mirrored)",
           -90, 90);
  f.target("equilibrium_from_release_deg", &O::equilibrium_from_release_deg, "deg",
           "the same signed towards the release's side [deg] (+: it rests on the side it was released from, -: "
           "on the other; a mirror flips the release too, so the sign counts): what a clip from the release "
           "gives; instead of equilibrium_tilt_deg",
           -90, 90);
};

class TumblerTask : public Task {
 public:
  TumblerTask(const TaskConfig& c, const VolumeCloud& cloud) : Task(c, cloud) {
    options_ = rigidOptionsFromConfig(c, geometry_.gravity);
    const TumblerOptions o = readOptions<TumblerOptions>(c, kTumblerFields);
    axis_ = o.rocking_axis;
    up_ = o.up_axis;
    if (axis_.norm() == 0 || up_.norm() == 0)
      throw TopoError("rocking_axis/up_axis", "is zero", "give non-zero directions");
    axis_.normalize();
    up_.normalize();
    tilt0_ = o.initial_tilt_deg / kDeg;
    omega0_ = o.initial_angular_velocity_rad_s;
    w_period_ = o.weight_period;
    w_tilt_ = o.weight_tilt;
    w_amplitude_ = o.weight_amplitude;
    amplitude_target_ = o.amplitude_deg.value_or(-1);
    w_equilibrium_ = o.weight_equilibrium;
    if (o.equilibrium_tilt_deg && o.equilibrium_from_release_deg)
      throw TopoError("tumbler targets", "give both equilibrium_tilt_deg and equilibrium_from_release_deg",
                      "give one: equilibrium_from_release_deg when the sign relative to the release is known");
    has_equilibrium_target_ = o.equilibrium_tilt_deg || o.equilibrium_from_release_deg;
    equilibrium_from_release_ = o.equilibrium_from_release_deg.has_value();
    equilibrium_target_ = o.equilibrium_from_release_deg.value_or(o.equilibrium_tilt_deg.value_or(0.0));
    cycles_ = o.measured_cycles;
    period_target_ = o.period_s.value_or(-1);
    tilt_target_ = o.max_tilt_deg.value_or(-1);
    std::string note;
    all_contact_ = groundContactPoints(cloud, &note, &all_weights_);
    if (!note.empty()) notes_.push_back(note);
    if (all_contact_.empty())
      throw TopoError("volume cloud", "has neither contact samples nor surface particles for ground contact",
                      "fill it with `topo fill` (it samples the true surface and flags the boundary particles)");
    const double spacing = groundContactSpacing(cloud);
    selectContactCandidates(spacing > 0 ? spacing : 0.01 * size_);
    geometry_.has_point = false;
  }

  void requireTargets() const override {
    if (period_target_ <= 0 && tilt_target_ <= 0 && amplitude_target_ <= 0)
      throw TopoError("tumbler targets", "neither period_s nor max_tilt_deg nor amplitude_deg is given",
                      "give the observed values, e.g. --target period_s=0.25 --target max_tilt_deg=12");
  }

  TaskEvaluation evaluate(const std::vector<double>& r, std::vector<double>* dL_dr) const override {
    const RigidMass rm = rigidMass(r, dL_dr != nullptr);
    TaskEvaluation ev;
    ev.mass = rm.props;
    const RigidInertia<Dual10> inertia = seedInertia(ev.mass);
    const Eigen::Quaterniond q0(Eigen::AngleAxisd(tilt0_, axis_));
    RigidState<Dual10> s0 = restingState(inertia, q0, contact_, options_);
    s0.angular_velocity = (omega0_ * axis_).cast<Dual10>();
    // The optimiser's evaluations (those with a gradient) simulate until the measured cycles are complete
    // (MeasuredCyclesWatch, inference/oscillation.h), not the whole duration_s: the features are the same.
    // Without a gradient (the reported design, the analyses) the whole duration_s is simulated and shown.
    const Eigen::Vector3d ez(0, 0, 1), side = axis_.cross(ez);
    const auto simulate = [&](const std::vector<Eigen::Vector3d>& points, const RigidSimOptions& o) {
      RigidSimOptions run = withStop(o, should_stop_);
      if (dL_dr && cycles_ > 0) {
        const auto tilt = [&](const Eigen::Quaterniond& q) {
          const Eigen::Vector3d u = q * up_;
          return std::atan2(u.dot(side), u.dot(ez)) * kDeg;
        };
        auto watch = std::make_shared<MeasuredCyclesWatch>(o.output_dt_s, cycles_, omega0_ == 0.0);
        const auto& qs = s0.orientation;
        watch->add(tilt(Eigen::Quaterniond(qs.w().value(), qs.x().value(), qs.y().value(), qs.z().value())));
        run.stop_after_sample = [watch, tilt](double, const Eigen::Quaterniond& q) { return watch->add(tilt(q)); };
      }
      return simulateRigid(inertia, s0, points, run);
    };
    RigidTrajectory<Dual10> traj = simulate(contact_, options_);
    // The candidate set covers tilts up to reach_deg_: if the motion went further, redo it with all
    // surface particles (never silently miss a contact).
    double max_tilt = 0;
    for (const auto& st : traj.states) {
      const auto& q = st.orientation;
      const Eigen::Quaterniond qd(q.w().value(), q.x().value(), q.y().value(), q.z().value());
      const Eigen::Vector3d u = qd.normalized() * up_;
      max_tilt = std::max(max_tilt, std::acos(std::max(-1.0, std::min(1.0, u.z()))) * kDeg);
    }
    // Past 90 deg it falls over, rolls away or turns over: not a doll that rights itself. The candidates
    // cover tilts up to reach_deg_ only, so what it does past them is followed by pastUpright (double
    // precision, the candidates of every tilt about the rocking axis, until it is decided): refused
    // saying what happened, with the numbers. When that simulation stays below 90 deg (the candidates'
    // motion went past them), the design rocks: simulated on all of the surface's samples below.
    bool resimulate = false;
    if (max_tilt >= 90.0) {
      const PastUpright past = pastUpright(ev.mass);
      if (past.max_tilt_deg >= 90.0 || !past.simulated) refusePastUpright(past, max_tilt);
      resimulate = true;
    }
    if ((resimulate || max_tilt > reach_deg_ - 5.0) && contact_.size() < all_contact_.size())
      traj = simulate(all_contact_, options_all_);
    // Signed tilt about the rocking axis: rotating ez by φ about a gives cos φ ez + sin φ (a × ez).
    std::vector<Dual10> phi(traj.states.size());
    for (std::size_t k = 0; k < phi.size(); ++k) {
      const Vec3<Dual10> u = traj.states[k].orientation * up_.cast<Dual10>();
      using std::atan2;
      phi[k] = atan2(u.dot(side.cast<Dual10>()), u.dot(ez.cast<Dual10>())) * kDeg;
    }
    const double dt = traj.time_s.size() > 1 ? traj.time_s[1] - traj.time_s[0] : options_.output_dt_s;
    const OscillationFeatures<Dual10> f = analyseOscillation(phi, 0.0, dt, cycles_, omega0_ == 0.0);
    ev.signal_name = "tilt_deg";
    ev.signal_time_s = traj.time_s;
    for (const auto& p : phi) ev.signal.push_back(p.value());
    for (std::size_t k = 0; k < traj.states.size(); ++k)
      ev.motion.push_back(bodyPoseOf(traj.time_s[k], traj.states[k], ev.mass.com));
    if (!f.valid) {
      throw TopoError("tumbler simulation", f.message + " in " + std::to_string(options_.duration_s) + " s",
                      "check that the object rests on a rounded bottom with its centre of mass low enough to "
                      "right itself, or raise duration_s");
    }
    Eigen::Matrix<double, 10, 1> dL = Eigen::Matrix<double, 10, 1>::Zero();
    if (period_target_ > 0) {
      const Dual10 e = (f.period - period_target_) / period_target_;
      ev.loss += w_period_ * e.value() * e.value();
      dL += w_period_ * 2.0 * e.value() * e.derivatives();
    }
    if (tilt_target_ > 0) {
      const Dual10 e = (f.max_abs - tilt_target_) / tilt_target_;
      ev.loss += w_tilt_ * e.value() * e.value();
      dL += w_tilt_ * 2.0 * e.value() * e.derivatives();
    }
    if (amplitude_target_ > 0) {
      const Dual10 e = (f.amplitude - amplitude_target_) / amplitude_target_;
      ev.loss += w_amplitude_ * e.value() * e.value();
      dL += w_amplitude_ * 2.0 * e.value() * e.derivatives();
    }
    // The equilibrium (near 0) is compared on the release tilt's scale, as the max tilt is.
    // equilibrium_tilt_deg: by its magnitude (a camera on the other side sees the rocking mirrored);
    // equilibrium_from_release_deg: signed towards the side of the release (a mirror flips both, so
    // this sign is seen from either side), which tells a doll resting on the release's side from one
    // resting on the other: compared by magnitude, the two are separated by a ridge of the loss at 0.
    const double eq_scale = std::max(1.0, std::abs(tilt0_ * kDeg));
    const double release_sign = tilt0_ < 0 ? -1.0 : 1.0;
    const double eq_sign = equilibrium_from_release_ ? release_sign : (f.equilibrium.value() < 0 ? -1.0 : 1.0);
    if (has_equilibrium_target_) {
      const double target = equilibrium_from_release_ ? equilibrium_target_ : std::abs(equilibrium_target_);
      const Dual10 e = (eq_sign * f.equilibrium - target) / eq_scale;
      ev.loss += w_equilibrium_ * e.value() * e.value();
      dL += w_equilibrium_ * 2.0 * e.value() * e.derivatives();
    }
    Feature fp{"period_s", f.period.value(), "s", period_target_ > 0, period_target_, 1e-9, 0.01};
    Feature ft{"max_tilt_deg", f.max_abs.value(), "deg", tilt_target_ > 0, tilt_target_, 1e-9, 0.01};
    ev.features = {
        fp, ft,
        Feature{
            "equilibrium_tilt_deg", f.equilibrium.value(), "deg", has_equilibrium_target_,
            equilibrium_from_release_ ? release_sign * equilibrium_target_ : eq_sign * std::abs(equilibrium_target_),
            eq_scale, 0.01},
        Feature{"amplitude_deg", f.amplitude.value(), "deg", amplitude_target_ > 0, amplitude_target_, 1e-9, 0.01},
        Feature{"mass_kg", ev.mass.mass, "kg"}};
    // Observations: period, max tilt, equilibrium and amplitude with d/dp (Dual10); noise the features'
    // 1 % tolerance (of the release tilt for the equilibrium).
    const Dual10* obs[4] = {&f.period, &f.max_abs, &f.equilibrium, &f.amplitude};
    const Feature* feat[4] = {&ev.features[0], &ev.features[1], &ev.features[2], &ev.features[3]};
    for (int k = 0; k < 4; ++k) {
      const Feature& ft = *feat[k];
      const double noise = ft.tolerance * std::max({ft.has_target ? std::abs(ft.target) : std::abs(ft.value),
                                                    ft.scale > 1e-6 ? ft.scale : 0.0, 1e-12});
      ev.observations.push_back(
          Observation{ft.name, ft.value, ft.unit, ft.has_target, ft.target, noise, obs[k]->derivatives()});
    }
    if (dL_dr) chainToIndicator(rm, dL, dL_dr);
    return ev;
  }

 private:
  // Surface particles that can touch the ground while the body tilts up to reach_deg_ about the
  // rocking axis (and ±10° about the other horizontal axis): those within a few spacings of the
  // lowest point in one of the sampled poses. The rest never touch; skipping them makes each step
  // cheaper (every step scans every candidate).
  void selectContactCandidates(double spacing) {
    reach_deg_ = std::abs(tilt0_ * kDeg) + 30.0;
    band_m_ = 4.0 * spacing;
    options_all_ = options_;
    options_all_.ground.point_weights = all_weights_;
    contactBand(reach_deg_, &contact_, &options_);
  }

  // The contact points (and their weights in *o) within band_m_ of the lowest point in a pose tilted up to
  // reach_deg about the rocking axis, sampled every 2 deg, and ±10° about the other horizontal axis.
  void contactBand(double reach_deg, std::vector<Eigen::Vector3d>* points, RigidSimOptions* o) const {
    std::vector<char> keep(all_contact_.size(), 0);
    const Eigen::Vector3d other = up_.cross(axis_).normalized();
    std::vector<double> z(all_contact_.size());
    for (double a = -reach_deg; a <= reach_deg + 1e-9; a += 2.0) {
      for (double b : {-10.0, 0.0, 10.0}) {
        const Eigen::Matrix3d R =
            (Eigen::AngleAxisd(a / kDeg, axis_) * Eigen::AngleAxisd(b / kDeg, other)).toRotationMatrix();
        double zmin = 1e300;
        for (std::size_t i = 0; i < z.size(); ++i) zmin = std::min(zmin, z[i] = (R * all_contact_[i]).z());
        for (std::size_t i = 0; i < z.size(); ++i)
          if (z[i] <= zmin + band_m_) keep[i] = 1;
      }
    }
    points->clear();
    o->ground.point_weights.clear();
    for (std::size_t i = 0; i < keep.size(); ++i)
      if (keep[i]) {
        points->push_back(all_contact_[i]);
        if (!all_weights_.empty()) o->ground.point_weights.push_back(all_weights_[i]);
      }
  }

  // Contact points merged on a grid of the given cell size: per cell the point nearest the cell's mean,
  // weighted with the sum of the cell's weights (all 1 when none are given).
  static void mergeOnGrid(double cell, std::vector<Eigen::Vector3d>* points, RigidSimOptions* o) {
    std::vector<double>& w = o->ground.point_weights;
    std::map<std::array<long long, 3>, std::vector<std::size_t>> cells;
    for (std::size_t i = 0; i < points->size(); ++i) {
      const Eigen::Vector3d k = ((*points)[i] / cell).array().floor();
      cells[{static_cast<long long>(k.x()), static_cast<long long>(k.y()), static_cast<long long>(k.z())}].push_back(i);
    }
    std::vector<Eigen::Vector3d> merged;
    std::vector<double> weights;
    for (const auto& [key, members] : cells) {
      Eigen::Vector3d mean = Eigen::Vector3d::Zero();
      double sum = 0;
      for (std::size_t i : members) {
        mean += (*points)[i];
        sum += w.empty() ? 1.0 : w[i];
      }
      mean /= static_cast<double>(members.size());
      std::size_t best = members.front();
      for (std::size_t i : members)
        if (((*points)[i] - mean).squaredNorm() < ((*points)[best] - mean).squaredNorm()) best = i;
      merged.push_back((*points)[best]);
      weights.push_back(sum);
    }
    *points = std::move(merged);
    w = std::move(weights);
  }

  /// What a design that turned past 90 deg does next (pastUpright).
  struct PastUpright {
    bool simulated = false;  ///< false: it could not be followed (reason says why)
    std::string reason;
    double max_tilt_deg = 0;  ///< largest tilt from upright
    enum Kind { kRollsAway, kFallsOver, kComesBack, kRocksBack, kStillMoving } kind = kStillMoving;
    double turned_deg = 0;     ///< net turn about the rocking axis from the release
    double travel_m = 0;       ///< how far its centre of mass moved along the ground
    double seconds = 0;        ///< how long it was followed
    double rest_tilt_deg = 0;  ///< the tilt it came to rest at (kFallsOver, kComesBack)
    double last_tilt_deg = 0;  ///< its largest tilt over the last kLastS of the follow-up (kRocksBack)
  };

  // Follows the design from the release, in double precision on the contact candidates of every tilt
  // about the rocking axis, for duration_s (at least kFollowS) or until decided:
  //  - rolls away: it turns a full turn about the rocking axis (over and over along the ground);
  //  - falls over: it comes to rest (its tilt within kRestDeg over kRestS) at 45 deg or more;
  //  - comes back: it comes to rest below 45 deg;
  //  - rocks back: still moving at the end, but within 90 deg over the last kLastS;
  //  - still moving: none of these by the end (a body still rolling or tumbling; the travel tells).
  PastUpright pastUpright(const MassProperties& mass) const {
    constexpr double kFollowS = 3.0, kRestS = 0.3, kRestDeg = 0.1, kLastS = 1.0;
    constexpr std::size_t kFollowPoints = 3000;
    PastUpright out;
    std::vector<Eigen::Vector3d> points;
    RigidSimOptions o = withStop(options_all_, should_stop_);
    contactBand(180.0, &points, &o);
    // A fill's contact samples are dense (0.4 mm on a 10 cm doll: a flat face landing then needs hours); what
    // it does next needs far fewer: merged on a grid to at most kFollowPoints, each cell's weight the sum of its
    // points' (the same total contact stiffness and area).
    for (double cell = size_ / 100; points.size() > kFollowPoints; cell *= 1.5) mergeOnGrid(cell, &points, &o);
    o.duration_s = std::max(options_.duration_s, kFollowS);
    const Eigen::Vector3d ez(0, 0, 1), side = axis_.cross(ez);
    const auto tilt = [&](const Eigen::Quaterniond& q) {
      const Eigen::Vector3d u = q * up_;
      return std::atan2(u.dot(side), u.dot(ez)) * kDeg;
    };
    struct Watch {  // the unwrapped tilt about the rocking axis and the recent tilts
      double first = 0, last = 0, unwrapped = 0;
      std::vector<double> recent;
      bool rolled = false, rests = false;
    };
    auto watch = std::make_shared<Watch>();
    watch->first = watch->last = watch->unwrapped = tilt0_ * kDeg;
    const std::size_t rest_samples = static_cast<std::size_t>(std::ceil(kRestS / o.output_dt_s)) + 1;
    o.stop_after_sample = [watch, tilt, rest_samples, kRestDeg](double, const Eigen::Quaterniond& q) {
      const double phi = tilt(q);
      watch->unwrapped += std::remainder(phi - watch->last, 360.0);
      watch->last = phi;
      watch->rolled = std::abs(watch->unwrapped - watch->first) >= 360.0;
      watch->recent.push_back(watch->unwrapped);
      if (watch->recent.size() > rest_samples) watch->recent.erase(watch->recent.begin());
      const auto [lo, hi] = std::minmax_element(watch->recent.begin(), watch->recent.end());
      watch->rests = watch->recent.size() == rest_samples && *hi - *lo < kRestDeg;
      return watch->rolled || watch->rests;
    };
    const RigidInertia<double> inertia = toInertia(mass);
    RigidTrajectory<double> traj;
    try {
      RigidState<double> s0 = restingState(inertia, Eigen::Quaterniond(Eigen::AngleAxisd(tilt0_, axis_)), points, o);
      s0.angular_velocity = omega0_ * axis_;
      traj = simulateRigid(inertia, s0, points, o);
    } catch (const TopoError& e) {
      out.reason = e.what();
      out.reason = out.reason.substr(0, out.reason.find(". Fix: "));  // its fix is not the user's
      return out;
    }
    out.simulated = true;
    const auto from_upright = [&](const Eigen::Quaterniond& q) {
      return std::acos(std::clamp((q.normalized() * up_).z(), -1.0, 1.0)) * kDeg;
    };
    for (const auto& st : traj.states) out.max_tilt_deg = std::max(out.max_tilt_deg, from_upright(st.orientation));
    const Eigen::Vector3d moved = traj.states.back().position - traj.states.front().position;
    out.travel_m = std::hypot(moved.x(), moved.y());
    out.seconds = traj.time_s.back();
    out.turned_deg = watch->unwrapped - watch->first;
    out.rest_tilt_deg = from_upright(traj.states.back().orientation);
    for (std::size_t k = 0; k < traj.states.size(); ++k)
      if (traj.time_s[k] >= out.seconds - kLastS)
        out.last_tilt_deg = std::max(out.last_tilt_deg, from_upright(traj.states[k].orientation));
    if (watch->rolled)
      out.kind = PastUpright::kRollsAway;
    else if (watch->rests)
      out.kind = out.rest_tilt_deg >= 45.0 ? PastUpright::kFallsOver : PastUpright::kComesBack;
    else if (out.seconds > kLastS && out.last_tilt_deg < 90.0)
      out.kind = PastUpright::kRocksBack;
    return out;
  }

  // Refuses a design that turned past 90 deg (from the candidates' simulation, to max_tilt), saying what
  // it did next (pastUpright) with the numbers, and the fix for that.
  [[noreturn]] void refusePastUpright(const PastUpright& past, double max_tilt) const {
    std::string what = "the design turns past 90 deg (to " +
                       numberText(past.simulated ? past.max_tilt_deg : max_tilt, 3) + " deg) from the release at " +
                       numberText(tilt0_ * kDeg, 3) + " deg" +
                       (omega0_ != 0.0 ? " with " + numberText(omega0_, 3) + " rad/s" : std::string());
    const std::string smaller = "a smaller initial_tilt_deg or initial_angular_velocity_rad_s";
    const std::string follow = "followed for " + numberText(past.seconds, 3) + " s";
    switch (past.simulated ? past.kind : PastUpright::kStillMoving) {
      case PastUpright::kRollsAway:
        throw TopoError("tumbler simulation",
                        what + " and rolls away instead of rocking back: it rolled " + numberText(past.travel_m, 3) +
                            " m along the ground in " + numberText(past.seconds, 3) + " s (" +
                            numberText(std::abs(past.turned_deg) / 360.0, 2) + " full turn about its rocking axis, " +
                            numberText(past.travel_m / past.seconds, 3) + " m/s)",
                        "a design whose centre of mass lies below the centre of its rounded bottom (then it rolls "
                        "back), or " +
                            smaller);
      case PastUpright::kFallsOver:
        throw TopoError("tumbler simulation",
                        what + " and falls over instead of rocking back: it comes to rest at " +
                            numberText(past.rest_tilt_deg, 3) + " deg, " + numberText(past.travel_m, 2) +
                            " m from where it was released (" + follow + ")",
                        "a design with its centre of mass lower, so that it is over the part it rests on at the "
                        "largest tilt, or " +
                            smaller);
      case PastUpright::kComesBack:
        throw TopoError("tumbler simulation",
                        what + " before it comes to rest at " + numberText(past.rest_tilt_deg, 3) + " deg, " +
                            numberText(past.travel_m, 2) + " m from where it was released (" + follow +
                            "): a doll's rocking stays within 90 deg",
                        "a design with its centre of mass lower, or " + smaller);
      case PastUpright::kRocksBack:
        throw TopoError("tumbler simulation",
                        what + " and rocks back: still rocking when " + follow + ", up to " +
                            numberText(past.last_tilt_deg, 3) +
                            " deg over its last second; a rocking past 90 deg is beyond what the task measures "
                            "(max_tilt_deg up to 90)",
                        smaller);
      case PastUpright::kStillMoving:
        break;
    }
    if (past.simulated)
      throw TopoError("tumbler simulation",
                      what + " and is still moving when " + follow +
                          ", neither rolled away (a full turn) nor at rest: up to " +
                          numberText(past.last_tilt_deg, 3) + " deg over its last second, turned " +
                          numberText(past.turned_deg, 3) + " deg, " + numberText(past.travel_m, 2) +
                          " m from where it was released",
                      "a design with its centre of mass lower, or " + smaller);
    throw TopoError(
        "tumbler simulation",
        what + ": it falls over or rolls away instead of rocking back (not followed further: " + past.reason + ")",
        "a design with its centre of mass lower (below the centre of its rounded bottom), or " + smaller);
  }

  RigidSimOptions options_;      ///< with the candidates' weights
  RigidSimOptions options_all_;  ///< with every contact point's weight
  std::vector<Eigen::Vector3d> all_contact_;
  std::vector<double> all_weights_;
  double reach_deg_ = 90;
  double band_m_ = 0;  ///< contact candidates: within this of the lowest point
  Eigen::Vector3d axis_, up_;
  double tilt0_ = 0, omega0_ = 0, w_period_ = 1, w_tilt_ = 1, w_amplitude_ = 1;
  double period_target_ = -1, tilt_target_ = -1, amplitude_target_ = -1;
  double equilibrium_target_ = 0, w_equilibrium_ = 1;
  bool has_equilibrium_target_ = false, equilibrium_from_release_ = false;
  int cycles_ = 2;
  std::vector<Eigen::Vector3d> contact_;
};

}  // namespace

namespace {

/// The tracker's signal resampled at its median frame interval (linear interpolation over gaps).
bool uniformSignal(const std::vector<double>& t, const std::vector<double>& y, std::vector<double>* out, double* dt) {
  if (t.size() != y.size() || t.size() < 8) return false;
  std::vector<double> d;
  for (std::size_t i = 1; i < t.size(); ++i) d.push_back(t[i] - t[i - 1]);
  std::nth_element(d.begin(), d.begin() + std::ptrdiff_t(d.size() / 2), d.end());
  *dt = d[d.size() / 2];
  if (!(*dt > 0)) return false;
  out->clear();
  std::size_t j = 0;
  for (double s = t.front(); s <= t.back() + 1e-9 * *dt; s += *dt) {
    while (j + 2 < t.size() && t[j + 1] < s) ++j;
    const double w = t[j + 1] > t[j] ? std::clamp((s - t[j]) / (t[j + 1] - t[j]), 0.0, 1.0) : 0.0;
    out->push_back((1 - w) * y[j] + w * y[j + 1]);
  }
  return out->size() >= 8;
}

/// period_s, max_tilt_deg and (from a window that starts at the release) amplitude_deg from observed
/// rocking (inference/motion_targets.h describes the rule).
MotionTargets rockingTargets(const TaskConfig& config, const motion::MotionFeatures& f) {
  MotionTargets out;
  if (!f.oscillation_found || !(f.period_s > 0)) {
    out.note = motionFeaturesOrigin(f) + " hold no oscillation" + (f.message.empty() ? "" : ": " + f.message);
    return out;
  }
  // Released at rest at initial_tilt_deg, the doll's largest tilt is at least the release tilt: an
  // observed maximum at or below it (within 1 %: tracking error) says the swing never went past the
  // release, so the target is the release tilt itself (anything below is unreachable).
  const TumblerOptions options = readOptions<TumblerOptions>(config, kTumblerFields);
  const double release = std::abs(options.initial_tilt_deg);
  std::ostringstream os;
  double period = f.period_s, tilt = f.amplitude_confidence > 0 ? f.max_tilt_deg : 0.0, amplitude = 0.0;
  double from_release = NAN;  // the equilibrium signed towards the release's side (a release window)
  double first = NAN;         // |tilt| the tracker read at the release (a release window)
  std::vector<double> y;
  double dt = 0;
  // An absolute tilt the tracker could not tell (confidence 0: an axis known only modulo 90 deg, a
  // pendulum's path without a pivot) leaves the period alone.
  const bool tilt_known = f.amplitude_confidence > 0;
  if (!tilt_known)
    os << "the tracker gives no absolute tilt (confidence 0): its signal, largest tilt and equilibrium are not used";
  if (tilt_known && uniformSignal(f.time_s, f.angle_deg, &y, &dt)) {
    // A window that starts at the release (the first sample a turning point, the first step small
    // against the range, far from the centre) is measured as the task measures its simulation.
    double lo = y[0], hi = y[0], peak = 0;
    for (double v : y) lo = std::min(lo, v), hi = std::max(hi, v), peak = std::max(peak, std::abs(v));
    const bool at_rest = std::abs(y[1] - y[0]) < 0.05 * (hi - lo) && std::abs(y[0]) >= 0.5 * peak;
    const int cycles = options.measured_cycles;
    const OscillationFeatures<double> o =
        at_rest ? analyseOscillation(y, 0.0, dt, cycles, true) : OscillationFeatures<double>{};
    if (o.valid && o.period > 0) {
      period = o.period;
      tilt = o.max_abs;
      // Measured as the task measures its simulation, the amplitude is comparable too (over a window
      // started mid-swing the swing may have decayed, so it is used only here).
      amplitude = o.amplitude;
      from_release = (y[0] < 0 ? -1.0 : 1.0) * o.equilibrium;
      first = std::abs(y[0]);
      os << "the window starts at a release: the task's analysis of the observed signal (" << y.size()
         << " samples, first " << cycles << " cycles) gives period " << o.period << " s, max tilt " << o.max_abs
         << " deg, amplitude " << o.amplitude << " deg (the tracker's own over the window: " << f.period_s << " s, "
         << f.max_tilt_deg << " deg)";
    } else {
      os << "the window starts mid-swing: the tracker's period and max tilt over the window are used";
    }
  }
  out.targets.emplace_back("period_s", period);
  // From a release window the largest tilt is compared with the tilt the same tracker read at the
  // release, so its bias there cancels (a silhouette's axis seen in perspective read a doll released at
  // 10 deg as 10.15–10.17 deg, its far swing of 16.41 deg as 16.42): a largest tilt no more than 1 % above
  // that reading is the release itself, whose tilt the task knows.
  const bool beyond = std::isfinite(first) && first > 0 ? tilt > 1.01 * first : tilt > 1.01 * release;
  if (beyond) {
    out.targets.emplace_back("max_tilt_deg", tilt);
  } else if (release > 0) {
    out.targets.emplace_back("max_tilt_deg", release);
    os << "; the max tilt " << tilt << " deg does not exceed the release tilt"
       << (std::isfinite(first) ? " as the tracker read it (" + numberText(first, 4) + " deg)" : std::string())
       << ", so its target is the release tilt " << release << " deg";
  } else {
    os << "; the tilt was not measured, only the period is used";
  }
  if (amplitude > 0) out.targets.emplace_back("amplitude_deg", amplitude);
  // The tilt it rocks about fixes the centre of mass across the rocking axis (a doll at rest upright
  // rocks about 0); the tracker's mean of its turning points, when it measured it.
  // From a window that starts at the release, the task's own analysis gives it signed towards the
  // release's side (equilibrium_from_release_deg: a doll released at +10 deg that swings out to −16.5
  // rests on the other side, whichever side the camera looks from); otherwise its magnitude counts.
  if (tilt_known && f.equilibrium_confidence > 0 && std::isfinite(f.equilibrium_deg)) {
    if (std::isfinite(from_release)) {
      out.targets.emplace_back("equilibrium_from_release_deg", from_release);
      os << "; equilibrium tilt " << from_release << " deg towards the release's side";
    } else {
      out.targets.emplace_back("equilibrium_tilt_deg", f.equilibrium_deg);
      os << "; equilibrium tilt " << f.equilibrium_deg << " deg";
    }
  }
  out.note = os.str();
  return out;
}

}  // namespace

void registerTumblerTask(TaskList* tasks) {
  TaskDefinition t;
  t.name = "tumbler";
  t.summary = "a wobbly doll released at a tilt rocks on the ground: rocking period and maximum tilt";
  t.declare_parameters = [](TaskParameters& p) {
    declareRigidMotionParameters(p, 2.0, 0.1);
    declareOptions<TumblerOptions>(p, kTumblerFields);
    p.setDefault("loss_tolerance", 1e-8);  // relative feature errors of 1e-4 are plenty
  };
  t.make = [](const TaskConfig& config, const VolumeCloud& cloud) -> std::unique_ptr<Task> {
    return std::make_unique<TumblerTask>(config, cloud);
  };
  t.motion_targets = rockingTargets;
  t.rocking_axis_parameter = "rocking_axis";  // identifiability: rock it about another axis too

  RigTwinMotion rocking;  // the twin of a tumbler rig: released at rest, it rocks
  rocking.duration_parameter = "duration_s";
  rocking.period_feature = "period_s";
  rocking.cavity_centre = Eigen::Vector3d(0.0, 0.0, 0.4);
  rocking.cavity_radius = 0.5;
  rocking.default_for_shapes = {"tumbler"};
  t.twin = rocking;
  tasks->push_back(t);
}

}  // namespace topo_gaussian::inference
