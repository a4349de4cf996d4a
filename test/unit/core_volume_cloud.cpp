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
