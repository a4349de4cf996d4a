// README.md's "Task parameters" block is the output of `topo tasks --markdown` (generated from the
// tasks' declarations): this test fails when they differ. With TOPO_UPDATE_README=1 it rewrites the
// block first (then checks the rewritten file).
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include "test_util.h"

using topo_test::runTopo;

namespace {

const std::string kBegin = "<!-- task-parameters:begin -->\n";
const std::string kEnd = "<!-- task-parameters:end -->";

std::string readmePath() { return std::string(TOPO_SOURCE_DIR) + "/README.md"; }

std::string slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

}  // namespace

TEST(Readme, TaskParameterTablesAreGeneratedFromTheDeclarations) {
  const topo_test::ToolRun r = runTopo("tasks --markdown", topo_test::Stderr::Discard);
  ASSERT_EQ(r.code, 0) << r.out;
  ASSERT_NE(r.out.find("#### `tumbler`"), std::string::npos) << r.out;
  std::string readme = slurp(readmePath());
  const auto b = readme.find(kBegin), e = readme.find(kEnd);
  ASSERT_NE(b, std::string::npos) << readmePath() << " has no line " << kBegin;
  ASSERT_NE(e, std::string::npos) << readmePath() << " has no line " << kEnd;
  ASSERT_LT(b, e);
  const std::size_t from = b + kBegin.size();
  if (const char* u = std::getenv("TOPO_UPDATE_README"); u && std::string(u) == "1") {
    readme.replace(from, e - from, r.out);
    std::ofstream(readmePath()) << readme;
    readme = slurp(readmePath());
  }
  const std::string block = readme.substr(from, readme.find(kEnd) - from);
  EXPECT_TRUE(block == r.out)
      << "README.md's task-parameters block differs from `topo tasks --markdown`: regenerate it with\n"
         "  TOPO_UPDATE_README=1 build/devel/lib/topo_gaussian/inference_readme_tasks\n"
         "(or paste the output of `topo tasks --markdown` between the markers), and commit README.md.";
}
