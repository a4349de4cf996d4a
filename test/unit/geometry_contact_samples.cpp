// Contact samples on the true surface (geometry/contact_samples.h): they lie on the input surface,
// their normals point out, their areas sum to the surface's area, they are evenly spread, they travel
// in volume.ply, and bad surfaces (inverted, floaters, holes, nothing on the body) are named.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>

#include "test_clouds.h"
#include "test_util.h"
#include "topo_gaussian/common/error.h"
#include "topo_gaussian/geometry/contact_samples.h"
#include "topo_gaussian/geometry/interior_fill.h"
#include "topo_gaussian/geometry/shape_generator.h"
#include "topo_gaussian/io/text_file.h"
#include "topo_gaussian/io/volume_ply.h"
#include "topo_gaussian/physics/default_shapes.h"
#include "topo_gaussian/physics/neighbor_list.h"

using namespace topo_gaussian;
using namespace topo_gaussian::geometry;

namespace {

double meshArea(const SurfaceData& m) {
  double a = 0.0;
  for (const auto& t : m.triangles)
    a += 0.5 * (m.points[t[1]] - m.points[t[0]]).cross(m.points[t[2]] - m.points[t[0]]).norm();
  return a;
}

bool hasWarning(const std::vector<std::string>& w, const std::string& part) {
  for (const auto& s : w)
    if (s.find(part) != std::string::npos) return true;
  return false;
}

/// Median and 10th/90th percentiles of the nearest-neighbour distances.
void nearestNeighbourSpread(const std::vector<Eigen::Vector3d>& X, double cell, double* p10, double* p50, double* p90) {
  const SpatialGrid grid(X, cell);
  std::vector<double> d;
  for (std::size_t i = 0; i < X.size(); ++i) {
    double best = 1e300;
    grid.query(X[i], [&](int j, const Eigen::Vector3d& x) {
      if (std::size_t(j) != i) best = std::min(best, (x - X[i]).norm());
    });
    if (best < 1e299) d.push_back(best);
  }
  std::sort(d.begin(), d.end());
  *p10 = d[d.size() / 10];
  *p50 = d[d.size() / 2];
  *p90 = d[d.size() * 9 / 10];
}

}  // namespace

// A closed sphere mesh: samples on its faces (within the faces' sagitta of the sphere), normals along
// the radius, areas summing to the mesh area, ~1 sample per s² with nearest neighbours 0.7–1.3 s apart.
TEST(ContactSamples, MeshSamplesLieOnTheSurfaceEvenlyWithTheirAreas) {
  const double R = 0.05;
  const SurfaceData mesh = makeSphere(R, 128, 64);
  FillOptions o;
  FillReport rep;
  const VolumeCloud cloud = fillInterior(mesh, o, &rep);
  const ContactSamples& c = cloud.contact;
  ASSERT_FALSE(c.empty());
  EXPECT_EQ(c.origin, "mesh triangles");
  EXPECT_NEAR(c.spacing, defaultContactSpacing(cloud, SurfaceKind::Mesh), 1e-15);
  // How far the mesh itself lies inside the sphere: no point of a face is deeper than its plane's
  // distance from the centre (the default samples are finer than the faces, so they show the faces).
  double sagitta = 0.0;
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3d &a = mesh.points[t[0]], &b = mesh.points[t[1]], &d = mesh.points[t[2]];
    const Eigen::Vector3d n = (b - a).cross(d - a);
    if (n.norm() > 0) sagitta = std::max(sagitta, R - std::abs(n.normalized().dot(a)));
  }
  double worst_r = 0.0, worst_n = 1.0;
  for (std::size_t k = 0; k < c.size(); ++k) {
    worst_r = std::max(worst_r, std::abs(c.X[k].norm() - R));
    worst_n = std::min(worst_n, c.normal[k].dot(c.X[k].normalized()));
  }
  // Lloyd moves a sample to its candidates' centroid (a patch of radius ≲ 2 · 0.85 s), inside the
  // curved surface by ≲ (1.7 s)² / (4 R).
  EXPECT_LT(worst_r, sagitta + 0.75 * c.spacing * c.spacing / R);
  EXPECT_GT(worst_n, 0.99);
  EXPECT_NEAR(c.totalArea() / meshArea(mesh), 1.0, 1e-9);
  EXPECT_NEAR(rep.contact_area_m2 / meshArea(mesh), 1.0, 1e-9);
  const double per_area = double(c.size()) * c.spacing * c.spacing / c.totalArea();
  EXPECT_GT(per_area, 0.75);  // a maximal disk set of radius 0.85 s holds ~0.96 / s², less after Lloyd
  EXPECT_LT(per_area, 1.5);
  double p10, p50, p90;
  nearestNeighbourSpread(c.X, 2.0 * c.spacing, &p10, &p50, &p90);
  std::printf("sphere R %.3f m: %zu samples at s = %.3g m; nearest neighbour p10 %.3f s, median %.3f s, p90 %.3f s\n",
              R, c.size(), c.spacing, p10 / c.spacing, p50 / c.spacing, p90 / c.spacing);
  EXPECT_GT(p10, 0.6 * c.spacing);
  EXPECT_LT(p90, 1.3 * c.spacing);
  double amin = 1e300, amax = 0.0;
  for (double a : c.area) amin = std::min(amin, a), amax = std::max(amax, a);
  // Areas vary (Lloyd cells at face seams and the poles); the ground contact weights each by its area.
  EXPECT_LT(amax / amin, 8.0) << "areas " << amin << " .. " << amax;
}

// An explicit --contact-spacing is used; a finer one gives more samples with the same area.
TEST(ContactSamples, SpacingOptionIsHonoured) {
  const SurfaceData mesh = makeBox(Eigen::Vector3d(0.1, 0.06, 0.04));
  FillOptions o;
  o.contact.spacing_m = 0.004;
  const VolumeCloud coarse = fillInterior(mesh, o);
  o.contact.spacing_m = 0.002;
  const VolumeCloud fine = fillInterior(mesh, o);
  const double area = 2 * (0.1 * 0.06 + 0.1 * 0.04 + 0.06 * 0.04);
  EXPECT_NEAR(coarse.contact.totalArea() / area, 1.0, 1e-9);
  EXPECT_NEAR(fine.contact.totalArea() / area, 1.0, 1e-9);
  EXPECT_NEAR(double(fine.contact.size()) / double(coarse.contact.size()), 4.0, 0.6);
  o.contact.enabled = false;
  EXPECT_TRUE(fillInterior(mesh, o).contact.empty());
  o.contact.enabled = true;
  o.contact.spacing_m = std::nan("");
  EXPECT_THROW(fillInterior(mesh, o), TopoError);
}

// A mesh whose faces all point inwards: the samples' normals still point out, and the fill says so.
TEST(ContactSamples, InvertedMeshIsNamedAndItsNormalsTurnedOut) {
  SurfaceData mesh = makeSphere(0.05, 64, 32);
  for (auto& t : mesh.triangles) std::swap(t[1], t[2]);
  mesh.source = "inverted.obj";
  FillReport rep;
  const VolumeCloud cloud = fillInterior(mesh, FillOptions{}, &rep);
  EXPECT_TRUE(hasWarning(rep.warnings, "point inwards")) << ::testing::PrintToString(rep.warnings);
  for (std::size_t k = 0; k < cloud.contact.size(); ++k)
    ASSERT_GT(cloud.contact.normal[k].dot(cloud.contact.X[k].normalized()), 0.9) << "sample " << k;
}

// A noisy point cloud of a sphere with floaters: the floaters are not samples (and are counted in a
// warning), the samples are smoothed onto the sphere (scatter well below the noise).
TEST(ContactSamples, PointCloudSamplesAreSmoothedAndFloatersLeftOut) {
  const double R = 0.05, noise = 0.0003;
  SurfaceData s;
  s.kind = SurfaceKind::Points;
  s.source = "noisy sphere";
  std::mt19937 rng(7);
  std::normal_distribution<double> g(0.0, 1.0);
  for (int i = 0; i < 40000; ++i) {
    Eigen::Vector3d d(g(rng), g(rng), g(rng));
    d.normalize();
    s.points.push_back((R + noise * g(rng)) * d);
  }
  for (int i = 0; i < 20; ++i) s.points.push_back(Eigen::Vector3d(0.2 + 0.001 * i, 0.2, 0.2));  // floaters
  FillReport rep;
  const VolumeCloud cloud = fillInterior(s, FillOptions{}, &rep);
  const ContactSamples& c = cloud.contact;
  ASSERT_FALSE(c.empty());
  EXPECT_EQ(c.origin, "points");
  double sum2 = 0.0;
  std::vector<double> along;
  for (std::size_t k = 0; k < c.size(); ++k) {
    ASSERT_LT(c.X[k].norm(), 0.1) << "a floater became a contact sample";
    sum2 += std::pow(c.X[k].norm() - R, 2);
    along.push_back(c.normal[k].dot(c.X[k].normalized()));
  }
  std::sort(along.begin(), along.end());
  const double worst_n = along[along.size() / 1000];  // 0.1 % quantile: noise flips a few plane fits
  const double rms = std::sqrt(sum2 / double(c.size()));
  std::printf("noisy sphere (noise %.2g m): %zu samples, radial RMS %.3g m, area %.4g m^2 (exact %.4g)\n", noise,
              c.size(), rms, c.totalArea(), 4 * M_PI * R * R);
  EXPECT_LT(rms, 0.5 * noise);
  EXPECT_GT(worst_n, 0.9);
  EXPECT_NEAR(c.totalArea() / (4 * M_PI * R * R), 1.0, 0.1);
}

// A scan with a missing cap: the hole is named (where, how much) and the body keeps ground contact
// there through its lattice particles — never silently.
TEST(ContactSamples, HoleInTheSurfaceIsNamed) {
  const SurfaceData mesh = makeSphere(0.05, 96, 48);
  const VolumeCloud filled = fillInterior(mesh, FillOptions{});
  SurfaceData scan;
  scan.kind = SurfaceKind::Points;
  scan.source = "holed scan";
  for (const auto& x : fillInterior(mesh, FillOptions{}).contact.X)
    if (x.z() > -0.04) scan.points.push_back(x);  // the bottom cap (z < −0.04 m) was not scanned
  std::vector<std::string> warnings;
  const ContactSamples c = sampleContactSurface(scan, filled, ContactSampleOptions{}, &warnings);
  ASSERT_TRUE(hasWarning(warnings, "has a hole")) << ::testing::PrintToString(warnings);
  double lowest = 0.0;
  for (const auto& x : c.X) lowest = std::min(lowest, x.z());
  EXPECT_LT(lowest, -0.045) << "the hole's lattice particles carry the contact";
}

// A surface that does not touch the filled body gives no samples: an error naming it.
TEST(ContactSamples, SurfaceAwayFromTheBodyIsRefused) {
  const VolumeCloud filled = fillInterior(makeSphere(0.05, 64, 32), FillOptions{});
  SurfaceData far;
  far.kind = SurfaceKind::Points;
  far.source = "other_object.ply";
  for (int i = 0; i < 100; ++i) far.points.push_back(Eigen::Vector3d(1.0 + 0.001 * i, 1.0, 1.0));
  try {
    sampleContactSurface(far, filled, ContactSampleOptions{}, nullptr);
    FAIL() << "expected TopoError";
  } catch (const TopoError& e) {
    EXPECT_NE(std::string(e.what()).find("other_object.ply"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("no contact samples"), std::string::npos) << e.what();
  }
}

// volume.ply carries the samples (element contact); a file without them still reads (empty); a
// truncated contact element is named.
TEST(ContactSamples, VolumePlyRoundTripAndOldFiles) {
  const VolumeCloud cloud = fillInterior(makeSphere(0.05, 64, 32), FillOptions{});
  const std::string path = ::testing::TempDir() + "contact_roundtrip.ply";
  io::writeVolumePly(cloud, path);
  const VolumeCloud back = io::readVolumePly(path);
  ASSERT_EQ(back.contact.size(), cloud.contact.size());
  EXPECT_NEAR(back.contact.spacing, cloud.contact.spacing, 1e-15);
  EXPECT_EQ(back.contact.origin, cloud.contact.origin);
  for (std::size_t k = 0; k < cloud.contact.size(); ++k) {
    ASSERT_LT((back.contact.X[k] - cloud.contact.X[k]).norm(), 1e-7);
    ASSERT_LT((back.contact.normal[k] - cloud.contact.normal[k]).norm(), 1e-6);
    ASSERT_NEAR(back.contact.area[k] / cloud.contact.area[k], 1.0, 1e-6);
  }
  VolumeCloud plain = cloud;
  plain.contact = ContactSamples{};
  io::writeVolumePly(plain, path);
  EXPECT_TRUE(io::readVolumePly(path).contact.empty());
  io::writeVolumePly(cloud, path);
  std::string bytes = io::readTextFile(path);
  bytes.resize(bytes.size() - 10 * 28);
  io::writeTextFile(path, bytes);
  try {
    io::readVolumePly(path);
    FAIL() << "expected TopoError";
  } catch (const TopoError& e) {
    EXPECT_NE(std::string(e.what()).find("contact records present"), std::string::npos) << e.what();
  }
}

// The default shapes sample their exact surface: the tumbler body's samples lie on its sphere or its
// cut, with areas summing to its exact area.
TEST(ContactSamples, DefaultShapeSamplesLieOnTheExactSurface) {
  namespace d = default_shape_dims;
  const VolumeCloud cloud = defaultShapeCloud("tumbler", 0.004);
  const ContactSamples& c = cloud.contact;
  ASSERT_FALSE(c.empty());
  const double R = d::kTumblerRadius, cut = d::kTumblerCutZ;
  for (std::size_t k = 0; k < c.size(); ++k) {
    const double on_sphere = std::abs(c.X[k].norm() - R), on_cut = std::abs(c.X[k].z() - cut);
    ASSERT_LT(std::min(on_sphere, on_cut), 1e-9) << "sample " << k;
  }
  const double cap_h = R - cut;  // the cut removes a cap of height R − c
  const double area = 4 * M_PI * R * R - 2 * M_PI * R * cap_h + M_PI * (R * R - cut * cut);
  // The crossings' areas s² |n_a| use plane-fit normals, which are poor along the rim of the cut.
  EXPECT_NEAR(c.totalArea() / area, 1.0, 0.06);
}

// A dense scan (600k points on a sphere R 5 cm, 0.23 mm apart, against a 0.5 mm contact spacing) is
// binned by cubes of s before its fits (one mean per cube instead of per s/3 cell: ~9x fewer fits
// with ~9x fewer neighbours each) and its floaters are decided per cube of s. The samples must keep
// what the sparse path gives: on the sphere (radial error well below s), evenly spread, their areas
// adding up to the sphere's (within 2 %: a count of means within a sharp radius would give −6 %), and
// the floaters counted exactly as point-by-point (points 4–12 mm out, across the 2 h = 8 mm limit; those
// within it are surface points, so the samples are checked on the scan without them).
TEST(ContactSamples, DenseScanIsBinnedAndKeepsItsSamples) {
  const double R = 0.05;
  const int n = 600000;
  SurfaceData s;
  s.kind = SurfaceKind::Points;
  s.source = "dense sphere";
  for (int i = 0; i < n; ++i) {
    const double z = 1.0 - 2.0 * (i + 0.5) / n, rho = std::sqrt(1.0 - z * z), phi = M_PI * (3.0 - std::sqrt(5.0)) * i;
    s.points.push_back(R * Eigen::Vector3d(rho * std::cos(phi), rho * std::sin(phi), z));
  }
  FillOptions fo;
  fo.spacing_m = 0.004;
  const VolumeCloud cloud = fillInterior(s, fo);
  // Floater candidates at 4–12 mm outside, and the exact count of those farther than 2 h from every
  // boundary particle.
  std::mt19937 rng(11);
  std::normal_distribution<double> g(0.0, 1.0);
  std::uniform_real_distribution<double> U(0.004, 0.012);
  std::vector<Eigen::Vector3d> boundary;
  for (std::size_t i = 0; i < cloud.size(); ++i)
    if (cloud.surface[i]) boundary.push_back(cloud.X[i]);
  SurfaceData with_floaters = s;
  std::size_t expected = 0;
  for (int i = 0; i < 400; ++i) {
    Eigen::Vector3d d(g(rng), g(rng), g(rng));
    d.normalize();
    const Eigen::Vector3d p = (R + U(rng)) * d;
    with_floaters.points.push_back(p);
    double best = 1e300;
    for (const auto& x : boundary) best = std::min(best, (x - p).norm());
    expected += !(best < 2.0 * cloud.spacing);
  }
  ASSERT_GT(expected, 20u);
  ASSERT_LT(expected, 380u) << "the candidates must straddle the 2 h limit";
  std::vector<std::string> w;
  sampleContactSurface(with_floaters, cloud, ContactSampleOptions{}, &w);
  const ContactSamples c = sampleContactSurface(s, cloud, ContactSampleOptions{}, nullptr);
  const std::string count = std::to_string(expected) + " points lie farther than 2 spacings";
  EXPECT_TRUE(hasWarning(w, count)) << "expected \"" << count << "\" in " << ::testing::PrintToString(w);
  double worst = 0.0;
  for (std::size_t k = 0; k < c.size(); ++k) {
    worst = std::max(worst, std::abs(c.X[k].norm() - R));
    ASSERT_GT(c.normal[k].dot(c.X[k].normalized()), 0.99) << "sample " << k;
  }
  double p10, p50, p90;
  nearestNeighbourSpread(c.X, 2.0 * c.spacing, &p10, &p50, &p90);
  std::printf(
      "dense sphere: %zu samples at s %.3g mm, worst radial error %.3g mm, area %+.2f %%, nearest neighbour "
      "p10/p50/p90 %.2f/%.2f/%.2f s, %zu floaters\n",
      c.size(), 1e3 * c.spacing, 1e3 * worst, 100.0 * (c.totalArea() / (4 * M_PI * R * R) - 1.0), p10 / c.spacing,
      p50 / c.spacing, p90 / c.spacing, expected);
  // Measured: 35 155 samples at s 0.851 mm, worst radial error 0.0046 s, area −0.02 %, p10/p50/p90
  // 0.87/0.99/1.11 s, 188 floaters.
  EXPECT_LT(worst, 0.01 * c.spacing);
  EXPECT_NEAR(c.totalArea() / (4 * M_PI * R * R), 1.0, 0.02);
  EXPECT_GT(p10, 0.8 * c.spacing);
  EXPECT_LT(p90, 1.2 * c.spacing);
}

// volume.ply carries the spacing the volume was filled at (comment spacing, 17 digits): read back
// exactly. A file without the comment (an older writer's) gets the one fallback, the cube root of the
// median volume, with a warning; for a small object (mostly partial boundary cells) that is 0.80 h.
TEST(ContactSamples, VolumePlyKeepsTheSpacing) {
  const VolumeCloud cloud = topo_test::smallBallCloud(0.003);
  const std::string path = ::testing::TempDir() + "spacing_roundtrip.ply";
  io::writeVolumePly(cloud, path);
  std::string warning = "not set";
  EXPECT_EQ(io::readVolumePly(path, &warning).spacing, cloud.spacing);
  EXPECT_EQ(warning, "");

  std::string bytes = io::readTextFile(path);
  const std::size_t at = bytes.find("comment spacing ");
  ASSERT_NE(at, std::string::npos);
  bytes.erase(at, bytes.find('\n', at) + 1 - at);
  io::writeTextFile(path, bytes);
  const VolumeCloud old = io::readVolumePly(path, &warning);
  EXPECT_NEAR(old.spacing, spacingFromVolumes(cloud.V), 1e-6 * cloud.spacing);  // volumes stored as float32
  EXPECT_GT(std::abs(old.spacing / cloud.spacing - 1.0), 0.02);
  EXPECT_NE(warning.find(path), std::string::npos) << warning;
  EXPECT_NE(warning.find("derived"), std::string::npos) << warning;
}
