// Test helpers shared by the unit tests: the message of a TopoError a call throws, and running a
// command-line tool (the `topo` executable) and collecting its exit code and output. Standard
// library and topo_gaussian/common/error.h only, so the core_* tests (topo_physics alone) can use it.
#pragma once

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <functional>
#include <string>

#include "topo_gaussian/common/error.h"

namespace topo_test {

/// The message of the TopoError that `f` throws, or "" when it throws none.
inline std::string errorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const topo_gaussian::TopoError& e) {
    return e.what();
  }
  return "";
}

/// Exit code (-1 when the tool could not be started or did not exit normally) and captured output.
struct ToolRun {
  int code = -1;
  std::string out;
};

/// What runTool does with the tool's standard error.
enum class Stderr { Capture, Discard };

/// Runs `tool args` through the shell; stdout, and stderr unless discarded, end up in `out`.
inline ToolRun runTool(const std::string& tool, const std::string& args, Stderr err = Stderr::Capture) {
  ToolRun r;
  const std::string cmd = tool + " " + args + (err == Stderr::Capture ? " 2>&1" : " 2>/dev/null");
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return r;
  std::array<char, 4096> buf;
  while (std::fgets(buf.data(), int(buf.size()), p)) r.out += buf.data();
  const int st = pclose(p);
  r.code = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

#ifdef TOPO_TOOL_PATH
/// runTool on the `topo` executable of this build (TOPO_TOOL_PATH is defined per test target).
inline ToolRun runTopo(const std::string& args, Stderr err = Stderr::Capture) {
  return runTool(TOPO_TOOL_PATH, args, err);
}
#endif

}  // namespace topo_test
