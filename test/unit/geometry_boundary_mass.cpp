// Exact mass at the boundary: fillInterior of a closed mesh gives boundary particles
// the inside part of their cell (cell_clip.h), so volume, centre of mass and inertia of a solid match
// the mesh's own polyhedral integrals (divergence theorem, computed here independently) whatever the
// lattice's alignment; the staircase of whole cells (before) is printed beside them.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <random>

#include "topo_gaussian/geometry/cell_clip.h"
#include "topo_gaussian/geometry/interior_fill.h"
#include "topo_gaussian/geometry/mesh_fill.h"
#include "topo_gaussian/geometry/mesh_metrics.h"
#include "topo_gaussian/geometry/shape_generator.h"
#include "topo_gaussian/physics/mass_properties.h"

using namespace topo_gaussian;
using namespace topo_gaussian::geometry;

namespace {

// Volume, first and second moments of a closed outward mesh by the divergence theorem: signed
// tetrahedra (0, a, b, c); ∫x xᵀ over a tetrahedron = V/20 (Σ_k p_k p_kᵀ + s sᵀ), s = Σ_k p_k.
struct Reference {
  double volume = 0.0;
  Eigen::Vector3d com = Eigen::Vector3d::Zero();
  Eigen::Vector3d principal = Eigen::Vector3d::Zero();  // inertia about com, unit density, ascending
};

Reference polyhedralReference(const SurfaceData& m) {
  double v = 0.0;
  Eigen::Vector3d m1 = Eigen::Vector3d::Zero();
  Eigen::Matrix3d m2 = Eigen::Matrix3d::Zero();
  for (const auto& t : m.triangles) {
    const Eigen::Vector3d &a = m.points[t[0]], &b = m.points[t[1]], &c = m.points[t[2]];
    const double vt = a.dot(b.cross(c)) / 6.0;
    const Eigen::Vector3d s = a + b + c;
    v += vt;
    m1 += vt * s / 4.0;
    m2 += vt / 20.0 * (a * a.transpose() + b * b.transpose() + c * c.transpose() + s * s.transpose());
  }
  Reference r;
  r.volume = v;
  r.com = m1 / v;
  const Eigen::Matrix3d C = m2 - v * r.com * r.com.transpose();
  const Eigen::Matrix3d I = C.trace() * Eigen::Matrix3d::Identity() - C;
  r.principal = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(I).eigenvalues();
  return r;
}

struct Measured {
  double volume = 0.0;
  Eigen::Vector3d com = Eigen::Vector3d::Zero();
  Eigen::Vector3d principal = Eigen::Vector3d::Zero();
};

Measured measure(const std::vector<Eigen::Vector3d>& X, const std::vector<double>& V, double cell_variance) {
  const MassProperties p = computeMassProperties(X, V, cell_variance);  // unit density
  Measured m;
  m.volume = p.mass;
  m.com = p.com;
  p.principal(&m.principal, nullptr);
  return m;
}

struct Errors {
  double volume, com, inertia;  // relative: |ΔV|/V, |Δc|/V^(1/3), max_k |ΔI_k|/I_k
};

Errors errorsOf(const Measured& m, const Reference& r) {
  Errors e;
  e.volume = std::abs(m.volume / r.volume - 1.0);
  e.com = (m.com - r.com).norm() / std::cbrt(r.volume);
  e.inertia = ((m.principal - r.principal).array() / r.principal.array()).abs().maxCoeff();
  return e;
}

// Today's staircase on the same lattice: a whole cell at every inside cell centre, point masses.
Measured staircase(const SurfaceData& mesh, double h) {
  Eigen::Vector3d lo, hi;
  surfaceBounds(mesh, &lo, &hi);
  const Lattice L = Lattice::covering(lo, hi, h, 1);
  const std::vector<std::uint8_t> in = meshInsideParity(mesh, L);
  std::vector<Eigen::Vector3d> X;
  for (int k = 0; k < L.n[2]; ++k)
    for (int j = 0; j < L.n[1]; ++j)
      for (int i = 0; i < L.n[0]; ++i)
        if (in[L.index(i, j, k)]) X.push_back(L.center(i, j, k));
  return measure(X, std::vector<double>(X.size(), h * h * h), 0.0);
}

SurfaceData transformed(SurfaceData m, const Eigen::Affine3d& T) {
  for (auto& p : m.points) p = T * p;
  return m;
}

// Solid hemisphere of radius R, flat face up at z = 0: revolve the meridian from the bottom pole
// along the arc to the rim, then across the flat face to the top centre.
SurfaceData makeHemisphere(double R, int seg, int arc_rings) {
  std::vector<Eigen::Vector2d> profile;  // (r, z)
  for (int i = 0; i <= arc_rings; ++i) {
    const double th = -0.5 * M_PI + 0.5 * M_PI * i / arc_rings;
    profile.emplace_back(R * std::cos(th), R * std::sin(th));
  }
  profile.emplace_back(0.0, 0.0);
  SurfaceData m;
  m.kind = SurfaceKind::Mesh;
  m.source = "hemisphere";
  const int rings = int(profile.size()) - 2;
  m.points.emplace_back(0, 0, profile.front().y());
  for (int i = 1; i <= rings; ++i)
    for (int j = 0; j < seg; ++j) {
      const double ph = 2 * M_PI * j / seg;
      m.points.emplace_back(profile[i].x() * std::cos(ph), profile[i].x() * std::sin(ph), profile[i].y());
    }
  const int top = int(m.points.size());
  m.points.emplace_back(0, 0, profile.back().y());
  auto ring = [&](int i, int j) { return 1 + (i - 1) * seg + (j % seg); };
  for (int j = 0; j < seg; ++j) m.triangles.emplace_back(0, ring(1, j + 1), ring(1, j));
  for (int i = 1; i < rings; ++i)
    for (int j = 0; j < seg; ++j) {
      m.triangles.emplace_back(ring(i, j), ring(i, j + 1), ring(i + 1, j + 1));
      m.triangles.emplace_back(ring(i, j), ring(i + 1, j + 1), ring(i + 1, j));
    }
  for (int j = 0; j < seg; ++j) m.triangles.emplace_back(top, ring(rings, j), ring(rings, j + 1));
  return m;
}

struct Shape {
  std::string name;
  SurfaceData mesh;
  bool rotate_about_z_only;
};

std::vector<Shape> shapes() {
  const Eigen::Affine3d skew(Eigen::AngleAxisd(M_PI / 6.0, Eigen::Vector3d(1, 2, 3).normalized()));
  return {{"sphere", makeSphere(0.1), false},
          {"hemisphere", makeHemisphere(0.1, 96, 24), true},
          {"box30", transformed(makeBox(Eigen::Vector3d(0.12, 0.08, 0.05)), skew), false},
          {"torus", makeTorus(0.06, 0.02), false}};
}

// A random pose: fillInterior centres its lattice on the bounding box, so a translation alone does
// not move the lattice against the object; a rotation (and a translation by a fraction of a cell)
// changes the bounding box, hence the spacing and the lattice's phase on the surface.
Eigen::Affine3d randomPose(std::mt19937& rng, bool about_z_only, double h) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::Quaterniond q;
  if (about_z_only)
    q = Eigen::AngleAxisd(M_PI * u(rng), Eigen::Vector3d::UnitZ());
  else
    q = Eigen::Quaterniond(u(rng), u(rng), u(rng), u(rng)).normalized();
  Eigen::Affine3d T = Eigen::Affine3d::Identity();
  T.translate(h * Eigen::Vector3d(u(rng), u(rng), u(rng)));
  T.rotate(q);
  return T;
}

// Closed mesh z ≤ z0 + s x + t y over the column [lo, hi]² (a box with a planar, tilted top).
SurfaceData tiltedTopBox(double z0, double s, double t, double lo, double hi, double bottom) {
  SurfaceData m;
  m.kind = SurfaceKind::Mesh;
  m.source = "tilted box";
  const double xy[4][2] = {{lo, lo}, {hi, lo}, {hi, hi}, {lo, hi}};
  for (const auto& p : xy) m.points.emplace_back(p[0], p[1], bottom);
  for (const auto& p : xy) m.points.emplace_back(p[0], p[1], z0 + s * p[0] + t * p[1]);
  auto quad = [&](int a, int b, int c, int d) {
    m.triangles.emplace_back(a, b, c);
    m.triangles.emplace_back(a, c, d);
  };
  quad(0, 3, 2, 1);  // bottom, normal −z
  quad(4, 5, 6, 7);  // top, normal +z
  for (int k = 0; k < 4; ++k) quad(k, (k + 1) % 4, 4 + (k + 1) % 4, 4 + k);
  return m;
}

// Inside volume and first moment of the unit cell [0,1]³ under z ≤ f(x) = a + b x (no y), by
// splitting [0,1] where f crosses 0 and 1: exact piecewise polynomials.
void unitCellUnderRamp(double a, double b, double* V, Eigen::Vector3d* c) {
  // x where f = 0 and f = 1 (b > 0), clamped to [0, 1]
  const double x0 = std::clamp(-a / b, 0.0, 1.0), x1 = std::clamp((1.0 - a) / b, 0.0, 1.0);
  auto P = [&](double x, int n) { return std::pow(x, n); };
  // ramp part ∫_{x0}^{x1} (a + b x) dx, ∫ x(a + b x), ∫ ½(a + b x)²; top part (f ≥ 1) over [x1, 1]
  const double v = a * (x1 - x0) + b * (P(x1, 2) - P(x0, 2)) / 2 + (1 - x1);
  const double mx = a * (P(x1, 2) - P(x0, 2)) / 2 + b * (P(x1, 3) - P(x0, 3)) / 3 + (1 - x1 * x1) / 2;
  const double mz = (std::pow(a + b * x1, 3) - std::pow(a + b * x0, 3)) / (6 * b) + 0.5 * (1 - x1);
  *V = v;
  *c = Eigen::Vector3d(mx / v, 0.5, mz / v);
}

}  // namespace

TEST(CellClip, CubeCellCutByAPlaneIsExact) {
  Lattice L;
  L.origin = Eigen::Vector3d::Zero();
  L.h = 1.0;
  L.n = {1, 1, 1};
  struct Case {
    double z0, s, t;
  };
  // horizontal cut; a tilt within the cell; a ramp that leaves the cell through its bottom and top
  for (const Case& k : {Case{0.37, 0.0, 0.0}, Case{0.3, 0.2, 0.1}, Case{-0.2, 1.4, 0.0}, Case{0.05, 0.6, 0.0}}) {
    const SurfaceData box = tiltedTopBox(k.z0, k.s, k.t, -1.0, 2.0, -1.0);
    const CellClipResult r = clipCells(box, L);
    ASSERT_EQ(r.partial.size(), 1u) << k.z0;
    double V;
    Eigen::Vector3d c;
    if (k.s == 0.0 && k.t == 0.0) {
      V = k.z0;
      c = Eigen::Vector3d(0.5, 0.5, 0.5 * k.z0);
    } else if (k.t == 0.0) {
      unitCellUnderRamp(k.z0, k.s, &V, &c);
    } else {  // plane inside (0,1) over the whole square: polynomial integrals on [0,1]²
      const double a = k.z0, b = k.s, e = k.t;
      V = a + b / 2 + e / 2;
      const double mx = a / 2 + b / 3 + e / 4, my = a / 2 + b / 4 + e / 3;
      const double mz = 0.5 * (a * a + b * b / 3 + e * e / 3 + a * b + a * e + b * e / 2);
      c = Eigen::Vector3d(mx, my, mz) / V;
    }
    EXPECT_NEAR(r.partial[0].volume_m3, V, 1e-12) << k.z0 << " " << k.s;
    EXPECT_LT((r.partial[0].centroid - c).norm(), 1e-12)
        << k.z0 << " " << k.s << ": " << r.partial[0].centroid.transpose() << " vs " << c.transpose();
    EXPECT_EQ(r.winding_anomalies, 0u);
  }
}

TEST(CellClip, EveryCellOfAVerticalWallAndTheTotalAreExact) {
  // A box whose side walls cut cell columns (x = 0.3, 2.55; no tilted face crosses those middle
  // cells: only the sweep of the top and bottom faces gives them their fraction).
  SurfaceData box = makeBox(Eigen::Vector3d(2.25, 1.7, 2.4));
  for (auto& p : box.points) p += Eigen::Vector3d(1.425, 1.45, 1.5);  // spans x 0.3..2.55, y 0.6..2.3, z 0.3..2.7
  Lattice L;
  L.h = 1.0;
  L.n = {3, 3, 3};
  const CellClipResult r = clipCells(box, L);
  EXPECT_NEAR(r.volume_m3, 2.25 * 1.7 * 2.4, 1e-12);
  EXPECT_NEAR(meshSignedVolume(box), 2.25 * 1.7 * 2.4, 1e-12);
  EXPECT_EQ(r.winding_anomalies, 0u);
  // cell (0,1,1): x 0.3..1, y 1..2, z 1..2: wholly in z and y, fraction 0.7 in x
  bool found = false;
  for (const CellPart& p : r.partial)
    if (p.cell == L.index(0, 1, 1)) {
      found = true;
      EXPECT_NEAR(p.volume_m3, 0.7, 1e-12);
      EXPECT_LT((p.centroid - Eigen::Vector3d(0.65, 1.5, 1.5)).norm(), 1e-12);
    }
  EXPECT_TRUE(found);
  EXPECT_EQ(r.wholly_inside, 1u);  // only the middle cell (1,1,1) touches no face
}

TEST(BoundaryMass, FilledSolidsMatchTheirPolyhedralMoments) {
  std::mt19937 rng(20250415);
  std::printf(
      "[boundary-mass] shape pose count  h[mm]  staircase: dV%%  dc%%  dI%%  |  exact cells: dV%%  dc%%  dI%%\n");
  for (const Shape& shape : shapes()) {
    for (int pose = 0; pose < 3; ++pose) {
      const SurfaceData mesh = transformed(shape.mesh, randomPose(rng, shape.rotate_about_z_only, 0.005));
      const Reference ref = polyhedralReference(mesh);
      ASSERT_GT(ref.volume, 0.0) << shape.name;
      double coarse_inertia = 0.0;  // convergence: the inertia error is O(h³), 8× smaller at half the spacing
      for (std::size_t count : {std::size_t(6250), std::size_t(50000)}) {
        FillOptions o;
        o.target_count = count;
        FillReport rep;
        const VolumeCloud c = fillInterior(mesh, o, &rep);
        ASSERT_TRUE(rep.exact_boundary) << shape.name;
        EXPECT_TRUE(rep.warnings.empty()) << shape.name << ": " << rep.warnings.front();
        EXPECT_NEAR(rep.mesh_volume_m3 / ref.volume, 1.0, 1e-12) << shape.name;
        const Errors after = errorsOf(measure(c.X, c.V, cubeCellVariance(c.spacing)), ref);
        const Errors before = errorsOf(staircase(mesh, c.spacing), ref);
        std::printf("[boundary-mass] %-10s %d %6zu %6.3f  %8.4f %6.4f %6.4f  |  %8.2e %8.2e %8.4f\n",
                    shape.name.c_str(), pose, c.size(), 1e3 * c.spacing, 100 * before.volume, 100 * before.com,
                    100 * before.inertia, 100 * after.volume, 100 * after.com, 100 * after.inertia);
        // Volume and first moment are exact (merging keeps both); the inertia misses only the
        // clipped cells' smaller own second moment and the spread of merged parts, O(h³).
        EXPECT_LT(after.volume, 1e-9) << shape.name << " pose " << pose << " count " << count;
        EXPECT_LT(after.com, 1e-9) << shape.name << " pose " << pose << " count " << count;
        EXPECT_LT(after.inertia, count == 50000 ? 1e-4 : 5e-4) << shape.name << " pose " << pose << " count " << count;
        if (count == 50000)
          EXPECT_LT(after.inertia, coarse_inertia / 4) << shape.name << " pose " << pose;
        else
          coarse_inertia = after.inertia;
        // No sliver particles for the soft-body sums: a cell holds a particle when at least half of
        // it is inside, and the parts of the other cut cells are merged into a neighbour.
        const double h3 = c.spacing * c.spacing * c.spacing;
        double vmin = 1e300;
        for (double v : c.V) vmin = std::min(vmin, v);
        EXPECT_GE(vmin, (0.5 - 1e-12) * h3) << shape.name;
        EXPECT_EQ(rep.own_particle_cells, 0u) << shape.name;
      }
    }
  }
}

TEST(BoundaryMass, InvertedNormalsAreFlippedWithAWarning) {
  SurfaceData inverted = makeSphere(0.1);
  for (auto& t : inverted.triangles) std::swap(t[1], t[2]);
  const Reference ref = polyhedralReference(makeSphere(0.1));
  FillReport rep;
  const VolumeCloud c = fillInterior(inverted, FillOptions{}, &rep);
  ASSERT_EQ(rep.warnings.size(), 1u);
  EXPECT_NE(rep.warnings[0].find("normals point inwards"), std::string::npos) << rep.warnings[0];
  EXPECT_TRUE(rep.exact_boundary);
  EXPECT_NEAR(rep.mesh_volume_m3 / ref.volume, 1.0, 1e-12);
  EXPECT_NEAR(c.totalVolume() / ref.volume, 1.0, 1e-9);
}

TEST(BoundaryMass, MixedOrientationIsReorientedAndFilledExactly) {
  SurfaceData mixed = makeSphere(0.1);
  const std::size_t half = mixed.triangles.size() / 2;
  for (std::size_t t = 0; t < half; ++t) std::swap(mixed.triangles[t][1], mixed.triangles[t][2]);
  const Reference ref = polyhedralReference(makeSphere(0.1));
  FillReport rep;
  const VolumeCloud c = fillInterior(mixed, FillOptions{}, &rep);
  // The faces are turned to agree with their neighbours (half of them: either half), so the boundary
  // cells are exact again instead of the parity fill's whole cells.
  EXPECT_EQ(rep.repair.reoriented_faces, half);
  EXPECT_EQ(rep.topology.misoriented_edges, 0u);
  ASSERT_FALSE(rep.warnings.empty());
  EXPECT_NE(rep.warnings[0].find("re-oriented"), std::string::npos) << rep.warnings[0];
  EXPECT_TRUE(rep.exact_boundary);
  EXPECT_NEAR(rep.mesh_volume_m3 / ref.volume, 1.0, 1e-12);
  EXPECT_NEAR(c.totalVolume() / ref.volume, 1.0, 1e-9);
}
