#include "topo_gaussian/io/task_dir.h"

#include <cstdlib>
#include <filesystem>
#include <sstream>

#include "topo_gaussian/io/text_file.h"

namespace topo_gaussian::io {

namespace fs = std::filesystem;

namespace {

/// True when dir/package.xml names the package topo_gaussian.
bool isOurPackage(const fs::path& dir) {
  std::error_code ec;
  if (!fs::is_regular_file(dir / "package.xml", ec)) return false;
  try {
    return readTextFile((dir / "package.xml").string(), 1 << 20).find("<name>topo_gaussian</name>") !=
           std::string::npos;
  } catch (const std::exception&) {
    return false;
  }
}

}  // namespace

std::string defaultTaskDir() {
  if (const char* env = std::getenv("TOPO_TASK_DIR")) return env;
  if (const char* rpp = std::getenv("ROS_PACKAGE_PATH")) {
    std::istringstream paths(rpp);
    for (std::string p; std::getline(paths, p, ':');) {
      if (p.empty()) continue;
      // An entry is a package or a folder of packages (one level is enough for a catkin workspace).
      std::error_code ec;
      if (isOurPackage(p)) return (fs::path(p) / "config/tasks").string();
      for (const auto& e : fs::directory_iterator(p, ec))
        if (e.is_directory(ec) && isOurPackage(e.path())) return (e.path() / "config/tasks").string();
    }
  }
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);  // <prefix>/lib/topo_gaussian/topo
  if (!ec) {
    const fs::path share = exe.parent_path().parent_path().parent_path() / "share/topo_gaussian/config/tasks";
    if (fs::is_directory(share, ec)) return share.string();
  }
  return "";
}

}  // namespace topo_gaussian::io
