// Identified mass properties as messages (ros/inertia_msg.h): from a real weighed hanging inference,
// geometry_msgs/InertiaStamped holds the result's mass, centre of mass and the six inertia tensor
// elements in the given frame; IdentifiedInertia adds the analysis's ten standard deviations and
// verdicts in the moments' order; without an analysis the stds are NaN and nothing is determined.
#include <gtest/gtest.h>

#include <cmath>

#include "test_clouds.h"
#include "topo_gaussian/inference/pipeline.h"
#include "topo_gaussian/ros/inertia_msg.h"

using namespace topo_gaussian;

namespace {

const inference::InferenceResult& weighedHang() {
  static const inference::InferenceResult r = [] {
    inference::TaskConfig c = inference::TaskConfig::defaults("hanging");
    c.setNumber("target_roll_deg", 8.0);
    c.setNumber("target_pitch_deg", -5.0);
    c.setNumber("mass_kg", 0.06);
    c.set("max_evaluations", "25");
    return inference::runInference(c, topo_test::boxCloud(0.06, 0.04, 0.03, 0.005));
  }();
  return r;
}

}  // namespace

TEST(InertiaMsg, InertiaStampedHoldsTheResultsMassPropertiesInTheObjectsFrame) {
  const MassProperties& mp = weighedHang().final.task.mass;
  const ::ros::Time stamp(12.5);
  const geometry_msgs::InertiaStamped m = topo_ros::toInertiaStamped(mp, "object", stamp);
  EXPECT_EQ(m.header.frame_id, "object");
  EXPECT_EQ(m.header.stamp, stamp);
  EXPECT_EQ(m.inertia.m, mp.mass);
  EXPECT_EQ(m.inertia.com.x, mp.com.x());
  EXPECT_EQ(m.inertia.com.y, mp.com.y());
  EXPECT_EQ(m.inertia.com.z, mp.com.z());
  EXPECT_EQ(m.inertia.ixx, mp.inertia(0, 0));
  EXPECT_EQ(m.inertia.ixy, mp.inertia(0, 1));
  EXPECT_EQ(m.inertia.ixz, mp.inertia(0, 2));
  EXPECT_EQ(m.inertia.iyy, mp.inertia(1, 1));
  EXPECT_EQ(m.inertia.iyz, mp.inertia(1, 2));
  EXPECT_EQ(m.inertia.izz, mp.inertia(2, 2));
  EXPECT_NE(m.inertia.ixy, 0.0) << "the off-centre target leaves products of inertia";
}

TEST(InertiaMsg, IdentifiedInertiaCarriesTheAnalysisStdsInTheMomentsOrder) {
  const inference::InferenceResult& r = weighedHang();
  ASSERT_TRUE(r.identifiability.available);
  const IdentifiedInertia m = topo_ros::toIdentifiedInertia(r.final.task.mass, r.identifiability, "object", {});
  ASSERT_TRUE(m.analysed);
  ASSERT_EQ(m.moment_names.size(), 10u);
  ASSERT_EQ(m.moment_std.size(), 10u);
  ASSERT_EQ(m.determined.size(), 10u);
  for (std::size_t k = 0; k < 10; ++k) {
    EXPECT_EQ(m.moment_names[k], r.identifiability.moments[k].name);
    EXPECT_EQ(m.moment_std[k], r.identifiability.moments[k].std) << m.moment_names[k];
    EXPECT_EQ(bool(m.determined[k]), r.identifiability.moments[k].determined) << m.moment_names[k];
  }
  EXPECT_TRUE(m.determined[0]) << "the scale's reading determines the mass";
  EXPECT_TRUE(std::isfinite(m.moment_std[0]));
  EXPECT_EQ(m.inertia.m, r.final.task.mass.mass);
  EXPECT_EQ(m.summary, r.identifiability.summary);
}

TEST(InertiaMsg, WithoutAnAnalysisTheStdsAreNaNAndNothingIsDetermined) {
  inference::IdentifiabilityAnalysis none;  // a soft task: not analysed
  MassProperties mp;
  mp.mass = 2.0;
  mp.inertia = Eigen::Vector3d(1, 2, 2.5).asDiagonal();
  const IdentifiedInertia m = topo_ros::toIdentifiedInertia(mp, none, "finger", {});
  EXPECT_FALSE(m.analysed);
  ASSERT_EQ(m.moment_std.size(), 10u);
  for (std::size_t k = 0; k < 10; ++k) {
    EXPECT_TRUE(std::isnan(m.moment_std[k])) << k;
    EXPECT_FALSE(m.determined[k]) << k;
  }
  EXPECT_EQ(m.inertia.izz, 2.5);
}
