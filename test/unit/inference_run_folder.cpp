// One run folder for every front end (workflow::runInference, io/run_folder.h): a folder written by
// `topo infer` loads with io::loadRunFolder (what the interior_inference node restores from), a
// folder written by the library call the node makes is read back by `topo simulate` and `topo
// export`; run folders are unique within one second; the newest complete run is found past newer
// broken ones, each named with the reason; a folder holding an earlier run is refused (or, asked,
// cleared of that run's files only); writes are atomic.
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "test_util.h"
#include "topo_gaussian/inference/task_config.h"
#include "topo_gaussian/io/run_folder.h"
#include "topo_gaussian/io/text_file.h"
#include "topo_gaussian/io/volume_ply.h"
#include "topo_gaussian/physics/default_shapes.h"
#include "topo_gaussian/workflow/inference_run.h"

using namespace topo_gaussian;
using topo_test::errorOf;
using topo_test::runTopo;
using topo_test::ToolRun;

namespace fs = std::filesystem;

namespace {

class RunFolder : public testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = testing::TempDir() + "/topo_run_folder";
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    volume_ = std::make_shared<VolumeCloud>(defaultShapeCloud("tumbler", 0.006));
    io::writeVolumePly(*volume_, dir_ + "/tumbler.ply");
  }
  /// The request the node builds for a tumbler goal with one target, into a new folder under `parent`.
  static workflow::InferenceRunRequest nodeLikeRequest(const std::string& parent) {
    workflow::InferenceRunRequest rq;
    rq.config = inference::TaskConfig::defaults("tumbler");
    rq.config.setNumber("max_evaluations", 2);
    rq.volume = volume_;
    rq.targets = {"period_s=0.5"};
    rq.targets_origin = "goal targets";
    rq.output_parent = parent;
    rq.export_files = false;
    return rq;
  }
  static std::string dir_;
  static std::shared_ptr<VolumeCloud> volume_;
};
std::string RunFolder::dir_;
std::shared_ptr<VolumeCloud> RunFolder::volume_;

}  // namespace

TEST_F(RunFolder, ACliRunLoadsAsTheNodeLoadsIt) {
  const std::string out = dir_ + "/cli/tumbler_cli";
  const ToolRun r = runTopo("infer --task tumbler --volume " + dir_ +
                            "/tumbler.ply --target period_s=0.5 --set max_evaluations=2 "
                            "--quiet --output " +
                            out);
  ASSERT_TRUE(r.code == 0 || r.code == 3) << r.out;
  for (const char* f :
       {"volume.ply", "interior.ply", "report.json", "signal.csv", "interior.stl", "slices.png", "export.json"})
    EXPECT_TRUE(fs::exists(out + "/" + f)) << f << " missing from the CLI's run folder";
  const io::RunFiles run = io::loadRunFolder(out);
  EXPECT_EQ(run.task, "tumbler");
  EXPECT_EQ(run.volume.size(), volume_->size());
  EXPECT_EQ(run.interior.r.size(), volume_->size());
  EXPECT_NEAR(run.volume.spacing, volume_->spacing, 1e-12);
  // The node restores the newest loadable run under its ~output_dir: this one.
  const io::LatestRun latest = io::findLatestRun(dir_ + "/cli");
  ASSERT_TRUE(latest.found);
  EXPECT_EQ(latest.run.dir, out);
  EXPECT_TRUE(latest.skipped.empty());
}

TEST_F(RunFolder, TheNodesRunIsReadByTheCli) {
  const workflow::InferenceRunOutcome o = workflow::runInference(nodeLikeRequest(dir_ + "/node"));
  ASSERT_TRUE(fs::is_directory(o.output_dir));
  EXPECT_EQ(fs::path(o.output_dir).parent_path(), fs::path(dir_ + "/node"));
  EXPECT_EQ(o.files.size(), 4u) << "interior.ply, report.json, signal.csv, volume.ply without the export";
  const ToolRun s = runTopo("simulate --task tumbler --volume " + o.output_dir + "/volume.ply --interior " +
                            o.output_dir + "/interior.ply --json");
  ASSERT_EQ(s.code, 0) << s.out;
  EXPECT_NE(s.out.find("\"period_s\""), std::string::npos) << s.out;
  const ToolRun e =
      runTopo("export --volume " + o.output_dir + "/volume.ply --interior " + o.output_dir + "/interior.ply --report " +
              o.output_dir + "/report.json --output " + o.output_dir + "/export");
  EXPECT_EQ(e.code, 0) << e.out;
  EXPECT_TRUE(fs::exists(o.output_dir + "/export/interior.stl"));
  // report.json carries the interface section even without the export's files.
  EXPECT_NE(io::readTextFile(o.output_dir + "/report.json").find("\"interface\""), std::string::npos);
}

TEST_F(RunFolder, TwoRunsInOneSecondGetTwoFolders) {
  const std::string parent = dir_ + "/same_second";
  const std::string a = io::createRunFolder(parent, "hanging");
  const std::string b = io::createRunFolder(parent, "hanging");
  const std::string c = io::createRunFolder(parent, "hanging");
  EXPECT_NE(a, b);
  EXPECT_NE(b, c);
  EXPECT_TRUE(fs::is_directory(a) && fs::is_directory(b) && fs::is_directory(c));
}

TEST_F(RunFolder, RestoreWalksBackPastBrokenRunsAndSaysWhy) {
  const std::string parent = dir_ + "/restore";
  const workflow::InferenceRunOutcome good = workflow::runInference(nodeLikeRequest(parent));
  // Newer, broken: an empty report (killed while writing), and a truncated interior.
  const std::string empty_report = parent + "/tumbler_empty_report", truncated = parent + "/tumbler_truncated";
  fs::create_directories(empty_report);
  fs::create_directories(truncated);
  for (const char* f : {"volume.ply", "interior.ply"}) {
    fs::copy_file(good.output_dir + "/" + f, empty_report + "/" + f);
    fs::copy_file(good.output_dir + "/" + f, truncated + "/" + f);
  }
  std::ofstream(empty_report + "/report.json").close();
  fs::copy_file(good.output_dir + "/report.json", truncated + "/report.json");
  fs::resize_file(truncated + "/interior.ply", fs::file_size(truncated + "/interior.ply") / 2);
  const auto later = fs::last_write_time(good.output_dir + "/report.json") + std::chrono::seconds(5);
  fs::last_write_time(empty_report + "/report.json", later);
  fs::last_write_time(truncated + "/report.json", later + std::chrono::seconds(1));
  fs::create_directories(parent + "/not_a_run");  // no report.json: not a run, not mentioned

  const io::LatestRun latest = io::findLatestRun(parent);
  ASSERT_TRUE(latest.found);
  EXPECT_EQ(latest.run.dir, good.output_dir);
  ASSERT_EQ(latest.skipped.size(), 2u);
  EXPECT_NE(latest.skipped[0].find("tumbler_truncated"), std::string::npos) << latest.skipped[0];
  EXPECT_NE(latest.skipped[0].find("truncated"), std::string::npos) << latest.skipped[0];
  EXPECT_NE(latest.skipped[1].find("tumbler_empty_report"), std::string::npos) << latest.skipped[1];
  EXPECT_NE(latest.skipped[1].find("is empty"), std::string::npos) << latest.skipped[1];
  EXPECT_FALSE(io::findLatestRun(dir_ + "/no_such_folder").found);
}

TEST_F(RunFolder, RestorePassesOverAnInterruptedRun) {
  // A run stopped while it optimises (a cancelled goal, Ctrl-C: should_stop) still writes its files, the
  // best design so far; it is not a finished run, so the restore goes back to the older complete one.
  const std::string parent = dir_ + "/interrupted";
  const workflow::InferenceRunOutcome good = workflow::runInference(nodeLikeRequest(parent));
  ASSERT_FALSE(good.cancelled);
  workflow::InferenceRunRequest rq = nodeLikeRequest(parent);
  rq.config.setNumber("max_evaluations", 50);
  bool evaluated = false;
  rq.on_evaluation = [&](const inference::ProblemEvaluation&) { evaluated = true; };
  rq.should_stop = [&] { return evaluated; };  // stopped once the first design is evaluated
  const workflow::InferenceRunOutcome cut = workflow::runInference(rq);
  ASSERT_TRUE(cut.cancelled);
  ASSERT_NE(cut.output_dir, good.output_dir);
  fs::last_write_time(cut.output_dir + "/report.json",
                      fs::last_write_time(good.output_dir + "/report.json") + std::chrono::seconds(5));
  EXPECT_EQ(io::loadRunFolder(cut.output_dir).task, "tumbler");  // named, it still loads

  const io::LatestRun latest = io::findLatestRun(parent);
  ASSERT_TRUE(latest.found);
  EXPECT_EQ(latest.run.dir, good.output_dir);
  ASSERT_EQ(latest.skipped.size(), 1u);
  EXPECT_NE(latest.skipped[0].find(cut.output_dir), std::string::npos) << latest.skipped[0];
  EXPECT_NE(latest.skipped[0].find("interrupted"), std::string::npos) << latest.skipped[0];
}

TEST_F(RunFolder, RestorePassesOverARunOfAnUnknownTask) {
  // A newer run whose report names a task this installation does not know (a task file gone, another
  // version's task) is skipped with the folder and the task named; the older complete run is restored.
  const std::string parent = dir_ + "/unknown_task";
  const workflow::InferenceRunOutcome good = workflow::runInference(nodeLikeRequest(parent));
  const std::string other = parent + "/tumbler_29990101_000000";
  fs::create_directories(other);
  for (const char* f : {"volume.ply", "interior.ply"}) fs::copy_file(good.output_dir + "/" + f, other + "/" + f);
  nlohmann::json report = nlohmann::json::parse(io::readTextFile(good.output_dir + "/report.json"));
  report["task"] = "no_such_task";
  io::writeTextFile(other + "/report.json", report.dump(2));
  fs::last_write_time(other + "/report.json",
                      fs::last_write_time(good.output_dir + "/report.json") + std::chrono::seconds(5));

  const workflow::RestorableRun found = workflow::findRestorableRun(parent, "");
  ASSERT_TRUE(found.latest.found);
  EXPECT_EQ(found.latest.run.dir, good.output_dir);
  EXPECT_EQ(found.config.task(), "tumbler");
  ASSERT_EQ(found.latest.skipped.size(), 1u);
  EXPECT_NE(found.latest.skipped[0].find(other), std::string::npos) << found.latest.skipped[0];
  EXPECT_NE(found.latest.skipped[0].find("no_such_task"), std::string::npos) << found.latest.skipped[0];
}

TEST_F(RunFolder, ARequestWithoutTargetsOrFolderFailsBeforeAnyWork) {
  workflow::InferenceRunRequest rq = nodeLikeRequest(dir_ + "/refused");
  rq.targets.clear();
  rq.missing_targets_hint = " (hint from the front end)";
  const std::string e = errorOf([&] { workflow::runInference(rq); });
  EXPECT_NE(e.find("period_s"), std::string::npos) << e;
  EXPECT_NE(e.find("hint from the front end"), std::string::npos) << e;
  EXPECT_FALSE(fs::exists(dir_ + "/refused")) << "no folder for a refused run";
  rq = nodeLikeRequest("");
  EXPECT_NE(errorOf([&] { workflow::runInference(rq); }).find("no output folder"), std::string::npos);
  rq = nodeLikeRequest(dir_ + "/refused");
  rq.targets = {"density_solid=3"};
  EXPECT_NE(errorOf([&] { workflow::runInference(rq); }).find("not an observed feature"), std::string::npos);
}

// Issue 52 §2: `topo infer --output R` (or a goal's output_dir) where R held an earlier run overwrote it
// silently and left the old run's other files (signal.csv, signal.png) beside the new report. A
// folder that holds anything is refused before any work, naming what it holds and the fix; --force
// (replace_output) removes only the names a run writes, never another file.
TEST_F(RunFolder, AFolderHoldingAnEarlierRunIsRefusedAndForceRemovesOnlyItsFiles) {
  const std::string folder = dir_ + "/reused";
  workflow::InferenceRunRequest rq = nodeLikeRequest("");
  rq.output_dir = folder;  // as the node's goal.output_dir and topo infer --output give it
  workflow::runInference(rq);
  std::ofstream(folder + "/signal.png") << "an earlier run's picture";  // left by a run of another task
  const std::string report = io::readTextFile(folder + "/report.json");
  const std::string e = errorOf([&] { workflow::runInference(rq); });
  EXPECT_NE(e.find("output directory " + folder + ": holds an earlier run of task tumbler ("), std::string::npos) << e;
  EXPECT_NE(e.find("report.json"), std::string::npos) << e;
  EXPECT_NE(e.find("Fix: give another folder"), std::string::npos) << e;
  EXPECT_NE(e.find("--force"), std::string::npos) << e;
  EXPECT_EQ(io::readTextFile(folder + "/report.json"), report) << "the earlier run was touched";
  // Through the CLI: exit 1 with the same message; with --force the run replaces the earlier one.
  const std::string cli = "infer --task tumbler --volume " + dir_ +
                          "/tumbler.ply --target period_s=0.5 --set max_evaluations=1 --no-export --quiet --output " +
                          folder;
  const ToolRun refused = runTopo(cli);
  EXPECT_EQ(refused.code, 1) << refused.out;
  EXPECT_NE(refused.out.find("holds an earlier run of task tumbler"), std::string::npos) << refused.out;
  std::ofstream(folder + "/notes.txt") << "the user's own file";
  fs::create_directories(folder + "/photos");
  std::ofstream(folder + "/report.json.tmp12345") << "{";  // an interrupted write of the earlier run
  const ToolRun forced = runTopo(cli + " --force");
  ASSERT_TRUE(forced.code == 0 || forced.code == 3) << forced.out;
  EXPECT_NE(forced.out.find("removed the earlier run's"), std::string::npos) << forced.out;
  EXPECT_FALSE(fs::exists(folder + "/signal.png")) << "the earlier run's picture was left beside the new run";
  EXPECT_FALSE(fs::exists(folder + "/report.json.tmp12345"));
  EXPECT_TRUE(fs::exists(folder + "/notes.txt")) << "a file no run writes was removed";
  EXPECT_TRUE(fs::is_directory(folder + "/photos"));
  EXPECT_EQ(io::loadRunFolder(folder).task, "tumbler");
  // A folder with only other files is refused too (without --force), naming them; an empty one is used.
  const std::string other = dir_ + "/not_empty";
  fs::create_directories(other);
  std::ofstream(other + "/notes.txt") << "x";
  rq.output_dir = other;
  const std::string e2 = errorOf([&] { workflow::runInference(rq); });
  EXPECT_NE(e2.find("output directory " + other + ": is not empty (notes.txt)"), std::string::npos) << e2;
  const std::string empty = dir_ + "/empty";
  fs::create_directories(empty);
  rq.output_dir = empty;
  EXPECT_EQ(errorOf([&] { workflow::runInference(rq); }), "");
}

// Issue 52 §2: motion features the tracker itself calls unreliable (confidence 0.01, "do not use these
// numbers") became targets with `warnings: []`. They are still taken, with a warning in the message
// and in report.json naming the features, their confidence and the targets taken from them.
TEST_F(RunFolder, TargetsFromFeaturesTheTrackerCallsUnreliableAreAWarning) {
  auto seen = std::make_shared<motion::MotionFeatures>();
  seen->kind = "tilt";
  seen->source = "doubtful.mp4";
  seen->oscillation_found = true;
  seen->period_s = 0.5;
  seen->period_confidence = 0.01;
  seen->message = "unreliable: an oscillation was fitted, but with confidence 0.01; do not use these numbers";
  workflow::InferenceRunRequest rq = nodeLikeRequest(dir_ + "/unreliable");
  rq.targets.clear();
  rq.observed = seen;
  const workflow::InferenceRunOutcome o = workflow::runInference(rq);
  ASSERT_FALSE(o.result.warnings.empty()) << o.message;
  const std::string& w = o.result.warnings.front();
  EXPECT_NE(w.find("doubtful.mp4"), std::string::npos) << w;
  EXPECT_NE(w.find("the tracker rates period 0.01 (confidence < 0.3: unreliable"), std::string::npos) << w;
  EXPECT_NE(w.find("yet period_s"), std::string::npos) << w;
  EXPECT_NE(o.message.find("warning: motion features (doubtful.mp4"), std::string::npos) << o.message;
  const nlohmann::json report = nlohmann::json::parse(io::readTextFile(o.output_dir + "/report.json"));
  ASSERT_TRUE(report.contains("warnings")) << report.dump();
  EXPECT_NE(report["warnings"].dump().find("the tracker rates period 0.01"), std::string::npos) << report.dump();
  // A window measured with confidence gives its targets without that warning.
  seen->period_confidence = 0.9;
  seen->message.clear();
  const workflow::InferenceRunOutcome sure = workflow::runInference(rq);
  for (const auto& x : sure.result.warnings) EXPECT_EQ(x.find("the tracker rates"), std::string::npos) << x;
}

TEST(TextFile, WritesAreAtomicAndNameThePath) {
  const std::string dir = testing::TempDir() + "/topo_text_file";
  fs::create_directories(dir);
  io::writeTextFile(dir + "/a.txt", "first");
  io::writeTextFile(dir + "/a.txt", "second");
  EXPECT_EQ(io::readTextFile(dir + "/a.txt"), "second");
  for (const auto& e : fs::directory_iterator(dir)) EXPECT_EQ(e.path().filename(), "a.txt") << "no temporary left";
  const std::string e = errorOf([&] { io::writeTextFile(dir + "/missing/b.txt", "x"); });
  EXPECT_NE(e.find("missing/b.txt"), std::string::npos) << e;
  EXPECT_EQ(io::readTextFile(dir + "/a.txt"), "second") << "a failed write leaves the old file";
  EXPECT_NE(errorOf([&] { io::readTextFile(dir + "/a.txt", 3); }).find("more than"), std::string::npos);
  EXPECT_NE(errorOf([&] { io::readTextFile(dir); }).find("not a regular file"), std::string::npos);
}
