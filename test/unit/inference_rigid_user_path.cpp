// Rigid motion on the user path: a surface goes through what `topo fill` does
// (geometry::ingestSurface with the command's defaults and --spacing), then through what
// `topo simulate --task tumbler|ball` does (inference::simulateInterior with the task's default
// contact settings), and the result is held to closed forms (rolling_closed_form.h), never to our own
// model: the exact rocking period of a solid hemisphere at 3°, 10° and 20° for 2–6 mm spacings, its
// drift over 20 cycles, a weighted tumbler (offset centre of mass), a ball rolling down a 15° incline
// (a = 5/7 g sin β), a ball dropped with spin (v = 2/7 ω₀ R once it rolls), and the hemisphere given as
// 3D Gaussians and as a noisy point cloud.
//
// Each case prints one line "[user-path] <case> | ours ... | reference ... | error ... %" for the
// docs/accuracy.md's user-path table.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

#include "rolling_closed_form.h"
#include "topo_gaussian/geometry/ingest.h"
#include "topo_gaussian/geometry/shape_generator.h"
#include "topo_gaussian/geometry/surface_data.h"
#include "topo_gaussian/inference/pipeline.h"
#include "topo_gaussian/inference/task_config.h"
#include "user_path_helpers.h"

using namespace topo_gaussian;
using topo_test::kRollPi;

namespace {

constexpr double kG = 9.81;
constexpr double kR = 0.1;  // hemisphere radius [m] (the reference tumbler)
// 640 × 160: the pole cone is one ring (0.56°, 1 mm) wide, well inside the 3° swing's contact travel
// (256 × 64 made the 3° period −1.6 %).
constexpr int kSegments = 640, kRings = 160;
using topo_test::hemisphereMesh;

/// Points on the hemisphere's surface (curved part and flat face) with outward normals, about
/// `spacing` apart: a Fibonacci lattice on the lower half sphere and a sunflower on the disc.
void hemisphereSurfaceSamples(double R, double spacing, std::vector<Eigen::Vector3d>* x,
                              std::vector<Eigen::Vector3d>* n) {
  const double golden = kRollPi * (3.0 - std::sqrt(5.0));
  const long nc = std::lround(2.0 * kRollPi * R * R / (spacing * spacing));
  for (long i = 0; i < nc; ++i) {
    const double z = -1.0 + (i + 0.5) / double(nc);  // uniform in z over [−1, 0]: uniform in area
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z)), phi = golden * double(i);
    const Eigen::Vector3d u(r * std::cos(phi), r * std::sin(phi), z);
    x->push_back(R * u);
    n->push_back(u);
  }
  const long nd = std::lround(kRollPi * R * R / (spacing * spacing));
  for (long i = 0; i < nd; ++i) {
    const double r = R * std::sqrt((i + 0.5) / double(nd)), phi = golden * double(i);
    x->emplace_back(r * std::cos(phi), r * std::sin(phi), 0.0);
    n->emplace_back(0, 0, 1);
  }
}

/// The hemisphere as a trained 3DGS would give it: flat surfels tangent to the surface (as
/// geometry_fill.cpp's Gaussian sphere), 2 mm apart, opacity 0.7.
geometry::SurfaceData gaussianHemisphere(double R) {
  geometry::SurfaceData s;
  s.kind = geometry::SurfaceKind::Gaussians;
  s.source = "gaussian hemisphere";
  const double spacing = 0.002;
  std::vector<Eigen::Vector3d> n;
  hemisphereSurfaceSamples(R, spacing, &s.points, &n);
  for (const auto& nrm : n) {
    const Eigen::Quaterniond q = Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), nrm);
    s.rotations.emplace_back(q.w(), q.x(), q.y(), q.z());
    s.scales.emplace_back(spacing, spacing, 1e-4 * R);
    s.opacity.push_back(0.7);
    s.covariances.push_back(geometry::gaussianCovariance(s.scales.back(), s.rotations.back()));
    s.colors.emplace_back(0.5, 0.5, 0.5);
  }
  s.sh_degree = 0;
  return s;
}

/// The hemisphere as a depth scan would give it: points 2 mm apart with Gaussian noise of σ = 0.3 mm
/// in every direction (the seed picks the sampling of the noise), no normals.
geometry::SurfaceData noisyPointHemisphere(double R, unsigned seed = 15) {
  geometry::SurfaceData s;
  s.kind = geometry::SurfaceKind::Points;
  s.source = "noisy point hemisphere (seed " + std::to_string(seed) + ")";
  std::vector<Eigen::Vector3d> n;
  hemisphereSurfaceSamples(R, 0.002, &s.points, &n);
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 0.3e-3);
  for (auto& p : s.points) p += Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
  return s;
}

/// What `topo fill --input SURFACE --spacing S` does (src/tools/fill_command.cpp: IngestOptions
/// defaults, the spacing given); spacing 0: `topo fill` without --spacing (--count 50000).
VolumeCloud fillLikeTopoFill(const geometry::SurfaceData& surface, double spacing_m, std::string* method = nullptr) {
  geometry::IngestOptions o;
  o.fill.spacing_m = spacing_m;
  geometry::IngestResult r = geometry::ingestSurface(surface, o);
  if (method) *method = r.fill.method;
  return std::move(r.cloud);
}

double feature(const inference::ProblemEvaluation& ev, const std::string& name) {
  for (const auto& f : ev.task.features)
    if (f.name == name) return f.value;
  ADD_FAILURE() << "no feature " << name;
  return std::nan("");
}

/// What `topo simulate --task tumbler --volume V --set initial_tilt_deg=A [--set ...]` does.
inference::ProblemEvaluation simulateTumbler(const VolumeCloud& cloud, double tilt_deg,
                                             const std::vector<std::string>& sets = {},
                                             const std::vector<double>& r = {}) {
  inference::TaskConfig c = inference::TaskConfig::defaults("tumbler");
  c.setNumber("initial_tilt_deg", tilt_deg);
  for (const auto& s : sets) c.setAssignment(s);
  return inference::simulateInterior(c, cloud, r);
}

/// One full swing of a rocking signal: its period (between every other zero crossing) and its
/// amplitude (the mean of the two half swings' largest |tilt|).
struct Cycle {
  double period_s = 0, amplitude_deg = 0, start_s = 0;
};
std::vector<Cycle> cyclesOf(const std::vector<double>& t, const std::vector<double>& y) {
  std::vector<double> tc;
  std::vector<double> half_amp;  // largest |y| between consecutive crossings
  double peak = 0;
  for (std::size_t i = 1; i < y.size(); ++i) {
    peak = std::max(peak, std::abs(y[i - 1]));
    const double a = y[i - 1], b = y[i];
    if ((a < 0.0 && b >= 0.0) || (a > 0.0 && b <= 0.0)) {
      tc.push_back(t[i - 1] + (t[i] - t[i - 1]) * a / (a - b));
      if (tc.size() > 1) half_amp.push_back(peak);
      peak = 0;
    }
  }
  std::vector<Cycle> out;
  for (std::size_t k = 0; k + 2 < tc.size(); k += 2)
    out.push_back(Cycle{tc[k + 2] - tc[k], 0.5 * (half_amp[k] + half_amp[k + 1]), tc[k]});
  return out;
}

double pct(double ours, double ref) { return 100.0 * (ours / ref - 1.0); }

/// Least-squares fit of y = c0 + c1 t + c2 t² over the samples with t in [t0, t1].
Eigen::Vector3d quadraticFit(const std::vector<double>& t, const std::vector<double>& y, double t0, double t1) {
  Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < t.size(); ++i) {
    if (t[i] < t0 || t[i] > t1) continue;
    const Eigen::Vector3d row(1.0, t[i], t[i] * t[i]);
    A += row * row.transpose();
    b += row * y[i];
  }
  return A.ldlt().solve(b);
}

}  // namespace

TEST(ClosedForm, HemisphereRockingPeriodsMatchTheIssue) {
  // Reference values integrated independently of this code.
  const topo_test::RoundBottom h = topo_test::solidHemisphere(kR);
  EXPECT_NEAR(topo_test::smallAmplitudeRockingPeriod(h), 0.8352, 5e-5);
  EXPECT_NEAR(topo_test::rockingPeriod(h, 1e-6), 0.8352, 5e-5);
  const double deg = kRollPi / 180.0;
  EXPECT_NEAR(topo_test::rockingPeriod(h, 3 * deg), 0.8357, 5e-5);
  EXPECT_NEAR(topo_test::rockingPeriod(h, 5 * deg), 0.8365, 5e-5);
  EXPECT_NEAR(topo_test::rockingPeriod(h, 10 * deg), 0.8404, 5e-5);
  EXPECT_NEAR(topo_test::rockingPeriod(h, 15 * deg), 0.8470, 5e-5);
  // The moments route gives the same body.
  const topo_test::RoundBottom m = topo_test::roundBottomFromMoments(kR, topo_test::hemisphereMoments(kR));
  EXPECT_NEAR(m.a, h.a, 1e-12);
  EXPECT_NEAR(m.k2, h.k2, 1e-12);
  // Rolling: 5/7 g sin β, 2/7 ω₀ R for a solid ball (k² = 2/5 R²).
  EXPECT_NEAR(topo_test::inclineRollingAcceleration(0.05, 0.4 * 0.05 * 0.05, 0.3, kG), 5.0 / 7.0 * kG * std::sin(0.3),
              1e-12);
  EXPECT_NEAR(topo_test::spinDropRollingSpeed(0.05, 0.4 * 0.05 * 0.05, 20.0), 2.0 / 7.0 * 20.0 * 0.05, 1e-12);
}

// The reference case: a solid hemisphere mesh filled as `topo fill --spacing S` does, released at rest
// at 3°, 10° and 20° with the tumbler task's defaults: the period within 1 % of the exact one.
TEST(RigidUserPath, HemisphereTumblerPeriodsWithinOnePercent) {
  const geometry::SurfaceData mesh = hemisphereMesh(kR, kSegments, kRings);
  const topo_test::RoundBottom exact = topo_test::solidHemisphere(kR);
  for (double spacing : {0.002, 0.0035, 0.006}) {
    const VolumeCloud cloud = fillLikeTopoFill(mesh, spacing);
    for (double tilt : {3.0, 10.0, 20.0}) {
      const inference::ProblemEvaluation ev = simulateTumbler(cloud, tilt);
      const double T = feature(ev, "period_s"), Tref = topo_test::rockingPeriod(exact, tilt * kRollPi / 180.0);
      std::printf(
          "[user-path] hemisphere mesh R 0.1 m, topo fill --spacing %.4g (%zu particles), tumbler %g deg | ours %.5f s "
          "| reference %.5f s | error %+.2f %%\n",
          spacing, cloud.size(), tilt, T, Tref, pct(T, Tref));
      EXPECT_NEAR(T / Tref, 1.0, 0.01) << "spacing " << spacing << " m, tilt " << tilt << " deg";
    }
  }
}

// 20 cycles from 10° on the default fill (`topo fill` without --spacing: 50 000 particles, about
// 3.5 mm): each of the first 20 cycles swings (amplitude ≥ 1°) and its period is within 1 % of the
// exact period at that cycle's amplitude (the contact damping may shrink the swing; the period must
// follow the closed form as it does, not drift away from it).
TEST(RigidUserPath, HemisphereTwentyCyclesDoNotDrift) {
  const VolumeCloud cloud = fillLikeTopoFill(hemisphereMesh(kR, kSegments, kRings), 0.0);
  const topo_test::RoundBottom exact = topo_test::solidHemisphere(kR);
  const int kCycles = 20;
  const double duration = kCycles * topo_test::rockingPeriod(exact, 10.0 * kRollPi / 180.0) + 0.6;
  const inference::ProblemEvaluation ev =
      simulateTumbler(cloud, 10.0, {"duration_s=" + std::to_string(duration), "measured_cycles=0"});
  std::vector<Cycle> cycles = cyclesOf(ev.task.signal_time_s, ev.task.signal);
  std::size_t swinging = 0;  // cycles before the amplitude first falls below 1°
  while (swinging < cycles.size() && cycles[swinging].amplitude_deg >= 1.0) ++swinging;
  std::vector<double> err(std::min<std::size_t>(swinging, kCycles));
  double worst = 0;  // largest |error| of one cycle [%]
  std::size_t worst_k = 0;
  for (std::size_t k = 0; k < err.size(); ++k) {
    err[k] = pct(cycles[k].period_s, topo_test::rockingPeriod(exact, cycles[k].amplitude_deg * kRollPi / 180.0));
    if (std::abs(err[k]) >= worst) worst = std::abs(err[k]), worst_k = k;
  }
  std::printf("[user-path] hemisphere mesh, topo fill default (%zu particles, spacing %.4g m), 10 deg, %zu cycles ",
              cloud.size(), cloud.spacing, cycles.size());
  std::printf("(%zu with amplitude >= 1 deg):", swinging);
  for (std::size_t k : {std::size_t(0), std::size_t(9), std::size_t(kCycles - 1)})
    if (k < err.size())
      std::printf(" cycle %zu (amplitude %.2f deg) | ours %.5f s | reference %.5f s | error %+.2f %%;", k + 1,
                  cycles[k].amplitude_deg, cycles[k].period_s,
                  topo_test::rockingPeriod(exact, cycles[k].amplitude_deg * kRollPi / 180.0), err[k]);
  std::printf(" worst of the first %zu: %.2f %% (cycle %zu)\n", err.size(), worst, worst_k + 1);
  ASSERT_GE(swinging, std::size_t(kCycles)) << "the tumbler stopped rocking after " << swinging << " cycles";
  EXPECT_LT(worst, 1.0) << "cycle " << worst_k + 1 << " at t = " << cycles[worst_k].start_s << " s (amplitude "
                        << cycles[worst_k].amplitude_deg << " deg): period " << cycles[worst_k].period_s << " s";
}

// A weighted tumbler: the hemisphere of light material (300 kg/m³) with a dense ball (3000 kg/m³,
// radius 35 mm, centre 60 mm below the flat face) in its bottom, given as the interior r. The centre
// of mass is 47 mm below the sphere centre (not 3R/8); closed form from the mass moments.
TEST(RigidUserPath, WeightedTumblerWithOffsetCentreOfMass) {
  const double rb = 0.035, zb = -0.06, rho_light = 300.0, rho_dense = 3000.0;
  const VolumeCloud cloud = fillLikeTopoFill(hemisphereMesh(kR, kSegments, kRings), 0.002);
  std::vector<double> r(cloud.size(), 0.0);
  for (std::size_t i = 0; i < cloud.size(); ++i)
    if ((cloud.X[i] - Eigen::Vector3d(0, 0, zb)).norm() < rb) r[i] = 1.0;
  const topo_test::AxialMoments hm = topo_test::hemisphereMoments(kR), bm = topo_test::ballMoments(rb, zb);
  topo_test::AxialMoments weighted;  // ρ_light · hemisphere + (ρ_dense − ρ_light) · ball
  weighted.volume = rho_light * hm.volume + (rho_dense - rho_light) * bm.volume;
  weighted.first_z = rho_light * hm.first_z + (rho_dense - rho_light) * bm.first_z;
  weighted.Jxx = rho_light * hm.Jxx + (rho_dense - rho_light) * bm.Jxx;
  const topo_test::RoundBottom exact = topo_test::roundBottomFromMoments(kR, weighted);
  const std::vector<std::string> materials = {"density_solid=" + std::to_string(rho_dense),
                                              "density_hollow=" + std::to_string(rho_light)};
  for (double tilt : {5.0, 15.0}) {
    const inference::ProblemEvaluation ev = simulateTumbler(cloud, tilt, materials, r);
    const double T = feature(ev, "period_s"), Tref = topo_test::rockingPeriod(exact, tilt * kRollPi / 180.0);
    std::printf(
        "[user-path] weighted hemisphere (com %.2f mm below the centre, spacing 2 mm), tumbler %g deg | ours %.5f s | "
        "reference %.5f s | error %+.2f %%\n",
        1e3 * exact.a, tilt, T, Tref, pct(T, Tref));
    EXPECT_NEAR(T / Tref, 1.0, 0.01) << "tilt " << tilt << " deg";
  }
}

// A solid ball (R = 5 cm, UV sphere mesh) filled at 2.5 mm rolls down a 15° incline (the ball task
// with gravity tilted by 15°; the ground is the incline): a = 5/7 g sin 15°.
TEST(RigidUserPath, BallRollsDownAnInclineAtFiveSeventhsGSinBeta) {
  const double R = 0.05, beta = 15.0 * kRollPi / 180.0;
  const VolumeCloud cloud = fillLikeTopoFill(geometry::makeSphere(R, 256, 128), 0.0025);
  inference::TaskConfig c = inference::TaskConfig::defaults("ball");
  c.setNumber("initial_height_m", 0.0);
  c.setNumber("duration_s", 1.0);
  c.setVector("gravity", Eigen::Vector3d(kG * std::sin(beta), 0.0, -kG * std::cos(beta)));
  const inference::ProblemEvaluation ev = inference::simulateInterior(c, cloud, {});
  std::vector<double> t, x;
  for (const auto& row : ev.task.trajectory_rows) t.push_back(row[0]), x.push_back(row[1]);  // the centroid
  ASSERT_GT(t.size(), 100u);
  const double a = 2.0 * quadraticFit(t, x, 0.1, t.back())[2];
  const double aref = topo_test::inclineRollingAcceleration(R, 0.4 * R * R, beta, kG);
  std::printf(
      "[user-path] ball mesh R 5 cm, spacing 2.5 mm (%zu particles), rolling down 15 deg | ours %.4f m/s^2 | reference "
      "%.4f m/s^2 (5/7 g sin b) | error %+.2f %%\n",
      cloud.size(), a, aref, pct(a, aref));
  EXPECT_NEAR(a / aref, 1.0, 0.01);
}

// The same ball dropped from 5 cm spinning at 20 rad/s about +y, with no horizontal velocity:
// once it rolls, v = 2/7 ω₀ R along +x (angular momentum about the contact point is conserved).
TEST(RigidUserPath, BallDroppedSpinningRollsAtTwoSeventhsOmegaR) {
  const double R = 0.05, omega0 = 20.0;
  const VolumeCloud cloud = fillLikeTopoFill(geometry::makeSphere(R, 256, 128), 0.0025);
  inference::TaskConfig c = inference::TaskConfig::defaults("ball");
  c.setNumber("initial_height_m", 0.05);
  c.setNumber("duration_s", 0.8);
  c.setVector("initial_angular_velocity", Eigen::Vector3d(0.0, omega0, 0.0));
  const inference::ProblemEvaluation ev = inference::simulateInterior(c, cloud, {});
  std::vector<double> t, x;
  for (const auto& row : ev.task.trajectory_rows) t.push_back(row[0]), x.push_back(row[1]);
  ASSERT_GT(t.size(), 100u);
  // The speed at 0.4 s, from a fit over 0.4–0.8 s: it lands at 0.1 s, the bounces (contact damping
  // 0.3: restitution ~0.4) and the skid (~0.03 s per contact) are over by then, and it rolls.
  const Eigen::Vector3d fit = quadraticFit(t, x, 0.4, 0.8);
  const double v = fit[1] + 2.0 * fit[2] * 0.4;
  const double vref = topo_test::spinDropRollingSpeed(R, 0.4 * R * R, omega0);
  std::printf(
      "[user-path] ball mesh R 5 cm, spacing 2.5 mm, dropped 5 cm spinning %g rad/s | ours %.4f m/s | reference %.4f "
      "m/s (2/7 w0 R) | error %+.2f %%; deceleration while rolling %.3f m/s^2 (exact: 0)\n",
      omega0, v, vref, pct(v, vref), -2.0 * fit[2]);
  // 2.5 %: the skid and the bounces run through the penalty contact, whose damper (∝ penetration and
  // its rate) and anchored friction springs put a small torque on the spin while the ball slips;
  // measured −1.9 % on this UV sphere (−0.9 % on `topo generate --shape sphere`).
  EXPECT_NEAR(v / vref, 1.0, 0.025);
}

// The hemisphere given as 3D Gaussians and as a noisy point cloud (the inputs a lab has), filled as
// `topo fill` does at 3.5 mm: the 10° rocking period and the filled volume within 2 % of the exact ones.
TEST(RigidUserPath, GaussianAndNoisyPointHemispheresWithinTwoPercent) {
  const topo_test::RoundBottom exact = topo_test::solidHemisphere(kR);
  const double Tref = topo_test::rockingPeriod(exact, 10.0 * kRollPi / 180.0);
  for (const geometry::SurfaceData& s : {gaussianHemisphere(kR), noisyPointHemisphere(kR)}) {
    std::string method;
    const VolumeCloud cloud = fillLikeTopoFill(s, 0.0035, &method);
    const double V = cloud.totalVolume(), Vref = topo_test::hemisphereMoments(kR).volume;
    const inference::ProblemEvaluation ev = simulateTumbler(cloud, 10.0);
    const double T = feature(ev, "period_s");
    std::printf(
        "[user-path] %s (%zu samples, %s, spacing 3.5 mm, volume %+.2f %%), tumbler 10 deg | ours %.5f s | reference "
        "%.5f s | error %+.2f %%\n",
        s.source.c_str(), s.size(), method.c_str(), pct(V, Vref), T, Tref, pct(T, Tref));
    EXPECT_NEAR(T / Tref, 1.0, 0.02) << s.source;
    // The period alone can be right for a wrong body (it depends on the shape's proportions, not its
    // scale alone): the volume must be right too (≤ 2 % from points or Gaussians).
    EXPECT_NEAR(V / Vref, 1.0, 0.02) << s.source << " volume";
  }
}

// The same scan's noise drawn again (four seeds): the period must not depend on which sampling of the
// noise the scanner happened to give. With the contact fits at 8 s whatever the noise, these four
// gave −1.63 / −5.05 / −3.43 / −0.42 %; widened with the noise (contact_samples.cpp widenNoisyFits)
// −1.46 / −0.19 / −1.27 / +0.93 %, and seeds 19–26 −0.74…+0.98 % (TOPO_NOISE_SEEDS=19,20,...).
TEST(RigidUserPath, NoisyPointHemisphereWithinTwoPercentForEverySampling) {
  const topo_test::RoundBottom exact = topo_test::solidHemisphere(kR);
  const double Tref = topo_test::rockingPeriod(exact, 10.0 * kRollPi / 180.0);
  const char* only = std::getenv("TOPO_NOISE_SEEDS");  // e.g. "16,17": a subset while investigating
  std::vector<unsigned> seeds = {15, 16, 17, 18};
  if (only) {
    seeds.clear();
    for (const char* c = only; *c;) {
      char* end = nullptr;
      seeds.push_back(unsigned(std::strtoul(c, &end, 10)));
      c = *end ? end + 1 : end;
    }
  }
  for (unsigned seed : seeds) {
    const geometry::SurfaceData s = noisyPointHemisphere(kR, seed);
    geometry::IngestOptions o;
    o.fill.spacing_m = 0.0035;
    const geometry::IngestResult in = geometry::ingestSurface(s, o);
    const VolumeCloud& cloud = in.cloud;
    bool widened = false;  // the fill says the noise widened the contact fits
    for (const auto& w : in.warnings) widened = widened || w.find("contact fits widened") != std::string::npos;
    EXPECT_TRUE(widened) << s.source;
    const double T = feature(simulateTumbler(cloud, 10.0), "period_s");
    std::printf("[user-path] %s, spacing 3.5 mm, tumbler 10 deg | ours %.5f s | reference %.5f s | error %+.2f %%\n",
                s.source.c_str(), T, Tref, pct(T, Tref));
    EXPECT_NEAR(T / Tref, 1.0, 0.02) << s.source;
  }
}
