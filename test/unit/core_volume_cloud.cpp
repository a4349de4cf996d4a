// VolumeCloud: totals, centroid, bounds and validation messages.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/physics/volume_cloud.h"

using topo_gaussian::TopoError;
using topo_gaussian::VolumeCloud;

namespace {

VolumeCloud twoParticles() {
  VolumeCloud c;
  c.spacing = 0.01;
  c.X = {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 2, 3)};
  c.V = {1.0, 3.0};
  c.surface = {1, 0};
  return c;
}

}  // namespace

TEST(VolumeCloud, TotalsAndVolumeWeightedCentroid) {
  const VolumeCloud c = twoParticles();
  EXPECT_DOUBLE_EQ(c.totalVolume(), 4.0);
  const Eigen::Vector3d g = c.centroid();
  EXPECT_DOUBLE_EQ(g.x(), 0.75);
  EXPECT_DOUBLE_EQ(g.y(), 1.5);
  EXPECT_DOUBLE_EQ(g.z(), 2.25);
  EXPECT_EQ(c.surfaceCount(), 1u);
  Eigen::Vector3d lo, hi;
  c.bounds(&lo, &hi);
  EXPECT_EQ(lo, Eigen::Vector3d(0, 0, 0));
  EXPECT_EQ(hi, Eigen::Vector3d(1, 2, 3));
  EXPECT_NO_THROW(c.validate());
}

TEST(VolumeCloud, ValidateNamesTheProblem) {
  auto expectError = [](const VolumeCloud& c, const std::string& words) {
    try {
      c.validate("cloud.ply");
      FAIL() << "no error for " << words;
    } catch (const TopoError& e) {
      const std::string m = e.what();
      EXPECT_NE(m.find("cloud.ply"), std::string::npos) << m;
      EXPECT_NE(m.find(words), std::string::npos) << m;
    }
  };
  expectError(VolumeCloud{}, "no particles");
  VolumeCloud c = twoParticles();
  c.V.pop_back();
  expectError(c, "1 volumes");
  c = twoParticles();
  c.X[1].y() = std::numeric_limits<double>::quiet_NaN();
  expectError(c, "particle 1 has a non-finite position");
  c = twoParticles();
  c.V[0] = 0.0;
  expectError(c, "particle 0 has volume");
  c = twoParticles();
  c.spacing = -1;
  expectError(c, "spacing");
}

// The one fallback for a volume read from an older file or message without its spacing: the cube
// root of the median volume (not the mean, which a fill's partial boundary cells pull down), set only
// where the spacing is missing, with a warning that names the source and says it was derived.
TEST(VolumeCloud, DerivesAMissingSpacingOnceAndSaysSo) {
  using topo_gaussian::ContactSamples;
  using topo_gaussian::deriveMissingSpacing;
  using topo_gaussian::spacingFromAreas;
  using topo_gaussian::spacingFromVolumes;
  EXPECT_DOUBLE_EQ(spacingFromVolumes({0.5e-6, 1e-6, 1e-6, 1e-6, 0.6e-6}), 0.01);  // the mean would give 0.0095
  EXPECT_EQ(spacingFromVolumes({}), 0.0);
  EXPECT_EQ(spacingFromVolumes({-1.0, -2.0, 1.0}), 0.0);
  EXPECT_DOUBLE_EQ(spacingFromAreas({4e-6, 1e-6, 4e-6}), 0.002);

  VolumeCloud c = twoParticles();  // carries 0.01
  EXPECT_EQ(deriveMissingSpacing(&c, "volume.ply"), "");
  EXPECT_EQ(c.spacing, 0.01);
  c.spacing = 0.0;
  const std::string warning = deriveMissingSpacing(&c, "old.ply");
  EXPECT_DOUBLE_EQ(c.spacing, std::cbrt(3.0));  // the median of {1, 3}: the upper one
  EXPECT_NE(warning.find("old.ply"), std::string::npos) << warning;
  EXPECT_NE(warning.find("derived"), std::string::npos) << warning;
  VolumeCloud empty;
  EXPECT_EQ(deriveMissingSpacing(&empty, "none"), "");
  EXPECT_EQ(empty.spacing, 0.0);

  ContactSamples s;
  s.X = {Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX()};
  s.normal = {Eigen::Vector3d::UnitZ(), Eigen::Vector3d::UnitZ()};
  s.area = {1e-6, 4e-6};
  EXPECT_NE(deriveMissingSpacing(&s, "/contact_samples").find("/contact_samples"), std::string::npos);
  EXPECT_DOUBLE_EQ(s.spacing, 0.002);
  EXPECT_EQ(deriveMissingSpacing(&s, "/contact_samples"), "");
}
