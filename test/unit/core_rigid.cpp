// Rigid-body simulator against closed-form results: rocking periods (hemisphere, round-bottomed
// body), physical pendulum, rolling on an incline, sliding → rolling ball; forward-mode derivatives
// against central finite differences; divergence and bad-input errors; speed.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <vector>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/physics/mass_properties.h"
#include "topo_gaussian/physics/rigid_body.h"

using namespace topo_gaussian;

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kG = 9.81;

/// Fibonacci points on the sphere of radius R centred at the origin, keeping those within
/// `cap_deg` of the bottom pole (0, 0, −R); the full sphere has round(4πR²/spacing²) points.
std::vector<Eigen::Vector3d> sphereCap(double R, double spacing, double cap_deg) {
  const long n = std::lround(4.0 * kPi * R * R / (spacing * spacing));
  const double golden = kPi * (3.0 - std::sqrt(5.0));
  const double zmax = -std::cos(cap_deg * kPi / 180.0);
  std::vector<Eigen::Vector3d> pts;
  for (long i = 0; i < n; ++i) {
    const double z = -1.0 + (2.0 * i + 1.0) / n;  // from the bottom pole upwards
    if (z > zmax + 1e-12) break;
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    const double phi = golden * i;
    pts.emplace_back(R * r * std::cos(phi), R * r * std::sin(phi), R * z);
  }
  return pts;
}

/// Rotation about y of the body z axis, seen in the world (x–z plane).
template <typename S>
double tiltY(const RigidState<S>& s) {
  const Eigen::Quaterniond q(valueOf(s.orientation.w()), valueOf(s.orientation.x()), valueOf(s.orientation.y()),
                             valueOf(s.orientation.z()));
  const Eigen::Matrix3d R = q.toRotationMatrix();
  return std::atan2(R(0, 2), R(2, 2));
}
template <typename S>
double tiltX(const RigidState<S>& s) {
  const Eigen::Quaterniond q(valueOf(s.orientation.w()), valueOf(s.orientation.x()), valueOf(s.orientation.y()),
                             valueOf(s.orientation.z()));
  const Eigen::Matrix3d R = q.toRotationMatrix();
  return std::atan2(-R(1, 2), R(2, 2));
}

/// Period from linearly interpolated zero crossings (both directions) of a signal about `mean`, over
/// whole periods only (an even number of half periods, so a slight offset of the equilibrium, which
/// makes consecutive half periods alternate, cancels): T = 2 (t_j − t_0) / j with j even.
/// Returns NaN with fewer than 3 crossings.
double periodFromCrossings(const std::vector<double>& t, const std::vector<double>& y, double mean, int* count) {
  std::vector<double> tc;
  for (size_t i = 1; i < y.size(); ++i) {
    const double a = y[i - 1] - mean, b = y[i] - mean;
    if ((a < 0.0 && b >= 0.0) || (a > 0.0 && b <= 0.0)) tc.push_back(t[i - 1] + (t[i] - t[i - 1]) * a / (a - b));
  }
  if (count) *count = static_cast<int>(tc.size());
  if (tc.size() < 3) return std::numeric_limits<double>::quiet_NaN();
  const size_t j = (tc.size() - 1) % 2 == 0 ? tc.size() - 1 : tc.size() - 2;
  return 2.0 * (tc[j] - tc[0]) / static_cast<double>(j);
}

/// Solid hemisphere (flat face up, sphere centre at the body origin): analytic mass properties.
MassProperties hemisphere(double R, double rho) {
  MassProperties p;
  p.mass = 2.0 / 3.0 * kPi * R * R * R * rho;
  p.com = Eigen::Vector3d(0, 0, -3.0 * R / 8.0);
  p.inertia = Eigen::Vector3d(83.0 / 320.0, 83.0 / 320.0, 2.0 / 5.0).asDiagonal() * (p.mass * R * R);
  return p;
}

/// Round-bottomed body: sphere of radius R (centre at the body origin), com h below the centre.
MassProperties roundBottom(double h) {
  MassProperties p;
  p.mass = 0.8;
  p.com = Eigen::Vector3d(0, 0, -h);
  p.inertia << 6.0e-4, 0.0, 0.0, 0.0, 5.0e-4, 0.0, 0.0, 0.0, 7.0e-4;
  return p;
}

double rockingPeriod(const MassProperties& props, const std::vector<Eigen::Vector3d>& pts, double tilt_deg,
                     double duration, RigidSimOptions opt, int* crossings, RigidTrajectory<double>* out = nullptr) {
  const RigidInertia<double> in = toInertia(props);
  const Eigen::Quaterniond q(Eigen::AngleAxisd(tilt_deg * kPi / 180.0, Eigen::Vector3d::UnitY()));
  opt.duration_s = duration;
  const RigidState<double> s0 = restingState(in, q, pts, opt);
  const RigidTrajectory<double> tr = simulateRigid(in, s0, pts, opt);
  std::vector<double> y;
  for (const auto& s : tr.states) y.push_back(tiltY(s));
  if (out) *out = tr;
  return periodFromCrossings(tr.time_s, y, 0.0, crossings);
}

}  // namespace

// 1. Solid hemisphere R = 0.1 m, ρ = 1000 kg/m³ rocking on its curved face: T = 0.8352 s.
TEST(RigidRocking, HemispherePeriod) {
  const double R = 0.1;
  const MassProperties props = hemisphere(R, 1000.0);
  // Contact points: Fibonacci sampling of the curved surface within 30° of the bottom, spacing 1.5 mm.
  const std::vector<Eigen::Vector3d> pts = sphereCap(R, 1.5e-3, 30.0);
  RigidSimOptions opt;
  opt.output_dt_s = 2e-3;
  int nc = 0;
  RigidTrajectory<double> tr;
  const double T = rockingPeriod(props, pts, 3.0, 5.0, opt, &nc, &tr);
  const double h = 3.0 * R / 8.0;
  const double Tref = 2.0 * kPi * std::sqrt((83.0 / 320.0 * R * R + (R - h) * (R - h)) / (kG * h));
  std::printf(
      "hemisphere: %zu contact points, k = %.4g N/m, dt = %.3g s, T = %.5f s, closed form %.5f s "
      "(%+.3f %%), %d crossings\n",
      pts.size(), tr.stiffness_used, tr.substep_s, T, Tref, 100.0 * (T / Tref - 1.0), nc);
  EXPECT_NEAR(Tref, 0.8352, 1e-4);
  EXPECT_GE(nc, 8);
  EXPECT_NEAR(T / Tref, 1.0, 0.005);
}

// 2. Round-bottomed body (sphere R, com h below the centre): T = 2π √((I + m(R−h)²)/(m g h)).
TEST(RigidRocking, RoundBottomPeriod) {
  const double R = 0.05, h = 0.015;
  const MassProperties props = roundBottom(h);
  // Contact points: Fibonacci sampling within 30° of the bottom, spacing 0.7 mm. (The contact patch
  // travels R θ = 2.6 mm at 3°: the sampling must be a fraction of that, with 1 mm the lattice makes
  // the period depend on the amplitude by a few tenths of a percent.)
  const std::vector<Eigen::Vector3d> pts = sphereCap(R, 0.7e-3, 30.0);
  RigidSimOptions opt;
  opt.output_dt_s = 2e-3;
  int nc = 0;
  RigidTrajectory<double> tr;
  const double T = rockingPeriod(props, pts, 3.0, 4.0, opt, &nc, &tr);
  const double Iyy = props.inertia(1, 1), m = props.mass;
  const double Tref = 2.0 * kPi * std::sqrt((Iyy + m * (R - h) * (R - h)) / (m * kG * h));
  std::printf(
      "round bottom: %zu contact points, k = %.4g N/m, dt = %.3g s, T = %.5f s, closed form %.5f s "
      "(%+.3f %%), %d crossings\n",
      pts.size(), tr.stiffness_used, tr.substep_s, T, Tref, 100.0 * (T / Tref - 1.0), nc);
  EXPECT_GE(nc, 8);
  EXPECT_NEAR(T / Tref, 1.0, 0.005);
}

// 3. Physical pendulum on a pivot: T = 2π √(I_p / (m g d)); energy drift over 10 periods.
TEST(RigidPendulum, PeriodAndEnergy) {
  MassProperties props;
  props.mass = 1.2;
  props.com = Eigen::Vector3d(0.0, 0.0, 0.0);
  props.inertia << 0.010, 0.0, 0.0, 0.0, 0.020, 0.0, 0.0, 0.0, 0.015;
  const RigidInertia<double> in = toInertia(props);
  RigidSimOptions opt;
  opt.ground.enabled = false;
  opt.pivot = true;
  opt.pivot_body = Eigen::Vector3d(0.0, 0.0, 0.2);
  opt.pivot_world = Eigen::Vector3d(0.0, 0.0, 1.0);
  const double d = 0.2;
  const double Ip = props.inertia(0, 0) + props.mass * d * d;
  const double Tref = 2.0 * kPi * std::sqrt(Ip / (props.mass * kG * d));
  opt.duration_s = 10.0 * Tref + 0.05;
  opt.output_dt_s = 2e-3;
  const double amp = 2.0 * kPi / 180.0;
  const RigidState<double> s0 =
      pivotState(in, Eigen::Quaterniond(Eigen::AngleAxisd(amp, Eigen::Vector3d::UnitX())), opt);
  const RigidTrajectory<double> tr = simulateRigid(in, s0, {}, opt);
  std::vector<double> y;
  for (const auto& s : tr.states) y.push_back(tiltX(s));
  int nc = 0;
  const double T = periodFromCrossings(tr.time_s, y, 0.0, &nc);
  // Oscillation energy: m g d (1 − cos θ0); drift measured against it (stricter than the total).
  const double e_osc = props.mass * kG * d * (1.0 - std::cos(amp));
  const double e0 = rigidEnergy(in, tr.states.front(), {}, opt);
  double drift = 0.0;
  for (const auto& s : tr.states) drift = std::max(drift, std::abs(rigidEnergy(in, s, {}, opt) - e0));
  // The pivot stays put.
  double pivot_err = 0.0;
  for (const auto& s : tr.states) {
    const Eigen::Vector3d xp = s.position + s.orientation.toRotationMatrix() * (opt.pivot_body - props.com);
    pivot_err = std::max(pivot_err, (xp - opt.pivot_world).norm());
  }
  std::printf(
      "pendulum: dt = %.3g s, T = %.5f s, closed form %.5f s (%+.4f %%), energy drift %.3g of the "
      "oscillation energy over 10 periods, pivot error %.2g m\n",
      tr.substep_s, T, Tref, 100.0 * (T / Tref - 1.0), drift / e_osc, pivot_err);
  EXPECT_GE(nc, 19);
  EXPECT_NEAR(T / Tref, 1.0, 0.005);
  EXPECT_LT(drift / e_osc, 1e-3);
  EXPECT_LT(pivot_err, 1e-9);
}

// 4. A solid sphere rolls down an incline (gravity rotated by θ) with a = 5/7 g sin θ.
TEST(RigidRolling, InclineAcceleration) {
  const double R = 0.05, rho = 1000.0, theta = 15.0 * kPi / 180.0;
  MassProperties props;
  props.mass = 4.0 / 3.0 * kPi * R * R * R * rho;
  props.com.setZero();
  props.inertia = Eigen::Matrix3d::Identity() * (0.4 * props.mass * R * R);
  const std::vector<Eigen::Vector3d> pts = sphereCap(R, 2.0e-3, 180.0);  // whole sphere, 2 mm
  const RigidInertia<double> in = toInertia(props);
  RigidSimOptions opt;
  opt.gravity = Eigen::Vector3d(kG * std::sin(theta), 0.0, -kG * std::cos(theta));
  opt.ground.damping_ratio = 0.01;  // rolling freely: the normal damper causes rolling drag ∝ ζ v
  opt.duration_s = 0.6;
  opt.output_dt_s = 5e-3;
  const RigidState<double> s0 = restingState(in, Eigen::Quaterniond::Identity(), pts, opt);
  const RigidTrajectory<double> tr = simulateRigid(in, s0, pts, opt);
  // Least-squares fit x(t) = x0 + v0 t + a t²/2 after a short settling time.
  Eigen::MatrixXd A;
  Eigen::VectorXd b;
  std::vector<int> idx;
  for (size_t i = 0; i < tr.time_s.size(); ++i)
    if (tr.time_s[i] >= 0.05) idx.push_back(static_cast<int>(i));
  A.resize(idx.size(), 3);
  b.resize(idx.size());
  for (size_t r = 0; r < idx.size(); ++r) {
    const double t = tr.time_s[idx[r]];
    A.row(r) << 1.0, t, 0.5 * t * t;
    b(r) = tr.states[idx[r]].position.x();
  }
  const Eigen::Vector3d coef = A.colPivHouseholderQr().solve(b);
  const double aref = 5.0 / 7.0 * kG * std::sin(theta);
  const RigidState<double>& sf = tr.states.back();
  const double slip = sf.velocity.x() - sf.angular_velocity.y() * R;
  std::printf(
      "incline: %zu points, k = %.4g N/m, dt = %.3g s, a = %.5f m/s^2, 5/7 g sin(theta) = %.5f (%+.3f %%), "
      "final v = %.4f m/s, slip v - wR = %.2g m/s\n",
      pts.size(), tr.stiffness_used, tr.substep_s, coef(2), aref, 100.0 * (coef(2) / aref - 1.0), sf.velocity.x(),
      slip);
  EXPECT_NEAR(coef(2) / aref, 1.0, 0.01);
}

// 5. A ball launched sliding (v0, no spin) ends rolling at 5/7 v0 with ω = v / R.
TEST(RigidRolling, SlidingBallEndsRolling) {
  const double R = 0.05, rho = 1000.0, v0 = 1.0;
  MassProperties props;
  props.mass = 4.0 / 3.0 * kPi * R * R * R * rho;
  props.com.setZero();
  props.inertia = Eigen::Matrix3d::Identity() * (0.4 * props.mass * R * R);
  const std::vector<Eigen::Vector3d> pts = sphereCap(R, 2.0e-3, 180.0);
  const RigidInertia<double> in = toInertia(props);
  RigidSimOptions opt;
  opt.ground.friction_mu = 0.3;
  opt.ground.damping_ratio = 0.02;
  opt.duration_s = 0.3;  // sliding ends after 2 v0 / (7 μ g) = 0.097 s
  opt.output_dt_s = 5e-3;
  RigidState<double> s0 = restingState(in, Eigen::Quaterniond::Identity(), pts, opt);
  s0.velocity = Eigen::Vector3d(v0, 0.0, 0.0);
  const RigidTrajectory<double> tr = simulateRigid(in, s0, pts, opt);
  const RigidState<double>& sf = tr.states.back();
  const double v = sf.velocity.x(), w = sf.angular_velocity.y();
  std::printf("sliding ball: final v = %.5f m/s (5/7 v0 = %.5f, %+.3f %%), w R = %.5f m/s (%+.3f %% of v)\n", v,
              5.0 / 7.0 * v0, 100.0 * (v / (5.0 / 7.0 * v0) - 1.0), w * R, 100.0 * (w * R / v - 1.0));
  EXPECT_NEAR(v / (5.0 / 7.0 * v0), 1.0, 0.02);
  EXPECT_NEAR(w * R / v, 1.0, 0.02);
}

namespace {

/// Central finite differences of f over the ten MassProperties parameters, scaled by each
/// parameter's size; compared with the forward-mode derivatives ad (also scaled).
void compareDerivatives(const char* what, const MassProperties& props, const Eigen::Matrix<double, 10, 1>& ad,
                        const std::function<double(const MassProperties&)>& f, double L) {
  const Eigen::Matrix<double, 10, 1> p0 = props.toVector();
  const double Iscale = props.inertia.diagonal().maxCoeff();
  Eigen::Matrix<double, 10, 1> scale;
  scale << props.mass, L, L, L, Iscale, Iscale, Iscale, Iscale, Iscale, Iscale;
  Eigen::Matrix<double, 10, 1> fd, ads;
  for (int k = 0; k < 10; ++k) {
    const double hk = 1e-7 * scale(k);  // small: the contact map is only piecewise smooth (stick/slip, clamps)
    Eigen::Matrix<double, 10, 1> pp = p0, pm = p0;
    pp(k) += hk;
    pm(k) -= hk;
    fd(k) = (f(MassProperties::fromVector(pp)) - f(MassProperties::fromVector(pm))) / (2.0 * hk) * scale(k);
    ads(k) = ad(k) * scale(k);
  }
  const double floor = 1e-3 * fd.cwiseAbs().maxCoeff();
  for (int k = 0; k < 10; ++k) {
    const double rel = std::abs(ads(k) - fd(k)) / std::max(std::abs(fd(k)), floor);
    std::printf("%s d/dp[%d]*scale: forward %+.8e  FD %+.8e  rel err %.2e\n", what, k, ads(k), fd(k), rel);
    // 3e-4: the Hunt–Crossley damper (∝ pen · v) leaves ~2e-4 of FD noise on the smallest components.
    EXPECT_LT(rel, 3e-4) << what << " parameter " << k;
  }
}

}  // namespace

// 6a. Derivatives of a short tumbler run (0.3 s) w.r.t. the ten mass parameters.
TEST(RigidDerivatives, TumblerForwardModeMatchesFiniteDifferences) {
  const double R = 0.05;
  MassProperties props = roundBottom(0.015);
  props.com = Eigen::Vector3d(0.002, -0.001, -0.015);
  props.inertia << 6.0e-4, 0.3e-4, -0.2e-4, 0.3e-4, 5.0e-4, 0.4e-4, -0.2e-4, 0.4e-4, 7.0e-4;
  const std::vector<Eigen::Vector3d> pts = sphereCap(R, 2.0e-3, 60.0);
  RigidSimOptions opt;
  opt.duration_s = 0.3;
  opt.output_dt_s = 5e-3;
  const Eigen::Quaterniond q(Eigen::AngleAxisd(5.0 * kPi / 180.0, Eigen::Vector3d(0.3, 1.0, 0.0).normalized()));

  const RigidInertia<Dual10> ind = seedInertia(props);
  const RigidState<Dual10> s0 = restingState(ind, q, pts, opt);
  const RigidTrajectory<Dual10> trd = simulateRigid(ind, s0, pts, opt);
  const RigidState<Dual10>& sf = trd.states.back();

  const auto run = [&](const MassProperties& p) {
    const RigidInertia<double> in = toInertia(p);
    return simulateRigid(in, restingState(in, q, pts, opt), pts, opt).states.back();
  };
  // Final tilt about y (through the rotation matrix entries) and final x position.
  Eigen::Matrix<double, 10, 1> ad_tilt;
  {
    const Mat3<Dual10> Rf = sf.orientation.toRotationMatrix();
    const Dual10 t = atan2(Rf(0, 2), Rf(2, 2));
    ad_tilt = t.derivatives();
  }
  compareDerivatives(
      "tumbler tilt", props, ad_tilt, [&](const MassProperties& p) { return tiltY(run(p)); }, R);
  compareDerivatives(
      "tumbler x", props, sf.position.x().derivatives(), [&](const MassProperties& p) { return run(p).position.x(); },
      R);
  compareDerivatives(
      "tumbler wy", props, sf.angular_velocity.y().derivatives(),
      [&](const MassProperties& p) { return run(p).angular_velocity.y(); }, R);
  // The Dual10 run has the same values as the double run.
  const RigidState<double> sv = run(props);
  EXPECT_NEAR(sf.position.x().value(), sv.position.x(), 1e-12);
}

// 6b. Derivatives of a pendulum swing.
TEST(RigidDerivatives, PendulumForwardModeMatchesFiniteDifferences) {
  MassProperties props;
  props.mass = 1.2;
  props.com = Eigen::Vector3d(0.01, -0.02, 0.005);
  props.inertia << 0.010, 0.001, -0.0005, 0.001, 0.020, 0.002, -0.0005, 0.002, 0.015;
  RigidSimOptions opt;
  opt.ground.enabled = false;
  opt.pivot = true;
  opt.pivot_body = Eigen::Vector3d(0.0, 0.0, 0.2);
  opt.pivot_world = Eigen::Vector3d(0.0, 0.0, 1.0);
  opt.duration_s = 0.7;
  opt.output_dt_s = 5e-3;
  const Eigen::Quaterniond q(Eigen::AngleAxisd(0.4, Eigen::Vector3d(1.0, 0.5, 0.2).normalized()));
  const RigidInertia<Dual10> ind = seedInertia(props);
  const RigidTrajectory<Dual10> trd = simulateRigid(ind, pivotState(ind, q, opt), {}, opt);
  const RigidState<Dual10>& sf = trd.states.back();
  const auto run = [&](const MassProperties& p) {
    const RigidInertia<double> in = toInertia(p);
    return simulateRigid(in, pivotState(in, q, opt), {}, opt).states.back();
  };
  compareDerivatives(
      "pendulum x", props, sf.position.x().derivatives(), [&](const MassProperties& p) { return run(p).position.x(); },
      0.2);
  compareDerivatives(
      "pendulum wx", props, sf.angular_velocity.x().derivatives(),
      [&](const MassProperties& p) { return run(p).angular_velocity.x(); }, 0.2);
}

// 6c. An observer that ends the run (stop_after_sample): called once per output sample with that
// sample's orientation; the trajectory ends at the sample where it said stop, and up to there it is the
// full run's, bit for bit (a task that stops once its features are measured gets the same features).
TEST(RigidRocking, StopAfterSampleEndsTheRunWhereItSaysAndChangesNothingBefore) {
  const std::vector<Eigen::Vector3d> pts = sphereCap(0.05, 2.0e-3, 60.0);
  RigidSimOptions opt;
  opt.duration_s = 1.0;
  const RigidInertia<Dual10> in = seedInertia(roundBottom(0.015));
  const Eigen::Quaterniond q(Eigen::AngleAxisd(8.0 * kPi / 180.0, Eigen::Vector3d::UnitY()));
  const RigidState<Dual10> s0 = restingState(in, q, pts, opt);
  const RigidTrajectory<Dual10> full = simulateRigid(in, s0, pts, opt);
  RigidSimOptions stopping = opt;
  std::vector<double> seen_t;
  double largest_gap = 0;  // between the orientation passed and the stored state's
  int crossings = 0;
  double last = tiltY(s0);
  stopping.stop_after_sample = [&](double t, const Eigen::Quaterniond& o) {
    const RigidState<Dual10>& stored = full.states[seen_t.size() + 1];
    largest_gap = std::max(
        largest_gap, (o.coeffs() - Eigen::Vector4d(stored.orientation.x().value(), stored.orientation.y().value(),
                                                   stored.orientation.z().value(), stored.orientation.w().value()))
                         .cwiseAbs()
                         .maxCoeff());
    seen_t.push_back(t);
    const double now = std::atan2(o.toRotationMatrix()(0, 2), o.toRotationMatrix()(2, 2));
    if ((last > 0) != (now > 0)) ++crossings;
    last = now;
    return crossings == 3;  // one and a half swings
  };
  const RigidTrajectory<Dual10> cut = simulateRigid(in, s0, pts, stopping);
  std::printf("[rigid] stopped at t = %.3f s of %.1f s, after %zu samples\n", cut.time_s.back(), opt.duration_s,
              seen_t.size());
  ASSERT_EQ(crossings, 3);
  ASSERT_EQ(cut.states.size(), seen_t.size() + 1);  // the start, then one sample per call
  EXPECT_LT(cut.time_s.back(), opt.duration_s - 0.1);
  EXPECT_EQ(largest_gap, 0.0);
  for (std::size_t k = 0; k < cut.states.size(); ++k) {
    EXPECT_EQ(cut.time_s[k], full.time_s[k]);
    if (k) {
      EXPECT_EQ(seen_t[k - 1], full.time_s[k]);
    }
    EXPECT_EQ(cut.states[k].position.x().value(), full.states[k].position.x().value());
    EXPECT_EQ(cut.states[k].angular_velocity.y().value(), full.states[k].angular_velocity.y().value());
    EXPECT_EQ(cut.states[k].orientation.y().derivatives(), full.states[k].orientation.y().derivatives());
  }
}

// 7a. Absurd stiffness with a forced large step is detected and explained.
TEST(RigidErrors, DivergenceIsReported) {
  const MassProperties props = roundBottom(0.015);
  const std::vector<Eigen::Vector3d> pts = sphereCap(0.05, 2.0e-3, 40.0);
  const RigidInertia<double> in = toInertia(props);
  RigidSimOptions opt;
  opt.ground.stiffness_n_per_m = 1e9;
  opt.max_substep_s = 2e-3;
  opt.duration_s = 1.0;
  const RigidState<double> s0 =
      restingState(in, Eigen::Quaterniond(Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitY())), pts, opt);
  try {
    simulateRigid(in, s0, pts, opt);
    FAIL() << "expected a divergence error";
  } catch (const TopoError& e) {
    const std::string msg = e.what();
    std::printf("divergence message: %s\n", msg.c_str());
    EXPECT_NE(msg.find("step"), std::string::npos);
    EXPECT_NE(msg.find("stiffness"), std::string::npos);
    EXPECT_NE(msg.find("max_substep_s"), std::string::npos);
  }
}

// 7b. Bad inputs name the input.
TEST(RigidErrors, BadInputs) {
  const MassProperties props = roundBottom(0.015);
  const std::vector<Eigen::Vector3d> pts = sphereCap(0.05, 4.0e-3, 40.0);
  RigidSimOptions opt;
  opt.duration_s = 0.05;
  const RigidInertia<double> good = toInertia(props);
  const RigidState<double> s0 = restingState(good, Eigen::Quaterniond::Identity(), pts, opt);
  EXPECT_NO_THROW(simulateRigid(good, s0, pts, opt));

  const auto expectError = [&](const RigidInertia<double>& in, const RigidState<double>& s,
                               const std::vector<Eigen::Vector3d>& p, const RigidSimOptions& o, const char* needle) {
    try {
      simulateRigid(in, s, p, o);
      ADD_FAILURE() << "expected TopoError mentioning " << needle;
    } catch (const TopoError& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  };
  RigidInertia<double> bad = good;
  bad.mass = 0.0;
  expectError(bad, s0, pts, opt, "mass");
  bad.mass = -1.0;
  expectError(bad, s0, pts, opt, "mass");
  bad = good;
  bad.inertia(2, 2) = -1e-4;
  expectError(bad, s0, pts, opt, "inertia");
  bad = good;
  bad.com.x() = std::nan("");
  expectError(bad, s0, pts, opt, "centre of mass");
  RigidSimOptions o = opt;
  o.duration_s = 0.0;
  expectError(good, s0, pts, o, "duration_s");
  o = opt;
  o.output_dt_s = -1.0;
  expectError(good, s0, pts, o, "output_dt_s");
  o = opt;
  o.output_dt_s = std::nan("");
  expectError(good, s0, pts, o, "output_dt_s");
  RigidState<double> sn = s0;
  sn.velocity.y() = std::nan("");
  expectError(good, sn, pts, opt, "velocity");
  std::vector<Eigen::Vector3d> pn = pts;
  pn[3].z() = std::nan("");
  expectError(good, s0, pn, opt, "contact points");
  EXPECT_THROW(restingState(good, Eigen::Quaterniond::Identity(), {}, opt), TopoError);
  // The Dual10 instantiation validates the same way.
  MassProperties pz = props;
  pz.mass = 0.0;
  const RigidState<Dual10> sd = restingState(seedInertia(props), Eigen::Quaterniond::Identity(), pts, opt);
  EXPECT_THROW(simulateRigid(seedInertia(pz), sd, pts, opt), TopoError);
}

// Speed: tumbler (hemisphere, ~5000 contact points on its curved face), 2 s of motion.
TEST(RigidSpeed, Tumbler5000Points) {
  const double R = 0.1;
  const MassProperties props = hemisphere(R, 1000.0);
  const std::vector<Eigen::Vector3d> pts = sphereCap(R, std::sqrt(2.0 * kPi * R * R / 5000.0), 90.0);
  RigidSimOptions opt;
  opt.duration_s = 2.0;
  const Eigen::Quaterniond q(Eigen::AngleAxisd(5.0 * kPi / 180.0, Eigen::Vector3d::UnitY()));
  using Clock = std::chrono::steady_clock;
  const RigidInertia<double> in = toInertia(props);
  auto t0 = Clock::now();
  const RigidTrajectory<double> tr = simulateRigid(in, restingState(in, q, pts, opt), pts, opt);
  const double td = std::chrono::duration<double>(Clock::now() - t0).count();
  const RigidInertia<Dual10> ind = seedInertia(props);
  t0 = Clock::now();
  const RigidTrajectory<Dual10> trd = simulateRigid(ind, restingState(ind, q, pts, opt), pts, opt);
  const double tdual = std::chrono::duration<double>(Clock::now() - t0).count();
  std::printf(
      "speed: %zu contact points, 2 s of motion, %ld substeps of %.3g s: double %.3f s, Dual10 %.3f s "
      "(ratio %.2f)\n",
      pts.size(), std::lround(2.0 / tr.substep_s), tr.substep_s, td, tdual, tdual / td);
  EXPECT_NEAR(trd.states.back().position.x().value(), tr.states.back().position.x(), 1e-12);
  EXPECT_LT(tdual, 10.0);  // goal < 2 s on 2 cores; generous bound for a loaded machine
}
