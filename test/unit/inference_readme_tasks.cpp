// docs/tasks.md's "Task parameters" block is the output of `topo tasks --markdown` (generated from the
// tasks' declarations): this test fails when they differ. With TOPO_UPDATE_DOCS=1 (or the older name
// TOPO_UPDATE_README=1) it rewrites the block first (then checks the rewritten file).
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

std::string docPath() { return std::string(TOPO_SOURCE_DIR) + "/docs/tasks.md"; }

std::string slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

bool updateRequested() {
  for (const char* name : {"TOPO_UPDATE_DOCS", "TOPO_UPDATE_README"}) {
    if (const char* u = std::getenv(name); u && std::string(u) == "1") return true;
  }
  return false;
}

}  // namespace

TEST(Docs, TaskParameterTablesAreGeneratedFromTheDeclarations) {
  const topo_test::ToolRun r = runTopo("tasks --markdown", topo_test::Stderr::Discard);
  ASSERT_EQ(r.code, 0) << r.out;
  ASSERT_NE(r.out.find("#### `tumbler`"), std::string::npos) << r.out;
  std::string doc = slurp(docPath());
  ASSERT_FALSE(doc.empty()) << docPath() << " is missing or empty";
  const auto b = doc.find(kBegin), e = doc.find(kEnd);
  ASSERT_NE(b, std::string::npos) << docPath() << " has no line " << kBegin;
  ASSERT_NE(e, std::string::npos) << docPath() << " has no line " << kEnd;
  ASSERT_LT(b, e);
  const std::size_t from = b + kBegin.size();
  if (updateRequested()) {
    doc.replace(from, e - from, r.out);
    std::ofstream(docPath()) << doc;
    doc = slurp(docPath());
  }
  const std::string block = doc.substr(from, doc.find(kEnd) - from);
  EXPECT_TRUE(block == r.out)
      << "docs/tasks.md's task-parameters block differs from `topo tasks --markdown`: regenerate it with\n"
         "  TOPO_UPDATE_DOCS=1 build/devel/lib/topo_gaussian/inference_readme_tasks\n"
         "(or paste the output of `topo tasks --markdown` between the markers), and commit docs/tasks.md.";
}
