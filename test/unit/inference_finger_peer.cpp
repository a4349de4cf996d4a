// The pneumatic finger held to CalculiX (DESIGN.md "Physics": soft bodies held to a FEM
// peer). Geometry: a 0.1 x 0.02 x 0.02 m box mesh (x ∈ [0, 0.1], base at x = 0) filled by the
// library's fillInterior (the user path), with a chamber x ∈ [0.015, 0.065], |y| < 0.005,
// z ∈ [−0.005, 0]: walls 5 mm below and beside it (the thinnest), 10 mm above, so it bends to +z.
// Materials: the paper's Table 2 "Soft (real)" (E 1e7 Pa, ν 0.49) and pressure 5e5 Pa; the finger
// task's defaults otherwise (clamp 0.01 m, tip_fraction 0.15, static mode). Two chamber models:
//  - soft solid (the task's default r = 0 material: E 1e6 Pa, ν 0): CalculiX meshes the chamber as a
//    second material; ours' chamber particles carry the pressure energy −p Σ V_i (det F_i − 1);
//  - void (the paper: pressure on the chamber walls): CalculiX leaves the chamber cells out; ours
//    keeps chamber particles (the paper's E_a over them) with a residual 1e-3 of the wall stiffness.
// CalculiX: C3D10 on a rectilinear grid (2.5 mm cells, nodes on the clamp, chamber and segment
// planes), half model (y ≥ 0, symmetry plane y = 0), nodes x ≤ 0.01 fixed, follower pressure on the
// walls' chamber faces, NLGEOM in 5 increments. Bend angle as finger_task.cpp defines it: the deformed
// centroid of the tip segment (rest x past 0.85 of the particle extent) minus that of the segment
// before it, θ = atan2(dz, dx); CalculiX's centroids integrate the C3D10 displacement exactly over the
// same cells.
// Measured (2 particles through the 5 mm wall at the task's default 2.5 mm spacing; CalculiX 2.5 mm
// cells), with the finger's default StVK material (Green strain: what CalculiX's *ELASTIC computes
// under NLGEOM, and the paper's): soft solid ours 0.551 deg vs CalculiX 0.688 (−19.9 %), void 0.389 vs
// 0.571 (−31.8 %); the CalculiX void at 1.25 mm cells gives 0.588 deg (+3.1 %: the peer mesh is
// converged to about 3 %; too slow for the test). Refined (BendAngleConvergesWithRefinement,
// TOPO_SLOW_PEERS=1): soft solid −19.9 / −10.4 / −7.0 / −4.9 % at 2 / 3 / 4 / 5 particles through the
// wall, void −31.8 / −10.2 / −5.7 / −3.4 %: within 5 % from 5 particles through the wall. The corotated
// linear model (Cauchy strain) gave −29.8 / −20.9 / −18.7 % (void −51.5 / −37.2 %), levelling off near
// −17 %: the bend at 5e5 Pa is strongly nonlinear (linear CalculiX gives 0.163 deg for the void; from
// 5e3 to 5e5 Pa CalculiX's bend grows ×1.59 soft solid / ×3.40 void, StVK's ×1.54 / ×3.57, the
// corotated model's ×1.35 / ×2.56), and at ν 0.49 the bend is a small difference of the end caps'
// push and the walls' Poisson shortening, so the discretisation error is amplified (ν 0.3: StVK within
// ±2.3 % at 2.5 mm). Not volumetric locking: at 5e3 Pa both bends are linear in ν with the same slope
// from 0.3 to 0.49.
// Tests skip (with the reason) only when ccx is not installed.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "peer_world/calculix_peer.h"
#include "topo_gaussian/common/number_text.h"
#include "topo_gaussian/geometry/interior_fill.h"
#include "topo_gaussian/geometry/shape_generator.h"
#include "topo_gaussian/inference/task.h"
#include "topo_gaussian/inference/task_config.h"
#include "user_path_helpers.h"

using namespace topo_gaussian;
using namespace topo_gaussian::inference;
using topo_test::feature;

namespace {

struct Finger {
  double length = 0.1, width = 0.02, height = 0.02;  // x ∈ [0, L], y, z centred
  calculix_peer::Vec3 ch_lo{0.015, -0.005, -0.005}, ch_hi{0.065, 0.005, 0.0};
  double E = 1e7, nu = 0.49, E_ch = 1e6, nu_ch = 0.0, p = 5e5, clamp = 0.01;
};

/// Ours' void: the chamber particles carry the pressure energy (paper §"Actuation model") with a
/// residual stiffness of 1e-3 of the wall's (0 leaves the chamber particles' own positions undetermined).
constexpr double kVoidYoungsModulus = 1e4;

struct Ours {
  double angle = NAN, seconds = 0;
  std::size_t n = 0;
  double tip_lo = NAN, pre_lo = NAN;
};

Ours ours(const Finger& f, double h, bool void_chamber, double E_void, const std::string& extra = "") {
  geometry::SurfaceData box = geometry::makeBox(Eigen::Vector3d(f.length, f.width, f.height));
  for (auto& p : box.points) p.x() += 0.5 * f.length;
  geometry::FillOptions fo;
  fo.spacing_m = h;
  const VolumeCloud cloud = geometry::fillInterior(box, fo);
  TaskConfig c = TaskConfig::defaults("finger");
  c.setNumber("youngs_modulus_solid", f.E);
  c.setNumber("poisson_ratio", f.nu);
  c.setNumber("youngs_modulus_hollow", void_chamber ? E_void : f.E_ch);
  c.setNumber("poisson_ratio_hollow", f.nu_ch);
  c.setNumber("pressure_pa", f.p);
  c.setNumber("clamp_length_m", f.clamp);
  if (!extra.empty()) c.setAssignment(extra);
  std::vector<double> r(cloud.size(), 1.0);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    bool in = true;
    for (int a = 0; a < 3; ++a) in = in && cloud.X[i][a] > f.ch_lo[a] && cloud.X[i][a] < f.ch_hi[a];
    if (in) r[i] = 0.0;
  }
  const auto t0 = std::chrono::steady_clock::now();
  const auto task = makeTask(c, cloud);
  const TaskEvaluation ev = task->evaluate(r, nullptr);
  Ours o;
  o.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  o.angle = feature(ev, "bend_angle_deg");
  o.n = cloud.size();
  double xmin = 1e9, xmax = -1e9;
  for (auto& x : cloud.X) xmin = std::min(xmin, x.x()), xmax = std::max(xmax, x.x());
  return o;
}

/// Tip and pre segments of the finger task for lattice spacing h: cells whose centres have
/// u = X − X_min > 0.85 len (tip), > 0.7 len (pre), len = L − h.
void segments(const Finger& f, double h, double* tip_lo, double* pre_lo) {
  const double len = f.length - h;
  auto first_cell_face = [&](double frac) {
    // cell centres at h/2 + k h; first k with k h > frac * len
    const int k = static_cast<int>(std::floor(frac * len / h + 1e-9)) + 1;
    return k * h;
  };
  *tip_lo = first_cell_face(0.85);
  *pre_lo = first_cell_face(0.70);
}

double calculix(const Finger& f, double h, bool void_chamber, double cell, bool nlgeom, double* seconds) {
  using namespace calculix_peer;
  double tip_lo, pre_lo;
  segments(f, h, &tip_lo, &pre_lo);
  const auto xs = VoxelGeometry::axis(0.0, f.length, cell, {f.clamp, f.ch_lo[0], f.ch_hi[0], tip_lo, pre_lo});
  const auto ys = VoxelGeometry::axis(0.0, 0.5 * f.width, cell, {f.ch_hi[1]});
  const auto zs = VoxelGeometry::axis(-0.5 * f.height, 0.5 * f.height, cell, {f.ch_lo[2], f.ch_hi[2]});
  VoxelGeometry g = VoxelGeometry::rectilinear(xs, ys, zs);
  g.carve(f.ch_lo, f.ch_hi, void_chamber ? 0 : 2);
  const TetMesh m = meshVoxels(g);
  Material wall, ch;
  wall.youngs_modulus_pa = f.E;
  wall.poisson_ratio = f.nu;
  ch.youngs_modulus_pa = f.E_ch;
  ch.poisson_ratio = f.nu_ch;
  Load load;
  load.gravity_m_s2 = {0, 0, 0};
  load.void_pressure_pa = f.p;
  load.nlgeom = nlgeom;
  load.increments = 5;
  load.symmetry_y_m = 0.0;
  const auto t0 = std::chrono::steady_clock::now();
  const Result r = staticSolve(m, wall, f.clamp, load, &ch);
  *seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const calculix_peer::Vec3 ct = deformedCentroid(m, r, tip_lo, 1e9), cp = deformedCentroid(m, r, pre_lo, tip_lo);
  std::fprintf(stderr, "  ccx cell %.4g: %zu nodes %zu tets %zu pressure faces, %.1f s\n", cell, m.nodes.size(),
               m.tets.size(), m.void_faces.size(), *seconds);
  return std::atan2(ct[2] - cp[2], ct[0] - cp[0]) * 180.0 / M_PI;
}

}  // namespace

#define REQUIRE_CALCULIX()                                    \
  do {                                                        \
    std::string why;                                          \
    if (!calculix_peer::available(&why)) GTEST_SKIP() << why; \
  } while (0)

// Both chamber models at the finger task's default spacing (2.5 mm: 2 particles through the 5 mm
// thinnest wall; the task warns with the bias measured below and in the convergence test). Measured
// (see the file header): ours is too stiff by a fifth (soft-solid chamber) and a third (void); the
// tolerances below are what these numbers support at this spacing, not the 5 % goal (reached by
// refinement: BendAngleConvergesWithRefinement).
TEST(FingerPeer, BendAngleAgainstCalculixBothChamberModels) {
  REQUIRE_CALCULIX();
  const Finger f;
  const double h = 0.0025;
  struct Case {
    const char* name;
    bool void_chamber;
    double tolerance;
  };
  for (const Case& k : {Case{"soft-solid chamber (E 1e6, nu 0)", false, 0.25}, Case{"void chamber", true, 0.40}}) {
    testing::internal::CaptureStderr();
    const Ours o = ours(f, h, k.void_chamber, kVoidYoungsModulus);
    const std::string err = testing::internal::GetCapturedStderr();
    double seconds = 0;
    const double p = calculix(f, h, k.void_chamber, 0.0025, true, &seconds);
    const double e = o.angle / p - 1.0;
    std::printf(
        "[user-path] finger %s, 0.1 x 0.02 x 0.02 m box filled at %.4g m (%zu particles), E 1e7, nu 0.49, p 5e5 Pa "
        "| ours %.4f deg | CalculiX %.4f deg (C3D10, NLGEOM) | error %+.1f %% | %.1f s (ccx %.1f s)\n",
        k.name, h, o.n, o.angle, p, 100 * e, o.seconds, seconds);
    EXPECT_GT(o.angle, 0.0) << k.name << ": the finger must bend towards the thick wall (+z)";
    EXPECT_LT(std::abs(e), k.tolerance) << k.name;
    // The task says what this model's bend is worth (the measured bias), naming the wall resolution.
    EXPECT_NE(err.find("[finger] warning"), std::string::npos) << err;
    EXPECT_NE(err.find("gives 2 particles"), std::string::npos) << err;
    EXPECT_NE(err.find("--spacing 0.001 m or finer"), std::string::npos) << err;  // 5 mm / 5
  }
}

// The warning (the bias BendAngleConvergesWithRefinement measured) names the design's wall
// resolution and the spacing that reaches 5 % (5 particles through that wall, measured): a 0.1 x
// 0.025 x 0.025 m finger with 10 mm walls around its chamber has 4 particles through them at 2.5 mm
// and 3 at 3.125 mm (the lattice wall is 3 spacings): fill at 10 mm / 5 = 2 mm (9.375 / 5). A 0.04 m thick
// finger (7 particles through its walls at 2.5 mm) only gets a note; a design without a chamber has no
// wall to resolve: silent. With energy_model corotated_linear the warning says that model levels off.
// No pressure: only the start of the evaluation matters here.
TEST(FingerPeer, WarnsOfTheMeasuredBiasWithTheWallResolution) {
  struct Case {
    double side, h;
    const char* model;
    const char* expect;
  };
  for (const Case& k :
       {Case{0.025, 0.0025, "stvk", "gives 4 particles"}, Case{0.025, 0.003125, "stvk", "gives 3 particles"},
        Case{0.04, 0.0025, "stvk", "gives 7 particles"},
        Case{0.025, 0.0025, "corotated_linear", "levelling off near -17 %"}}) {
    geometry::SurfaceData box = geometry::makeBox(Eigen::Vector3d(0.1, k.side, k.side));
    for (auto& q : box.points) q.x() += 0.05;
    geometry::FillOptions fo;
    fo.spacing_m = k.h;
    const VolumeCloud cloud = geometry::fillInterior(box, fo);
    std::vector<double> r(cloud.size(), 1.0);
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      const Eigen::Vector3d& x = cloud.X[i];
      if (x.x() > 0.02 && x.x() < 0.06 && std::abs(x.y()) < 0.0025 && std::abs(x.z()) < 0.0025) r[i] = 0.0;
    }
    TaskConfig c = TaskConfig::defaults("finger");
    c.setNumber("pressure_pa", 0.0);
    c.setAssignment(std::string("energy_model=") + k.model);
    for (const bool chamber : {true, false}) {
      const auto task = makeTask(c, cloud);
      testing::internal::CaptureStderr();
      task->evaluate(chamber ? r : std::vector<double>(cloud.size(), 1.0), nullptr);
      const std::string err = testing::internal::GetCapturedStderr();
      if (!chamber) {
        EXPECT_EQ(err.find("[finger]"), std::string::npos) << err;
        continue;
      }
      EXPECT_NE(err.find(k.expect), std::string::npos) << err;
      if (std::string(k.model) == "corotated_linear") {
        EXPECT_NE(err.find("[finger] warning"), std::string::npos) << err;
        continue;
      }
      if (k.side > 0.03) {  // 7 particles through the wall: a note, not a warning
        EXPECT_EQ(err.find("[finger] warning"), std::string::npos) << err;
        EXPECT_NE(err.find("within 5 % from 5"), std::string::npos) << err;
        continue;
      }
      EXPECT_NE(err.find("[finger] warning"), std::string::npos) << err;
      EXPECT_NE(err.find("-20 / -10 / -7.0 / -4.9 %"), std::string::npos) << err;
      EXPECT_NE(err.find("larger or softer"), std::string::npos) << err;
      const double wall_m = (k.h > 0.003 ? 3.0 : 4.0) * k.h;  // 9.375 mm / 10 mm
      const std::size_t at = err.find("--spacing ");
      ASSERT_NE(at, std::string::npos) << err;
      const double named = std::atof(err.c_str() + at + 10);  // wall / 5, to the 3 digits printed
      EXPECT_NEAR(named, wall_m / 5.0, 0.006 * wall_m / 5.0) << err;
      EXPECT_NE(err.find(" m or finer (5 particles through this wall"), std::string::npos) << err;
    }
  }
}

// The convergence curve (converging with refinement): both chamber models at 2, 3, 4 and 5 particles through the 5 mm wall, each against CalculiX
// with its segments on that lattice (2.5 mm C3D10 cells: the peer itself is converged to ~3 %, see
// the file header). Ours at 1 mm is 40 000 particles and the whole curve takes ~10 min on 2 cores,
// so the test runs only with TOPO_SLOW_PEERS=1 (the curve is in docs/accuracy.md and the
// file header). It asserts what the numbers show: the error shrinks with every refinement, and at 5
// particles through the wall both chamber models are within the 5 % goal (−4.9 %, −3.4 %).
TEST(FingerPeer, BendAngleConvergesWithRefinement) {
  REQUIRE_CALCULIX();
  if (!std::getenv("TOPO_SLOW_PEERS"))
    GTEST_SKIP() << "about 10 minutes on 2 cores: set TOPO_SLOW_PEERS=1 to run (the measured curve is in docs/accuracy.md)";
  const Finger f;
  double last[2] = {INFINITY, INFINITY};  // soft-solid, void
  for (const double h : {0.0025, 0.0025 / 1.5, 0.00125, 0.001}) {
    for (const bool void_chamber : {false, true}) {
      testing::internal::CaptureStderr();
      const Ours o = ours(f, h, void_chamber, kVoidYoungsModulus);
      testing::internal::GetCapturedStderr();
      double seconds = 0;
      const double p = calculix(f, h, void_chamber, 0.0025, true, &seconds);
      const double e = o.angle / p - 1.0;
      std::printf(
          "[convergence] finger %s at %.4g m (%.0f particles through the 5 mm wall, %zu particles) | ours %.4f deg | "
          "CalculiX %.4f deg | error %+.1f %% | %.0f s\n",
          void_chamber ? "void chamber" : "soft-solid chamber", h, 0.005 / h, o.n, o.angle, p, 100 * e, o.seconds);
      std::fflush(stdout);
      EXPECT_LT(std::abs(e), last[void_chamber]) << "the error must shrink with refinement (h " << h << ")";
      if (h < 0.00101) EXPECT_LT(std::abs(e), 0.05) << "5 particles through the wall: the 5 % goal";
      last[void_chamber] = std::abs(e);
    }
  }
}
