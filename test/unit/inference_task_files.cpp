// Every task file of the package loads through TaskConfig (unknown keys and impossible values throw):
// config/tasks/*.yaml, and the task part of config/rigs/*.yaml — a rig file (it names an `object:`)
// gives a task and `set:` overrides, which must be valid for that task; a rig file without an
// object is a task file itself.
#include <gtest/gtest.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "test_util.h"
#include "topo_gaussian/common/error.h"
#include "topo_gaussian/inference/task_config.h"

using topo_gaussian::inference::TaskConfig;

namespace {

std::vector<std::string> yamlFiles(const std::string& dir) {
  std::vector<std::string> out;
  for (const auto& e : std::filesystem::directory_iterator(dir))
    if (e.path().extension() == ".yaml") out.push_back(e.path().string());
  std::sort(out.begin(), out.end());
  return out;
}

const std::string kTaskDir = std::string(TOPO_SOURCE_DIR) + "/config/tasks";

/// The message of the TopoError that loading the task file `path` throws, "" when it loads.
std::string errorOf(const std::string& path) {
  return topo_test::errorOf([&] { TaskConfig::fromYamlFile(path); });
}

}  // namespace

TEST(TaskFiles, EveryConfigTaskFileLoads) {
  const auto files = yamlFiles(kTaskDir);
  ASSERT_GE(files.size(), TaskConfig::taskNames().size()) << "one file per task at least";
  for (const auto& f : files) {
    try {
      const TaskConfig c = TaskConfig::fromYamlFile(f);
      EXPECT_EQ(c.source(), f);
      EXPECT_EQ(std::filesystem::path(f).stem().string(), c.task()) << f << " is named after its task";
    } catch (const topo_gaussian::TopoError& e) {
      ADD_FAILURE() << e.what();
    }
  }
}

TEST(TaskFiles, EveryRigFilesTaskAndOverridesLoad) {
  int checked = 0;
  for (const auto& f : yamlFiles(std::string(TOPO_SOURCE_DIR) + "/config/rigs")) {
    const YAML::Node root = YAML::LoadFile(f);
    if (!root.IsMap() || !root["task"]) continue;  // not a task file (camera or scene settings only)
    try {
      if (!root["object"]) {
        TaskConfig::fromYamlFile(f);
      } else {
        TaskConfig c = TaskConfig::load(root["task"].as<std::string>(), kTaskDir);
        if (root["set"])
          for (const auto& a : root["set"]) c.setAssignment(a.as<std::string>(), f + " set");
      }
      ++checked;
    } catch (const topo_gaussian::TopoError& e) {
      ADD_FAILURE() << f << ": " << e.what();
    }
  }
  EXPECT_GE(checked, 1) << "config/rigs/tumbler_twin.yaml names a task";
}

TEST(TaskFiles, AnUnknownKeyInATaskFileIsRefused) {
  const std::string path = testing::TempDir() + "/unknown_key_task.yaml";
  {
    std::ofstream out(path);
    out << "task: tumbler\nrocking_axiss: [0, 1, 0]\n";
  }
  try {
    TaskConfig::fromYamlFile(path);
    ADD_FAILURE() << "an unknown key was accepted";
  } catch (const topo_gaussian::TopoError& e) {
    EXPECT_NE(std::string(e.what()).find("did you mean 'rocking_axis'"), std::string::npos) << e.what();
  }
}

// Issue 52 §2: an experiments file whose item names the file itself (or a → b → a) recursed until the
// stack overflowed (exit 139 in `topo infer`, the interior_inference node killed by a goal). It is a
// TopoError naming the chain of files and the fix, from the library and from the CLI.
TEST(TaskFiles, AnExperimentsFileThatRefersToItselfIsACycleNamedNotACrash) {
  const std::string dir = testing::TempDir() + "/topo_task_cycle_" + std::to_string(::getpid());
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string self = dir + "/self.yaml", a = dir + "/a.yaml", b = dir + "/b.yaml";
  std::ofstream(self) << "experiments:\n  - {name: a, file: self.yaml}\n";
  std::ofstream(a) << "experiments:\n  - {name: first, file: b.yaml}\n";
  std::ofstream(b) << "experiments:\n  - {name: second, file: ./a.yaml}\n";
  const std::string e_self = errorOf(self);
  EXPECT_NE(e_self.find("refers to itself"), std::string::npos) << e_self;
  EXPECT_NE(e_self.find("(" + self + " -> " + self + ")"), std::string::npos) << e_self;
  EXPECT_NE(e_self.find("Fix: an experiment's `file:` must hold one experiment"), std::string::npos) << e_self;
  const std::string e_ab = errorOf(a);
  EXPECT_NE(e_ab.find(a + " -> " + dir + "/b.yaml -> " + dir + "/./a.yaml"), std::string::npos) << e_ab;
  // Through the loader `topo infer` and the node's goals use, and the CLI: exit 1 with the message.
  const std::string e_load = topo_test::errorOf([&] { TaskConfig::loadWithExperiments(a, {}); });
  EXPECT_NE(e_load.find("refers to itself"), std::string::npos) << e_load;
  const topo_test::ToolRun r = topo_test::runTopo("infer --task " + self + " --output " + dir + "/run");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("refers to itself"), std::string::npos) << r.out;
  // A file named twice as separate experiments is no cycle: the usual duplicate-name rules apply.
  const std::string one = dir + "/one.yaml", two = dir + "/two.yaml";
  std::ofstream(one) << "task: tumbler\n";
  std::ofstream(two) << "experiments:\n  - {name: x, file: one.yaml}\n  - {name: y, file: one.yaml}\n";
  EXPECT_EQ(errorOf(two), "");
}

// Issue 52 §2: a key written twice in one map (`density_solid` twice) was accepted, the last value
// winning silently. It is refused naming the file, the map and the key, as an unknown key is.
TEST(TaskFiles, AKeyGivenTwiceInOneMapIsRefusedNamingIt) {
  const std::string dir = testing::TempDir() + "/topo_task_duplicate_" + std::to_string(::getpid());
  std::filesystem::create_directories(dir);
  const std::string top = dir + "/top.yaml";
  std::ofstream(top) << "task: tumbler\ndensity_solid: 1000\ndensity_solid: 5000\n";
  EXPECT_NE(errorOf(top).find(top + " density_solid: is given twice"), std::string::npos) << errorOf(top);
  const std::string targets = dir + "/targets.yaml";
  std::ofstream(targets) << "task: tumbler\ntargets:\n  period_s: 0.5\n  period_s: 0.6\n";
  EXPECT_NE(errorOf(targets).find(targets + " targets period_s: is given twice"), std::string::npos)
      << errorOf(targets);
  const std::string shared = dir + "/shared.yaml";
  std::ofstream(shared) << "density_solid: 1000\ndensity_solid: 5000\nexperiments:\n  - {name: a, task: tumbler}\n";
  EXPECT_NE(errorOf(shared).find(shared + " density_solid: is given twice"), std::string::npos) << errorOf(shared);
  const std::string item = dir + "/item.yaml";
  std::ofstream(item) << "experiments:\n  - name: a\n    task: tumbler\n    initial_tilt_deg: 10\n"
                         "    initial_tilt_deg: 20\n";
  EXPECT_NE(errorOf(item).find("experiments[0] (a) initial_tilt_deg: is given twice"), std::string::npos)
      << errorOf(item);
  EXPECT_NE(errorOf(top).find("Fix: keep one density_solid line"), std::string::npos) << errorOf(top);
  // The CLI refuses it before any work.
  const topo_test::ToolRun r = topo_test::runTopo("infer --task " + top + " --list-params");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("is given twice"), std::string::npos) << r.out;
}

// Issue 52 §2: `--set gravity=0,0,-1e160` was accepted (a 90 deg tilt, periods of 0 s, exit 3). Each
// component of gravity is within [-1000, 1000] m/s^2 (about 100 g); beyond, refused with the range.
TEST(TaskFiles, AGravityBeyondAHundredGIsRefusedWithTheRange) {
  TaskConfig c = TaskConfig::defaults("tumbler");
  const std::string e = topo_test::errorOf([&] { c.set("gravity", "0,0,-1e160"); });
  EXPECT_NE(e.find("--set gravity: component z = -1e+160 is outside [-1000, 1000]"), std::string::npos) << e;
  EXPECT_NE(e.find("Fix: gravity in the world frame [m/s^2]"), std::string::npos) << e;
  EXPECT_NE(topo_test::errorOf([&] { c.set("gravity", "2000,0,-9.81"); }).find("component x = 2000"),
            std::string::npos);
  EXPECT_EQ(topo_test::errorOf([&] { c.set("gravity", "0,0,-1000"); }), "");
  EXPECT_EQ(topo_test::errorOf([&] { c.set("gravity", "0,-1.62,0"); }), "");
  const topo_test::ToolRun r = topo_test::runTopo("simulate --task tumbler --set gravity=0,0,-1e160");
  EXPECT_EQ(r.code, 1) << r.out;  // bad input, as every refused --set
  EXPECT_NE(r.out.find("is outside [-1000, 1000]"), std::string::npos) << r.out;
}
