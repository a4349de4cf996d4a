// The task registry (inference/task_registry.h): every registered task builds its defaults and its
// task, declares each parameter once with a default inside its range and a unit its documentation
// states, and the registry's answers (names, default shapes, shorthands, the rig twin's tasks) are
// those the callers relied on when they branched on task names. An alias (an old parameter name) sets
// and reads its parameter and is listed with its note.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <set>

#include "test_clouds.h"
#include "test_util.h"
#include "topo_gaussian/inference/pipeline.h"
#include "topo_gaussian/inference/task.h"
#include "topo_gaussian/inference/task_config.h"
#include "topo_gaussian/inference/task_registry.h"
#include "topo_gaussian/physics/default_shapes.h"
#include "topo_gaussian/workflow/rig_twin.h"

using namespace topo_gaussian;
using namespace topo_gaussian::inference;
using topo_test::errorOf;
using topo_test::runTopo;

TEST(TaskRegistry, NamesInOrderAndTheUnknownTaskErrorListsThem) {
  const std::vector<std::string> expected = {"hanging", "balance", "stand", "tumbler",   "qiqi",
                                             "ball",    "finger",  "pear",  "cantilever"};
  EXPECT_EQ(TaskConfig::taskNames(), expected);
  ASSERT_EQ(taskDefinitions().size(), expected.size());
  const std::string e = errorOf([] { TaskConfig::defaults("juggling"); });
  EXPECT_NE(e.find("unknown task"), std::string::npos) << e;
  for (const auto& name : expected) EXPECT_NE(e.find(name), std::string::npos) << name << " missing from: " << e;
  EXPECT_EQ(findTaskDefinition("juggling"), nullptr);
  EXPECT_NE(errorOf([] { taskDefinition("juggling"); }).find("cantilever"), std::string::npos);
}

TEST(TaskRegistry, EveryTaskDeclaresItsParametersOnceInsideTheirRanges) {
  for (const auto& t : taskDefinitions()) {
    SCOPED_TRACE(t.name);
    EXPECT_FALSE(t.summary.empty());
    EXPECT_EQ(t.summary.find('\n'), std::string::npos) << "one line";
    ASSERT_TRUE(t.make);
    const TaskConfig c = TaskConfig::defaults(t.name);
    EXPECT_EQ(c.task(), t.name);
    EXPECT_GT(c.specs().size(), TaskConfig::common().specs().size()) << "the task declares parameters of its own";
    std::set<std::string> names;
    for (const auto& s : c.specs()) {
      SCOPED_TRACE(s.name);
      EXPECT_TRUE(names.insert(s.name).second) << "declared twice";
      EXPECT_FALSE(s.doc.empty());
      // units: numbers, vectors and lists carry one, stated in the documentation
      if (s.type == ParamType::Text || s.type == ParamType::Boolean) {
        EXPECT_TRUE(s.unit.empty()) << "text and boolean parameters have no unit";
      } else if (s.unit == "unitless") {
        EXPECT_NE(s.doc.find("unitless"), std::string::npos) << s.doc;
      } else {
        ASSERT_FALSE(s.unit.empty()) << "no unit declared";
        EXPECT_NE(s.doc.find("[" + s.unit + "]"), std::string::npos) << "doc lacks [" << s.unit << "]: " << s.doc;
      }
      if (s.is_target) EXPECT_FALSE(c.has(s.name)) << "targets have no default";
      if (!c.has(s.name)) continue;
      // the default passes the same check as a user's value (range, choices, whole numbers)
      TaskConfig again = c;
      EXPECT_NO_THROW(again.set(s.name, c.valueText(s.name), "default")) << c.valueText(s.name);
      if (s.type == ParamType::Number || s.type == ParamType::Integer) {
        const double v = c.number(s.name);
        EXPECT_TRUE(s.min_exclusive ? v > s.min : v >= s.min) << v;
        EXPECT_LE(v, s.max);
      }
    }
  }
}

TEST(TaskRegistry, EveryFactoryBuildsItsTask) {
  // On the task's default shape when it brings one, else on a small box.
  const VolumeCloud box = topo_test::boxCloud(0.04, 0.04, 0.06, 0.01);
  for (const auto& t : taskDefinitions()) {
    SCOPED_TRACE(t.name);
    const TaskConfig c = TaskConfig::defaults(t.name);
    const VolumeCloud cloud =
        t.default_shape.empty() ? box : defaultShapeCloud(t.default_shape, c.number("default_spacing_m"));
    std::unique_ptr<Task> task;
    ASSERT_NO_THROW(task = makeTask(c, cloud));
    ASSERT_NE(task, nullptr);
    EXPECT_EQ(task->name(), t.name);
  }
}

TEST(TaskRegistry, DefaultShapesShorthandsAndTheTwinsTasks) {
  EXPECT_EQ(defaultShapeForTask("finger"), "finger");
  EXPECT_EQ(defaultShapeForTask("pear"), "pear");
  EXPECT_EQ(defaultShapeForTask("cantilever"), "beam");
  for (const char* t : {"hanging", "balance", "stand", "tumbler", "qiqi", "ball", "no_such_task"})
    EXPECT_EQ(defaultShapeForTask(t), "") << t;
  for (const auto& t : taskDefinitions())
    if (!t.default_shape.empty()) EXPECT_NO_THROW(defaultShape(t.default_shape)) << t.name;

  // the cantilever's uniform-material shorthands set both materials; other tasks have none
  TaskConfig beam = TaskConfig::defaults("cantilever");
  beam.set("youngs_modulus", "2e7");
  EXPECT_EQ(beam.number("youngs_modulus_solid"), 2e7);
  EXPECT_EQ(beam.number("youngs_modulus_hollow"), 2e7);
  beam.set("density", "1100");
  EXPECT_EQ(beam.number("density_solid"), 1100.0);
  EXPECT_EQ(beam.number("density_hollow"), 1100.0);
  beam.set("poisson_ratio", "0.25");
  EXPECT_EQ(beam.number("poisson_ratio"), 0.25);
  EXPECT_EQ(beam.number("poisson_ratio_hollow"), 0.25);
  EXPECT_NE(errorOf([&] { beam.set("poisson_ratio", "0.6"); }).find("poisson_ratio"), std::string::npos);
  TaskConfig finger = TaskConfig::defaults("finger");
  finger.set("poisson_ratio", "0.4");
  EXPECT_EQ(finger.number("poisson_ratio_hollow"), 0.0) << "no shorthand outside the cantilever";
  EXPECT_NE(errorOf([&] { finger.set("youngs_modulus", "1e7"); }).find("unknown parameter"), std::string::npos);

  // the rig twin: which task a shape's twin runs, and the tasks it can replay
  EXPECT_EQ(workflow::RigTwin::defaultTaskFor("tumbler"), "tumbler");
  EXPECT_EQ(workflow::RigTwin::defaultTaskFor("pear"), "hanging");
  EXPECT_EQ(workflow::RigTwin::defaultInteriorQuadric("tumbler").size(), 10);
  EXPECT_DOUBLE_EQ(workflow::RigTwin::defaultInteriorQuadric("hanging")[8], -0.6);  // −2 u0_z, u0 = (0, 0, 0.3)
  const std::string no_twin = errorOf([] { workflow::RigTwin::defaultInteriorQuadric("ball"); });
  EXPECT_NE(no_twin.find("hanging, tumbler"), std::string::npos) << "the tasks the twin can replay: " << no_twin;
}

TEST(TaskRegistry, TaskSpecificDefaultsOfCommonParameters) {
  EXPECT_EQ(TaskConfig::common().number("loss_tolerance"), 1e-12);
  EXPECT_EQ(TaskConfig::defaults("tumbler").number("loss_tolerance"), 1e-8);
  EXPECT_EQ(TaskConfig::defaults("finger").vector3("gravity"), Eigen::Vector3d::Zero());
  EXPECT_EQ(TaskConfig::defaults("finger").number("density_hollow"), 1.0);
  EXPECT_EQ(TaskConfig::defaults("pear").number("density_hollow"), 1000.0);
  EXPECT_FALSE(TaskConfig::defaults("cantilever").boolean("pin_shell"));
  EXPECT_TRUE(TaskConfig::defaults("finger").boolean("pin_shell"));
  EXPECT_EQ(TaskConfig::defaults("ball").number("contact_damping_ratio"), 0.05);
  EXPECT_EQ(TaskConfig::defaults("tumbler").number("contact_damping_ratio"), 0.1);
  EXPECT_EQ(TaskConfig::defaults("cantilever").integer("gradient_order"), 2);
  EXPECT_EQ(TaskConfig::defaults("hanging").spec("density_solid")->paper_value, "1e3 synthetic, 5e3 real");
  EXPECT_EQ(TaskConfig::defaults("tumbler").spec("dt_s")->unit, "s");
}

TEST(TaskRegistry, MaxIterationsIsAnAliasOfMaxEvaluations) {
  // The old name sets and reads the limit it always was: objective evaluations.
  TaskConfig c = TaskConfig::defaults("tumbler");
  EXPECT_EQ(c.integer("max_evaluations"), 200);
  c.set("max_iterations", "17");
  EXPECT_EQ(c.integer("max_evaluations"), 17);
  EXPECT_EQ(c.integer("max_iterations"), 17);
  EXPECT_EQ(c.explicitKeys().count("max_evaluations"), 1u);
  EXPECT_EQ(c.spec("max_iterations"), c.spec("max_evaluations"));
  EXPECT_EQ(c.aliasText("max_iterations"), "max_iterations: alias of max_evaluations (it always counted evaluations)");
  // One origin giving both names different values is refused, naming both; the same value is one value.
  const std::string both = errorOf([&] { c.set("max_evaluations", "18", "--set"); });
  EXPECT_NE(both.find("max_iterations"), std::string::npos) << both;
  EXPECT_NE(both.find("max_evaluations"), std::string::npos) << both;
  EXPECT_NE(both.find("17"), std::string::npos) << both;
  EXPECT_NE(both.find("18"), std::string::npos) << both;
  EXPECT_NO_THROW(c.set("max_evaluations", "17", "--set"));
  // A later origin overrides an earlier one, whichever name each used.
  EXPECT_NO_THROW(c.set("max_evaluations", "19", "goal overrides"));
  EXPECT_EQ(c.integer("max_evaluations"), 19);

  // A task file: the old name works, both names with different values are refused.
  const std::string dir = ::testing::TempDir() + "/alias_max_iterations";
  std::filesystem::create_directories(dir);
  std::ofstream(dir + "/old.yaml") << "task: hanging\nmax_iterations: 50\n";
  std::ofstream(dir + "/both.yaml") << "task: hanging\nmax_iterations: 50\nmax_evaluations: 60\n";
  TaskConfig old_file = TaskConfig::fromYamlFile(dir + "/old.yaml");
  EXPECT_EQ(old_file.integer("max_evaluations"), 50);
  old_file.setAssignment("max_evaluations=60");
  EXPECT_EQ(old_file.integer("max_evaluations"), 60) << "--set overrides the file";
  const std::string file_both = errorOf([&] { TaskConfig::fromYamlFile(dir + "/both.yaml"); });
  EXPECT_NE(file_both.find("max_iterations and max_evaluations"), std::string::npos) << file_both;

  // Several experiments: the alias is a shared parameter like its parameter.
  EXPECT_TRUE(TaskConfig::isShared("max_iterations"));
  TaskConfig joint = TaskConfig::loadWithExperiments("tumbler", {"hanging"}, "", {"max_iterations=7"});
  joint.setAssignment("max_iterations=7");
  EXPECT_EQ(joint.integer("max_evaluations"), 7);
  for (const auto& e : joint.experiments()) EXPECT_EQ(e.config.integer("max_evaluations"), 7) << e.name;

  // The declaration refuses an alias of nothing, or one named like a parameter.
  TaskConfig bare;
  TaskParameters p(bare);
  p.integer("count", 1, "unitless", "a count, unitless", 0, 10);
  EXPECT_NE(errorOf([&] { p.alias("old_count", "no_such", ""); }).find("not declared"), std::string::npos);
  EXPECT_NE(errorOf([&] { p.alias("count", "count", ""); }).find("already a parameter"), std::string::npos);

  // The command line: --set with the old name, both refused, and --list-params / topo tasks show the alias.
  topo_test::ToolRun r = runTopo("infer --task hanging --set max_iterations=3 --list-params");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("--set max_evaluations=3"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("max_iterations: alias of max_evaluations (it always counted evaluations)"), std::string::npos)
      << r.out;
  r = runTopo("infer --task hanging --set max_iterations=3 --set max_evaluations=4 --list-params");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("max_iterations and max_evaluations"), std::string::npos) << r.out;
  r = runTopo("tasks");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("max_iterations: alias of max_evaluations"), std::string::npos) << r.out;
}
