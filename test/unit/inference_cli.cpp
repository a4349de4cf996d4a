// `topo infer` and `topo simulate` end to end: generate a mesh, fill it, infer, simulate the result,
// and the errors a user gets for bad input (exit codes and messages).
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include "test_util.h"

using topo_test::runTopo;
using topo_test::ToolRun;

namespace {

std::string slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

class Cli : public testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = testing::TempDir() + "/topo_cli";
    std::system(("rm -rf " + dir_ + " && mkdir -p " + dir_).c_str());  // a run folder must be new or empty
    ASSERT_EQ(runTopo("generate --shape box --size 0.1 --output " + dir_ + "/box.obj").code, 0);
    const ToolRun f = runTopo("fill --input " + dir_ + "/box.obj --output " + dir_ + "/box.ply --count 8000");
    ASSERT_EQ(f.code, 0) << f.out;
  }
  static std::string dir_;
};
std::string Cli::dir_;

}  // namespace

TEST_F(Cli, InferWritesInteriorAndReportAndSimulateReproducesIt) {
  const std::string out = dir_ + "/hang";
  const ToolRun r = runTopo("infer --task hanging --volume " + dir_ +
                            "/box.ply --set hanging_point=0.01,0.005,0.05 --output " + out + " --json");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("[topo infer] iteration"), std::string::npos) << "progress lines";
  const std::string report = slurp(out + "/report.json");
  for (const char* key : {"\"task\": \"hanging\"", "\"targets\"", "\"achieved_features\"", "\"loss_history\"",
                          "\"timings_s\"", "\"hanging_point\": [0.01, 0.005, 0.05]", "\"gravity\": [0, 0, -9.81]",
                          "\"center_of_mass\"", "\"converged\": true"})
    EXPECT_NE(report.find(key), std::string::npos) << key << " missing from report.json";
  const ToolRun s = runTopo("simulate --task hanging --volume " + dir_ + "/box.ply --interior " + out +
                            "/interior.ply --set hanging_point=0.01,0.005,0.05 --json");
  ASSERT_EQ(s.code, 0) << s.out;
  // The interior is stored as float32 r, so the re-simulated offset is tiny but not exactly the optimiser's.
  const auto at = s.out.find("\"com_offset_m\": {\"value\": ");
  ASSERT_NE(at, std::string::npos) << s.out;
  EXPECT_LT(std::stod(s.out.substr(at + 26)), 1e-4);
}

TEST_F(Cli, SimulateNamesAMissingInterior) {
  // A missing interior file is named in the error.
  const ToolRun s =
      runTopo("simulate --task tumbler --volume " + dir_ + "/box.ply --interior " + dir_ + "/nonexistent.ply");
  EXPECT_EQ(s.code, 1);
  EXPECT_NE(s.out.find("nonexistent.ply"), std::string::npos) << s.out;
}

TEST_F(Cli, BadInputExitsNonZeroWithTheReason) {
  ToolRun r =
      runTopo("infer --task hanging --volume " + dir_ + "/box.ply --set densty_solid=3 --output " + dir_ + "/x");
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.out.find("did you mean 'density_solid'"), std::string::npos) << r.out;
  r = runTopo("infer --task hanging --volume " + dir_ + "/box.ply --set dt_s=0 --output " + dir_ + "/x");
  EXPECT_EQ(r.code, 1);
  r = runTopo("infer --task tumbler --volume " + dir_ + "/box.ply --set dt_s=-1 --output " + dir_ + "/x");
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.out.find("dt_s"), std::string::npos) << r.out;
  r = runTopo("infer --task tumbler --volume " + dir_ + "/box.ply --output " + dir_ + "/x");
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.out.find("--target period_s"), std::string::npos) << r.out;
  r = runTopo("infer --task juggling --volume " + dir_ + "/box.ply --output " + dir_ + "/x");
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.out.find("unknown task"), std::string::npos) << r.out;
  r = runTopo("infer --task hanging --output " + dir_ + "/x");
  EXPECT_EQ(r.code, 2);
  r = runTopo("infer --task hanging --volume " + dir_ + "/missing.ply --output " + dir_ + "/x");
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.out.find("missing.ply"), std::string::npos) << r.out;
  r = runTopo("infer --task tumbler --target density_solid=3 --volume " + dir_ + "/box.ply --output " + dir_ + "/x");
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.out.find("use --set density_solid=3"), std::string::npos) << r.out;
  r = runTopo("infer --task tumbler --list-params");
  EXPECT_EQ(r.code, 0);
  EXPECT_NE(r.out.find("--target period_s"), std::string::npos) << r.out;
}
