// Meshes of the default soft-body shapes (finger, pear, beam, tumbler): watertight and outward,
// the same solids as the lattice clouds, and `topo shape` end to end.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cstdlib>
#include <functional>
#include <iostream>
#include <map>
#include <utility>

#include "test_util.h"
#include "topo_gaussian/common/error.h"
#include "topo_gaussian/geometry/mesh_fill.h"
#include "topo_gaussian/geometry/mesh_metrics.h"
#include "topo_gaussian/geometry/shape_generator.h"
#include "topo_gaussian/geometry/surface_reader.h"
#include "topo_gaussian/io/volume_ply.h"
#include "topo_gaussian/physics/default_shapes.h"

using namespace topo_gaussian;
using namespace topo_gaussian::geometry;
using topo_test::errorOf;
using topo_test::runTopo;
using topo_test::ToolRun;

namespace {

// Every directed edge used once and its reverse used once: each undirected edge is shared by
// exactly two triangles with opposite orientation. Returns the number of violations.
std::size_t watertightViolations(const SurfaceData& m) {
  std::map<std::pair<int, int>, int> directed;
  for (const auto& t : m.triangles)
    for (int e = 0; e < 3; ++e) ++directed[{t[e], t[(e + 1) % 3]}];
  std::size_t bad = 0;
  for (const auto& [edge, count] : directed) {
    const auto rev = directed.find({edge.second, edge.first});
    if (count != 1 || rev == directed.end() || rev->second != 1) ++bad;
  }
  return bad;
}

std::size_t degenerateTriangles(const SurfaceData& m) {
  std::size_t bad = 0;
  for (const auto& t : m.triangles) {
    const Eigen::Vector3d a = m.points[t[0]], b = m.points[t[1]], c = m.points[t[2]];
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2] || (b - a).cross(c - a).norm() < 1e-14) ++bad;
  }
  return bad;
}

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

}  // namespace

TEST(DefaultShapeMesh, WatertightOutwardAndOnTheSolidsSurface) {
  for (const auto& name : defaultShapeNames()) {
    const DefaultShape shape = defaultShape(name);
    const SurfaceData m = makeDefaultShapeMesh(name);
    EXPECT_EQ(m.kind, SurfaceKind::Mesh);
    ASSERT_GT(m.triangles.size(), 0u) << name;
    EXPECT_EQ(watertightViolations(m), 0u) << name;
    EXPECT_EQ(degenerateTriangles(m), 0u) << name;
    const MeshTopology topo = analyseMesh(m);
    EXPECT_TRUE(topo.closed()) << name;
    EXPECT_EQ(topo.nonmanifold_edges, 0u) << name;
    // closed genus-0 surface: V − E + F = 2
    EXPECT_EQ(long(m.points.size()) - long(topo.edges) + long(m.triangles.size()), 2) << name;
    const MeshIntegrals I = meshIntegrals(m);
    EXPECT_GT(I.volume, 0.0) << name << " must be outward oriented";
    EXPECT_NEAR(I.volume / shape.volume_m3, 1.0, 0.01) << name;
    Eigen::Vector3d lo, hi;
    surfaceBounds(m, &lo, &hi);
    EXPECT_LT((lo - shape.lo).cwiseAbs().maxCoeff(), 5e-4) << name;
    EXPECT_LT((hi - shape.hi).cwiseAbs().maxCoeff(), 5e-4) << name;
    // every vertex is on the solid's boundary: just inside towards the centroid, just outside away
    // from it (all four solids are star-shaped about their centroid)
    std::size_t off_surface = 0;
    for (const auto& v : m.points) {
      const Eigen::Vector3d d = v - I.centroid;
      if (!shape.inside(I.centroid + d * (1 - 1e-6)) || shape.inside(I.centroid + d * (1 + 1e-6))) ++off_surface;
    }
    EXPECT_EQ(off_surface, 0u) << name;
    std::cout << name << ": " << m.points.size() << " vertices, " << m.triangles.size() << " triangles, mesh volume "
              << I.volume << " m^3, exact " << shape.volume_m3 << " (" << 100 * (I.volume / shape.volume_m3 - 1)
              << " %)\n";
  }
}

TEST(DefaultShapeMesh, VolumeMatchesTheLatticeCloud) {
  const std::map<std::string, double> spacing{
      {"beam", 0.001}, {"finger", 0.001}, {"pear", 0.0015}, {"tumbler", 0.0015}};
  for (const auto& name : defaultShapeNames()) {
    const double mesh_volume = meshIntegrals(makeDefaultShapeMesh(name, 128)).volume;
    const VolumeCloud c = defaultShapeCloud(name, spacing.at(name));
    EXPECT_NEAR(c.totalVolume() / mesh_volume, 1.0, 0.03) << name;
    std::cout << name << ": mesh (resolution 128) " << mesh_volume << " m^3, cloud at " << 1000 * spacing.at(name)
              << " mm " << c.size() << " particles " << c.totalVolume() << " m^3 ("
              << 100 * (c.totalVolume() / mesh_volume - 1) << " %)\n";
  }
}

TEST(DefaultShapeMesh, ResolutionConvergesAndBadInputIsRefused) {
  for (const std::string name : {"finger", "pear", "tumbler"}) {
    const double exact = defaultShape(name).volume_m3;
    const double coarse = std::abs(meshIntegrals(makeDefaultShapeMesh(name, 16)).volume / exact - 1);
    const double fine = std::abs(meshIntegrals(makeDefaultShapeMesh(name, 256)).volume / exact - 1);
    EXPECT_LT(fine, 0.25 * coarse) << name;
    EXPECT_LT(fine, 5e-4) << name;  // inscribed polygons: ~(2π/N)²/6 around, the same along the profile
    EXPECT_EQ(watertightViolations(makeDefaultShapeMesh(name, 8)), 0u) << name;
  }
  const std::string unknown = errorOf([] { makeDefaultShapeMesh("banana"); });
  EXPECT_TRUE(contains(unknown, "finger, pear, beam, tumbler")) << unknown;
  EXPECT_TRUE(contains(errorOf([] { makeDefaultShapeMesh("pear", 4); }), "8 to 4096"));
  // the older generator is unchanged
  for (const auto& n : shapeNames()) EXPECT_TRUE(analyseMesh(makeShape(n, 0.1)).closed()) << n;
}

TEST(DefaultShapeCli, ShapeWritesMeshAndVolume) {
  const std::string dir = testing::TempDir() + "/topo_shape_cli";
  std::system(("mkdir -p " + dir).c_str());
  const ToolRun r = runTopo("shape finger --output " + dir + "/finger.obj");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(contains(r.out, "[topo shape] wrote " + dir + "/finger.obj")) << r.out;
  EXPECT_TRUE(contains(r.out, "triangles, volume")) << r.out;
  const SurfaceData back = readSurface(dir + "/finger.obj");
  EXPECT_EQ(back.kind, SurfaceKind::Mesh);
  EXPECT_TRUE(analyseMesh(back).closed());
  const double exact = defaultShape("finger").volume_m3;
  EXPECT_NEAR(meshIntegrals(back).volume / exact, 1.0, 0.01);

  const ToolRun v = runTopo("shape tumbler --output " + dir +
                            "/tumbler.obj --resolution 32 --spacing 0.0025 --volume " + dir + "/tumbler.ply");
  ASSERT_EQ(v.code, 0) << v.out;
  EXPECT_TRUE(contains(v.out, "particles")) << v.out;
  const VolumeCloud cloud = io::readVolumePly(dir + "/tumbler.ply");
  const VolumeCloud expected = defaultShapeCloud("tumbler", 0.0025);
  EXPECT_EQ(cloud.size(), expected.size());
  EXPECT_NEAR(cloud.totalVolume() / expected.totalVolume(), 1.0, 1e-5);  // volumes stored as float
  EXPECT_EQ(cloud.surfaceCount(), expected.surfaceCount());
  EXPECT_EQ(readSurface(dir + "/tumbler.obj").size(), makeDefaultShapeMesh("tumbler", 32).size());

  const ToolRun help = runTopo("shape --help");
  EXPECT_EQ(help.code, 0);
  for (const char* s : {"finger", "pear", "beam", "tumbler", "metres", "m^3", "--resolution", "--spacing", "--volume"})
    EXPECT_TRUE(contains(help.out, s)) << s << "\n" << help.out;
  EXPECT_TRUE(contains(runTopo("--help").out, "shape"));
}

TEST(DefaultShapeCli, ErrorsHaveTheRightExitCodeAndMessage) {
  const std::string dir = testing::TempDir() + "/topo_shape_cli";
  std::system(("mkdir -p " + dir).c_str());
  const ToolRun unknown = runTopo("shape banana --output " + dir + "/b.obj");
  EXPECT_EQ(unknown.code, 1) << unknown.out;
  EXPECT_TRUE(contains(unknown.out, "finger, pear, beam, tumbler")) << unknown.out;
  const ToolRun coarse = runTopo("shape finger --spacing 0.01 --volume " + dir + "/f.ply");
  EXPECT_EQ(coarse.code, 1) << coarse.out;
  EXPECT_TRUE(contains(coarse.out, "at most 0.005 m")) << coarse.out;
  for (const std::string args : {"shape --output x.obj", "shape finger", "shape finger --output x.obj --resolution 3",
                                 "shape finger --output x.obj --resolution many", "shape finger --volume x.ply",
                                 "shape finger --output x.obj --spacing -1 --volume x.ply", "shape finger extra",
                                 "shape finger --output x.obj --colour red"}) {
    const ToolRun r = runTopo(args);
    EXPECT_EQ(r.code, 2) << args << "\n" << r.out;
    EXPECT_TRUE(contains(r.out, "topo shape --help")) << args << "\n" << r.out;
  }
}
