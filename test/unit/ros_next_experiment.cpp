// The next experiment as the infer_interior result carries it (ros/interior_inference_node.h
// fillNextExperiment): a rig performs it from the task and its set-up overrides alone, never from the
// design's predictions (the targets a suggestion's config holds), nor from the object's shared
// parameters (the rig and the node keep those); the periods and a hang's pose go to the instruments;
// the loop rule's decision comes with it.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "topo_gaussian/inference/identifiability.h"
#include "topo_gaussian/inference/task_config.h"
#include "topo_gaussian/ros/interior_inference_node.h"

using namespace topo_gaussian;

namespace {

bool has(const std::vector<std::string>& v, const std::string& s) { return std::find(v.begin(), v.end(), s) != v.end(); }

bool anyStartsWith(const std::vector<std::string>& v, const std::string& prefix) {
  return std::any_of(v.begin(), v.end(), [&](const std::string& s) { return s.rfind(prefix, 0) == 0; });
}

/// An analysis with everything free and a suggested swing from (0.01, -0.02, 0.03) m, as
/// suggestNextExperiment builds it: the object's density, the design's predicted rest pose and periods.
inference::IdentifiabilityAnalysis swingAnalysis() {
  inference::IdentifiabilityAnalysis a;
  a.available = true;
  for (const char* name : {"m", "cx", "cy", "cz", "Ixx", "Iyy", "Izz", "Ixy", "Ixz", "Iyz"}) {
    inference::MomentIdentification m;
    m.name = name;
    m.determined = false;
    a.moments.push_back(m);
  }
  a.has_suggestion = true;
  inference::ExperimentSuggestion& s = a.suggestion;
  s.kind = "swing";
  s.config = inference::TaskConfig::defaults("hanging");
  s.config.set("density_solid", "5000");
  s.config.set("hanging_point", "0.01,-0.02,0.03");
  s.config.setNumber("target_roll_deg", 41.5);
  s.config.setNumber("target_pitch_deg", -12.25);
  s.config.setNumber("axle_swing_period_s", 0.5123);
  s.config.setNumber("cross_axle_swing_period_s", 0.4987);
  s.score_gain = 12.0;
  s.newly_determined = {"Ixx"};
  s.sentence = "hang it from (0.01, -0.02, 0.03) m on a horizontal axle ...";
  return a;
}

}  // namespace

TEST(NextExperiment, TheRigGetsTheSetUpTheInstrumentsTheRestAndTheRule) {
  topo_gaussian::InferInteriorResult result;
  topo_ros::fillNextExperiment(swingAnalysis(), 0.25, 3, &result);
  EXPECT_EQ(result.next_experiment_kind, "swing");
  EXPECT_EQ(result.next_experiment_task, "hanging");
  EXPECT_TRUE(anyStartsWith(result.next_experiment_overrides, "hanging_point=")) << result.next_experiment;
  // never the design's predictions, nor the object's shared material
  for (const char* key : {"target_roll_deg=", "target_pitch_deg=", "axle_swing_period_s=",
                          "cross_axle_swing_period_s=", "density_solid="})
    EXPECT_FALSE(anyStartsWith(result.next_experiment_overrides, key)) << key;
  // the rig reads the periods and the hung pose
  for (const char* key :
       {"axle_swing_period_s", "cross_axle_swing_period_s", "target_roll_deg", "target_pitch_deg"})
    EXPECT_TRUE(has(result.next_experiment_instruments, key)) << key;
  EXPECT_DOUBLE_EQ(result.next_experiment_tilt_deg, 41.5);
  EXPECT_DOUBLE_EQ(result.uncertain_fraction, 0.25);
  EXPECT_TRUE(result.loop_continues) << result.loop_reason;
  EXPECT_EQ(result.loop_decision, "continue");

  // the rig applies the overrides to the task's defaults: the suggestion's set-up again
  inference::TaskConfig performed = inference::TaskConfig::defaults("hanging");
  for (const auto& o : result.next_experiment_overrides) performed.setAssignment(o, "test");
  EXPECT_TRUE(performed.vector3("hanging_point").isApprox(Eigen::Vector3d(0.01, -0.02, 0.03), 1e-15));
  EXPECT_FALSE(performed.has("target_pitch_deg"));

  // five experiments: the rule stops, the suggestion still named
  topo_gaussian::InferInteriorResult at_five;
  topo_ros::fillNextExperiment(swingAnalysis(), 0.25, 5, &at_five);
  EXPECT_FALSE(at_five.loop_continues);
  EXPECT_EQ(at_five.loop_decision, "max_experiments");
  EXPECT_EQ(at_five.next_experiment_task, "hanging");

  // no suggestion: nothing to perform, the tilt unknown
  inference::IdentifiabilityAnalysis none = swingAnalysis();
  none.has_suggestion = false;
  topo_gaussian::InferInteriorResult nothing;
  topo_ros::fillNextExperiment(none, NAN, 3, &nothing);
  EXPECT_TRUE(nothing.next_experiment_task.empty());
  EXPECT_TRUE(nothing.next_experiment_overrides.empty());
  EXPECT_TRUE(std::isnan(nothing.next_experiment_tilt_deg));
  EXPECT_FALSE(nothing.loop_continues);
}
