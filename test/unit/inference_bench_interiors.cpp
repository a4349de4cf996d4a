// bench_interiors --quick --check (bench/interiors/README.md): interiors inferred at ~6k particles
// from observations of a reference filled at half the spacing (~48k particles) with a known geometric
// interior and noise, never from the inference's own lattice. The bench exits 1 when a case's mass,
// inertia or held-out error exceeds its bound (the 2 % goal, or a bound the case states where the
// experiments do not fix a moment); this test also shows that the bound can fail: the body all of its
// other material (the unweighed start, baseline_start) lies outside it in every case.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "shared_data.h"
#include "test_util.h"

namespace {

TEST(BenchInteriors, QuickCasesMeetTheirBoundsAndTheStartDesignDoesNot) {
  const std::string out = "/tmp/topo_test_bench_interiors_" + std::to_string(::getpid());
  const auto run = topo_test::runTool("cd " + std::string(TOPO_SOURCE_DIR) + " && " + TOPO_BENCH_INTERIORS_PATH,
                                      "--quick --check --out " + out, topo_test::Stderr::Discard);
  EXPECT_EQ(run.code, 0) << run.out;
  const bool data = topo_test::fileExists(topo_test::sharedDataDir() + "/meshes/bunny.off");
  if (!data && topo_test::sharedDataRequired()) ADD_FAILURE() << "missing shared data (meshes/bunny.off)";
  std::istringstream lines(run.out);
  std::string line;
  int cases = 0;
  while (std::getline(lines, line)) {
    if (line.empty() || line[0] != '{') continue;
    const nlohmann::json j = nlohmann::json::parse(line);
    const std::string name = j.at("case");
    ++cases;
    SCOPED_TRACE(name);
    // The body alone misses by more than 2 % somewhere: the bounds can fail.
    const auto& b = j.at("baseline_start");
    EXPECT_GT(std::max({b.at("mass_err").get<double>(), b.at("inertia_err").get<double>(),
                        b.at("held_out_err").get<double>()}),
              0.02);
    EXPECT_TRUE(topo_test::fileExists(j.at("png").get<std::string>()));
    if (name == "box_two_material") {
      // A plane between two materials is a quadric's zero set and three hanging poses fix c: the
      // interior is found, not only the features matched.
      EXPECT_GE(j.at("iou_region").get<double>(), 0.9);
      EXPECT_LE(j.at("mass_err").get<double>(), 0.02);
      EXPECT_LE(j.at("inertia_err").get<double>(), 0.02);
    }
  }
  EXPECT_EQ(cases, data ? 3 : 2);
  std::filesystem::remove_all(out);
}

}  // namespace
