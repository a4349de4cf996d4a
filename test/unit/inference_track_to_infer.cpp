// `topo track --json` → `topo infer --features`: what the tracker wrote is what the inference reads,
// and the task takes its targets from it by the same rule as the interior_inference node
// (inference/motion_targets.h). A rendered pendulum hanging 6° off vertical: the hanging task's
// target_roll_deg comes from the tracked equilibrium.
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "test_util.h"
#include "topo_gaussian/io/text_file.h"
#include "topo_gaussian/vision/synthetic_video.h"

using namespace topo_gaussian;

TEST(TrackToInfer, TheTrackersDocumentSetsTheTaskTargets) {
  const std::string dir = testing::TempDir() + "/topo_track_to_infer";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  vision::PendulumScene scene;
  scene.duration_s = 4.0;
  scene.equilibrium_deg = 6.0;
  vision::writeVideo(vision::renderPendulum(scene), scene.fps, dir + "/pendulum.avi");
  const auto tracked =
      topo_test::runTopo("track --video " + dir + "/pendulum.avi --json --series > " + dir + "/seen.json");
  ASSERT_EQ(tracked.code, 0) << tracked.out;

  ASSERT_EQ(topo_test::runTopo("shape beam --spacing 0.005 --volume " + dir + "/beam.ply").code, 0);
  const auto run = topo_test::runTopo("infer --task hanging --volume " + dir + "/beam.ply --features " + dir +
                                      "/seen.json --set max_evaluations=3 --no-export --quiet --output " + dir + "/run");
  ASSERT_TRUE(run.code == 0 || run.code == 3) << run.out;
  EXPECT_NE(run.out.find("target_roll_deg"), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("from the motion features"), std::string::npos) << run.out;
  const nlohmann::json report = nlohmann::json::parse(io::readTextFile(dir + "/run/report.json"));
  ASSERT_TRUE(report["targets"].contains("target_roll_deg")) << report["targets"].dump();
  EXPECT_NEAR(report["targets"]["target_roll_deg"].get<double>(), scene.equilibrium_deg, 0.3);

  // An explicit --target wins over the tracked one; a document that is not one is named.
  const auto explicit_target = topo_test::runTopo(
      "infer --task hanging --volume " + dir + "/beam.ply --features " + dir +
      "/seen.json --target target_roll_deg=2 --set max_evaluations=2 --no-export --quiet --output " + dir + "/run2");
  ASSERT_TRUE(explicit_target.code == 0 || explicit_target.code == 3) << explicit_target.out;
  const nlohmann::json report2 = nlohmann::json::parse(io::readTextFile(dir + "/run2/report.json"));
  EXPECT_DOUBLE_EQ(report2["targets"]["target_roll_deg"].get<double>(), 2.0);
  io::writeTextFile(dir + "/not_features.json", "{\"task\": \"hanging\"}");
  const auto bad = topo_test::runTopo("infer --task hanging --volume " + dir + "/beam.ply --features " + dir +
                                      "/not_features.json --output " + dir + "/run3");
  EXPECT_EQ(bad.code, 1) << bad.out;
  EXPECT_NE(bad.out.find("not_features.json"), std::string::npos) << bad.out;
}
