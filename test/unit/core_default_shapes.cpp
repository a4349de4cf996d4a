// Default soft-body shapes (finger, pear, beam, tumbler): lattice clouds against the analytic
// volumes, surface flags, the pear's profile, and the errors for bad names and spacings.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <iostream>
#include <limits>

#include "test_clouds.h"
#include "test_util.h"
#include "topo_gaussian/common/error.h"
#include "topo_gaussian/physics/default_shapes.h"

using namespace topo_gaussian;
using topo_test::errorOf;

namespace {

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

}  // namespace

TEST(DefaultShapes, NamesAndBounds) {
  const std::vector<std::string> expected{"finger", "pear", "beam", "tumbler"};
  EXPECT_EQ(defaultShapeNames(), expected);
  for (const auto& n : defaultShapeNames()) {
    const DefaultShape s = defaultShape(n);
    EXPECT_EQ(s.name, n);
    EXPECT_FALSE(s.description.empty());
    EXPECT_TRUE((s.hi.array() > s.lo.array()).all()) << n;
    EXPECT_GT(s.volume_m3, 0.0) << n;
    EXPECT_LE(s.volume_m3, (s.hi - s.lo).prod() * (1 + 1e-12)) << n;
    EXPECT_TRUE(s.inside(0.5 * (s.lo + s.hi) + Eigen::Vector3d(0, 0, n == "tumbler" ? -0.01 : 0.0))) << n;
    EXPECT_FALSE(s.inside(s.hi + Eigen::Vector3d::Constant(1e-4))) << n;
    EXPECT_FALSE(s.inside(s.lo - Eigen::Vector3d::Constant(1e-4))) << n;
  }
  // the beam is clamped at x = 0 and runs along +x; the finger's base is at x = 0
  EXPECT_DOUBLE_EQ(defaultShape("beam").lo.x(), 0.0);
  EXPECT_DOUBLE_EQ(defaultShape("beam").hi.x(), 0.2);
  EXPECT_DOUBLE_EQ(defaultShape("finger").lo.x(), 0.0);
  EXPECT_DOUBLE_EQ(defaultShape("pear").lo.z(), 0.0);
  EXPECT_DOUBLE_EQ(defaultShape("pear").hi.z(), 0.12);
  // the finger's tip: a half-cylinder of radius 7.5 mm about y, centred at x = 0.0925
  const DefaultShape f = defaultShape("finger");
  EXPECT_TRUE(f.inside({0.0999, 0.0, 0.0}));
  EXPECT_TRUE(f.inside({0.0925, 0.0099, -0.0074}));
  EXPECT_FALSE(f.inside({0.0925 + 0.0075 * std::cos(0.7) + 1e-5, 0.0, 0.0075 * std::sin(0.7)}));
  EXPECT_TRUE(f.inside({0.0925 + 0.0075 * std::cos(0.7) - 1e-5, 0.0, 0.0075 * std::sin(0.7)}));
}

// Each shape declares its outline beside its inside test (one entry per shape, default_shapes.cpp); the
// mesh (geometry/shape_generator.h) is built from it. The curve's points lie on the solid's boundary:
// inside, and outside just beyond along the outward direction from the shape's middle.
TEST(DefaultShapes, EveryShapeDeclaresItsOutlineOnItsBoundary) {
  for (const auto& n : defaultShapeNames()) {
    const DefaultShape s = defaultShape(n);
    ASSERT_TRUE(bool(s.outline)) << n;
    const ShapeOutline o = s.outline(64);
    if (o.kind == ShapeOutline::Kind::Box) {
      EXPECT_TRUE(o.curve.empty()) << n;
      EXPECT_TRUE(s.inside(s.lo) && s.inside(s.hi)) << n;
      continue;
    }
    ASSERT_GE(o.curve.size(), 3u) << n;
    if (o.kind == ShapeOutline::Kind::ExtrudedAlongY) EXPECT_DOUBLE_EQ(o.half_width, s.hi.y()) << n;
    const Eigen::Vector3d mid = 0.5 * (s.lo + s.hi);
    for (const auto& q : o.curve) {
      // the extrusion's polygon at y = 0; the profile (r, z) on the meridian y = 0
      const Eigen::Vector3d p(q.x(), 0.0, q.y());
      EXPECT_TRUE(s.inside(p + 1e-9 * (mid - p).normalized())) << n << " (" << q.transpose() << ")";
      Eigen::Vector3d out = p - mid;
      out.y() = 0.0;
      EXPECT_FALSE(s.inside(p + 1e-6 * out.normalized())) << n << " (" << q.transpose() << ")";
    }
  }
}

TEST(DefaultShapes, PearProfileIsAPear) {
  EXPECT_EQ(pearRadius(0.0), 0.0);
  EXPECT_EQ(pearRadius(0.12), 0.0);
  EXPECT_EQ(pearRadius(-0.001), 0.0);
  EXPECT_EQ(pearRadius(0.1201), 0.0);
  EXPECT_NEAR(pearRadius(0.04), 0.04, 1e-12) << "bulb";
  const double neck = pearRadius(0.1);
  EXPECT_GT(neck, 0.02);
  EXPECT_LT(neck, 0.025) << "neck";
  // rounded ends: near the poles r ~ sqrt(2 R z) with the bulb's and the head's radius
  EXPECT_NEAR(pearRadius(1e-5), std::sqrt(2 * 0.04 * 1e-5), 1e-6);
  EXPECT_NEAR(pearRadius(0.12 - 1e-5), std::sqrt(2 * 0.02 * 1e-5), 1e-6);
  double rmax = 0.0;
  for (int i = 0; i <= 1200; ++i) rmax = std::max(rmax, pearRadius(1e-4 * i));
  EXPECT_LE(rmax, 0.04 + 1e-12) << "the bounding box is tight";
  for (int i = 400; i < 1200; ++i)
    EXPECT_LE(pearRadius(1e-4 * (i + 1)), pearRadius(1e-4 * i) + 1e-12) << "z " << 1e-4 * i;
  // the volume lies between the two spheres it blends and their enclosing cylinder
  const double v = defaultShape("pear").volume_m3;
  EXPECT_GT(v, 4.0 / 3.0 * M_PI * (std::pow(0.04, 3) + std::pow(0.02, 3)));
  EXPECT_LT(v, M_PI * 0.04 * 0.04 * 0.12);
  std::cout << "pear: volume " << v << " m^3, neck radius at z=0.1: " << neck << " m\n";
}

TEST(DefaultShapes, CloudVolumesMatchTheAnalyticVolumes) {
  const double h = 0.0025;
  // beam: a box whose sides the spacing divides: exact
  const VolumeCloud beam = defaultShapeCloud("beam", h);
  EXPECT_EQ(beam.size(), 80u * 8u * 8u);
  EXPECT_NEAR(beam.totalVolume(), 0.2 * 0.02 * 0.02, 1e-15);
  EXPECT_EQ(beam.surfaceCount(), 80u * 8u * 8u - 78u * 6u * 6u);
  EXPECT_NEAR(beam.spacing, h, 0.0);
  // tumbler: a sphere of radius R cut at z = c; spherical cap formula
  const double R = 0.05, c = 0.02;
  const double tumbler_exact = 4.0 / 3.0 * M_PI * R * R * R - M_PI * (R - c) * (R - c) * (2 * R + c) / 3.0;
  const VolumeCloud tumbler = defaultShapeCloud("tumbler", h);
  EXPECT_NEAR(defaultShape("tumbler").volume_m3, tumbler_exact, 1e-15);
  EXPECT_NEAR(tumbler.totalVolume() / tumbler_exact, 1.0, 0.02);
  EXPECT_EQ(tumbler.size(), topo_test::tumblerCloud(R, 0.4, h).size()) << "the same solid as the test helper";
  // finger: box + half-cylinder tip
  const double finger_exact = 0.0925 * 0.02 * 0.015 + 0.5 * M_PI * 0.0075 * 0.0075 * 0.02;
  const VolumeCloud finger = defaultShapeCloud("finger", h);
  EXPECT_NEAR(defaultShape("finger").volume_m3, finger_exact, 1e-15);
  EXPECT_NEAR(finger.totalVolume() / finger_exact, 1.0, 0.03);
  // pear: the integrated profile
  const VolumeCloud pear = defaultShapeCloud("pear", h);
  const double pear_exact = defaultShape("pear").volume_m3;
  EXPECT_NEAR(pear.totalVolume() / pear_exact, 1.0, 0.02);
  const VolumeCloud pear_fine = defaultShapeCloud("pear", 0.001);
  EXPECT_NEAR(pear_fine.totalVolume() / pear_exact, 1.0, 0.005);
  std::cout << "at h = 2.5 mm: beam " << beam.size() << " particles, " << beam.totalVolume() << " m^3 (exact " << 8e-5
            << ")\n"
            << "  tumbler " << tumbler.size() << " particles, " << tumbler.totalVolume() << " m^3 vs " << tumbler_exact
            << " (" << 100 * (tumbler.totalVolume() / tumbler_exact - 1) << " %)\n"
            << "  finger " << finger.size() << " particles, " << finger.totalVolume() << " m^3 vs " << finger_exact
            << " (" << 100 * (finger.totalVolume() / finger_exact - 1) << " %)\n"
            << "  pear " << pear.size() << " particles, " << pear.totalVolume() << " m^3 vs " << pear_exact << " ("
            << 100 * (pear.totalVolume() / pear_exact - 1) << " %); at 1 mm " << pear_fine.size() << " particles ("
            << 100 * (pear_fine.totalVolume() / pear_exact - 1) << " %)\n";
  for (const VolumeCloud* cl : {&beam, &tumbler, &finger, &pear}) EXPECT_NO_THROW(cl->validate());
}

TEST(DefaultShapes, LatticeIsCentredSoSymmetricShapesStaySymmetric) {
  // 3 mm divides none of the tumbler's extents; the lattice is centred on the bounding box.
  const VolumeCloud t = defaultShapeCloud("tumbler", 0.003);
  EXPECT_LT(std::abs(t.centroid().x()), 1e-12);
  EXPECT_LT(std::abs(t.centroid().y()), 1e-12);
  const VolumeCloud f = defaultShapeCloud("finger", 0.0035);
  EXPECT_LT(std::abs(f.centroid().y()), 1e-12);
  EXPECT_LT(std::abs(f.centroid().z()), 1e-12);
  Eigen::Vector3d lo, hi;
  f.bounds(&lo, &hi);
  EXPECT_GT(lo.x(), 0.0) << "every particle lies inside the finger";
  EXPECT_LT(hi.x(), 0.1);
}

TEST(DefaultShapes, SurfaceFlagsMarkTheBoundaryLayer) {
  const double h = 0.0025, R = 0.05, c = 0.02;
  const VolumeCloud t = defaultShapeCloud("tumbler", h);
  ASSERT_GT(t.surfaceCount(), 0u);
  ASSERT_LT(t.surfaceCount(), t.size());
  std::size_t near_unflagged = 0, far_flagged = 0;
  for (std::size_t i = 0; i < t.size(); ++i) {
    const double dist = std::min(R - t.X[i].norm(), c - t.X[i].z());  // distance to the boundary
    if (dist < 0.4 * h && !t.surface[i]) ++near_unflagged;
    if (dist > h && t.surface[i]) ++far_flagged;
  }
  EXPECT_EQ(near_unflagged, 0u) << "particles within 0.4 spacing of the boundary are surface particles";
  EXPECT_EQ(far_flagged, 0u) << "surface particles lie within one spacing of the boundary";
  for (const auto& n : defaultShapeNames()) {
    const VolumeCloud cl = defaultShapeCloud(n, 0.0025);
    EXPECT_GT(cl.surfaceCount(), 0u) << n;
    EXPECT_LT(cl.surfaceCount(), cl.size()) << n;
  }
  // finger at the coarsest spacing, 5 mm: 20 x 4 x 3 cells, all inside (the tip's corner cells at
  // x = 0.0975, z = ±0.005 lie within its 7.5 mm radius); interior = the middle z row, the inner two
  // y columns, all but the end x cells
  const VolumeCloud f = defaultShapeCloud("finger", 0.005);
  EXPECT_EQ(f.size(), 240u);
  EXPECT_EQ(f.size() - f.surfaceCount(), 18u * 2u * 1u);
}

TEST(DefaultShapes, BadNamesAndSpacingsAreRefusedWithTheFix) {
  const std::string unknown = errorOf([] { defaultShape("banana"); });
  EXPECT_TRUE(contains(unknown, "banana")) << unknown;
  EXPECT_TRUE(contains(unknown, "finger, pear, beam, tumbler")) << unknown;
  EXPECT_TRUE(contains(errorOf([] { defaultShapeCloud("Finger", 0.001); }), "finger, pear, beam, tumbler"));

  for (double bad : {0.0, -0.001, std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()}) {
    const std::string e = errorOf([&] { defaultShapeCloud("beam", bad); });
    EXPECT_TRUE(contains(e, "not a positive number")) << bad << ": " << e;
    EXPECT_TRUE(contains(e, "at most 0.006667 m")) << e;
  }
  const std::string coarse = errorOf([] { defaultShapeCloud("finger", 0.006); });
  EXPECT_TRUE(contains(coarse, "too coarse")) << coarse;
  EXPECT_TRUE(contains(coarse, "finger")) << coarse;
  EXPECT_TRUE(contains(coarse, "at most 0.005 m")) << coarse;
  EXPECT_NO_THROW(defaultShapeCloud("finger", 0.005)) << "exactly 3 across is enough";
  EXPECT_TRUE(contains(errorOf([] { defaultShapeCloud("tumbler", 0.03); }), "at most 0.02333 m"));
  const std::string fine = errorOf([] { defaultShapeCloud("pear", 1e-5); });
  EXPECT_TRUE(contains(fine, "too fine")) << fine;
  EXPECT_TRUE(contains(fine, "at least")) << fine;
  std::cout << "messages:\n  " << unknown << "\n  " << coarse << "\n  " << fine << "\n";
}
