// Several experiments of one object: the experiments file format, the shared parameters
// of one object, NAME.KEY assignments, the joint loss Σ_e w_e L_e and its gradient, observed windows
// tagged with their experiment, and hanging from two points pinning the whole centre of mass (the
// closed-form equilibrium: the centre of mass hangs straight below each point).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include "test_clouds.h"
#include "topo_gaussian/common/error.h"
#include "topo_gaussian/inference/interior_problem.h"
#include "topo_gaussian/inference/pipeline.h"
#include "topo_gaussian/inference/task_config.h"
#include "topo_gaussian/physics/mass_properties.h"
#include "topo_gaussian/workflow/inference_run.h"

using topo_gaussian::TopoError;
using topo_gaussian::VolumeCloud;
using namespace topo_gaussian::inference;

namespace {

constexpr double kDeg = 180.0 / M_PI;

std::string tempDir() {
  const std::string d = std::filesystem::temp_directory_path().string() + "/topo_experiments_" +
                        std::to_string(::testing::UnitTest::GetInstance()->random_seed()) + "_" +
                        ::testing::UnitTest::GetInstance()->current_test_info()->name();
  std::filesystem::remove_all(d);
  std::filesystem::create_directories(d);
  return d;
}

std::string writeFile(const std::string& path, const std::string& text) {
  std::ofstream(path) << text;
  return path;
}

std::string errorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const TopoError& e) {
    return e.what();
  }
  return "";
}

/// The rotation (roll about world x, then pitch about world y: targetRotation) in which the body hangs
/// from `point` at rest: the centre of mass straight below the point. Closed form.
std::pair<double, double> hangingPose(const Eigen::Vector3d& com, const Eigen::Vector3d& point) {
  const Eigen::Vector3d d = com - point;
  const double roll = std::atan2(-d.y(), -d.z());
  const double n = std::hypot(d.y(), d.z());
  const double pitch = std::atan2(d.x(), n);
  return {roll * kDeg, pitch * kDeg};
}

/// A box 0.1 × 0.06 × 0.08 m with an off-centre spherical cavity: its indicator and mass properties.
struct CavityBox {
  VolumeCloud cloud = topo_test::boxCloud(0.1, 0.06, 0.08, 0.005);
  std::vector<double> r;
  topo_gaussian::MassProperties truth;
  CavityBox() {
    const Eigen::Vector3d centre(0.02, 0.0, 0.01);
    for (const auto& x : cloud.X) r.push_back((x - centre).norm() < 0.025 ? 0.0 : 1.0);
    std::vector<double> m(r.size());
    for (std::size_t i = 0; i < r.size(); ++i) m[i] = 1000.0 * r[i] * cloud.V[i];
    truth = topo_gaussian::computeMassProperties(cloud.X, m, topo_gaussian::cubeCellVariance(cloud.spacing));
  }
};

}  // namespace

TEST(Experiments, AnExperimentsFileHoldsSharedParametersAndEachExperimentsOwn) {
  const std::string dir = tempDir();
  writeFile(dir + "/rock.yaml", "task: tumbler\ninitial_tilt_deg: 12\ntargets:\n  period_s: 0.5\n");
  const std::string path = writeFile(dir + "/object.yaml", R"(description: one doll, three experiments
representation: quadric
density_solid: 4000
experiments:
  - name: rock_x
    task: tumbler
    rocking_axis: [1, 0, 0]
    targets: {period_s: 0.40, max_tilt_deg: 10}
  - name: rock_y
    file: rock.yaml
    weight: 2.5
    rocking_axis: [0, 1, 0]
  - name: hang
    task: hanging
    hanging_point: [0.03, 0, 0.02]
)");
  const TaskConfig c = TaskConfig::fromYamlFile(path);
  ASSERT_TRUE(c.hasExperiments());
  ASSERT_EQ(c.experiments().size(), 3u);
  EXPECT_EQ(c.task(), "tumbler") << "the object's config takes the first experiment's task";
  const auto& e = c.experiments();
  EXPECT_EQ(e[0].name, "rock_x");
  EXPECT_EQ(e[1].name, "rock_y");
  EXPECT_EQ(e[2].name, "hang");
  EXPECT_DOUBLE_EQ(e[1].weight, 2.5);
  EXPECT_DOUBLE_EQ(e[0].weight, 1.0);
  EXPECT_EQ(e[2].config.task(), "hanging");
  for (const auto& x : e) EXPECT_DOUBLE_EQ(x.config.number("density_solid"), 4000.0) << x.name;
  EXPECT_DOUBLE_EQ(e[1].config.number("initial_tilt_deg"), 12.0) << "from the experiment's own file";
  EXPECT_DOUBLE_EQ(e[1].config.number("period_s"), 0.5);
  EXPECT_DOUBLE_EQ(e[1].config.vector3("rocking_axis").y(), 1.0) << "the item's keys win over its file";
  EXPECT_DOUBLE_EQ(e[0].config.number("max_tilt_deg"), 10.0);
  EXPECT_DOUBLE_EQ(e[2].config.vector3("hanging_point").x(), 0.03);
  EXPECT_EQ(c.experimentList().size(), 3u);
  // A single-task config is its own one experiment.
  const TaskConfig single = TaskConfig::defaults("hanging");
  ASSERT_EQ(single.experimentList().size(), 1u);
  EXPECT_EQ(single.experimentList()[0].name, "hanging");
}

TEST(Experiments, OneObjectHasOneMaterialRepresentationAndOptimiser) {
  const std::string dir = tempDir();
  const std::string path = writeFile(dir + "/conflict.yaml", R"(experiments:
  - name: a
    task: hanging
    density_solid: 1000
  - name: b
    task: hanging
    density_solid: 5000
)");
  const std::string e = errorOf([&] { TaskConfig::fromYamlFile(path); });
  EXPECT_NE(e.find("experiment 'b' density_solid"), std::string::npos) << e;
  EXPECT_NE(e.find("once, at the top"), std::string::npos) << e;
  // A task's own parameter at the top is refused, naming it.
  const std::string top = writeFile(dir + "/top.yaml", "rocking_axis: [1, 0, 0]\nexperiments:\n  - task: tumbler\n");
  const std::string e2 = errorOf([&] { TaskConfig::fromYamlFile(top); });
  EXPECT_NE(e2.find("rocking_axis"), std::string::npos) << e2;
  EXPECT_NE(e2.find("move rocking_axis into the experiment"), std::string::npos) << e2;
  // Two names alike, a weight ≤ 0, an empty list, task and experiments together.
  TaskConfig c = TaskConfig::common();
  c.addExperiment("a", 1.0, TaskConfig::defaults("hanging"));
  EXPECT_NE(errorOf([&] { c.addExperiment("a", 1.0, TaskConfig::defaults("hanging")); }).find("named twice"),
            std::string::npos);
  EXPECT_NE(errorOf([&] { c.addExperiment("b", 0.0, TaskConfig::defaults("hanging")); }).find("weight"),
            std::string::npos);
  EXPECT_NE(errorOf([&] { c.addExperiment("c.d", 1.0, TaskConfig::defaults("hanging")); }).find("contains '.'"),
            std::string::npos);
  const std::string empty = writeFile(dir + "/empty.yaml", "experiments: []\n");
  EXPECT_NE(errorOf([&] { TaskConfig::fromYamlFile(empty); }).find("non-empty list"), std::string::npos);
  const std::string both = writeFile(dir + "/both.yaml", "task: hanging\nexperiments:\n  - task: hanging\n");
  EXPECT_NE(errorOf([&] { TaskConfig::fromYamlFile(both); }).find("both `task:` and `experiments:`"),
            std::string::npos);
}

TEST(Experiments, AssignmentsReachTheirExperiments) {
  TaskConfig c = TaskConfig::common();
  c.addExperiment("rock_x", 1.0, TaskConfig::defaults("tumbler"));
  TaskConfig y = TaskConfig::defaults("tumbler");
  y.set("rocking_axis", "0,1,0");
  c.addExperiment("rock_y", 1.0, y);
  c.addExperiment("hang", 1.0, TaskConfig::defaults("hanging"));
  c.set("rock_y.period_s", "0.61");
  EXPECT_DOUBLE_EQ(c.experiments()[1].config.number("period_s"), 0.61);
  EXPECT_FALSE(c.experiments()[0].config.has("period_s"));
  // A target two experiments have must name its experiment.
  const std::string e = errorOf([&] { c.set("period_s", "0.5"); });
  EXPECT_NE(e.find("is a target of 2 experiments"), std::string::npos) << e;
  EXPECT_NE(e.find("rock_y.period_s=VALUE"), std::string::npos) << e;
  // A shared parameter is set for all; a task parameter for the experiments whose task has it.
  c.set("density_solid", "2500");
  for (const auto& x : c.experiments()) EXPECT_DOUBLE_EQ(x.config.number("density_solid"), 2500.0);
  EXPECT_DOUBLE_EQ(c.number("density_solid"), 2500.0);
  c.set("hanging_point", "0.01,0,0.02");
  EXPECT_DOUBLE_EQ(c.experiments()[2].config.vector3("hanging_point").x(), 0.01);
  c.set("initial_tilt_deg", "7");
  EXPECT_DOUBLE_EQ(c.experiments()[0].config.number("initial_tilt_deg"), 7.0);
  EXPECT_DOUBLE_EQ(c.experiments()[1].config.number("initial_tilt_deg"), 7.0);
  EXPECT_NE(errorOf([&] { c.set("rock_z.period_s", "1"); }).find("names no experiment 'rock_z'"), std::string::npos);
  EXPECT_NE(errorOf([&] { c.set("hang.density_solid", "1"); }).find("shared by all experiments"), std::string::npos);
  EXPECT_NE(errorOf([&] { c.set("no_such_key", "1"); }).find("none of the experiments"), std::string::npos);
}

// The shipped task files differ in their material (tumbler.yaml density_solid 5000, hanging.yaml
// 1000): joined as named experiments (`--experiment hang=hanging`, the goal's `experiments`) they are
// refused unless the user names the object's value (`--set density_solid=5000`), which then reaches
// every file before they are joined.
TEST(Experiments, TheUsersSharedValueJoinsTaskFilesWhoseOwnValuesDiffer) {
  const std::string dir = std::string(TOPO_SOURCE_DIR) + "/config/tasks";
  const std::string e = errorOf([&] { TaskConfig::loadWithExperiments("tumbler", {"hang=hanging"}, dir); });
  EXPECT_NE(e.find("experiment 'hang' density_solid"), std::string::npos) << e;
  const TaskConfig c = TaskConfig::loadWithExperiments(
      "tumbler", {"hang=hanging"}, dir, {"density_solid=5000", "hang.hanging_point=0,0.04,0.02", "period_s=1"});
  ASSERT_EQ(c.experiments().size(), 2u);
  for (const auto& x : c.experiments()) EXPECT_DOUBLE_EQ(x.config.number("density_solid"), 5000.0) << x.name;
  EXPECT_DOUBLE_EQ(c.number("density_solid"), 5000.0);
  // only shared values are applied here (the caller applies the rest as before)
  EXPECT_FALSE(c.experiments()[1].config.has("hanging_point"));
  EXPECT_FALSE(c.experiments()[0].config.has("period_s"));
}

TEST(Experiments, TheJointLossIsTheWeightedSumAndItsGradientMatchesFiniteDifferences) {
  const CavityBox box;
  TaskConfig c = TaskConfig::common();
  c.set("representation", "quadric");
  TaskConfig a = TaskConfig::defaults("hanging"), b = TaskConfig::defaults("hanging");
  a.set("hanging_point", "0.03,0.01,0.04");
  a.set("target_roll_deg", "4");
  b.set("hanging_point", "-0.05,0,0.0");
  b.set("target_pitch_deg", "-20");
  c.addExperiment("a", 1.0, a);
  c.addExperiment("b", 2.5, b);
  const InteriorProblem joint(c, box.cloud);
  ASSERT_EQ(joint.numExperiments(), 2u);
  std::mt19937 rng(3);
  std::normal_distribution<double> n(0, 0.3);
  Eigen::VectorXd theta = joint.initialParameters();
  for (int k = 0; k < theta.size(); ++k) theta[k] += n(rng);
  std::vector<double> r;
  joint.indicator(theta, &r);
  // Each experiment alone, through its own problem: the joint task loss is their weighted sum.
  TaskConfig ca = c.experiments()[0].config, cb = c.experiments()[1].config;
  const double la = InteriorProblem(ca, box.cloud).evaluateIndicator(r, nullptr).task_loss;
  const double lb = InteriorProblem(cb, box.cloud).evaluateIndicator(r, nullptr).task_loss;
  const ProblemEvaluation ev = joint.evaluateIndicator(r, nullptr);
  EXPECT_NEAR(ev.task_loss, la + 2.5 * lb, 1e-12 * (la + 2.5 * lb));
  ASSERT_EQ(ev.experiments.size(), 2u);
  EXPECT_NEAR(ev.experiments[1].eval.loss, lb, 1e-14);
  EXPECT_EQ(ev.task.features.front().name.rfind("a.", 0), 0u) << "features are named EXPERIMENT.feature";
  // The gradient with respect to θ against central differences.
  Eigen::VectorXd g;
  joint.evaluate(theta, &g);
  for (int k = 0; k < theta.size(); ++k) {
    const double eps = 1e-6;
    Eigen::VectorXd tp = theta, tm = theta;
    tp[k] += eps;
    tm[k] -= eps;
    const double fd = (joint.evaluate(tp, nullptr) - joint.evaluate(tm, nullptr)) / (2 * eps);
    EXPECT_NEAR(g[k], fd, 1e-6 * std::max(1.0, std::abs(fd)) + 1e-4 * std::abs(fd)) << "theta " << k;
  }
}

TEST(Experiments, HangingFromTwoPointsPinsTheWholeCentreOfMass) {
  const CavityBox box;
  // The poses the true body hangs in, from two points (closed form: c straight below each point).
  const Eigen::Vector3d p1(0.05, 0.03, 0.04), p2(-0.05, -0.03, 0.0);
  const auto [roll1, pitch1] = hangingPose(box.truth.com, p1);
  const auto [roll2, pitch2] = hangingPose(box.truth.com, p2);
  TaskConfig c = TaskConfig::common();
  c.set("representation", "quadric");
  c.set("max_evaluations", "300");
  for (int k = 0; k < 2; ++k) {
    TaskConfig h = TaskConfig::defaults("hanging");
    h.setVector("hanging_point", k == 0 ? p1 : p2);
    h.setNumber("target_roll_deg", k == 0 ? roll1 : roll2);
    h.setNumber("target_pitch_deg", k == 0 ? pitch1 : pitch2);
    c.addExperiment(k == 0 ? "corner" : "edge", 1.0, h);
  }
  const InferenceResult res = runInference(c, box.cloud);
  ASSERT_EQ(res.final.experiments.size(), 2u);
  EXPECT_TRUE(res.targets_reached) << res.message;
  // One hang leaves c free along the vertical through its point; two pin all of c.
  const Eigen::Vector3d got = res.final.task.mass.com;
  EXPECT_LT((got - box.truth.com).norm(), 0.001 * 0.1414)
      << "got " << got.transpose() << ", true " << box.truth.com.transpose();
  EXPECT_GT(box.truth.com.norm(), 0.002) << "the cavity moves the centre of mass (the solid start is off)";
  EXPECT_GT((res.initial.task.mass.com - box.truth.com).norm(), 10 * 0.001 * 0.1414);
  EXPECT_NE(res.message.find("Per experiment"), std::string::npos) << res.message;
}

TEST(Experiments, ObservedWindowsGoToTheExperimentTheyAreTaggedWith) {
  const CavityBox box;
  TaskConfig c = TaskConfig::common();
  c.set("max_evaluations", "1");
  TaskConfig a = TaskConfig::defaults("hanging"), b = TaskConfig::defaults("hanging");
  a.set("hanging_point", "0.05,0,0.04");
  b.set("hanging_point", "-0.05,0,0.04");
  c.addExperiment("left", 1.0, a);
  c.addExperiment("right", 1.0, b);
  auto window = [](const std::string& experiment, double angle) {
    auto f = std::make_shared<topo_gaussian::motion::MotionFeatures>();
    f->kind = "pendulum";
    f->source = "test";
    f->experiment = experiment;
    f->equilibrium_deg = angle;
    f->equilibrium_confidence = 1.0;
    return f;
  };
  topo_gaussian::workflow::InferenceRunRequest rq;
  rq.config = c;
  rq.volume = std::make_shared<VolumeCloud>(box.cloud);
  rq.observed_experiments = {window("right", -7.0), window("left", 5.0)};
  rq.output_dir = tempDir();
  rq.export_files = false;
  const auto out = topo_gaussian::workflow::runInference(rq);
  EXPECT_DOUBLE_EQ(out.config.experiments()[0].config.number("target_roll_deg"), 5.0);
  EXPECT_DOUBLE_EQ(out.config.experiments()[1].config.number("target_roll_deg"), -7.0);
  // A window of an experiment the task does not have is refused, naming it and the experiments.
  rq.observed_experiments = {window("middle", 1.0)};
  const std::string e = errorOf([&] { topo_gaussian::workflow::runInference(rq); });
  EXPECT_NE(e.find("'middle'"), std::string::npos) << e;
  EXPECT_NE(e.find("left, right"), std::string::npos) << e;
}

TEST(Experiments, AnExperimentWithoutItsTargetsIsLeftOutWithAWarning) {
  const CavityBox box;
  TaskConfig c = TaskConfig::common();
  c.set("max_evaluations", "3");
  TaskConfig rock = TaskConfig::defaults("tumbler");  // no period_s, no max_tilt_deg
  TaskConfig hang = TaskConfig::defaults("hanging");
  hang.set("hanging_point", "0.05,0,0.04");
  c.addExperiment("rock", 1.0, rock);
  c.addExperiment("hang", 1.0, hang);
  topo_gaussian::workflow::InferenceRunRequest rq;
  rq.config = c;
  rq.volume = std::make_shared<VolumeCloud>(box.cloud);
  rq.output_dir = tempDir();
  rq.export_files = false;
  const auto out = topo_gaussian::workflow::runInference(rq);
  ASSERT_EQ(out.config.experiments().size(), 1u);
  EXPECT_EQ(out.config.experiments()[0].name, "hang");
  EXPECT_EQ(out.config.task(), "hanging") << "the object's config follows its first remaining experiment";
  ASSERT_FALSE(out.result.warnings.empty());
  EXPECT_NE(out.result.warnings.front().find("experiment 'rock' (tumbler)"), std::string::npos)
      << out.result.warnings.front();
  EXPECT_NE(out.result.warnings.front().find("left out"), std::string::npos);
  // Without any experiment that has its targets, the run is refused naming the last one.
  TaskConfig none = TaskConfig::common();
  none.addExperiment("rock_x", 1.0, rock);
  none.addExperiment("rock_y", 1.0, rock);
  rq.config = none;
  const std::string e = errorOf([&] { topo_gaussian::workflow::runInference(rq); });
  EXPECT_NE(e.find("no experiment has all its targets"), std::string::npos) << e;
}

TEST(Experiments, ContradictoryExperimentsAreSaidToBe) {
  const CavityBox box;
  TaskConfig c = TaskConfig::common();
  TaskConfig a = TaskConfig::defaults("hanging"), b = TaskConfig::defaults("hanging");
  a.set("hanging_point", "0,0,0.04");
  b.set("hanging_point", "0,0,0.04");
  a.set("target_roll_deg", "0");
  b.set("target_roll_deg", "30");  // the same point cannot hang the body level and at 30°
  c.addExperiment("level", 1.0, a);
  c.addExperiment("tilted", 1.0, b);
  const InferenceResult res = runInference(c, box.cloud);
  EXPECT_FALSE(res.targets_reached);
  EXPECT_FALSE(res.converged);
  EXPECT_NE(res.message.find("no single interior"), std::string::npos) << res.message;
  EXPECT_NE(res.message.find("level ("), std::string::npos) << res.message;
  EXPECT_NE(res.message.find("tilted ("), std::string::npos) << res.message;
}

TEST(Experiments, AGreyDesignIsComparedWithTheBinaryInteriorThatIsDrawn) {
  // A wide sigmoid (epsilon 20) leaves r between the materials: the interior drawn (solid where
  // r >= 0.5) is then not the one simulated, and the result says so with the binary design's features.
  const CavityBox box;
  TaskConfig c = TaskConfig::defaults("hanging");
  c.set("epsilon", "20");
  c.set("restarts", "0");
  c.set("hanging_point", "0.004,0,0.04");
  const InferenceResult res = runInference(c, box.cloud);
  EXPECT_GT(res.grey_fraction, 0.5) << res.message;
  ASSERT_TRUE(res.has_binarised);
  double grey_offset = -1, binary_offset = -1;
  for (const auto& f : res.final.task.features)
    if (f.name == "com_offset_m") grey_offset = f.value;
  for (const auto& f : res.binarised.task.features)
    if (f.name == "com_offset_m") binary_offset = f.value;
  ASSERT_GE(grey_offset, 0);
  ASSERT_GE(binary_offset, 0);
  std::printf("[grey] grey fraction %.3f: c offset %.3g m simulated, %.3g m drawn\n", res.grey_fraction, grey_offset,
              binary_offset);
  EXPECT_GT(std::abs(binary_offset - grey_offset), 10 * 1e-3 * 0.1414) << "the drawn design hangs differently";
  ASSERT_FALSE(res.warnings.empty());
  EXPECT_NE(res.warnings.back().find("is grey"), std::string::npos) << res.warnings.back();
  EXPECT_NE(res.message.find("not the simulated one"), std::string::npos) << res.message;
  // A sharp design (the default epsilon, reached targets) is not flagged unless it is grey.
  TaskConfig sharp = TaskConfig::defaults("hanging");
  sharp.set("restarts", "0");
  sharp.set("hanging_point", "0,0,0.04");
  const InferenceResult ok = runInference(sharp, box.cloud);
  for (const auto& w : ok.warnings) EXPECT_EQ(w.find("is grey"), std::string::npos) << w;
}
