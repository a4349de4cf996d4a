// T(A) = 4 ∫₀^A √(J(θ) / (2 (V(A) − V(θ)))) dθ and tan φ_e = d / h: the peer world's Bullet rocking
// (bench/peer_world/bullet_rocking.h) against the rolling closed forms (rolling_closed_form.h).
//  - A solid hemisphere mesh (R = 0.1 m, flat face up, sphere centre at the origin) with its exact mesh
//    moments, released at 10° about x (and at −10° about y): the period within 1 % of the exact rolling
//    period, the first sample's tilt the release tilt, the release pose touching the ground with the centre
//    of mass above the origin.
//    The same mesh given turned a quarter turn about x (its up axis body −y) rocks the same.
//  - The same hemisphere with an off-centre spherical cavity (combine), released at −10° on its lighter
//    side: it rocks about the static equilibrium of a sphere-bottomed body, the centre of mass straight
//    below the sphere centre: with the centre of mass at horizontal offset c_y and depth h below the sphere
//    centre, rotating by φ about x puts it at y = c_y cos φ + h sin φ, zero at φ_e = atan(−c_y / h). The potential m g
//    (R − ρ cos(θ − φ_e)) and the contact inertia are symmetric about φ_e, so the mean of the turning points is φ_e,
//    and the period is the round-bottom period with a = ρ = |c|, amplitude |θ0 − φ_e|.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include "peer_world/bullet_rocking.h"
#include "peer_world/exact_mass.h"
#include "rolling_closed_form.h"
#include "topo_gaussian/common/error.h"

using topo_gaussian::TopoError;
using namespace topo_gaussian::peer;
using Eigen::Vector3d;
using Eigen::Vector3i;
using topo_test::kRollPi;

namespace {

constexpr double kR = 0.1;
constexpr double kRho = 1000.0;
constexpr double kTiltDeg = 10.0;

/// Solid hemisphere z ≤ 0 (flat face up): the bottom pole, `rings` latitude rings of `segments` vertices up
/// to the equator, and the flat face fanned from its centre; outward triangles.
struct HemisphereMesh {
  std::vector<Vector3d> vertices;
  std::vector<Vector3i> triangles;
  HemisphereMesh(double R, int segments, int rings) {
    vertices.emplace_back(0.0, 0.0, -R);
    for (int ring = 1; ring <= rings; ++ring) {
      const double polar = 0.5 * kRollPi * ring / rings;
      for (int s = 0; s < segments; ++s) {
        const double az = 2.0 * kRollPi * s / segments;
        vertices.push_back(R *
                           Vector3d(std::sin(polar) * std::cos(az), std::sin(polar) * std::sin(az), -std::cos(polar)));
      }
    }
    vertices.emplace_back(0.0, 0.0, 0.0);
    const int centre = static_cast<int>(vertices.size()) - 1, equator = rings;
    const auto v = [segments](int ring, int s) { return ring == 0 ? 0 : 1 + (ring - 1) * segments + s % segments; };
    for (int s = 0; s < segments; ++s) {
      triangles.emplace_back(v(0, 0), v(1, s + 1), v(1, s));
      triangles.emplace_back(centre, v(equator, s), v(equator, s + 1));
      for (int ring = 1; ring < rings; ++ring) {
        triangles.emplace_back(v(ring, s), v(ring, s + 1), v(ring + 1, s + 1));
        triangles.emplace_back(v(ring, s), v(ring + 1, s + 1), v(ring + 1, s));
      }
    }
  }
};

/// Period from linearly interpolated crossings of `level` over whole periods: T = 2 (t_j − t_0) / j, j even.
double periodFromCrossings(const std::vector<double>& t, const std::vector<double>& y, double level, int* count) {
  std::vector<double> tc;
  for (std::size_t i = 1; i < y.size(); ++i) {
    const double a = y[i - 1] - level, b = y[i] - level;
    if ((a < 0.0 && b >= 0.0) || (a > 0.0 && b <= 0.0)) tc.push_back(t[i - 1] + (t[i] - t[i - 1]) * a / (a - b));
  }
  *count = static_cast<int>(tc.size());
  if (tc.size() < 3) return std::numeric_limits<double>::quiet_NaN();
  const std::size_t j = (tc.size() - 1) % 2 == 0 ? tc.size() - 1 : tc.size() - 2;
  return 2.0 * (tc[j] - tc[0]) / static_cast<double>(j);
}

/// Turning points: the release (sample 0) and every interior local extremum, refined by a parabola
/// through the three samples around it.
std::vector<double> turningPoints(const std::vector<double>& y) {
  std::vector<double> out{y.front()};
  for (std::size_t i = 1; i + 1 < y.size(); ++i) {
    const double a = y[i - 1], b = y[i], c = y[i + 1];
    if ((b > a && b >= c) || (b < a && b <= c)) {
      const double curvature = a - 2.0 * b + c;
      out.push_back(curvature != 0.0 ? b - 0.125 * (c - a) * (c - a) / curvature : b);
    }
  }
  return out;
}

/// z of the hull's lowest vertex at sample k.
double lowestZ(const std::vector<Vector3d>& vertices, const RockingRun& run, std::size_t k) {
  double z = 1e300;
  for (const Vector3d& v : vertices) z = std::min(z, (run.world_from_body[k] * v).z());
  return z;
}

}  // namespace

TEST(PeerWorldBulletRocking, HemisphereRocksWithTheRollingPeriod) {
  // 512 around, 128 rings: the faceting of the hull moves Bullet's period (peer_mesh_bullet_tumbler.cpp).
  const HemisphereMesh mesh(kR, 512, 128);
  const MassMoments m = meshMoments(mesh.vertices, mesh.triangles, kRho, "hemisphere mesh");
  const topo_test::AxialMoments ideal = topo_test::hemisphereMoments(kR);
  std::printf("[peer-world] hemisphere mesh moments vs the solid hemisphere: mass %+.3e, centre of mass depth %+.3e\n",
              m.mass_kg / (kRho * ideal.volume) - 1.0, -m.com_m.z() / (3.0 * kR / 8.0) - 1.0);

  RockingOptions o;
  o.initial_tilt_deg = kTiltDeg;
  o.duration_s = 3.0;
  const RockingRun run = rockOnGround(mesh.vertices, m, o);
  ASSERT_EQ(run.time_s.size(), run.tilt_deg.size());
  ASSERT_EQ(run.time_s.size(), run.world_from_body.size());
  EXPECT_EQ(run.time_s.size(), 721u) << "samples 0 … 3 s every 1/240 s";
  EXPECT_NEAR(run.time_s[1], 1.0 / 240, 1e-15);

  // The release: the task's tilt, touching z = 0, centre of mass above the origin, at rest.
  EXPECT_NEAR(run.tilt_deg.front(), kTiltDeg, 1e-6);
  const double z0 = lowestZ(mesh.vertices, run, 0);
  const Vector3d c0 = run.world_from_body.front() * m.com_m;
  EXPECT_NEAR(z0, 0.0, 1e-12);
  EXPECT_NEAR(c0.x(), 0.0, 1e-12);
  EXPECT_NEAR(c0.y(), 0.0, 1e-12);
  const Vector3d up0 = run.world_from_body.front().linear() * Vector3d::UnitZ();
  EXPECT_LT(up0.y(), 0.0) << "a positive tilt about +x leans the up axis towards −y";
  EXPECT_NEAR(run.tilt_deg[1], kTiltDeg, 0.01) << "released at rest";

  const double Tref = topo_test::rockingPeriod(topo_test::solidHemisphere(kR), kTiltDeg * kRollPi / 180.0);
  int crossings = 0;
  const double T = periodFromCrossings(run.time_s, run.tilt_deg, 0.0, &crossings);
  double lowest = 1e300, highest = -1e300;  // the hull's lowest point over the run: on the ground throughout
  for (std::size_t k = 0; k < run.time_s.size(); k += 24) {
    const double z = lowestZ(mesh.vertices, run, k);
    lowest = std::min(lowest, z), highest = std::max(highest, z);
  }
  const std::vector<double> turns = turningPoints(run.tilt_deg);
  std::printf(
      "[peer-world] Bullet hemisphere (%zu vertices) from %g deg | period %.5f s | closed form %.5f s | error %+.3f %% "
      "(%d crossings) | turning points %.3f, %.3f, %.3f deg | lowest point z in [%.2e, %.2e] m\n",
      mesh.vertices.size(), kTiltDeg, T, Tref, 100.0 * (T / Tref - 1.0), crossings, turns[0], turns[1],
      turns.size() > 2 ? turns[2] : NAN, lowest, highest);
  ASSERT_GE(crossings, 4);
  EXPECT_NEAR(T / Tref, 1.0, 0.01);
  EXPECT_NEAR(turns[1], -kTiltDeg, 0.5) << "rolls over to the mirror tilt";
  EXPECT_LT(std::max(std::abs(lowest), std::abs(highest)), 1e-3) << "stays on the ground";

  // Rocking about y from −10°: the same period; the first sample is the release tilt.
  o.rocking_axis_body = Vector3d(0, 2, 0);
  o.initial_tilt_deg = -kTiltDeg;
  o.duration_s = 2.0;
  const RockingRun about_y = rockOnGround(mesh.vertices, m, o);
  EXPECT_NEAR(about_y.tilt_deg.front(), -kTiltDeg, 1e-6);
  const Vector3d up_y = about_y.world_from_body.front().linear() * Vector3d::UnitZ();
  EXPECT_LT(up_y.x(), 0.0) << "a negative tilt about +y leans the up axis towards −x";
  const double Ty = periodFromCrossings(about_y.time_s, about_y.tilt_deg, 0.0, &crossings);
  std::printf("[peer-world] Bullet hemisphere about y from -10 deg | period %.5f s | error %+.3f %%\n", Ty,
              100.0 * (Ty / Tref - 1.0));
  EXPECT_NEAR(Ty / Tref, 1.0, 0.01);

  // The mesh and its moments given a quarter turn about x (S): up_axis_body = S e_z = −y; upright is S⁻¹.
  const Eigen::Matrix3d S = Eigen::AngleAxisd(0.5 * kRollPi, Vector3d::UnitX()).toRotationMatrix();
  std::vector<Vector3d> turned;
  for (const Vector3d& v : mesh.vertices) turned.push_back(S * v);
  const MassMoments mt{m.mass_kg, S * m.com_m, S * m.inertia_com_kg_m2 * S.transpose()};
  RockingOptions ot;
  ot.up_axis_body = S * Vector3d::UnitZ();
  ot.duration_s = 1.0;
  const RockingRun turned_run = rockOnGround(turned, mt, ot);
  double largest = 0.0;
  for (std::size_t k = 0; k < turned_run.tilt_deg.size(); ++k)
    largest = std::max(largest, std::abs(turned_run.tilt_deg[k] - run.tilt_deg[k]));
  std::printf(
      "[peer-world] the same hemisphere given turned (up axis body -y) | largest tilt difference over 1 s "
      "%.2e deg\n",
      largest);
  EXPECT_NEAR(turned_run.tilt_deg.front(), kTiltDeg, 1e-6);
  EXPECT_LT(largest, 0.05);
  EXPECT_LT((turned_run.world_from_body.front() * (S * m.com_m) - c0).norm(), 1e-12) << "the same release pose";
}

TEST(PeerWorldBulletRocking, OffCentreCavityShiftsTheRestTiltToTheHeavierSide) {
  const HemisphereMesh mesh(kR, 512, 128);
  // An empty sphere (ρ = 0) of radius 35 mm at y = +45 mm, 40 mm below the flat face: the −y half is heavier.
  const double r = 0.035;
  const Vector3d cavity(0.0, 0.045, -0.04);
  for (int k = 0; k < 200; ++k) {
    const double z = 1.0 - 2.0 * (k + 0.5) / 200, s = std::sqrt(1.0 - z * z), ph = kRollPi * (3.0 - std::sqrt(5.0)) * k;
    ASSERT_TRUE(insideMesh(mesh.vertices, mesh.triangles, cavity + r * Vector3d(s * std::cos(ph), s * std::sin(ph), z)))
        << "the cavity lies inside the hemisphere";
  }
  const MassMoments body = meshMoments(mesh.vertices, mesh.triangles, kRho, "hemisphere mesh");
  const MassMoments m = combine({body, sphereMoments(cavity, r, 0.0 - kRho)});

  // Closed form of the hollowed solid hemisphere: c = (V_h c_h − V_b c_b) / (V_h − V_b).
  const topo_test::AxialMoments hemi = topo_test::hemisphereMoments(kR);
  const double Vb = 4.0 / 3.0 * kRollPi * r * r * r;
  const Vector3d c = (hemi.volume * Vector3d(0, 0, -3.0 * kR / 8.0) - Vb * cavity) / (hemi.volume - Vb);
  const double equilibrium_deg = std::atan(-c.y() / -c.z()) * 180.0 / kRollPi;
  std::printf(
      "[peer-world] hollowed hemisphere | centre of mass (%.3e, %.3e, %.3e) m, closed form (%.3e, %.3e, %.3e) m "
      "| static equilibrium tilt %.4f deg\n",
      m.com_m.x(), m.com_m.y(), m.com_m.z(), c.x(), c.y(), c.z(), equilibrium_deg);
  EXPECT_LT((m.com_m - c).norm(), 1e-4 * kR) << "the mesh's faceting only";
  EXPECT_GT(std::abs(m.inertia_com_kg_m2(1, 2)), 1e-3 * m.inertia_com_kg_m2(0, 0)) << "the principal frame is tilted";

  // Released at −10°, on the lighter side: it swings to about 2 φ_e + 10° and back.
  RockingOptions o;
  o.initial_tilt_deg = -kTiltDeg;
  o.duration_s = 3.0;
  const RockingRun run = rockOnGround(mesh.vertices, m, o);
  EXPECT_NEAR(run.tilt_deg.front(), -kTiltDeg, 1e-6);
  EXPECT_NEAR(lowestZ(mesh.vertices, run, 0), 0.0, 1e-12);
  const Vector3d c0 = run.world_from_body.front() * m.com_m;
  EXPECT_NEAR(c0.x(), 0.0, 1e-12);
  EXPECT_NEAR(c0.y(), 0.0, 1e-12);

  // The mean of consecutive turning points (midpoints of each half swing, averaged: a slow decay cancels).
  const std::vector<double> turns = turningPoints(run.tilt_deg);
  ASSERT_GE(turns.size(), 5u);
  double sum = 0.0;
  for (std::size_t k = 1; k < turns.size(); ++k) sum += 0.5 * (turns[k - 1] + turns[k]);
  const double mean_deg = sum / static_cast<double>(turns.size() - 1);
  // Its period: the round-bottom closed form about φ_e, centre of mass ρ = |c| below the sphere centre,
  // k² = I_xx / m, amplitude |θ0 − φ_e|.
  int crossings = 0;
  const double T = periodFromCrossings(run.time_s, run.tilt_deg, mean_deg, &crossings);
  const topo_test::RoundBottom rb{kR, m.com_m.norm(), m.inertia_com_kg_m2(0, 0) / m.mass_kg};
  const double Tref = topo_test::rockingPeriod(rb, (equilibrium_deg + kTiltDeg) * kRollPi / 180.0);
  std::printf(
      "[peer-world] Bullet hollowed hemisphere from %g deg | %zu turning points: %.3f, %.3f, %.3f, %.3f deg | "
      "mean %.4f deg | static equilibrium %.4f deg | difference %+.4f deg | period %.5f s, closed form "
      "%.5f s, error %+.3f %%\n",
      -kTiltDeg, turns.size(), turns[0], turns[1], turns[2], turns[3], mean_deg, equilibrium_deg,
      mean_deg - equilibrium_deg, T, Tref, 100.0 * (T / Tref - 1.0));
  EXPECT_GT(equilibrium_deg, 1.0) << "the −y half is heavier: it goes down, a positive tilt about +x";
  EXPECT_GT(mean_deg, 0.0) << "released at a negative tilt, it rocks about a positive one: the heavier side";
  EXPECT_NEAR(mean_deg, equilibrium_deg, 0.3);
  EXPECT_NEAR(T / Tref, 1.0, 0.01);
}

TEST(PeerWorldBulletRocking, BadInputsThrow) {
  const HemisphereMesh mesh(kR, 16, 4);
  const MassMoments m = meshMoments(mesh.vertices, mesh.triangles, kRho);
  RockingOptions o;
  o.duration_s = 0.01;
  EXPECT_NO_THROW(rockOnGround(mesh.vertices, m, o));
  EXPECT_THROW(rockOnGround({}, m, o), TopoError);
  MassMoments bad = m;
  bad.mass_kg = 0.0;
  EXPECT_THROW(rockOnGround(mesh.vertices, bad, o), TopoError);
  bad = m;
  bad.inertia_com_kg_m2(2, 2) = -bad.inertia_com_kg_m2(2, 2);
  EXPECT_THROW(rockOnGround(mesh.vertices, bad, o), TopoError);
  const auto with = [&](auto change) {
    RockingOptions p = o;
    change(p);
    return p;
  };
  EXPECT_THROW(rockOnGround(mesh.vertices, m, with([](RockingOptions& p) { p.rocking_axis_body.setZero(); })),
               TopoError);
  EXPECT_THROW(rockOnGround(mesh.vertices, m, with([](RockingOptions& p) { p.up_axis_body.setZero(); })), TopoError);
  EXPECT_THROW(rockOnGround(mesh.vertices, m, with([](RockingOptions& p) { p.rocking_axis_body = Vector3d(1, 0, 1); })),
               TopoError);
  EXPECT_THROW(rockOnGround(mesh.vertices, m, with([](RockingOptions& p) { p.duration_s = 0; })), TopoError);
  EXPECT_THROW(rockOnGround(mesh.vertices, m, with([](RockingOptions& p) { p.sample_dt_s = -1; })), TopoError);
  EXPECT_THROW(rockOnGround(mesh.vertices, m, with([](RockingOptions& p) { p.bullet_dt_s = 0; })), TopoError);
  EXPECT_THROW(rockOnGround(mesh.vertices, m, with([](RockingOptions& p) { p.initial_tilt_deg = 95; })), TopoError);
}
