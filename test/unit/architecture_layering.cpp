// The module layering of DESIGN.md, enforced: every file of a module (src/<module>/ and
// include/topo_gaussian/<module>/) includes only headers of the modules below it, and the libraries
// that must not depend on PCL, OpenCV or ROS are not linked against them.
//
//   common                       standard library only
//   physics                      common (+ Eigen, OpenMP)
//   cuda                         common, physics (+ the CUDA runtime; part of topo_physics)
//   topology                     common, physics, cuda (+ Eigen, OpenMP)
//   io                           common, physics (+ nlohmann_json)
//   geometry                     common, physics, io (+ PCL)
//   vision                       common (+ OpenCV)
//   inference                    common, physics, topology, io (+ NLopt, yaml-cpp)
//   workflow                     all of the above
//   ros, tools                   all of the above (ros: + roscpp; tools never ros)
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <set>
#include <string>

#include "test_util.h"

namespace fs = std::filesystem;

namespace {

const std::map<std::string, std::set<std::string>>& allowed() {
  static const std::map<std::string, std::set<std::string>> a = {
      {"common", {"common"}},
      {"physics", {"common", "physics"}},
      {"cuda", {"common", "physics", "cuda"}},
      {"topology", {"common", "physics", "cuda", "topology"}},
      {"io", {"common", "physics", "io"}},
      {"geometry", {"common", "physics", "io", "geometry"}},
      {"vision", {"common", "vision"}},
      {"inference", {"common", "physics", "cuda", "topology", "io", "inference"}},
      {"workflow", {"common", "physics", "cuda", "topology", "io", "geometry", "vision", "inference", "workflow"}},
      {"ros", {"common", "physics", "cuda", "topology", "io", "geometry", "vision", "inference", "workflow", "ros"}},
      {"tools", {"common", "physics", "cuda", "topology", "io", "geometry", "vision", "inference", "workflow"}},
      {"nodes", {"common", "ros"}},
  };
  return a;
}

/// Third-party headers a module must not include (prefixes of the include path).
const std::map<std::string, std::vector<std::string>>& forbiddenThirdParty() {
  static const std::vector<std::string> ros = {
      "ros/",      "sensor_msgs/", "geometry_msgs/",  "std_msgs/",          "tf2",
      "actionlib", "cv_bridge",    "pcl_conversions", "visualization_msgs/"};
  static const std::map<std::string, std::vector<std::string>> f = [] {
    std::map<std::string, std::vector<std::string>> m;
    for (const char* mod : {"common", "physics", "cuda", "topology", "io", "inference"}) {
      m[mod] = ros;
      m[mod].insert(m[mod].end(), {"pcl/", "opencv2/", "flann/"});
    }
    for (const char* mod : {"geometry", "workflow", "tools"}) m[mod] = ros;
    m["vision"] = ros;
    m["vision"].push_back("pcl/");
    m["geometry"].push_back("opencv2/");
    m["common"].insert(m["common"].end(), {"Eigen/", "nlohmann/", "yaml-cpp/"});
    return m;
  }();
  return f;
}

struct Violation {
  std::string file, include;
};

std::vector<Violation> violationsOf(const std::string& module, const fs::path& dir) {
  std::vector<Violation> out;
  if (!fs::is_directory(dir)) return out;
  static const std::regex inc(R"re(^\s*#\s*include\s*[<"]([^>"]+)[>"])re");
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    if (!e.is_regular_file()) continue;
    std::ifstream in(e.path());
    for (std::string line; std::getline(in, line);) {
      std::smatch m;
      if (!std::regex_search(line, m, inc)) continue;
      const std::string path = m[1];
      if (path.rfind("topo_gaussian/", 0) == 0) {
        const auto slash = path.find('/', 14);
        if (slash == std::string::npos) {  // a generated message header (topo_gaussian/X.h): ros only
          if (module != "ros" && module != "nodes") out.push_back({e.path().string(), path});
          continue;
        }
        const std::string target = path.substr(14, slash - 14);
        if (!allowed().at(module).count(target)) out.push_back({e.path().string(), path});
      }
      const auto f = forbiddenThirdParty().find(module);
      if (f == forbiddenThirdParty().end()) continue;
      for (const auto& prefix : f->second)
        if (path.rfind(prefix, 0) == 0) out.push_back({e.path().string(), path});
    }
  }
  return out;
}

}  // namespace

TEST(Architecture, EveryModuleIncludesOnlyTheModulesBelowIt) {
  const fs::path root = TOPO_SOURCE_DIR;
  std::size_t files = 0;
  for (const auto& [module, ok] : allowed()) {
    const auto v = violationsOf(module, root / "src" / module);
    const auto h = violationsOf(module, root / "include/topo_gaussian" / module);
    for (const auto& x : v) ADD_FAILURE() << x.file << " (module " << module << ") includes " << x.include;
    for (const auto& x : h) ADD_FAILURE() << x.file << " (module " << module << ") includes " << x.include;
    if (fs::is_directory(root / "src" / module))
      for (const auto& e : fs::recursive_directory_iterator(root / "src" / module)) files += e.is_regular_file();
  }
  EXPECT_GT(files, 100u) << "the check must see the sources";
  // Every folder under src/ and include/topo_gaussian/ is a known module (src/topo_gaussian is the
  // Python client package of catkin_python_setup: no C++, outside the layering).
  for (const fs::path& base : {root / "src", root / "include/topo_gaussian"})
    for (const auto& e : fs::directory_iterator(base))
      if (e.is_directory() && e.path() != root / "src" / "topo_gaussian")
        EXPECT_TRUE(allowed().count(e.path().filename().string()))
            << e.path() << " is not a module of the layering table";
  if (fs::is_directory(root / "src" / "topo_gaussian"))
    for (const auto& e : fs::recursive_directory_iterator(root / "src" / "topo_gaussian"))
      EXPECT_FALSE(e.is_regular_file() && e.path().extension() != ".py" && e.path().extension() != ".pyc")
          << e.path() << ": the Python package holds Python only (C++ goes into a module of the table)";
}

TEST(Architecture, TheCheckCatchesAnUpwardInclude) {
  const fs::path dir = fs::path(testing::TempDir()) / "topo_layering_probe";
  fs::create_directories(dir);
  std::ofstream(dir / "probe.cpp") << "#include \"topo_gaussian/inference/pipeline.h\"\n#include <opencv2/core.hpp>\n";
  const auto v = violationsOf("io", dir);
  ASSERT_EQ(v.size(), 2u);
  EXPECT_EQ(v[0].include, "topo_gaussian/inference/pipeline.h");
  EXPECT_EQ(v[1].include, "opencv2/core.hpp");
}

#ifdef TOPO_LIBRARY_FILES
TEST(Architecture, CoreLibrariesDoNotLinkPclOpenCvOrRos) {
  // TOPO_LIBRARY_FILES: "name=path,name=path" of the built libraries (CMake generator expressions).
  std::string list = TOPO_LIBRARY_FILES;
  std::size_t checked = 0;
  for (std::size_t start = 0; start < list.size();) {
    const std::size_t end = std::min(list.find(',', start), list.size());
    const std::string item = list.substr(start, end - start);
    start = end + 1;
    const std::string name = item.substr(0, item.find('=')), path = item.substr(item.find('=') + 1);
    const bool archive = path.size() > 2 && path.compare(path.size() - 2, 2, ".a") == 0;
    if (archive) {
      // A static library (topo_physics is built before catkin turns shared libraries on) has no link
      // dependencies of its own: check that none of its undefined symbols is PCL's, OpenCV's or ROS's.
      const topo_test::ToolRun r = topo_test::runTool("nm", "-C -u " + path);
      ASSERT_EQ(r.code, 0) << r.out;
      EXPECT_GT(r.out.size(), 100u) << "nm must list the archive's undefined symbols";
      for (const char* banned : {"pcl::", "cv::", "ros::"})
        EXPECT_EQ(r.out.find(banned), std::string::npos) << name << " uses " << banned;
    } else {
      const topo_test::ToolRun r = topo_test::runTool("ldd", path);
      ASSERT_EQ(r.code, 0) << r.out;
      for (const char* banned : {"libpcl_", "libopencv_", "libroscpp", "libcv_bridge"})
        EXPECT_EQ(r.out.find(banned), std::string::npos) << name << " links " << banned << ":\n" << r.out;
    }
    ++checked;
  }
  EXPECT_GE(checked, 3u);
}
#endif
