// The pear task's ground contact on the object's true surface: the default pear's
// contact samples (points of the exact surface) embedded in the particles, against the old contact
// on the surface particles (the lattice staircase, the same cloud with its samples removed).
//  - At rest on the ground the lowest point of the true surface is within the resting penetration of
//    z = 0: at most the penetration of a rigid round bottom on the penalty foundation (Winkler,
//    closed form below), and above z = 0 never. The staircase rests on its lowest particles, whose
//    distance above the true bottom (here half a spacing) is how far the true surface sinks in.
//  - A drop bounces: the rebound height of the centre (its rise after the impact over the drop
//    height) is printed for both contact models; the embedded pear rebounds, and no higher than it fell.
//  - The same with samples as fine as `topo fill` makes them (0.8 mm), which the task merges to h/2.
//  - Without contact samples the task says so (a note naming the staircase and `topo fill`).
//  - The finger pressing against a rigid plane (obstacle plane) stops with its true surface at the
//    plane; the staircase lets its skin through by the particles' depth under it. The gradient with
//    the plane touched against central differences; bad obstacle input named.
#include <gtest/gtest.h>

#include "test_clouds.h"

#include <chrono>
#include <cmath>
#include <cstdio>

#include "topo_gaussian/inference/task.h"
#include "topo_gaussian/physics/default_shapes.h"
#include "user_path_helpers.h"

using namespace topo_gaussian;
using namespace topo_gaussian::inference;
using topo_test::feature;

namespace {

constexpr double kSpacing = 0.008;

VolumeCloud staircase(VolumeCloud c) {
  c.contact = ContactSamples();
  return c;
}

/// The same cloud with samples as fine as `topo fill` makes them (0.8 mm; the task merges them to h/2).
VolumeCloud fineSamples(VolumeCloud c) {
  c.contact = shapeContactSamples(defaultShape("pear"), 0.0008);
  return c;
}

double lowestParticleZ(const VolumeCloud& c) {
  double z = 1e300;
  for (const auto& p : c.X) z = std::min(z, p.z());
  return z;
}

}  // namespace

TEST(SoftContactTask, PearRestsOnItsTrueBottom) {
  const VolumeCloud embedded = defaultShapeCloud("pear", kSpacing);
  const VolumeCloud stairs = staircase(embedded);
  TaskConfig c = TaskConfig::defaults("pear");
  c.set("initial_height_m", "0");
  c.set("initial_tilt_deg", "0");
  c.set("duration_s", "0.4");
  c.set("damping_per_s", "40");  // settles the bounce of the release
  c.set("friction_mu", "0");
  const std::vector<double> r(embedded.size(), 1.0);  // uniform E = youngs_modulus_solid
  const TaskEvaluation ev = makeTask(c, embedded)->evaluate(r, nullptr);
  const TaskEvaluation es = makeTask(c, stairs)->evaluate(r, nullptr);
  const TaskEvaluation ef = makeTask(c, fineSamples(embedded))->evaluate(r, nullptr);
  // The true bottom (z = 0 at rest) of the staircase pear: its lowest particle sits this far above it.
  const double offset = lowestParticleZ(embedded);
  const double bottom_embedded = feature(ev, "final_lowest_contact_z_m");
  const double bottom_stairs = feature(es, "final_lowest_contact_z_m") - offset;
  const double bottom_fine = feature(ef, "final_lowest_contact_z_m");
  // Winkler foundation under a rigid sphere of radius R (the bulb's pole): stiffness k per h² of
  // surface, force k/h² ∫ (d − ρ²/2R) 2πρ dρ = π R k d²/h² = m g → d = √(m g h²/(π R k)); the
  // elastic flattening of the soft bottom spreads the load, so the penetration is at most this.
  const double E = c.number("youngs_modulus_solid"), nu = c.number("poisson_ratio");
  const double k = E * (1 - nu) / ((1 + nu) * (1 - 2 * nu)) * kSpacing;  // automatic: (λ + 2μ) h
  const double m = ev.mass.mass, R = default_shape_dims::kPearBulbRadius;
  const double d_winkler = std::sqrt(m * 9.81 * kSpacing * kSpacing / (M_PI * R * k));
  std::printf(
      "[pear rest] h = %.0f mm, %.0f contact samples: true bottom at %+.3f mm (rigid Winkler penetration %.3f mm); "
      "staircase (%.0f surface particles, lowest %.1f mm above the true bottom): true bottom at %+.3f mm\n",
      kSpacing * 1e3, feature(ev, "contact_points"), bottom_embedded * 1e3, d_winkler * 1e3,
      feature(es, "contact_points"), offset * 1e3, bottom_stairs * 1e3);
  std::printf("[pear rest] 0.8 mm samples merged to %.0f: true bottom at %+.3f mm\n", feature(ef, "contact_points"),
              bottom_fine * 1e3);
  EXPECT_GT(feature(ev, "contact_points"), 1000.0);
  EXPECT_LT(bottom_embedded, 0.0);  // it carries the weight, so it penetrates
  EXPECT_GT(bottom_embedded, -d_winkler);
  EXPECT_LT(bottom_fine, 0.0);
  EXPECT_GT(bottom_fine, -d_winkler);
  // The staircase sinks the true surface by about its offset (reported; > 5 Winkler penetrations).
  EXPECT_LT(bottom_stairs, -5.0 * d_winkler);
}

TEST(SoftContactTask, PearDropBouncesOnItsTrueSurface) {
  const VolumeCloud embedded = defaultShapeCloud("pear", kSpacing);
  const VolumeCloud stairs = staircase(embedded);
  const double drop = 0.03;
  TaskConfig c = TaskConfig::defaults("pear");
  c.setNumber("initial_height_m", drop);
  c.set("initial_tilt_deg", "0");
  c.set("duration_s", "0.2");
  c.set("sample_dt_s", "0.0005");
  const Eigen::Vector3d centre = embedded.centroid();
  c.setList("pivot_points", {centre.x(), centre.y(), centre.z()});
  const std::vector<double> r(embedded.size(), 1.0);
  const VolumeCloud fine = fineSamples(embedded);
  double rebound[3] = {0, 0, 0};
  const char* names[3] = {"true surface (embedded samples)", "staircase (surface particles)",
                          "true surface (0.8 mm samples, merged)"};
  for (int model = 0; model < 3; ++model) {
    const auto task = makeTask(c, model == 0 ? embedded : model == 1 ? stairs : fine);
    const auto t0 = std::chrono::steady_clock::now();
    const TaskEvaluation ev = task->evaluate(r, nullptr);
    const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const auto& rows = ev.trajectory_rows;
    ASSERT_GT(rows.size(), 100u);
    // The impact: the lowest centre height; the rebound: the highest after it.
    std::size_t lo = 0;
    for (std::size_t j = 1; j < rows.size(); ++j)
      if (rows[j][3] < rows[lo][3]) lo = j;
    // First local minimum (the first impact), not a later one.
    for (std::size_t j = 1; j + 1 < rows.size(); ++j)
      if (rows[j][3] <= rows[j - 1][3] && rows[j][3] < rows[j + 1][3] && rows[0][3] - rows[j][3] > 0.5 * drop) {
        lo = j;
        break;
      }
    double top = rows[lo][3];
    for (std::size_t j = lo; j < rows.size(); ++j) top = std::max(top, rows[j][3]);
    const double touch = rows[0][3] - drop;  // centre height when the lowest point touches z = 0
    rebound[model] = (top - touch) / drop;
    std::printf(
        "[pear drop %s] dropped %.0f mm: impact at t = %.4f s, centre %.2f mm below touch-down; rebound %.1f mm "
        "(%.2f of the drop); %.0f steps in %.2f s\n",
        names[model], drop * 1e3, rows[lo][0], (touch - rows[lo][3]) * 1e3, (top - touch) * 1e3, rebound[model],
        feature(ev, "steps"), secs);
  }
  for (int model : {0, 2}) {
    EXPECT_GT(rebound[model], 0.1);   // it bounces
    EXPECT_LT(rebound[model], 1.02);  // and gains no energy (conservative penalty, symplectic steps)
  }
}

TEST(SoftContactTask, WithoutContactSamplesTheTaskSaysSo) {
  const VolumeCloud embedded = defaultShapeCloud("pear", 0.012);
  const TaskConfig c = TaskConfig::defaults("pear");
  EXPECT_TRUE(makeTask(c, embedded)->notes().empty());
  const auto task = makeTask(c, staircase(embedded));
  ASSERT_EQ(task->notes().size(), 1u);
  const std::string& n = task->notes()[0];
  EXPECT_NE(n.find("no contact samples"), std::string::npos) << n;
  EXPECT_NE(n.find("staircase"), std::string::npos) << n;
  EXPECT_NE(n.find("topo fill"), std::string::npos) << n;
}

// The finger pressing against a rigid plane (finger task, obstacle plane): the chamber below the axis
// turns the tip towards +z; a plane above the tip's top, 40 % of the free tip displacement away,
// stops it. With the contact samples embedded the true surface stops at the plane (penetration of
// the penalty only: below a µm, against the spacing of 4 mm); the staircase's surface particles lie
// 1.5 mm inside the skin and stop at the plane, so its skin passes through the plane by that much and
// the finger bends further. A plane out of reach leaves the bend exactly as it was.
namespace {

/// The default finger, its walls at 1 MPa (as soft as its chamber) so that it bends by degrees.
TaskConfig softFinger() {
  TaskConfig c = TaskConfig::defaults("finger");
  c.setNumber("youngs_modulus_solid", 1e6);
  return c;
}

TaskConfig fingerAgainstPlane(double plane_z, TaskConfig c = softFinger()) {
  c.set("obstacle", "plane");
  c.setList("obstacle_point", {0.1, 0.0, plane_z});
  c.setList("obstacle_normal", {0.0, 0.0, -1.0});
  return c;
}

}  // namespace

TEST(SoftContactTask, FingerStopsAtTheObstacleOnItsTrueSurface) {
  const double h = 0.004;
  const VolumeCloud embedded = defaultShapeCloud("finger", h);
  const VolumeCloud stairs = staircase(embedded);
  ASSERT_FALSE(embedded.contact.empty());
  const std::vector<double> r = topo_test::fingerChamberBelowAxis(embedded);
  const TaskEvaluation free = makeTask(softFinger(), embedded)->evaluate(r, nullptr);
  const double bend_free = feature(free, "bend_angle_deg"), tip_free = feature(free, "tip_displacement_m");
  ASSERT_GT(bend_free, 0.1);
  double top_true = -1e300, top_particles = -1e300;
  for (const auto& y : embedded.contact.X) top_true = std::max(top_true, y.z());
  for (std::size_t i = 0; i < embedded.size(); ++i)
    if (embedded.surface[i]) top_particles = std::max(top_particles, embedded.X[i].z());
  const double gap = 0.4 * tip_free, plane = top_true + gap;
  const TaskEvaluation et = makeTask(fingerAgainstPlane(plane), embedded)->evaluate(r, nullptr);
  const TaskEvaluation es = makeTask(fingerAgainstPlane(plane), stairs)->evaluate(r, nullptr);
  const double clear_true = feature(et, "obstacle_clearance_m");
  // The staircase's skin: its particles' clearance less the particles' depth under the skin.
  const double offset = top_true - top_particles, clear_stairs = feature(es, "obstacle_clearance_m") - offset;
  std::printf(
      "[finger plane] h = %.0f mm, free bend %.4f deg, tip moved %.3f mm; plane %.3f mm above the top: true surface "
      "bend %.4f deg, clearance %+.2f um (%.0f samples touching); staircase (particles %.2f mm under the skin) bend "
      "%.4f deg, skin clearance %+.4f mm\n",
      h * 1e3, bend_free, tip_free * 1e3, gap * 1e3, feature(et, "bend_angle_deg"), clear_true * 1e6,
      feature(et, "obstacle_contact_points"), offset * 1e3, feature(es, "bend_angle_deg"), clear_stairs * 1e3);
  // True surface: stopped at the plane, within the penalty's penetration.
  EXPECT_GT(feature(et, "obstacle_contact_points"), 0.0);
  EXPECT_LT(clear_true, 0.0);
  EXPECT_GT(clear_true, -0.01 * h);
  EXPECT_LT(feature(et, "bend_angle_deg"), 0.8 * bend_free);
  // Staircase: its surface particles stop at the plane, so its skin passes through it by their depth
  // under the skin, and the finger bends further.
  EXPECT_GT(feature(es, "obstacle_contact_points"), 0.0);
  EXPECT_LT(clear_stairs, -0.9 * offset);
  EXPECT_GT(feature(es, "bend_angle_deg"), 1.1 * feature(et, "bend_angle_deg"));
  // Out of reach: the bend is the free one.
  const TaskEvaluation far = makeTask(fingerAgainstPlane(top_true + 0.01), embedded)->evaluate(r, nullptr);
  EXPECT_EQ(feature(far, "obstacle_contact_points"), 0.0);
  EXPECT_NEAR(feature(far, "bend_angle_deg"), bend_free, 1e-9 * bend_free);
}

// dL/dr of the finger pressed against the plane (the static equilibrium with the contact's Hessian
// and its adjoint) against central differences.
TEST(SoftContactTask, FingerAgainstThePlaneGradientMatchesFiniteDifferences) {
  const VolumeCloud cloud = defaultShapeCloud("finger", 0.004);
  std::vector<double> r = topo_test::fingerChamberBelowAxis(cloud);
  // the paper's walls (E 1e7): a grey design with the softer walls (1e6) bends too far for a tight solve
  const TaskEvaluation free = makeTask(TaskConfig::defaults("finger"), cloud)->evaluate(r, nullptr);
  double top = -1e300;
  for (const auto& y : cloud.contact.X) top = std::max(top, y.z());
  TaskConfig c = fingerAgainstPlane(top + 0.4 * feature(free, "tip_displacement_m"), TaskConfig::defaults("finger"));
  c.setNumber("bend_angle_deg", 25.0);
  c.setNumber("newton_tolerance", 1e-12);
  for (std::size_t i = 0; i < r.size(); ++i) r[i] = 0.3 + 0.4 * r[i] + 0.05 * std::sin(3.0 * i);
  const auto task = makeTask(c, cloud);
  std::vector<double> g;
  const TaskEvaluation ev = task->evaluate(r, &g);
  ASSERT_GT(feature(ev, "obstacle_contact_points"), 0.0) << "the plane must be touched for this check";
  double gmax = 0.0;
  for (double v : g) gmax = std::max(gmax, std::abs(v));
  const std::size_t n = cloud.size();
  for (std::size_t i : {n / 3, n / 2, (2 * n) / 3, n - 5}) {
    const double step = 1e-4;
    auto rp = r, rm = r;
    rp[i] += step;
    rm[i] -= step;
    const double fd = (task->evaluate(rp, nullptr).loss - task->evaluate(rm, nullptr).loss) / (2 * step);
    const double rel = std::abs(fd - g[i]) / std::max(std::abs(fd), 1e-3 * gmax);
    std::printf("[finger plane fd] r_%zu: adjoint %.8g fd %.8g rel %.2g\n", i, g[i], fd, rel);
    EXPECT_LT(rel, 1e-4) << "particle " << i;
  }
}

// The finger against the plane in implicit mode (implicit Euler over a 0.5 s pressure ramp, 10 ms
// steps, where obstacle friction applies): frictionless, the ramp ends where the static equilibrium
// does; with friction (mu 1) the skin's samples on the plane cannot slide freely, and it still stops at
// the plane.
TEST(SoftContactTask, FingerAgainstThePlaneInImplicitMode) {
  const double h = 0.004;
  const VolumeCloud cloud = defaultShapeCloud("finger", h);
  const std::vector<double> r = topo_test::fingerChamberBelowAxis(cloud);
  const TaskEvaluation free = makeTask(softFinger(), cloud)->evaluate(r, nullptr);
  double top = -1e300;
  for (const auto& y : cloud.contact.X) top = std::max(top, y.z());
  const double plane = top + 0.4 * feature(free, "tip_displacement_m");
  const TaskEvaluation st = makeTask(fingerAgainstPlane(plane), cloud)->evaluate(r, nullptr);
  auto implicitRun = [&](double mu, const char* duration) {
    TaskConfig c = fingerAgainstPlane(plane);
    c.set("mode", "implicit");
    c.set("duration_s", duration);
    c.set("dt_s", "0.01");
    c.setNumber("friction_mu", mu);
    return makeTask(c, cloud)->evaluate(r, nullptr);
  };
  const TaskEvaluation im0 = implicitRun(0.0, "0.5"), im1 = implicitRun(1.0, "0.5");
  std::printf(
      "[finger plane implicit] ramp 0.5 s: static bend %.5f deg, clearance %+.3f um; implicit mu 0: bend "
      "%.5f deg, clearance %+.3f um, %g touching; mu 1: bend %.5f deg, clearance %+.3f um, %g touching\n",
      feature(st, "bend_angle_deg"), feature(st, "obstacle_clearance_m") * 1e6, feature(im0, "bend_angle_deg"),
      feature(im0, "obstacle_clearance_m") * 1e6, feature(im0, "obstacle_contact_points"),
      feature(im1, "bend_angle_deg"), feature(im1, "obstacle_clearance_m") * 1e6,
      feature(im1, "obstacle_contact_points"));
  // Frictionless: the slow ramp ends in the static equilibrium (measured: equal to 5 digits).
  EXPECT_NEAR(feature(im0, "bend_angle_deg"), feature(st, "bend_angle_deg"), 1e-3 * feature(st, "bend_angle_deg"));
  EXPECT_NEAR(feature(im0, "obstacle_clearance_m"), feature(st, "obstacle_clearance_m"), 0.05 * 5.28e-6);
  EXPECT_EQ(feature(im0, "obstacle_contact_points"), feature(st, "obstacle_contact_points"));
  // With friction it still stops at the plane (penalty penetration only), and friction changes the
  // outcome (measured: bend +0.5 %, 5 samples in contact instead of 10).
  for (const TaskEvaluation* e : {&im0, &im1}) {
    EXPECT_LT(feature(*e, "obstacle_clearance_m"), 0.0);
    EXPECT_GT(feature(*e, "obstacle_clearance_m"), -0.01 * h);
    EXPECT_GT(feature(*e, "obstacle_contact_points"), 0.0);
    EXPECT_LT(feature(*e, "bend_angle_deg"), 0.8 * feature(free, "bend_angle_deg"));
  }
  EXPECT_GT(std::abs(feature(im1, "bend_angle_deg") - feature(im0, "bend_angle_deg")),
            1e-3 * feature(im0, "bend_angle_deg"));
}

TEST(SoftContactTask, FingerObstacleBadInputIsNamed) {
  const VolumeCloud cloud = defaultShapeCloud("finger", 0.004);
  TaskConfig c = TaskConfig::defaults("finger");
  c.set("obstacle", "plane");
  auto message = [&](const TaskConfig& cfg) {
    try {
      makeTask(cfg, cloud);
    } catch (const std::exception& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  const std::string no_point = message(c);
  EXPECT_NE(no_point.find("obstacle_point"), std::string::npos) << no_point;
  c.setList("obstacle_point", {0.05, 0.0, 0.0});  // through the finger's middle
  const std::string through = message(c);
  EXPECT_NE(through.find("past the plane"), std::string::npos) << through;
  c.setList("obstacle_point", {0.05, 0.0, 0.02});
  c.setList("obstacle_normal", {0.0, 0.0, 0.0});
  const std::string zero = message(c);
  EXPECT_NE(zero.find("obstacle_normal"), std::string::npos) << zero;
}
