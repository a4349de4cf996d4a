// bench_interiors --quick --check (bench/interiors/README.md): interiors inferred at ~6k particles
// from observations of a reference filled at half the spacing (~48k particles) with a known geometric
// interior and noise, never from the inference's own lattice. The bench exits 1 when a case's mass,
// inertia or held-out error exceeds its bound (the 2 % goal, or a bound the case states where the
// experiments do not fix a moment); this test also shows that the bound can fail: the body all of its
// other material (the unweighed start, baseline_start) lies outside it in every case.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "shared_data.h"
#include "test_util.h"

namespace {

/// Runs bench_interiors with `args` (its pictures to a folder of this process, removed after) and returns
/// its JSON lines; expects exit 0.
std::vector<nlohmann::json> runBench(const std::string& args) {
  const std::string out = "/tmp/topo_test_bench_interiors_" + std::to_string(::getpid());
  const auto run = topo_test::runTool("cd " + std::string(TOPO_SOURCE_DIR) + " && " + TOPO_BENCH_INTERIORS_PATH,
                                      args + " --out " + out, topo_test::Stderr::Discard);
  EXPECT_EQ(run.code, 0) << run.out;
  std::vector<nlohmann::json> cases;
  std::istringstream lines(run.out);
  std::string line;
  while (std::getline(lines, line))
    if (!line.empty() && line[0] == '{') {
      cases.push_back(nlohmann::json::parse(line));
      if (!cases.back().contains("skipped"))
        EXPECT_TRUE(topo_test::fileExists(cases.back().value("png", std::string()))) << line;
    }
  std::filesystem::remove_all(out);
  return cases;
}

/// The body alone misses by more than 2 % somewhere: the bounds can fail.
void expectBaselineOutsideTheGoal(const nlohmann::json& j) {
  const auto& b = j.at("baseline_start");
  EXPECT_GT(std::max({b.at("mass_err").get<double>(), b.at("inertia_err").get<double>(),
                      b.at("held_out_err").get<double>()}),
            0.02);
}

TEST(BenchInteriors, QuickCasesMeetTheirBoundsAndTheStartDesignDoesNot) {
  const bool data = topo_test::fileExists(topo_test::sharedDataDir() + "/meshes/bunny.off");
  if (!data && topo_test::sharedDataRequired()) ADD_FAILURE() << "missing shared data (meshes/bunny.off)";
  int cases = 0;
  for (const nlohmann::json& j : runBench("--quick --check")) {
    const std::string name = j.at("case");
    ++cases;
    SCOPED_TRACE(name);
    expectBaselineOutsideTheGoal(j);
    if (name == "box_two_material") {
      // A plane between two materials is a quadric's zero set and three hanging poses fix c: the
      // interior is found, not only the features matched.
      EXPECT_GE(j.at("iou_region").get<double>(), 0.9);
      EXPECT_LE(j.at("mass_err").get<double>(), 0.02);
      EXPECT_LE(j.at("inertia_err").get<double>(), 0.02);
    }
  }
  EXPECT_EQ(cases, data ? 3 : 2);
}

// The peer world's quick case (bench/peer_world/README.md): the tumbler with an off-centre cavity, its
// rocking simulated by Bullet and seen through the independent renderer and the tracker, its hangs and the
// truth from the exact moments of the true mesh and sphere. Nothing the inference sees was made by this
// package's simulators or renderer.
TEST(BenchInteriors, PeerWorldQuickTumblerCavity) {
#ifndef TOPO_HAVE_PEER_WORLD
  GTEST_SKIP() << "the peer world is built only where Bullet is found (libbullet-dev)";
#else
  const std::vector<nlohmann::json> cases = runBench("--quick --world peer --check tumbler_cavity");
  ASSERT_EQ(cases.size(), 1u);
  const nlohmann::json& j = cases[0];
  EXPECT_EQ(j.at("world"), "peer");
  // The rocking went through the peer's video: the targets' period within 0.5 % of Bullet's.
  ASSERT_EQ(j.at("video").size(), 1u) << j;
  const auto& v = j.at("video")[0];
  const double bullet = v.at("bullet_period_s"), tracked = v.at("tracked_period_s");
  EXPECT_NEAR(tracked, bullet, 0.005 * bullet) << j;
  EXPECT_LT(std::abs(v.at("tilt_error_mean_deg").get<double>()), 0.3) << j;
  // The found design predicts the held-out rocking (Bullet, about (1, 1, 0) from 15 deg) within the
  // goal while the body alone does not.
  EXPECT_LE(j.at("held_out_err").get<double>(), 0.02) << j;
  expectBaselineOutsideTheGoal(j);
#endif
}

}  // namespace
