// libFuzzer entry point for the task parser: TaskConfig::fromYamlFile (a task YAML file), set and
// setAssignment (the --set/--target and goal override text).
// The first byte selects the entry (taken modulo 3):
//   0  the rest is a task YAML file (written to a per-process temporary file);
//   1  the second byte picks a registered task, the rest is KEY=VALUE lines for setAssignment;
//   2  the second byte picks a task, the rest is KEY '\n' VALUE for set.
// A TopoError is the expected answer to bad text; any other exception escaping (a yaml-cpp
// conversion error, std::invalid_argument, an iostream error), a sanitizer report, or a parsed
// config whose values cannot be printed back is a bug in the parser.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/inference/task_config.h"

namespace {

using topo_gaussian::TopoError;
using topo_gaussian::inference::TaskConfig;

/// Every parameter of a config that parsed must print back (help() reads each value).
void checkPrintable(const TaskConfig& c) {
  if (c.help().empty()) std::abort();
}

/// The defaults of the task picked by b (built once per task: the parser, not the registry, is fuzzed).
const TaskConfig& taskDefaults(std::uint8_t b) {
  static const std::vector<TaskConfig> configs = [] {
    std::vector<TaskConfig> c;
    for (const auto& name : TaskConfig::taskNames()) c.push_back(TaskConfig::defaults(name));
    return c;
  }();
  return configs[b % configs.size()];
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 2) return 0;
  const int mode = data[0] % 3;
  try {
    if (mode == 0) {
      static const std::string path = "/tmp/fuzz_task_config_" + std::to_string(::getpid()) + ".yaml";
      {
        std::ofstream f(path, std::ios::binary | std::ios::trunc);
        f.write(reinterpret_cast<const char*>(data) + 1, static_cast<std::streamsize>(size - 1));
      }
      checkPrintable(TaskConfig::fromYamlFile(path));
      return 0;
    }
    TaskConfig c = taskDefaults(data[1]);
    const std::string text(reinterpret_cast<const char*>(data) + 2, size - 2);
    bool changed = false;
    if (mode == 1) {
      std::istringstream lines(text);
      std::string line;
      while (std::getline(lines, line)) {
        try {
          c.setAssignment(line, "fuzz");
          changed = true;
        } catch (const TopoError&) {
        }
      }
    } else {
      const auto nl = text.find('\n');
      c.set(text.substr(0, nl), nl == std::string::npos ? std::string() : text.substr(nl + 1), "fuzz");
      changed = true;
    }
    if (changed) checkPrintable(c);
  } catch (const TopoError&) {
  }
  return 0;
}
