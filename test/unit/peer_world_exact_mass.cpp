// m, c, I_c of the peer world's exact mass moments (bench/peer_world/exact_mass.h) against closed forms:
// box meshes (1e-12), a UV sphere converging to the sphere, a box clipped by x = c (the smaller box,
// 1e-12), a cube clipped by tilted planes (a triangular prism and a corner tetrahedron worked by hand),
// a sphere with a concentric cavity (the hollow sphere) and boxes side by side (one box) through
// combine(), and the checks: open or inconsistent meshes throw, inward meshes are flipped, insideMesh.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "peer_world/exact_mass.h"
#include "topo_gaussian/common/error.h"

using topo_gaussian::TopoError;
using namespace topo_gaussian::peer;
using Eigen::Matrix3d;
using Eigen::Vector3d;
using Eigen::Vector3i;

namespace {

constexpr double kPi = 3.14159265358979323846;

struct Mesh {
  std::vector<Vector3d> vertices;
  std::vector<Vector3i> triangles;
};

/// Axis-aligned box centre ± half, 12 outward triangles.
Mesh boxMesh(const Vector3d& centre, const Vector3d& half) {
  Mesh m;
  for (int k = 0; k < 8; ++k)
    m.vertices.push_back(centre + Vector3d((k & 1) ? half.x() : -half.x(), (k & 2) ? half.y() : -half.y(),
                                           (k & 4) ? half.z() : -half.z()));
  // Faces as quads (outward, counter-clockwise seen from outside), split into two triangles.
  const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : quads) {
    m.triangles.emplace_back(q[0], q[1], q[2]);
    m.triangles.emplace_back(q[0], q[2], q[3]);
  }
  return m;
}

/// UV sphere of radius r about `centre`: `segments` around, `rings` from pole to pole, vertices on the sphere.
Mesh uvSphere(const Vector3d& centre, double r, int segments, int rings) {
  Mesh m;
  m.vertices.push_back(centre + Vector3d(0, 0, -r));
  for (int i = 1; i < rings; ++i) {
    const double th = kPi * i / rings;
    for (int j = 0; j < segments; ++j) {
      const double ph = 2.0 * kPi * j / segments;
      m.vertices.push_back(centre +
                           r * Vector3d(std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), -std::cos(th)));
    }
  }
  m.vertices.push_back(centre + Vector3d(0, 0, r));
  const int north = static_cast<int>(m.vertices.size()) - 1;
  const auto at = [&](int ring, int j) { return 1 + (ring - 1) * segments + (j % segments); };
  for (int j = 0; j < segments; ++j) {
    m.triangles.emplace_back(0, at(1, j + 1), at(1, j));
    m.triangles.emplace_back(north, at(rings - 1, j), at(rings - 1, j + 1));
  }
  for (int i = 1; i + 1 < rings; ++i)
    for (int j = 0; j < segments; ++j) {
      m.triangles.emplace_back(at(i, j), at(i, j + 1), at(i + 1, j + 1));
      m.triangles.emplace_back(at(i, j), at(i + 1, j + 1), at(i + 1, j));
    }
  return m;
}

/// Largest of the relative errors of m, c (against the reference's size `length`) and I (against |I|).
double relativeError(const MassMoments& a, const MassMoments& ref, double length) {
  const double em = std::abs(a.mass_kg - ref.mass_kg) / std::abs(ref.mass_kg);
  const double ec = (a.com_m - ref.com_m).norm() / length;
  const double eI = (a.inertia_com_kg_m2 - ref.inertia_com_kg_m2).norm() / ref.inertia_com_kg_m2.norm();
  return std::max({em, ec, eI});
}

}  // namespace

TEST(PeerWorldExactMass, CubeAndBoxMeshesMatchTheClosedForm) {
  const struct {
    Vector3d centre, half;
    double rho;
  } cases[] = {{Vector3d(0, 0, 0), Vector3d(0.5, 0.5, 0.5), 1000.0},
               {Vector3d(1.0, -2.0, 3.0), Vector3d(0.3, 0.2, 0.1), 7800.0},
               {Vector3d(-0.05, 0.02, 0.4), Vector3d(0.01, 0.07, 0.03), -250.0}};
  for (const auto& c : cases) {
    const Mesh m = boxMesh(c.centre, c.half);
    const MassMoments got = meshMoments(m.vertices, m.triangles, c.rho, "box mesh");
    const MassMoments ref = boxMoments(c.centre, c.half, c.rho);
    const double e = relativeError(got, ref, c.half.norm());
    std::printf("[exact-mass] box mesh half (%g, %g, %g) at (%g, %g, %g), rho %g | relative error %.2e\n", c.half.x(),
                c.half.y(), c.half.z(), c.centre.x(), c.centre.y(), c.centre.z(), c.rho, e);
    EXPECT_LT(e, 1e-12);
  }
}

TEST(PeerWorldExactMass, UvSphereConvergesToTheSphere) {
  const Vector3d centre(0.1, -0.2, 0.3);
  const double r = 0.05, rho = 1200.0;
  const MassMoments ref = sphereMoments(centre, r, rho);
  double previous = 1e300;
  for (int segments : {32, 64, 128, 256}) {
    const Mesh m = uvSphere(centre, r, segments, segments / 2);
    const MassMoments got = meshMoments(m.vertices, m.triangles, rho, "UV sphere");
    const double em = std::abs(got.mass_kg / ref.mass_kg - 1.0);
    const double eI = (got.inertia_com_kg_m2 - ref.inertia_com_kg_m2).norm() / ref.inertia_com_kg_m2.norm();
    const double ec = (got.com_m - centre).norm() / r;
    std::printf("[exact-mass] UV sphere %d x %d | mass error %.3e, inertia error %.3e, centre error %.1e of r\n",
                segments, segments / 2, em, eI, ec);
    const double e = std::max(em, eI);
    EXPECT_LT(e, previous) << segments;
    if (segments > 32) {
      EXPECT_NEAR(previous / e, 4.0, 0.2) << "second order: halving the facets quarters the error";
    }
    EXPECT_LT(ec, 1e-12) << segments;
    previous = e;
  }
  EXPECT_LT(previous, 2e-3) << "the finest mesh (256 x 128) within 0.2 %";
}

TEST(PeerWorldExactMass, BoxClippedAtXEqualsCIsTheSmallerBox) {
  const Vector3d centre(0.2, 0.1, -0.3), half(0.4, 0.15, 0.25);
  const double rho = 2700.0;
  const Mesh m = boxMesh(centre, half);
  for (double c : {-0.1, 0.2, 0.55}) {
    const double lo = centre.x() - half.x(), hi = centre.x() + half.x();
    // The part x > c and the part x < c (normal −x).
    const MassMoments upper = clippedMeshMoments(m.vertices, m.triangles, Vector3d(c, 0, 0), Vector3d(2, 0, 0), rho);
    const MassMoments lower = clippedMeshMoments(m.vertices, m.triangles, Vector3d(c, 5, -7), Vector3d(-1, 0, 0), rho);
    const MassMoments ref_up =
        boxMoments(Vector3d(0.5 * (c + hi), centre.y(), centre.z()), Vector3d(0.5 * (hi - c), half.y(), half.z()), rho);
    const MassMoments ref_low =
        boxMoments(Vector3d(0.5 * (lo + c), centre.y(), centre.z()), Vector3d(0.5 * (c - lo), half.y(), half.z()), rho);
    const double eu = relativeError(upper, ref_up, half.norm()), el = relativeError(lower, ref_low, half.norm());
    std::printf("[exact-mass] box clipped at x = %g | x > c: relative error %.2e, x < c: %.2e\n", c, eu, el);
    EXPECT_LT(eu, 1e-12) << c;
    EXPECT_LT(el, 1e-12) << c;
    // The two parts make the whole box again.
    EXPECT_LT(relativeError(combine({upper, lower}), boxMoments(centre, half, rho), half.norm()), 1e-12) << c;
  }
  EXPECT_THROW(clippedMeshMoments(m.vertices, m.triangles, Vector3d(1.0, 0, 0), Vector3d(1, 0, 0), rho), TopoError)
      << "nothing of the box lies beyond x = 1";
  EXPECT_THROW(clippedMeshMoments(m.vertices, m.triangles, Vector3d(0, 0, 0), Vector3d::Zero(), rho), TopoError);
}

TEST(PeerWorldExactMass, TiltedPlanesClipTheUnitCubeIntoAPrismAndATetrahedron) {
  const Mesh cube = boxMesh(Vector3d::Constant(0.5), Vector3d::Constant(0.5));
  const double rho = 3.0;
  // x + z > 1: the triangular prism over (1,0), (1,1), (0,1) in (x, z), along y ∈ [0, 1]. With u = 1 − x,
  // w = 1 − z on the triangle u, w ≥ 0, u + w ≤ 1 (area 1/2): ∫u = 1/6, ∫u² = 1/12, ∫uw = 1/24, so the
  // centroid is x = z = 2/3 and C_xx = C_zz = 1/12 − 1/18 = 1/36, C_xz = 1/24 − 1/18 = −1/72, C_yy = 1/2 · 1/12
  // = 1/24; I = tr(C) 1 − C with tr C = 7/72.
  {
    const MassMoments got =
        clippedMeshMoments(cube.vertices, cube.triangles, Vector3d(0.5, 0.3, 0.5), Vector3d(2, 0, 2), rho);
    Matrix3d I;
    I << 5.0 / 72, 0, 1.0 / 72, 0, 4.0 / 72, 0, 1.0 / 72, 0, 5.0 / 72;
    const MassMoments ref{rho * 0.5, Vector3d(2.0 / 3, 0.5, 2.0 / 3), rho * I};
    const double e = relativeError(got, ref, 1.0);
    std::printf("[exact-mass] unit cube clipped to x + z > 1 (prism) | relative error %.2e\n", e);
    EXPECT_LT(e, 1e-12);
  }
  // x + y + z > 2.5: the corner tetrahedron with legs L = 1/2 at (1, 1, 1). For the tetrahedron x, y, z ≥ 0,
  // x + y + z ≤ L: V = L³/6, centroid L/4, ∫x² = L⁵/60, ∫xy = L⁵/120, so C_xx = L⁵/60 − L⁵/96 = L⁵/160 and
  // C_xy = L⁵/120 − L⁵/96 = −L⁵/480 (the reflection x → 1 − x keeps both); I_xx = L⁵/80, I_xy = L⁵/480.
  {
    const double L = 0.5, L5 = std::pow(L, 5);
    const MassMoments got =
        clippedMeshMoments(cube.vertices, cube.triangles, Vector3d(1, 1, 0.5), Vector3d(1, 1, 1), rho);
    Matrix3d I = Matrix3d::Constant(L5 / 480);
    I.diagonal().setConstant(L5 / 80);
    const MassMoments ref{rho * L * L * L / 6, Vector3d::Constant(1.0 - L / 4), rho * I};
    const double e = relativeError(got, ref, L);
    std::printf("[exact-mass] unit cube clipped to x + y + z > 2.5 (corner tetrahedron) | relative error %.2e\n", e);
    EXPECT_LT(e, 1e-12);
  }
}

TEST(PeerWorldExactMass, CombineMakesTheHollowSphereAndJoinsBoxes) {
  // A sphere of radius R with a concentric cavity of radius r (density ρ_c inside):
  // m = 4/3 π ρ (R³ − r³) + 4/3 π ρ_c r³; the shell's I = 2/5 (m_R R² − m_r r²).
  const double R = 0.1, r = 0.06, rho = 1000.0, rho_c = 0.0;
  const Vector3d c(0.3, 0.0, -0.1);
  const MassMoments got = combine({sphereMoments(c, R, rho), sphereMoments(c, r, rho_c - rho)});
  const double mR = 4.0 / 3.0 * kPi * R * R * R * rho, mr = 4.0 / 3.0 * kPi * r * r * r * rho;
  const MassMoments ref{mR - mr, c, 0.4 * (mR * R * R - mr * r * r) * Matrix3d::Identity()};
  const double e = relativeError(got, ref, R);
  std::printf("[exact-mass] hollow sphere R %g, cavity r %g by combine | relative error %.2e\n", R, r, e);
  EXPECT_LT(e, 1e-12);

  // An off-centre cavity moves the centre of mass away from it: c = (m_R c_R − m_r c_r) / (m_R − m_r).
  const Vector3d cav(0.3, 0.02, -0.1);
  const MassMoments off = combine({sphereMoments(c, R, rho), sphereMoments(cav, r, -rho)});
  EXPECT_LT((off.com_m - (mR * c - mr * cav) / (mR - mr)).norm(), 1e-15);

  // Two boxes side by side along x are one box (the parallel-axis theorem).
  const MassMoments joined = combine({boxMoments(Vector3d(-0.1, 0, 0), Vector3d(0.1, 0.2, 0.3), 500.0),
                                      boxMoments(Vector3d(0.1, 0, 0), Vector3d(0.1, 0.2, 0.3), 500.0)});
  EXPECT_LT(relativeError(joined, boxMoments(Vector3d::Zero(), Vector3d(0.2, 0.2, 0.3), 500.0), 0.4), 1e-14);

  // The same ellipsoid closed form as the sphere when its semi-axes are equal.
  EXPECT_LT(relativeError(ellipsoidMoments(c, Vector3d::Constant(R), rho), sphereMoments(c, R, rho), R), 1e-15);

  EXPECT_THROW(combine({}), TopoError);
  EXPECT_THROW(combine({sphereMoments(c, r, rho), sphereMoments(c, R, -rho)}), TopoError) << "more cavity than body";
  EXPECT_THROW(sphereMoments(c, 0.0, rho), TopoError);
  EXPECT_THROW(ellipsoidMoments(c, Vector3d(0.1, -0.1, 0.1), rho), TopoError);
  EXPECT_THROW(boxMoments(c, Vector3d(0.1, 0.1, 0.0), rho), TopoError);
}

TEST(PeerWorldExactMass, OpenOrInconsistentMeshesThrowAndInwardMeshesAreFlipped) {
  const Mesh box = boxMesh(Vector3d(0.1, 0.2, 0.3), Vector3d(0.2, 0.3, 0.4));
  Mesh open = box;
  open.triangles.pop_back();
  try {
    meshMoments(open.vertices, open.triangles, 1000.0, "lid-less box");
    ADD_FAILURE() << "an open mesh was measured";
  } catch (const TopoError& e) {
    const std::string what = e.what();
    std::printf("[exact-mass] open mesh: %s\n", what.c_str());
    EXPECT_NE(what.find("lid-less box"), std::string::npos) << "the error names the mesh";
    EXPECT_NE(what.find("not closed"), std::string::npos);
  }
  EXPECT_THROW(clippedMeshMoments(open.vertices, open.triangles, Vector3d(0.1, 0.2, 0.3), Vector3d(1, 0, 0), 1.0),
               TopoError);
  Mesh mixed = box;  // one triangle reversed: its edges run the same way as their neighbours'
  std::swap(mixed.triangles[3][1], mixed.triangles[3][2]);
  EXPECT_THROW(meshMoments(mixed.vertices, mixed.triangles, 1000.0), TopoError);
  Mesh bad_index = box;
  bad_index.triangles[0][0] = 8;
  EXPECT_THROW(meshMoments(bad_index.vertices, bad_index.triangles, 1000.0), TopoError);
  EXPECT_THROW(meshMoments(box.vertices, {}, 1000.0), TopoError);

  Mesh inward = box;  // every triangle reversed: measured as the outward box
  for (auto& t : inward.triangles) std::swap(t[1], t[2]);
  const MassMoments flipped = meshMoments(inward.vertices, inward.triangles, 1000.0);
  EXPECT_LT(relativeError(flipped, boxMoments(Vector3d(0.1, 0.2, 0.3), Vector3d(0.2, 0.3, 0.4), 1000.0), 0.5), 1e-12);
  const MassMoments clipped_in =
      clippedMeshMoments(inward.vertices, inward.triangles, Vector3d(0.2, 0, 0), Vector3d(1, 0, 0), 1000.0);
  EXPECT_LT(relativeError(clipped_in, boxMoments(Vector3d(0.25, 0.2, 0.3), Vector3d(0.05, 0.3, 0.4), 1000.0), 0.5),
            1e-12);
}

TEST(PeerWorldExactMass, InsideMeshOnKnownPoints) {
  const Mesh box = boxMesh(Vector3d(0.1, 0.2, 0.3), Vector3d(0.2, 0.3, 0.4));
  EXPECT_TRUE(insideMesh(box.vertices, box.triangles, Vector3d(0.1, 0.2, 0.3)));
  EXPECT_TRUE(insideMesh(box.vertices, box.triangles, Vector3d(0.299, 0.499, 0.699)));  // near a corner
  EXPECT_TRUE(insideMesh(box.vertices, box.triangles, Vector3d(0.3, 0.2, 0.3)));        // on a face
  EXPECT_TRUE(insideMesh(box.vertices, box.triangles, Vector3d(0.3, 0.5, 0.3)));        // on an edge
  EXPECT_FALSE(insideMesh(box.vertices, box.triangles, Vector3d(0.301, 0.2, 0.3)));
  EXPECT_FALSE(insideMesh(box.vertices, box.triangles, Vector3d(5, -3, 2)));
  Mesh inward = box;
  for (auto& t : inward.triangles) std::swap(t[1], t[2]);
  EXPECT_TRUE(insideMesh(inward.vertices, inward.triangles, Vector3d(0.1, 0.2, 0.3)));
  EXPECT_FALSE(insideMesh(inward.vertices, inward.triangles, Vector3d(0.1, 0.2, 1.0)));

  // A cavity's surface inside a sphere mesh, and one that pokes out.
  const Mesh sphere = uvSphere(Vector3d::Zero(), 0.1, 64, 32);
  int inside = 0, total = 0;
  for (int k = 0; k < 200; ++k, ++total) {  // a Fibonacci sphere of radius 0.04 about (0.05, 0, 0): reaches 0.09
    const double z = 1.0 - 2.0 * (k + 0.5) / 200, s = std::sqrt(1.0 - z * z), ph = kPi * (3.0 - std::sqrt(5.0)) * k;
    inside += insideMesh(sphere.vertices, sphere.triangles,
                         Vector3d(0.05, 0, 0) + 0.04 * Vector3d(s * std::cos(ph), s * std::sin(ph), z));
  }
  EXPECT_EQ(inside, total);
  EXPECT_FALSE(insideMesh(sphere.vertices, sphere.triangles, Vector3d(0.0, 0.0, 0.1001)));
  EXPECT_TRUE(insideMesh(sphere.vertices, sphere.triangles, Vector3d(0.0, 0.0, 0.0999)));

  Mesh open = box;
  open.triangles.pop_back();
  EXPECT_THROW(insideMesh(open.vertices, open.triangles, Vector3d(0.1, 0.2, 0.3)), TopoError);
}
