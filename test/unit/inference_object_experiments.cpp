// An object's experiments kept across inference goals (workflow/object_experiments.h): each goal adds
// its experiment to the object's earlier ones, with the targets they were run with.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/workflow/object_experiments.h"

using namespace topo_gaussian;
using inference::TaskConfig;

namespace {

TaskConfig hang(double roll_deg) {
  TaskConfig c = TaskConfig::defaults("hanging");
  c.set("density_solid", "1200");
  c.setNumber("target_roll_deg", roll_deg);
  c.setNumber("target_pitch_deg", 0.0);
  return c;
}

TaskConfig rock(double period_s) {
  TaskConfig c = TaskConfig::defaults("tumbler");
  c.set("density_solid", "1200");
  c.setNumber("period_s", period_s);
  return c;
}

std::vector<std::string> names(const TaskConfig& c) {
  std::vector<std::string> out;
  for (const auto& e : c.experiments()) out.push_back(e.name);
  return out;
}

TEST(ObjectExperiments, EachGoalAddsItsExperimentToTheObjectsEarlierOnes) {
  workflow::ObjectExperiments objects;
  // The first goal: the object is new, the goal runs alone.
  const TaskConfig first = objects.withEarlier("doll", hang(12.5));
  EXPECT_FALSE(first.hasExperiments());
  objects.remember("doll", first);
  EXPECT_EQ(objects.experimentNames("doll"), std::vector<std::string>({"hanging"}));
  // The second: rocked; the joint has the hang with its target, then the rocking.
  const TaskConfig second = objects.withEarlier("doll", rock(0.84));
  ASSERT_EQ(names(second), std::vector<std::string>({"hanging", "tumbler"}));
  EXPECT_DOUBLE_EQ(second.experiments()[0].config.number("target_roll_deg"), 12.5);
  EXPECT_DOUBLE_EQ(second.experiments()[1].config.number("period_s"), 0.84);
  EXPECT_DOUBLE_EQ(second.number("density_solid"), 1200.0);
  objects.remember("doll", second);
  // A second hang gets a name of its own; the record grows only when a run is remembered.
  const TaskConfig third = objects.withEarlier("doll", hang(-3.0));
  EXPECT_EQ(names(third), std::vector<std::string>({"hanging", "tumbler", "hanging_2"}));
  EXPECT_EQ(objects.experimentNames("doll").size(), 2u);
  objects.remember("doll", third);
  EXPECT_EQ(objects.experimentNames("doll").size(), 3u);
  // Another object, or none, is not touched.
  EXPECT_FALSE(objects.withEarlier("cup", rock(0.5)).hasExperiments());
  EXPECT_FALSE(objects.withEarlier("", rock(0.5)).hasExperiments());
  objects.remember("", rock(0.5));
  EXPECT_TRUE(objects.experimentNames("").empty());
  objects.forget("doll");
  EXPECT_TRUE(objects.experimentNames("doll").empty());
}

TEST(ObjectExperiments, AGoalThatRepeatsAnExperimentReplacesIt) {
  workflow::ObjectExperiments objects;
  TaskConfig joint = TaskConfig::common();
  joint.set("density_solid", "1200");
  joint.addExperiment("hang_top", 1.0, hang(10.0));
  joint.addExperiment("rock_x", 1.0, rock(0.8));
  objects.remember("doll", joint);
  TaskConfig again = TaskConfig::common();
  again.set("density_solid", "1200");
  again.addExperiment("rock_x", 2.0, rock(0.81));  // timed again, more carefully
  const TaskConfig out = objects.withEarlier("doll", again);
  ASSERT_EQ(names(out), std::vector<std::string>({"hang_top", "rock_x"}));
  EXPECT_DOUBLE_EQ(out.experiments()[1].config.number("period_s"), 0.81);
  EXPECT_DOUBLE_EQ(out.experiments()[1].weight, 2.0);
}

// What infer_client's loop sends: a goal with one new experiment whose task file brings its own density
// (hanging.yaml's 1000): the object's material wins; a goal that names another one itself is refused.
TEST(ObjectExperiments, ATaskFilesSharedValueYieldsToTheObjects) {
  workflow::ObjectExperiments objects;
  TaskConfig joint = TaskConfig::common();
  joint.set("density_solid", "5000");
  TaskConfig r = rock(0.8), h = hang(10.0);
  r.set("density_solid", "5000");
  h.set("density_solid", "5000");
  joint.addExperiment("rock10", 1.0, r);
  joint.addExperiment("hang", 1.0, h);
  objects.remember("doll", joint);
  TaskConfig goal = TaskConfig::common();
  TaskConfig file = hang(-30.0);
  file.set("density_solid", "1000");  // as hanging.yaml sets it
  goal.set("density_solid", "1000", "hanging.yaml");
  goal.addExperiment("auto4", 1.0, file);
  const TaskConfig out = objects.withEarlier("doll", goal);
  ASSERT_EQ(names(out), std::vector<std::string>({"rock10", "hang", "auto4"}));
  EXPECT_DOUBLE_EQ(out.number("density_solid"), 5000.0);
  for (const auto& e : out.experiments()) EXPECT_DOUBLE_EQ(e.config.number("density_solid"), 5000.0) << e.name;
  EXPECT_DOUBLE_EQ(out.experiments()[2].config.number("target_roll_deg"), -30.0);
  // named by the goal itself: refused
  TaskConfig named = TaskConfig::common();
  named.set("density_solid", "7800");
  TaskConfig steel = hang(-30.0);
  steel.set("density_solid", "7800");
  named.addExperiment("auto4", 1.0, steel);
  EXPECT_THROW(objects.withEarlier("doll", named, {"density_solid=7800"}), TopoError);
}

TEST(ObjectExperiments, AnotherMaterialIsRefusedNamingTheObject) {
  workflow::ObjectExperiments objects;
  objects.remember("doll", hang(12.5));
  TaskConfig steel = rock(0.84);
  steel.set("density_solid", "7800");
  try {
    objects.withEarlier("doll", steel);
    FAIL() << "a goal with another density_solid joined the object's experiments";
  } catch (const TopoError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("object 'doll'"), std::string::npos) << what;
    EXPECT_NE(what.find("density_solid"), std::string::npos) << what;
  }
  EXPECT_EQ(objects.experimentNames("doll").size(), 1u);  // the record is unchanged
}

}  // namespace
