// The pear task's ground contact on the object's true surface (issue 15 §1): the default pear's
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
#include <gtest/gtest.h>

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
