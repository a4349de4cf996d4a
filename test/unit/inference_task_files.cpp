// Every task file of the package loads through TaskConfig (unknown keys and impossible values throw):
// config/tasks/*.yaml, and the task part of config/rigs/*.yaml — a rig file (it names an `object:`)
// gives a task and `set:` overrides, which must be valid for that task; a rig file without an
// object is a task file itself.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

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
