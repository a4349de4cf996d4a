// View fusion and coverage (geometry/view_fusion.h, view_coverage.h): depth clouds of known solids
// from a simulated structured-light camera (test/unit/depth_views.h), fused and filled on the same
// path as cloud_ingest, against the solids' exact volumes; one-sided scans refused naming the hole.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <random>
#include <string>

#include "depth_views.h"
#include "topo_gaussian/common/error.h"
#include "topo_gaussian/geometry/ingest.h"
#include "topo_gaussian/geometry/view_coverage.h"
#include "topo_gaussian/geometry/view_fusion.h"

namespace {

namespace geo = topo_gaussian::geometry;
using topo_gaussian::TopoError;

/// Views of `solid` from `centre + distance * d` for each direction d, looking at the centre.
std::vector<geo::DepthView> viewsFrom(const topo_test::Solid& solid, const Eigen::Vector3d& centre,
                                      const std::vector<Eigen::Vector3d>& dirs, double distance, unsigned seed) {
  std::mt19937 rng(seed);
  std::vector<geo::DepthView> views;
  for (const auto& d : dirs) views.push_back(topo_test::depthView(solid, centre + distance * d, centre, {}, rng));
  return views;
}

/// RMS of |distance from `centre`| - R over points.
double radialRms(const std::vector<Eigen::Vector3d>& pts, const Eigen::Vector3d& centre, double R) {
  double s = 0.0;
  for (const auto& p : pts) s += std::pow((p - centre).norm() - R, 2);
  return std::sqrt(s / double(pts.size()));
}

double filledVolume(const geo::FusedViews& fused) {
  geo::IngestOptions options;  // the node's defaults
  options.fill.target_count = 8000;
  const auto r = geo::ingestSurface(fused.surface, options);
  std::cerr << "TIMING fused " << fused.voxels << " pts/voxel " << fused.mean_points_per_voxel << " voxel " << fused.voxel_m << " fill " << r.seconds << " s method " << r.fill.method << "\n";
  return r.cloud.totalVolume();
}

const Eigen::Vector3d kSphereCentre(0.1, -0.05, 0.3);
constexpr double kSphereR = 0.05;

std::vector<geo::DepthView> sphereAllRound() {
  return viewsFrom(topo_test::sphereSolid(kSphereCentre, kSphereR), kSphereCentre, topo_test::allRoundDirections(),
                   0.4, 7);
}

TEST(ViewFusion, SphereSeenAllRoundAveragesTheNoiseWithOutwardNormals) {
  const auto views = sphereAllRound();
  const geo::FusedViews fused = geo::fuseViews(views, {});
  EXPECT_EQ(fused.views, 14u);
  EXPECT_GT(fused.mean_points_per_voxel, 2.0) << "the views overlap: voxels average several points";
  ASSERT_TRUE(fused.surface.hasNormals());
  // Noise averaged: the fused points lie closer to the sphere than the raw ones (sigma 0.6..0.8 mm).
  std::vector<Eigen::Vector3d> raw;
  for (const auto& v : views)
    for (const auto& p : v.points)
      if (p.allFinite()) raw.push_back(v.world_from_sensor * p);
  const double raw_rms = radialRms(raw, kSphereCentre, kSphereR);
  const double fused_rms = radialRms(fused.surface.points, kSphereCentre, kSphereR);
  EXPECT_LT(fused_rms, 0.4 * raw_rms) << "raw " << raw_rms << " m, fused " << fused_rms << " m";
  // Normals point out of the sphere.
  int outward = 0;
  for (std::size_t i = 0; i < fused.surface.size(); ++i)
    outward += fused.surface.normals[i].dot((fused.surface.points[i] - kSphereCentre).normalized()) > 0.9;
  EXPECT_GT(outward, int(0.98 * fused.surface.size()));
  // Seen all round: coverage above the default minimum.
  EXPECT_GE(fused.coverage.fraction, 0.97) << fused.coverage.summary("world");
  EXPECT_NO_THROW(geo::requireCoverage(fused.coverage, 0.95, "views", "world"));
}

TEST(ViewFusion, SphereSeenAllRoundFillsWithinTwoPercent) {
  const geo::FusedViews fused = geo::fuseViews(sphereAllRound(), {});
  const double exact = 4.0 / 3.0 * M_PI * std::pow(kSphereR, 3);
  const double v = filledVolume(fused);
  EXPECT_NEAR(v, exact, 0.02 * exact) << "filled " << v << " m^3, sphere " << exact << " m^3";
}

TEST(ViewFusion, BoxSeenAllRoundFillsWithinTwoPercent) {
  const Eigen::Vector3d centre(-0.02, 0.04, 0.1), half(0.04, 0.03, 0.025);
  const auto views = viewsFrom(topo_test::boxSolid(centre, half), centre, topo_test::allRoundDirections(), 0.35, 11);
  const geo::FusedViews fused = geo::fuseViews(views, {});
  EXPECT_GE(fused.coverage.fraction, 0.97) << fused.coverage.summary("world");
  const double exact = 8.0 * half.prod();
  const double v = filledVolume(fused);
  EXPECT_NEAR(v, exact, 0.02 * exact) << "filled " << v << " m^3, box " << exact << " m^3";
}

TEST(ViewFusion, OneSideOnlyIsRefusedNamingTheHoleOppositeTheCamera) {
  const Eigen::Vector3d centre(0.0, 0.0, 0.2);
  const double R = 0.05;
  // A camera that sees only the +x side (three views 30 deg apart).
  const std::vector<Eigen::Vector3d> dirs = {Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(1, 0.5, 0).normalized(),
                                             Eigen::Vector3d(1, -0.5, 0).normalized()};
  const geo::FusedViews fused = geo::fuseViews(viewsFrom(topo_test::sphereSolid(centre, R), centre, dirs, 0.4, 3), {});
  EXPECT_LT(fused.coverage.fraction, 0.8) << fused.coverage.summary("world");
  ASSERT_FALSE(fused.coverage.holes.empty());
  const geo::CoverageHole& hole = fused.coverage.holes.front();
  EXPECT_GT(hole.direction.dot(Eigen::Vector3d(-1, 0, 0)), 0.8) << hole.text("world");
  EXPECT_GT(hole.fraction, 0.2);
  try {
    geo::requireCoverage(fused.coverage, 0.95, "cloud_ingest views", "world");
    FAIL() << "a one-sided scan was accepted";
  } catch (const TopoError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("cloud_ingest views"), std::string::npos) << m;
    EXPECT_NE(m.find("(-x)"), std::string::npos) << m;
    EXPECT_NE(m.find("add a view from around"), std::string::npos) << m;
    EXPECT_NE(m.find("frame world"), std::string::npos) << m;
  }
}

TEST(ViewFusion, ObjectOnATableIsRefusedNamingItsUnderside) {
  const Eigen::Vector3d centre(0.0, 0.0, 0.0);
  const double R = 0.05, table_z = -0.6 * R;  // the table hides what lies below it
  std::vector<Eigen::Vector3d> dirs;           // a turntable: a ring of views level and from above
  for (int i = 0; i < 8; ++i) {
    const double a = 2.0 * M_PI * i / 8;
    dirs.emplace_back(std::cos(a), std::sin(a), 0.0);
    dirs.push_back(Eigen::Vector3d(std::cos(a), std::sin(a), 1.0).normalized());
  }
  auto views = viewsFrom(topo_test::sphereSolid(centre, R), centre, dirs, 0.4, 5);
  for (auto& v : views)
    for (auto& p : v.points)
      if ((v.world_from_sensor * p).z() < table_z) p.setConstant(std::nan(""));
  const geo::FusedViews fused = geo::fuseViews(views, {});
  ASSERT_FALSE(fused.coverage.holes.empty()) << fused.coverage.summary("world");
  const geo::CoverageHole& hole = fused.coverage.holes.front();
  EXPECT_LT(hole.direction.z(), -0.95) << hole.text("world");
  // Seen from the bounding box's centre (z = (R + table_z) / 2), the table's rim lies 45 deg below
  // the horizon: an unseen cone of half-angle 45 deg, measured to within one direction bin (400
  // bins: 10 deg apart), and the rest of the directions seen.
  const double bin_deg = std::sqrt(4.0 * M_PI / 400) * 180.0 / M_PI;
  EXPECT_NEAR(hole.half_angle_deg, 45.0, bin_deg) << hole.text("world");
  EXPECT_NEAR(hole.fraction + fused.coverage.fraction, 1.0, 0.01) << fused.coverage.summary("world");
  EXPECT_NEAR(hole.position.z(), fused.coverage.centre.z() - fused.coverage.radius, 0.1 * R);
  try {
    geo::requireCoverage(fused.coverage, 0.95, "views", "world");
    FAIL() << "a scan without its underside was accepted";
  } catch (const TopoError& e) {
    EXPECT_NE(std::string(e.what()).find("(-z)"), std::string::npos) << e.what();
  }
}

TEST(ViewFusion, BadInputIsNamed) {
  EXPECT_THROW(geo::fuseViews(std::vector<geo::DepthView>{}, {}), TopoError);
  geo::DepthView v;
  v.name = "view 2 (frame cam)";
  v.points = {Eigen::Vector3d(std::nan(""), 0, 0)};
  try {
    geo::fuseViews({v}, {}, "depth_points");
    FAIL();
  } catch (const TopoError& e) {
    EXPECT_NE(std::string(e.what()).find("0 finite point"), std::string::npos) << e.what();
  }
  v.points.assign(10, Eigen::Vector3d(0.1, 0.2, 0.3));
  v.points[3].x() = 0.2;
  v.world_from_sensor.linear() *= 2.0;  // a scale, not a rotation
  try {
    geo::fuseViews({v}, {}, "depth_points");
    FAIL();
  } catch (const TopoError& e) {
    EXPECT_NE(std::string(e.what()).find("view 2 (frame cam)"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("rigid"), std::string::npos) << e.what();
  }
  geo::ViewFusionOptions o;
  o.voxel_m = -1.0;
  EXPECT_THROW(geo::fuseViews({v}, o), TopoError);
}

}  // namespace
