// What the rigid tasks say about a motion they simulate, held to an independent integration: the
// hanging swing's closed form for a design released away from its rest pose, and what the tumbler says
// of a design that turns past 90 deg (rolls away, or falls over onto its side).
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "test_clouds.h"
#include "test_util.h"
#include "topo_gaussian/inference/interior_problem.h"
#include "topo_gaussian/inference/pipeline.h"
#include "topo_gaussian/inference/task_config.h"

using namespace topo_gaussian;
using namespace topo_gaussian::inference;
using topo_test::errorOf;

namespace {

double featureOf(const ProblemEvaluation& ev, const std::string& name) {
  for (const auto& f : ev.task.features)
    if (f.name == name) return f.value;
  return std::nan("");
}

// The period of y(t) sampled every dt: the mean interval between its upward crossings of the middle of
// its range, each crossing interpolated linearly between the samples around it.
double crossingPeriod(const std::vector<double>& y, double dt) {
  double lo = y[0], hi = y[0];
  for (double v : y) lo = std::min(lo, v), hi = std::max(hi, v);
  const double mid = 0.5 * (lo + hi);
  std::vector<double> up;
  for (std::size_t k = 1; k < y.size(); ++k)
    if (y[k - 1] < mid && y[k] >= mid) up.push_back(dt * (k - 1 + (mid - y[k - 1]) / (y[k] - y[k - 1])));
  if (up.size() < 2) return std::nan("");
  return (up.back() - up.front()) / static_cast<double>(up.size() - 1);
}

// A rigid body on a ball joint, integrated by classical RK4 in its own variables (the world angular
// momentum about the pivot L and the orientation q): dL/dt = r × m g with r = R r_body the pivot → c
// offset, ω = (R I_p Rᵀ)⁻¹ L with I_p the inertia about the pivot, dq/dt = ½ (0, ω) q. Released at rest
// in q0; returns the period of the angle the task plots, atan2(r_y, −r_z).
double rk4BallJointSwingPeriod(const MassProperties& mp, const Eigen::Vector3d& pivot_body,
                               const Eigen::Quaterniond& q0, const Eigen::Vector3d& gravity, double duration_s) {
  const Eigen::Vector3d rb = mp.com - pivot_body;
  const Eigen::Matrix3d Ip =
      mp.inertia + mp.mass * (rb.squaredNorm() * Eigen::Matrix3d::Identity() - rb * rb.transpose());
  const Eigen::Matrix3d Ip_inv = Ip.inverse();
  struct State {
    Eigen::Vector3d L;
    Eigen::Vector4d q;  // w, x, y, z
  };
  auto rotation = [](const Eigen::Vector4d& q) {
    return Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized().toRotationMatrix();
  };
  auto rate = [&](const State& s) {
    const Eigen::Matrix3d R = rotation(s.q);
    const Eigen::Vector3d w = R * (Ip_inv * (R.transpose() * s.L));
    State d;
    d.L = (R * rb).cross(mp.mass * gravity);
    d.q = 0.5 * Eigen::Vector4d(-w.dot(s.q.tail<3>()), s.q[0] * w.x() + w.y() * s.q[3] - w.z() * s.q[2],
                                s.q[0] * w.y() + w.z() * s.q[1] - w.x() * s.q[3],
                                s.q[0] * w.z() + w.x() * s.q[2] - w.y() * s.q[1]);
    return d;
  };
  auto step = [](const State& s, const State& d, double h) { return State{s.L + h * d.L, s.q + h * d.q}; };
  const double h = 1e-4;
  State s{Eigen::Vector3d::Zero(), Eigen::Vector4d(q0.w(), q0.x(), q0.y(), q0.z())};
  std::vector<double> angle;
  for (int k = 0; k * h < duration_s; ++k) {
    const Eigen::Vector3d r = rotation(s.q) * rb;
    angle.push_back(std::atan2(r.y(), -r.z()));
    const State k1 = rate(s), k2 = rate(step(s, k1, h / 2)), k3 = rate(step(s, k2, h / 2)), k4 = rate(step(s, k3, h));
    s.L += h / 6 * (k1.L + 2 * k2.L + 2 * k3.L + k4.L);
    s.q += h / 6 * (k1.q + 2 * k2.q + 2 * k3.q + k4.q);
    s.q.normalize();
  }
  return crossingPeriod(angle, h);
}

}  // namespace

// A box hung 17 deg off its centre of mass across the roll hangs at 17 deg roll; the task's default target
// pose (0, 0) is not its rest, so the default release (3 deg about world x from the target pose) swings it
// in one plane about its rest pose with the whole offset, 20 deg, as amplitude. The closed form is held to
// the simulated swing, and both to an RK4 of the ball-joint pendulum written here.
TEST(HangingSwing, ClosedFormHoldsForADesignReleasedOffItsRestPose) {
  const VolumeCloud cloud = topo_test::boxCloud(0.2, 0.1, 0.06, 0.008);
  const Eigen::Vector3d c = simulateInterior(TaskConfig::defaults("hanging"), cloud, {}).task.mass.com;
  const double hang = 17 * M_PI / 180, L = 0.03;
  const Eigen::Vector3d point = c + Eigen::Vector3d(0, -L * std::sin(hang), L * std::cos(hang));
  TaskConfig t = TaskConfig::defaults("hanging");
  t.setVector("hanging_point", point);
  t.set("swing_duration_s", "3");
  const ProblemEvaluation ev = simulateInterior(t, cloud, {});
  const double tilt = featureOf(ev, "tilt_deg"), sim = featureOf(ev, "swing_period_s");
  const double closed = featureOf(ev, "swing_period_closed_form_s");
  const Eigen::Quaterniond q0(Eigen::AngleAxisd(t.number("swing_tilt_deg") * M_PI / 180, Eigen::Vector3d::UnitX()));
  const double rk4 = rk4BallJointSwingPeriod(ev.task.mass, point, q0, Eigen::Vector3d(0, 0, -9.81), 3.0);
  std::printf(
      "[hanging] hung at %.2f deg roll, released at the target pose: simulated %.6f s, RK4 %.6f s (%+.3f %%), "
      "closed form %.6f s (%+.3f %% of the simulated)\n",
      tilt, sim, rk4, 100 * (sim - rk4) / rk4, closed, 100 * (closed - sim) / sim);
  EXPECT_NEAR(tilt, 17.0, 0.5);
  EXPECT_NEAR(sim, rk4, 1e-3 * rk4);
  ASSERT_TRUE(std::isfinite(closed));
  EXPECT_NEAR(closed, sim, 5e-3 * sim);
  EXPECT_NEAR(closed, rk4, 5e-3 * rk4);
}

// Hung 17 deg off across the pitch and released 3 deg about world x, the box swings out of any one plane
// (17 deg across its long side, 3 deg across the roll, the two coupled by its inertia): no pendulum
// closed form describes the swing, so none is given, and a note says why. The simulated swing still
// agrees with the RK4.
TEST(HangingSwing, NoClosedFormForASwingOutOfOnePlane) {
  const VolumeCloud cloud = topo_test::boxCloud(0.2, 0.1, 0.06, 0.008);
  const Eigen::Vector3d c = simulateInterior(TaskConfig::defaults("hanging"), cloud, {}).task.mass.com;
  const double hang = 17 * M_PI / 180, L = 0.03;
  const Eigen::Vector3d point = c + Eigen::Vector3d(L * std::sin(hang), 0, L * std::cos(hang));
  TaskConfig t = TaskConfig::defaults("hanging");
  t.setVector("hanging_point", point);
  t.set("swing_duration_s", "3");
  const InteriorProblem problem(t, cloud);
  const ProblemEvaluation ev = problem.evaluateIndicator(std::vector<double>(cloud.size(), 1.0), nullptr);
  const double sim = featureOf(ev, "swing_period_s");
  const Eigen::Quaterniond q0(Eigen::AngleAxisd(t.number("swing_tilt_deg") * M_PI / 180, Eigen::Vector3d::UnitX()));
  const double rk4 = rk4BallJointSwingPeriod(ev.task.mass, point, q0, Eigen::Vector3d(0, 0, -9.81), 3.0);
  std::string notes;
  for (const std::string& n : problem.notes()) notes += n + "\n";
  std::printf("[hanging] hung at %.2f deg pitch: simulated %.6f s, RK4 %.6f s (%+.3f %%); notes: %s",
              featureOf(ev, "tilt_deg"), sim, rk4, 100 * (sim - rk4) / rk4, notes.c_str());
  EXPECT_NEAR(sim, rk4, 2e-3 * rk4);
  EXPECT_TRUE(std::isnan(featureOf(ev, "swing_period_closed_form_s")));
  EXPECT_NE(notes.find("swing_period_closed_form_s is left out"), std::string::npos) << notes;
  EXPECT_NE(notes.find("swings out of that plane"), std::string::npos) << notes;
}

namespace {

// The number after `word` in `text` (NaN when the word is not there).
double numberAfter(const std::string& text, const std::string& word) {
  const std::size_t at = text.find(word);
  if (at == std::string::npos) return std::nan("");
  return std::strtod(text.c_str() + at + word.size(), nullptr);
}

}  // namespace

// A uniform ball (centre of mass at its centre) released with a spin about the rocking axis does not rock:
// it rolls away. Spun at w0 with no speed, it slips until it rolls: its angular momentum about the contact
// point is kept, (I + m R^2) w = I w0, so it rolls at v = (2/7) R w0 (a solid ball), reached after
// v / (mu g) s, then slows a little as the lattice's facets bump it. The refusal says it rolls away, with
// how far it rolled in how long: a full turn rolls it 2 pi R (the lattice's surface particles lie between
// R - one spacing and R from the centre), at a mean speed up to v.
TEST(TumblerPast90, ABallThatRollsAwayIsSaidToRollAway) {
  const double R = 0.05, h = 0.005, w0 = 20;
  TaskConfig c = TaskConfig::defaults("tumbler");
  c.setNumber("initial_angular_velocity_rad_s", w0);
  const std::string e = errorOf([&] { simulateInterior(c, topo_test::tumblerCloud(R, 1.0, h), {}); });
  const double rolled = numberAfter(e, "it rolled "), seconds = numberAfter(e, " m along the ground in ");
  const double turns = numberAfter(e, " s ("), v = 2.0 / 7.0 * R * w0;
  std::printf(
      "[tumbler] spun ball: %s\n[tumbler] rolled %.4f m in %.3f s (%.3g turns): %.4f m/s, rolling without "
      "slipping %.4f m/s\n",
      e.c_str(), rolled, seconds, turns, rolled / seconds, v);
  EXPECT_NE(e.find("rolls away"), std::string::npos) << e;
  EXPECT_EQ(e.find("falls over"), std::string::npos) << e;
  ASSERT_TRUE(std::isfinite(rolled) && seconds > 0 && turns > 0) << e;
  EXPECT_GT(rolled, 2 * R) << e;
  EXPECT_GT(rolled / turns, 2 * M_PI * (R - h)) << e;
  EXPECT_LT(rolled / turns, 2 * M_PI * R) << e;
  EXPECT_LT(rolled / seconds, v) << e;
  EXPECT_GT(rolled / seconds, 0.8 * v) << e;
  EXPECT_NE(e.find("initial_angular_velocity_rad_s"), std::string::npos) << e;
}

// A tall box (0.04 x 0.04 x 0.12 m, its centre of mass 6 cm up) released 30 deg about its bottom edge, past
// the 18.4 deg at which its centre of mass is over that edge, falls over onto its side: it comes to rest at
// 90 deg, having moved little along the ground (its centre of mass ends 2 cm up and at most one
// height beside where the edge was). The refusal says it falls over, with the angle it rests at.
TEST(TumblerPast90, ATallBoxTippedPastItsEdgeFallsOver) {
  const VolumeCloud box = topo_test::boxCloud(0.04, 0.04, 0.12, 0.005);
  TaskConfig c = TaskConfig::defaults("tumbler");
  c.set("initial_tilt_deg", "30");
  const std::string e = errorOf([&] { simulateInterior(c, box, {}); });
  const double rest = numberAfter(e, "comes to rest at "), moved = numberAfter(e, " deg, ");
  std::printf("[tumbler] tall box tipped 30 deg: %s\n", e.c_str());
  EXPECT_NE(e.find("falls over"), std::string::npos) << e;
  EXPECT_EQ(e.find("rolls away"), std::string::npos) << e;
  EXPECT_NEAR(rest, 90.0, 2.0) << e;
  EXPECT_LT(moved, 0.12) << e;
  EXPECT_NE(e.find("initial_tilt_deg"), std::string::npos) << e;
}

// A doll (a ball cut flat at half its radius, centre of mass below the ball's centre) spun at 20 rad/s tips
// just past 90 deg and rocks back: refused (its rocking leaves what the task measures), saying it rocks back
// and how far it still swings, not that it falls over or rolls away.
TEST(TumblerPast90, ADollSpunJustPast90RocksBack) {
  TaskConfig c = TaskConfig::defaults("tumbler");
  c.set("initial_angular_velocity_rad_s", "20");
  const std::string e = errorOf([&] { simulateInterior(c, topo_test::tumblerCloud(0.05, 0.5, 0.005), {}); });
  const double last = numberAfter(e, ", up to ");
  std::printf("[tumbler] doll spun at 20 rad/s: %s\n", e.c_str());
  EXPECT_NE(e.find("rocks back"), std::string::npos) << e;
  EXPECT_EQ(e.find("falls over"), std::string::npos) << e;
  EXPECT_EQ(e.find("rolls away"), std::string::npos) << e;
  EXPECT_GT(last, 10.0) << e;
  EXPECT_LT(last, 90.0) << e;
}
