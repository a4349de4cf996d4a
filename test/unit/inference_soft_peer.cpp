// Soft bodies on the user path held to a FEM peer (DESIGN.md "Physics"): a beam mesh
// filled by the library's fillInterior (default options, the spacing `topo fill --spacing` gives),
// simulated by the cantilever task with its defaults, against CalculiX with quadratic tetrahedra
// (C3D10, calculix_peer.h) on the same box, material and clamp. The clamp: the task clamps the
// particles of the first clamp_length_m (3 spacings) of the beam, i.e. the cells they fill, so the
// peer fixes every node with x ≤ box min + 3 spacings. Ours: tip deflection (end layer extrapolated
// to the end face) and first frequency (inverse iteration); CalculiX: mean z displacement of the
// end face and *FREQUENCY's first eigenfrequency. The peer mesh (4 mm cells across, the spacing along
// x) is converged: halving its cells changes tip and frequency by < 0.1 % (0.2 × 0.02 × 0.02 m beam).
// Tests skip (with the reason) only when ccx is not installed.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>

#include "peer_world/calculix_peer.h"
#include "topo_gaussian/geometry/interior_fill.h"
#include "topo_gaussian/geometry/shape_generator.h"
#include "topo_gaussian/inference/task.h"
#include "topo_gaussian/inference/task_config.h"
#include "user_path_helpers.h"

using namespace topo_gaussian;
using namespace topo_gaussian::inference;
using topo_test::feature;

namespace {

struct Beam {
  double length_m, width_m, thickness_m;  ///< along x, y, z (gravity −z)
  double youngs_modulus_pa, density_kg_m3 = 1000.0, poisson_ratio = 0.3;
};

struct CantileverResult {
  double tip_m = NAN, frequency_hz = NAN, seconds = 0;
  int newton_iterations = -1;
  std::size_t particles = 0;
  TaskEvaluation evaluation;  ///< ours: every feature the task printed
  std::string said;           ///< ours: what the task wrote to stderr while built and evaluated
};

/// Ours: makeBox → fillInterior (default options, spacing) → cantilever task (defaults, no
/// vibration run; clamp_length_m when given) with r = 1.
CantileverResult ours(const Beam& b, double spacing_m, std::size_t target_count = 0, double clamp_m = 0) {
  geometry::SurfaceData box = geometry::makeBox(Eigen::Vector3d(b.length_m, b.width_m, b.thickness_m));
  for (auto& p : box.points) p.x() += 0.5 * b.length_m;  // x ∈ [0, L]
  geometry::FillOptions fo;
  fo.spacing_m = spacing_m;
  fo.contact.enabled = false;  // the cantilever has no contact: its samples would only cost the fill's time
  if (target_count) fo.target_count = target_count;
  const VolumeCloud cloud = geometry::fillInterior(box, fo);
  TaskConfig c = TaskConfig::defaults("cantilever");
  c.setNumber("youngs_modulus", b.youngs_modulus_pa);
  c.setNumber("density", b.density_kg_m3);
  c.setNumber("poisson_ratio", b.poisson_ratio);
  c.set("vibration", "false");
  if (clamp_m > 0) c.setNumber("clamp_length_m", clamp_m);
  const auto t0 = std::chrono::steady_clock::now();
  testing::internal::CaptureStderr();
  const auto task = makeTask(c, cloud);
  const TaskEvaluation ev = task->evaluate(std::vector<double>(cloud.size(), 1.0), nullptr);
  CantileverResult r;
  r.said = testing::internal::GetCapturedStderr();
  r.evaluation = ev;
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  r.tip_m = feature(ev, "tip_deflection_m");
  r.frequency_hz = feature(ev, "modal_frequency_hz");
  r.newton_iterations = static_cast<int>(feature(ev, "newton_iterations"));
  r.particles = cloud.size();
  return r;
}

/// CalculiX on the same box, clamped over x ≤ clamp_m; cells of about cell_m across, `along` cells
/// along x (a multiple that puts a node plane on the clamp).
CantileverResult calculix(const Beam& b, double clamp_m, int along, int across_y, int across_z, bool frequency = true) {
  using namespace calculix_peer;
  const auto g = VoxelGeometry::box({0.0, -0.5 * b.width_m, -0.5 * b.thickness_m},
                                    {b.length_m, 0.5 * b.width_m, 0.5 * b.thickness_m}, along, across_y, across_z);
  const TetMesh m = meshVoxels(g);
  Material mat;
  mat.youngs_modulus_pa = b.youngs_modulus_pa;
  mat.poisson_ratio = b.poisson_ratio;
  mat.density_kg_m3 = b.density_kg_m3;
  CantileverResult r;
  const auto t0 = std::chrono::steady_clock::now();
  const Result s = staticSolve(m, mat, clamp_m, Load());
  r.tip_m = -meanDisplacement(m, s, b.length_m, 2);
  if (frequency) r.frequency_hz = firstFrequency(m, mat, clamp_m);
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

#define REQUIRE_CALCULIX()                                    \
  do {                                                        \
    std::string why;                                          \
    if (!calculix_peer::available(&why)) GTEST_SKIP() << why; \
  } while (0)

}  // namespace

// The curve: 4, 5, 6 and 8 particles through the 0.02 m thickness (spacing 5, 4, 3.33, 2.5 mm).
// Goal: within 5 % of CalculiX at 4 particles through the thinnest dimension, and
// converging with refinement.
TEST(SoftPeer, CantileverMatchesCalculixOnAFilledBeam) {
  REQUIRE_CALCULIX();
  const Beam b{0.2, 0.02, 0.02, 1e7};
  const int layers[] = {4, 5, 6, 8};
  double prev_tip_err = INFINITY;
  for (int k : layers) {
    const double s = b.thickness_m / k;
    const CantileverResult o = ours(b, s);
    const int along = static_cast<int>(std::lround(b.length_m / s));
    const CantileverResult p = calculix(b, 3.0 * s, along, 5, 5);
    const double e_tip = o.tip_m / p.tip_m - 1.0, e_f = o.frequency_hz / p.frequency_hz - 1.0;
    std::printf(
        "[cantilever %d/thickness, spacing %.4g m, %zu particles] tip ours %.5e m, CalculiX %.5e m, error %+.2f %% | "
        "f1 ours %.4f Hz, CalculiX %.4f Hz, error %+.2f %% | Newton %d it, %.1f s (ccx %.1f s)\n",
        k, s, o.particles, o.tip_m, p.tip_m, 100 * e_tip, o.frequency_hz, p.frequency_hz, 100 * e_f,
        o.newton_iterations, o.seconds, p.seconds);
    EXPECT_LT(std::abs(e_tip), 0.05) << k << " particles through the thickness";
    EXPECT_LT(std::abs(e_f), 0.05) << k << " particles through the thickness";
    EXPECT_LT(std::abs(e_tip), prev_tip_err + 0.005) << "refinement does not converge";
    prev_tip_err = std::abs(e_tip);
  }
}

// A user-filled 0.5 × 0.04 × 0.04 m beam (topo fill --count 12000, E 1e8), a linear problem with a
// 6 mm tip deflection: a fixed tolerance 1e-8 of the per-particle load is below the gradient's
// round-off floor (about 3e-6 of it here), so Newton never met it. Must converge in a few Newton
// iterations and match Euler–Bernoulli over the task's free length (CalculiX agrees with it within
// 0.2 % on the 0.2 m beam of the same slenderness class; the peer itself is checked above).
TEST(SoftPeer, StiffLongBeamStaticSolveConverges) {
  const Beam b{0.5, 0.04, 0.04, 1e8};
  geometry::SurfaceData box = geometry::makeBox(Eigen::Vector3d(b.length_m, b.width_m, b.thickness_m));
  geometry::FillOptions fo;
  fo.target_count = 12000;
  const VolumeCloud cloud = geometry::fillInterior(box, fo);
  TaskConfig c = TaskConfig::defaults("cantilever");
  c.setNumber("youngs_modulus", b.youngs_modulus_pa);
  c.set("vibration", "false");
  const auto t0 = std::chrono::steady_clock::now();
  const TaskEvaluation ev = makeTask(c, cloud)->evaluate(std::vector<double>(cloud.size(), 1.0), nullptr);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double tip = feature(ev, "tip_deflection_m"), theory = feature(ev, "tip_deflection_euler_bernoulli_m");
  const double f = feature(ev, "modal_frequency_hz"), f_theory = feature(ev, "first_frequency_theory_hz");
  std::printf(
      "[0.5 m beam, %zu particles, spacing %.4g m] tip %.5e m vs Euler-Bernoulli %.5e m (%+.2f %%), f1 %.4f "
      "vs %.4f Hz (%+.2f %%), Newton %d iterations, %.1f s\n",
      cloud.size(), cloud.spacing, tip, theory, 100 * (tip / theory - 1), f, f_theory, 100 * (f / f_theory - 1),
      static_cast<int>(feature(ev, "newton_iterations")), seconds);
  EXPECT_LE(feature(ev, "newton_iterations"), 12);
  EXPECT_NEAR(tip / theory, 1.0, 0.05);
  EXPECT_NEAR(f / f_theory, 1.0, 0.05);
}

// Below 4 particles through the thinnest dimension the cantilever is not held to 5 % of CalculiX:
// the task says so when it starts and names the spacing that would be (here 0.02 m / 4 = 0.005 m).
TEST(SoftPeer, CantileverWarnsWhenTooCoarseToBeHeldToFivePercent) {
  geometry::SurfaceData box = geometry::makeBox(Eigen::Vector3d(0.2, 0.02, 0.02));
  for (const double spacing : {0.02 / 3.0, 0.005}) {
    geometry::FillOptions fo;
    fo.spacing_m = spacing;
    const VolumeCloud cloud = geometry::fillInterior(box, fo);
    testing::internal::CaptureStderr();
    makeTask(TaskConfig::defaults("cantilever"), cloud);
    const std::string err = testing::internal::GetCapturedStderr();
    if (spacing > 0.006) {
      EXPECT_NE(err.find("[cantilever] warning"), std::string::npos) << err;
      EXPECT_NE(err.find("--spacing 0.005"), std::string::npos) << err;
    } else {
      EXPECT_EQ(err.find("[cantilever] warning"), std::string::npos) << err;
    }
  }
}

namespace {

/// CalculiX's tip deflection on cells `cell_m` along x and `across` cells across (linear, clamp x ≤ clamp_m).
double calculixTip(const Beam& b, double clamp_m, double cell_m, int across) {
  const int along = static_cast<int>(std::lround(b.length_m / cell_m));
  return calculix(b, clamp_m, along, across, across, false).tip_m;
}

/// The task's own words on its accuracy: it warns of a bias it measured where it is not held within
/// 5 % of CalculiX, so where it says nothing the tip must be within 5 % (e: ours / CalculiX − 1).
void expectNoOverclaim(const CantileverResult& o, double e, const std::string& what) {
  const bool warned = o.said.find("comes out too small") != std::string::npos;
  if (!warned)
    EXPECT_LT(std::abs(e), 0.05) << what << ": off by more than 5 % and the task does not say so\n" << o.said;
  if (warned) {
    EXPECT_LT(e, 0.0) << what << ": the task says too small\n" << o.said;
    EXPECT_NE(o.said.find("tip_deflection_timoshenko_m"), std::string::npos) << o.said;
  }
}

}  // namespace

// A short thick beam (free length 2.5 × its thickness), where shear carries a tenth of the tip
// deflection: 0.12 × 0.04 × 0.04 m, E 1e6, ν 0.3, clamped over its first 0.02 m, under gravity.
// The peer: CalculiX C3D10 on cells 5 mm along x, 8 mm across (measured: 0.23 % below 2.5 × 4 × 4 mm
// cells with NLGEOM, 1.0383 mm, which further refinement moves < 0.1 %; NLGEOM alone < 0.01 %). Ours
// at 4 and 8 particles through the thickness, clamp_length_m a whole number of layers at both, and
// at 4 with the default clamp (3 spacings). Printed beside the result must be true: the
// Euler–Bernoulli value is named so, and the Timoshenko value (shear coefficient 10(1+ν)/(12+11ν) of
// a rectangle) is the formula over the task's free length and close to CalculiX where
// Euler–Bernoulli is not. The task's tip is not within 5 % here: it must say so.
TEST(SoftPeer, ThickCantileverAgainstCalculixAndTimoshenko) {
  REQUIRE_CALCULIX();
  const Beam b{0.12, 0.04, 0.04, 1e6};
  struct Case {
    int layers;
    double clamp_m;  ///< 0: the task's default, 3 spacings
  };
  double peer_clamp = NAN, peer_tip = NAN;  // one CalculiX run per clamp
  for (const Case c : {Case{4, 0.02}, Case{8, 0.02}, Case{4, 0.0}}) {
    const double s = b.thickness_m / c.layers;
    const CantileverResult o = ours(b, s, 0, c.clamp_m);
    const double clamp = c.clamp_m > 0 ? c.clamp_m : 3 * s;
    if (clamp != peer_clamp) peer_tip = calculixTip(b, peer_clamp = clamp, 0.005, 5);
    const double L = feature(o.evaluation, "free_length_m");
    const double eb = feature(o.evaluation, "tip_deflection_euler_bernoulli_m");
    const double tim = feature(o.evaluation, "tip_deflection_timoshenko_m");
    const double nu = b.poisson_ratio, E = b.youngs_modulus_pa, G = E / (2 * (1 + nu));
    const double A = b.width_m * b.thickness_m, I = b.width_m * std::pow(b.thickness_m, 3) / 12;
    const double q = b.density_kg_m3 * 9.81 * A, kappa = 10 * (1 + nu) / (12 + 11 * nu);
    const double eb_formula = q * std::pow(L, 4) / (8 * E * I);
    const double tim_formula = eb_formula + q * L * L / (2 * kappa * G * A);
    const double e_ours = o.tip_m / peer_tip - 1, e_eb = eb / peer_tip - 1, e_tim = tim / peer_tip - 1;
    std::printf(
        "[thick cantilever %d/thickness, clamp %.3g m, %zu particles] tip ours %.5e m, CalculiX %.5e m: ours %+.2f "
        "%%, Euler-Bernoulli %+.2f %%, Timoshenko %+.2f %% | %.1f s\n",
        c.layers, clamp, o.particles, o.tip_m, peer_tip, 100 * e_ours, 100 * e_eb, 100 * e_tim, o.seconds);
    EXPECT_NEAR(L, b.length_m - clamp, 1e-6);
    EXPECT_NEAR(eb / eb_formula, 1.0, 1e-9);
    EXPECT_NEAR(tim / tim_formula, 1.0, 1e-9);
    EXPECT_LT(std::abs(e_tim), 0.05) << "Timoshenko against CalculiX";
    EXPECT_GT(std::abs(e_eb), 0.08) << "the shear this beam is chosen for";
    expectNoOverclaim(o, e_ours, "thick beam");
  }
}

// Where the task claims 5 % on a stubby beam: free length 4.5 × the thickness (0.2 × 0.04 × 0.04 m,
// clamp 0.02 m), 4 and 8 particles through, against CalculiX on cells 5 mm along x, 8 mm across.
TEST(SoftPeer, StubbyCantileverHeldWhereTheTaskClaimsIt) {
  REQUIRE_CALCULIX();
  const Beam b{0.2, 0.04, 0.04, 1e6};
  const double peer_tip = calculixTip(b, 0.02, 0.005, 5);
  for (int k : {4, 8}) {
    const CantileverResult o = ours(b, b.thickness_m / k, 0, 0.02);
    const double e = o.tip_m / peer_tip - 1;
    std::printf("[stubby cantilever %d/thickness, %zu particles] tip ours %.5e m, CalculiX %.5e m: %+.2f %% | %.1f s\n",
                k, o.particles, o.tip_m, peer_tip, 100 * e, o.seconds);
    expectNoOverclaim(o, e, "stubby beam");
  }
}

// clamp_length_m 0.02 at 8 mm spacing is 2.5 particle layers: the clamp holds whole layers, says how
// many and how long, and free_length_m and the beam theories (Euler–Bernoulli; Timoshenko with the
// rectangle's shear coefficient 10(1+ν)/(12+11ν)) use that length; a whole number of layers (0.016 m)
// is not remarked on.
TEST(SoftPeer, CantileverSaysTheClampedLengthAndUsesIt) {
  const Beam b{0.12, 0.04, 0.04, 1e6};
  for (const double asked : {0.02, 0.016}) {
    const CantileverResult o = ours(b, 0.008, 0, asked);
    const double clamped = feature(o.evaluation, "clamped_length_m");
    const double layers = clamped / 0.008;
    std::printf("[clamp_length_m %.3g at 8 mm] clamped %.4g m (%.3g layers), free %.4g m\n", asked, clamped, layers,
                feature(o.evaluation, "free_length_m"));
    EXPECT_NEAR(layers, std::round(layers), 1e-6);
    EXPECT_LE(std::abs(clamped - asked), 0.5 * 0.008 + 1e-9);
    EXPECT_NEAR(feature(o.evaluation, "free_length_m"), b.length_m - clamped, 1e-6);
    const double L = b.length_m - clamped, E = b.youngs_modulus_pa, A = b.width_m * b.thickness_m, nu = b.poisson_ratio;
    const double q = b.density_kg_m3 * 9.81 * A, I = b.width_m * std::pow(b.thickness_m, 3) / 12;
    const double eb = q * std::pow(L, 4) / (8 * E * I);
    const double timoshenko = eb + q * L * L / (2 * 10 * (1 + nu) / (12 + 11 * nu) * E / (2 * (1 + nu)) * A);
    EXPECT_NEAR(feature(o.evaluation, "tip_deflection_euler_bernoulli_m") / eb, 1.0, 1e-6);
    EXPECT_NEAR(feature(o.evaluation, "tip_deflection_timoshenko_m") / timoshenko, 1.0, 1e-6);
    const bool differs = std::abs(clamped - asked) > 1e-6;
    const bool said =
        o.said.find("clamp_length_m") != std::string::npos && o.said.find("[cantilever] warning") != std::string::npos;
    EXPECT_EQ(said, differs) << o.said;
    if (differs) {
      char text[32];
      std::snprintf(text, sizeof text, "%.3g m", clamped);
      EXPECT_NE(o.said.find(text), std::string::npos) << "the clamped length, " << text << ", is said\n" << o.said;
    }
  }
}
