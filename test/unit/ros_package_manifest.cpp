// The package manifest rosdep can satisfy: every key of package.xml resolves through
// rosdep/topo_gaussian.yaml and its Debian packages are installed (scripts/install_deps.sh --check, the
// equivalent of `rosdep check --from-paths . --ignore-src` on a machine without rosdep); a key without a
// rule is named; every catkin component CMakeLists.txt finds is declared; catkin_lint (when installed)
// finds no error beyond the two orders this package chose on purpose (its ROS-free core is built before
// catkin is found, so that it builds without ROS; DESIGN.md).
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>
#include <string>

namespace {

const std::string kRoot = TOPO_SOURCE_DIR;

struct Shell {
  int code = -1;
  std::string out;
};

Shell shell(const std::string& cmd) {
  Shell r;
  FILE* p = popen((cmd + " 2>&1").c_str(), "r");
  if (!p) return r;
  char buf[512];
  while (fgets(buf, sizeof buf, p)) r.out += buf;
  const int st = pclose(p);
  r.code = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

std::string slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// The dependency keys of a package.xml text (outside comments).
std::set<std::string> manifestKeys(std::string xml) {
  xml = std::regex_replace(xml, std::regex("<!--[\\s\\S]*?-->"), "");
  std::set<std::string> keys;
  const std::regex dep("<([a-z_]*depend)>\\s*([^<\\s]+)\\s*</\\1>");
  for (auto it = std::sregex_iterator(xml.begin(), xml.end(), dep); it != std::sregex_iterator(); ++it)
    keys.insert((*it)[2].str());
  return keys;
}

}  // namespace

TEST(PackageManifest, EveryKeyResolvesAndItsPackagesAreInstalled) {
  const Shell r = shell("bash " + kRoot + "/scripts/install_deps.sh --check");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("keys of package.xml resolve"), std::string::npos) << r.out;
  // --list names each key of the manifest once
  const Shell list = shell("bash " + kRoot + "/scripts/install_deps.sh --list");
  ASSERT_EQ(list.code, 0) << list.out;
  for (const std::string& k : manifestKeys(slurp(kRoot + "/package.xml")))
    EXPECT_NE(("\n" + list.out).find("\n" + k + ": "), std::string::npos) << k;
}

TEST(PackageManifest, AKeyWithoutARuleIsNamedWithTheFix) {
  const std::string dir = (std::filesystem::temp_directory_path() / "topo_manifest_test").string();
  std::filesystem::create_directories(dir);
  std::string xml = slurp(kRoot + "/package.xml");
  xml.replace(xml.find("</package>"), 10, "  <depend>no_such_key_xyz</depend>\n</package>");
  std::ofstream(dir + "/package.xml") << xml;
  const Shell r = shell("TOPO_MANIFEST=" + dir + "/package.xml bash " + kRoot + "/scripts/install_deps.sh --check");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("no_such_key_xyz"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("rosdep/topo_gaussian.yaml"), std::string::npos) << r.out;
}

TEST(PackageManifest, EveryCatkinComponentTheBuildFindsIsDeclared) {
  const std::string cmake = slurp(kRoot + "/CMakeLists.txt");
  std::smatch m;
  ASSERT_TRUE(std::regex_search(cmake, m, std::regex("find_package\\(catkin REQUIRED COMPONENTS([^)]*)\\)")));
  const std::set<std::string> keys = manifestKeys(slurp(kRoot + "/package.xml"));
  std::istringstream components(m[1].str());
  std::string c;
  int n = 0;
  while (components >> c) {
    ++n;
    EXPECT_TRUE(keys.count(c)) << "CMakeLists.txt finds catkin component " << c << " but package.xml does not declare it";
  }
  EXPECT_GT(n, 5);
  for (const char* lib : {"nlohmann-json-dev", "nlopt", "yaml-cpp", "eigen", "urdfdom", "bullet", "rospy"})
    EXPECT_TRUE(keys.count(lib)) << lib;
}

TEST(PackageManifest, CatkinLintFindsNoErrorBeyondTheChosenOrder) {
  if (shell("command -v catkin_lint").code != 0) GTEST_SKIP() << "catkin_lint (catkin-lint) is not installed";
  // catkin_order_violation / order_violation: the ROS-free core is added before find_package(catkin) on
  // purpose; external_subdir: the build folder of the tests' generated inputs.
  const Shell r = shell("cd " + kRoot +
                        " && catkin_lint --pkg topo_gaussian --ignore catkin_order_violation --ignore order_violation "
                        "--ignore external_subdir .");
  EXPECT_EQ(r.out.find(": error:"), std::string::npos) << r.out;
}
