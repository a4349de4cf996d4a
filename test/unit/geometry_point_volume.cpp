// Volumes from points and Gaussians as true as from meshes: clean spheres, tori and
// boxes given as uniform random surface samples (with and without normals, two densities) and as
// generated 3DGS-like splats (flat discs tangent to the surface, spread sizes and opacities) filled
// at default options, against their closed-form volumes; the digital twin's scan against the twin's
// exact volume; a real 3DGS model (donut_3dgs.ply) at two spacings; the boundary particles' volume
// V_i = f_i h³ (the inside fraction of their cell), so the volume does not jump with the spacing;
// the closed-form cell fraction and the Euclidean distance transform the boundary is built from.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <functional>
#include <random>

#include "shared_data.h"
#include "topo_gaussian/geometry/ingest.h"
#include "topo_gaussian/geometry/interior_fill.h"
#include "topo_gaussian/geometry/surface_field.h"
#include "topo_gaussian/geometry/surface_reader.h"
#include "topo_gaussian/physics/default_shapes.h"
#include "topo_gaussian/workflow/rig_twin.h"

using namespace topo_gaussian;
using namespace topo_gaussian::geometry;

namespace {

// A closed surface that can be sampled uniformly by area: a random point and its outward normal.
struct Shape {
  std::string name;
  double volume_m3;
  double area_m2;
  std::function<void(std::mt19937&, Eigen::Vector3d*, Eigen::Vector3d*)> sample;
};

Shape sphere(double R) {
  return {"sphere", 4.0 / 3.0 * M_PI * R * R * R, 4.0 * M_PI * R * R,
          [R](std::mt19937& g, Eigen::Vector3d* p, Eigen::Vector3d* n) {
            std::normal_distribution<double> N;
            Eigen::Vector3d v(N(g), N(g), N(g));
            *n = v.normalized();
            *p = R * *n;
          }};
}

// Torus about z: tube centre radius a, tube radius b. Area element ∝ (a + b cos v): rejection.
Shape torus(double a, double b) {
  return {"torus", 2.0 * M_PI * M_PI * a * b * b, 4.0 * M_PI * M_PI * a * b,
          [a, b](std::mt19937& g, Eigen::Vector3d* p, Eigen::Vector3d* n) {
            std::uniform_real_distribution<double> U(0.0, 1.0);
            double u, v;
            do {
              u = 2 * M_PI * U(g);
              v = 2 * M_PI * U(g);
            } while (U(g) * (a + b) > a + b * std::cos(v));
            *n = Eigen::Vector3d(std::cos(v) * std::cos(u), std::cos(v) * std::sin(u), std::sin(v));
            *p = Eigen::Vector3d(a * std::cos(u), a * std::sin(u), 0.0) + b * *n;
          }};
}

// Box of edge lengths e, rotated (a box aligned with the lattice would be too easy).
Shape box(const Eigen::Vector3d& e) {
  const Eigen::Matrix3d Rot = (Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 3).normalized())).toRotationMatrix();
  const double areas[3] = {e.y() * e.z(), e.x() * e.z(), e.x() * e.y()};
  const double A = 2.0 * (areas[0] + areas[1] + areas[2]);
  return {"box", e.prod(), A, [e, Rot, areas, A](std::mt19937& g, Eigen::Vector3d* p, Eigen::Vector3d* n) {
            std::uniform_real_distribution<double> U(0.0, 1.0);
            double t = U(g) * A / 2.0;
            int axis = 0;
            while (axis < 2 && t > areas[axis]) t -= areas[axis++];
            Eigen::Vector3d q((U(g) - 0.5) * e.x(), (U(g) - 0.5) * e.y(), (U(g) - 0.5) * e.z());
            const double side = U(g) < 0.5 ? -1.0 : 1.0;
            q[axis] = side * 0.5 * e[axis];
            Eigen::Vector3d nn = Eigen::Vector3d::Zero();
            nn[axis] = side;
            *p = Rot * q;
            *n = Rot * nn;
          }};
}

// Uniform random samples of the surface, about `spacing` apart (areal density 1/spacing²).
SurfaceData pointCloud(const Shape& s, double spacing, bool normals, unsigned seed) {
  std::mt19937 g(seed);
  SurfaceData d;
  d.kind = SurfaceKind::Points;
  d.source = s.name + " points";
  const std::size_t n = std::size_t(s.area_m2 / (spacing * spacing));
  for (std::size_t i = 0; i < n; ++i) {
    Eigen::Vector3d p, nn;
    s.sample(g, &p, &nn);
    d.points.push_back(p);
    if (normals) d.normals.push_back(nn);
  }
  return d;
}

// Splats like a trained 3DGS: centres on the surface, flat discs tangent to it (thickness 5 % of
// their width), widths (standard deviations) spread log-normally about the spacing, random spin about
// the normal, opacities spread over [0.3, 1]. The surface is then opaque as a trained model's is:
// Σ α_i G_i ≈ 0.65 · 2π σ²/s² ≈ 4 along a ray through it (transmittance e^−4 ≈ 2 %).
SurfaceData gaussianCloud(const Shape& s, double spacing, unsigned seed) {
  std::mt19937 g(seed);
  std::lognormal_distribution<double> width(0.0, 0.3);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  SurfaceData d;
  d.kind = SurfaceKind::Gaussians;
  d.source = s.name + " gaussians";
  d.sh_degree = 0;
  const std::size_t n = std::size_t(s.area_m2 / (spacing * spacing));
  for (std::size_t i = 0; i < n; ++i) {
    Eigen::Vector3d p, nn;
    s.sample(g, &p, &nn);
    const Eigen::Quaterniond q = Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), nn) *
                                 Eigen::Quaterniond(Eigen::AngleAxisd(2 * M_PI * U(g), Eigen::Vector3d::UnitZ()));
    d.points.push_back(p);
    d.rotations.emplace_back(q.w(), q.x(), q.y(), q.z());
    const double w = spacing * width(g);
    d.scales.emplace_back(w, spacing * width(g), 0.05 * w);
    d.opacity.push_back(0.3 + 0.7 * U(g));
    d.covariances.push_back(gaussianCovariance(d.scales.back(), d.rotations.back()));
  }
  return d;
}

std::vector<Shape> shapes() { return {sphere(0.05), torus(0.06, 0.025), box(Eigen::Vector3d(0.1, 0.07, 0.05))}; }

// Relative volume error of a default fill.
double volumeError(const SurfaceData& s, double truth, FillReport* rep = nullptr) {
  FillReport local;
  const VolumeCloud c = fillInterior(s, FillOptions{}, rep ? rep : &local);
  return c.totalVolume() / truth - 1.0;
}

}  // namespace

TEST(PointVolume, RandomPointCloudsWithinTwoPercent) {
  for (const Shape& s : shapes())
    for (double spacing : {0.0025, 0.0015})
      for (bool normals : {true, false}) {
        FillReport rep;
        const double e = volumeError(pointCloud(s, spacing, normals, 7), s.volume_m3, &rep);
        std::printf("[points] %-6s spacing %.4f m normals %d: %zu particles h %.4f  volume error %+.2f %%\n",
                    s.name.c_str(), spacing, int(normals), rep.particles_out, rep.spacing_m, 100 * e);
        EXPECT_NEAR(e, 0.0, 0.02) << s.name << " spacing " << spacing << " normals " << normals;
      }
}

TEST(PointVolume, GaussianSplatsWithinTwoPercent) {
  for (const Shape& s : shapes())
    for (double spacing : {0.0025, 0.0015}) {
      FillReport rep;
      const double e = volumeError(gaussianCloud(s, spacing, 11), s.volume_m3, &rep);
      std::printf("[gaussians] %-6s spacing %.4f m: %zu particles h %.4f  volume error %+.2f %%\n", s.name.c_str(),
                  spacing, rep.particles_out, rep.spacing_m, 100 * e);
      EXPECT_NEAR(e, 0.0, 0.02) << s.name << " spacing " << spacing;
    }
}

// The twin's scan (rig_simulator publishes it on surface_cloud; cloud_ingest fills it) against the
// twin shape's exact volume, at the demo's 4 mm and the twin's 2.5 mm.
TEST(PointVolume, TwinScanWithinFivePercent) {
  workflow::RigTwinOptions o;
  o.task_dir = std::string(TOPO_SOURCE_DIR) + "/config/tasks";
  const workflow::RigTwin twin(o);
  SurfaceData scan;
  scan.source = "twin scan";
  scan.points = twin.scanPoints();
  scan.normals = twin.scanNormals();
  const double truth = defaultShape("tumbler").volume_m3;
  for (double h : {0.004, 0.0025}) {
    IngestOptions io;
    io.fill.spacing_m = h;
    const IngestResult r = ingestSurface(scan, io);
    const double e = r.cloud.totalVolume() / truth - 1.0;
    std::printf("[twin scan] %zu points, spacing %.4f m: %zu particles, volume error %+.2f %%\n", scan.size(), h,
                r.cloud.size(), 100 * e);
    EXPECT_NEAR(e, 0.0, 0.05) << "spacing " << h;
  }
}

TEST(PointVolume, DonutConsistentBetweenSpacings) {
  TOPO_SHARED_FILE(path, "gaussians/donut_3dgs.ply");
  const SurfaceData donut = readSurface(path);
  double v[2];
  int k = 0;
  for (double h : {0.003, 0.006}) {
    IngestOptions io;
    io.fill.spacing_m = h;
    const IngestResult r = ingestSurface(donut, io);
    v[k++] = r.cloud.totalVolume();
    std::printf("[donut] spacing %.4f m: %zu particles, volume %.5g m^3\n", h, r.cloud.size(), r.cloud.totalVolume());
  }
  EXPECT_NEAR(v[1] / v[0], 1.0, 0.05);
}

// The closed-form inside fraction of a cube cut by a plane (surface_field.h) against its exact
// values: a plane parallel to a face at height t keeps t; a corner cut x + y + z ≤ α (α ≤ 1) keeps
// the simplex α³/6; a plane through the centre keeps ½ whatever its tilt (the cube's symmetry); an
// edge cut x + y ≤ β (β ≤ 1) keeps β²/2.
TEST(SurfaceField, CubeFractionBelowPlaneClosedForms) {
  for (double t : {0.0, 1e-9, 0.05, 0.3, 0.5, 0.77, 1.0}) {
    // f_c + (z − ½) ≤ 0  ⇔  z ≤ ½ − f_c = t, along each axis and with the gradient's sign flipped
    // (then the inside is z ≥ 1 − t: the same fraction).
    for (int axis = 0; axis < 3; ++axis) {
      Eigen::Vector3d g = Eigen::Vector3d::Zero();
      g[axis] = 1.0;
      EXPECT_NEAR(cubeFractionBelowPlane(0.5 - t, g), t, 1e-12) << "axis " << axis << " t " << t;
      EXPECT_NEAR(cubeFractionBelowPlane(0.5 - t, -g), t, 1e-12) << "axis " << axis << " t " << t;
      EXPECT_NEAR(cubeFractionBelowPlane(3.0 * (0.5 - t), 3.0 * g), t, 1e-12) << "scaled, t " << t;
    }
  }
  for (double a : {1e-3, 0.1, 0.5, 0.9, 1.0}) {
    // f_c + (x + y + z − 3/2) ≤ 0  ⇔  x + y + z ≤ 3/2 − f_c = α.
    EXPECT_NEAR(cubeFractionBelowPlane(1.5 - a, Eigen::Vector3d(1, 1, 1)), a * a * a / 6.0, 1e-12) << a;
    // x + y ≤ β: a prism of area β²/2.
    EXPECT_NEAR(cubeFractionBelowPlane(1.0 - a, Eigen::Vector3d(1, 1, 0)), a * a / 2.0, 1e-12) << a;
  }
  for (const Eigen::Vector3d& g :
       {Eigen::Vector3d(1, 2, 3), Eigen::Vector3d(-0.3, 0.1, 5), Eigen::Vector3d(1, 1e-9, 0.4)})
    EXPECT_NEAR(cubeFractionBelowPlane(0.0, g), 0.5, 1e-12) << g.transpose();
  EXPECT_EQ(cubeFractionBelowPlane(-1.0, Eigen::Vector3d::Zero()), 1.0);
  EXPECT_EQ(cubeFractionBelowPlane(1.0, Eigen::Vector3d::Zero()), 0.0);
}

// The Euclidean distance transform (depth below a density shell in metres) against brute force on
// a random set of seed cells, and on a lattice with no seed.
TEST(SurfaceField, EuclideanDistanceMatchesBruteForce) {
  Lattice L;
  L.origin = Eigen::Vector3d(-0.1, 0.2, 0.05);
  L.h = 0.003;
  L.n = {17, 11, 9};
  std::mt19937 g(3);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  std::vector<std::uint8_t> seeds(L.cells(), 0);
  std::vector<Eigen::Vector3d> centres;
  for (int k = 0; k < L.n[2]; ++k)
    for (int j = 0; j < L.n[1]; ++j)
      for (int i = 0; i < L.n[0]; ++i)
        if (U(g) < 0.01) {
          seeds[L.index(i, j, k)] = 1;
          centres.push_back(L.center(i, j, k));
        }
  ASSERT_GT(centres.size(), 5u);
  const std::vector<float> d = euclideanDistance(L, seeds);
  double worst = 0.0;
  for (int k = 0; k < L.n[2]; ++k)
    for (int j = 0; j < L.n[1]; ++j)
      for (int i = 0; i < L.n[0]; ++i) {
        double best = 1e300;
        for (const auto& c : centres) best = std::min(best, (c - L.center(i, j, k)).norm());
        worst = std::max(worst, std::abs(double(d[L.index(i, j, k)]) - best));
      }
  EXPECT_LT(worst, 1e-7);  // float storage of distances up to ~0.06 m
  const std::vector<float> none = euclideanDistance(L, std::vector<std::uint8_t>(L.cells(), 0));
  EXPECT_TRUE(std::isinf(none[0]) && std::isinf(none.back()));
  // Trilinear interpolation between cell centres is exact for a linear field.
  std::vector<float> lin(L.cells());
  for (int k = 0; k < L.n[2]; ++k)
    for (int j = 0; j < L.n[1]; ++j)
      for (int i = 0; i < L.n[0]; ++i) lin[L.index(i, j, k)] = float(L.center(i, j, k).dot(Eigen::Vector3d(1, -2, 3)));
  const Eigen::Vector3d x = L.origin + L.h * Eigen::Vector3d(5.3, 4.71, 2.2);
  EXPECT_NEAR(interpolateCells(L, lin, x, 0.0), x.dot(Eigen::Vector3d(1, -2, 3)), 1e-6);
  EXPECT_EQ(interpolateCells(L, lin, L.origin - Eigen::Vector3d::Constant(1.0), -7.0), -7.0);
}

// A scan much denser than the field's kernel is binned (cubes of r/2) before the signed distance:
// the field at the nodes near the surface must stay what the raw points give. A 600k-point sphere
// (R 5 cm, 0.23 mm apart, exact normals) and a 1 mm kernel (the fill's 0.25 h at h 4 mm): the
// binned field's worst difference at the nodes within 2 r of the surface is held to 0.2 % of r (6e-4 r measured; a
// cube's points are replaced by their mean: the error is O((cube / r)²) of r, and mostly cancels
// between the weighted sums). Weights add up, and points of weight 0 are left out.
TEST(SurfaceField, BinnedDenseScanKeepsTheField) {
  const double R = 0.05, r = 0.001;
  const int n = 600000;
  OrientedPoints p;
  for (int i = 0; i < n; ++i) {
    const double z = 1.0 - 2.0 * (i + 0.5) / n, rho = std::sqrt(1.0 - z * z), phi = M_PI * (3.0 - std::sqrt(5.0)) * i;
    const Eigen::Vector3d d(rho * std::cos(phi), rho * std::sin(phi), z);
    p.points.push_back(R * d);
    p.normals.push_back(d);
    p.weights.push_back(i % 50 == 0 ? 0.0 : 1.0);
  }
  const OrientedPoints b = binnedPoints(p, 0.5 * r);
  double w_raw = 0.0, w_binned = 0.0;
  for (double w : p.weights) w_raw += w;
  for (double w : b.weights) w_binned += w;
  EXPECT_NEAR(w_binned, w_raw, 1e-6 * w_raw);
  EXPECT_GT(double(n) / double(b.points.size()), 3.0) << "the test cloud must be dense for the fill to bin it";
  Lattice L;
  L.h = 0.004;
  L.origin = Eigen::Vector3d::Constant(-0.058);
  L.n = {29, 29, 29};
  const std::vector<double> f_raw = nodeSignedDistance(p, L, r, 2.5 * L.h);
  const std::vector<double> f_bin = nodeSignedDistance(b, L, r, 2.5 * L.h);
  double worst = 0.0;
  int nodes = 0;
  for (int k = 0; k <= L.n[2]; ++k)
    for (int j = 0; j <= L.n[1]; ++j)
      for (int i = 0; i <= L.n[0]; ++i) {
        const Eigen::Vector3d x = L.origin + L.h * Eigen::Vector3d(i, j, k);
        if (std::abs(x.norm() - R) > 2.0 * r) continue;
        const std::size_t q = (std::size_t(k) * (L.n[1] + 1) + j) * (L.n[0] + 1) + i;
        ASSERT_TRUE(std::isfinite(f_raw[q]) && std::isfinite(f_bin[q]));
        worst = std::max(worst, std::abs(f_bin[q] - f_raw[q]));
        ++nodes;
      }
  std::printf("dense sphere: %d points -> %zu cubes; field at %d nodes near the surface: worst |binned - raw| %.3g r\n",
              n, b.points.size(), nodes, worst / r);
  EXPECT_GT(nodes, 1000);
  EXPECT_LT(worst, 0.002 * r);
}
