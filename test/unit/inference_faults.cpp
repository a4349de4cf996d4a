// Faults and bad input of an inference run: step and memory budgets refused before the work, cancel
// latency inside the simulations' time loops, the iteration limit, volumes too small for a task, a
// hanging point outside the object.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <fstream>
#include <random>
#include <thread>

#include "test_clouds.h"
#include "test_util.h"
#include "topo_gaussian/inference/interior_problem.h"
#include "topo_gaussian/inference/optimizer.h"
#include "topo_gaussian/inference/pipeline.h"
#include "topo_gaussian/io/interior_ply.h"
#include "topo_gaussian/io/volume_ply.h"
#include "topo_gaussian/physics/rigid_body.h"
#include "topo_gaussian/physics/soft_rollout.h"
#include "topo_gaussian/workflow/inference_run.h"

using namespace topo_gaussian;
using namespace topo_gaussian::inference;
using topo_test::errorOf;

namespace {

using Clock = std::chrono::steady_clock;
double secondsSince(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

std::string tempDir(const std::string& name) {
  const std::string d = "/tmp/topo_inference_faults_" + std::to_string(::getpid()) + "_" + name;
  std::system(("rm -rf '" + d + "'").c_str());
  return d;
}

TaskConfig tumblerConfig() {
  TaskConfig c = TaskConfig::defaults("tumbler");
  c.set("period_s", "0.5");
  c.set("max_tilt_deg", "9");
  c.set("representation", "quadric");
  return c;
}

/// An a-wide cube on a 1 cm lattice, bottom face at z = 0, with contact samples every `s` on its faces
/// (area s^2 each), as topo fill samples a box mesh.
VolumeCloud cubeWithContactSamples(double a, double s) {
  VolumeCloud c = topo_test::boxCloud(a, a, a, 0.01);
  for (auto& x : c.X) x.z() += a / 2;
  const int n = static_cast<int>(std::lround(a / s));
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side)
      for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
          Eigen::Vector3d x, normal = Eigen::Vector3d::Zero();
          x[axis] = side ? a / 2 : -a / 2;
          x[(axis + 1) % 3] = -a / 2 + (i + 0.5) * a / n;
          x[(axis + 2) % 3] = -a / 2 + (j + 0.5) * a / n;
          normal[axis] = side ? 1.0 : -1.0;
          c.contact.X.push_back(x + Eigen::Vector3d(0, 0, a / 2));
          c.contact.normal.push_back(normal);
          c.contact.area.push_back((a / n) * (a / n));
        }
  c.contact.spacing = a / n;
  c.contact.origin = "mesh triangles";
  return c;
}

}  // namespace

TEST(StepBudget, ManyContactSamplesOnAFlatFaceAreRefusedAtOnce) {
  // A tumbler on a 10 cm cube: released at 10 deg it lands on its face, where every sample under the face
  // touches at once. The contact step shrinks with their number, so the work grows as its 1.5th power:
  // 0.4 mm samples (topo fill's default on this box) would take hours; 5 mm ones take a second.
  const TaskConfig c = tumblerConfig();
  const VolumeCloud coarse = cubeWithContactSamples(0.1, 0.005);
  const ProblemEvaluation ev = simulateInterior(c, coarse, {});
  const auto period = std::find_if(ev.task.features.begin(), ev.task.features.end(),
                                   [](const Feature& f) { return f.name == "period_s"; });
  ASSERT_NE(period, ev.task.features.end());
  EXPECT_GT(period->value, 0.0);

  const VolumeCloud fine = cubeWithContactSamples(0.1, 0.0005);
  InteriorProblem problem(c, fine);
  const auto t0 = Clock::now();
  problem.setShouldStop([&] { return secondsSince(t0) > 30.0; });  // a test that fails, not one that hangs
  std::string e;
  try {
    e = errorOf([&] { problem.evaluateIndicator(std::vector<double>(fine.size(), 1.0), nullptr); });
  } catch (const SimulationCancelled&) {
    e = "still simulating after 30 s";
  }
  EXPECT_LT(secondsSince(t0), 10.0);
  EXPECT_NE(e.find("contact points"), std::string::npos) << e;
  EXPECT_NE(e.find("the limit is 1e+09"), std::string::npos) << e;
  EXPECT_NE(e.find("--contact-spacing"), std::string::npos) << e;
}

TEST(StepBudget, TinySubstepIsRefusedWithTheNumbersBeforeAnyWork) {
  const VolumeCloud cloud = topo_test::tumblerCloud(0.05, 0.5, 0.01);
  TaskConfig c = tumblerConfig();
  c.set("duration_s", "2");
  c.set("max_substep_s", "1e-12");
  const auto t0 = Clock::now();
  const std::string e = errorOf([&] { simulateInterior(c, cloud, {}); });
  EXPECT_LT(secondsSince(t0), 5.0);
  EXPECT_NE(e.find("1e-12 s steps over 2 s = 2e+12 steps"), std::string::npos) << e;
  EXPECT_NE(e.find("the limit is 1e+08"), std::string::npos) << e;
  EXPECT_NE(e.find("use max_substep_s >= 2e-08 s"), std::string::npos) << e;
  // The same through the run an optimiser starts: refused before the optimisation.
  const std::string e2 = errorOf([&] { runInference(c, cloud); });
  EXPECT_NE(e2.find("max_substep_s >="), std::string::npos) << e2;
}

TEST(StepBudget, RigidAndSoftSimulatorsRefuseOverTheLimit) {
  RigidSimOptions o;
  o.duration_s = 10.0;
  o.max_substep_s = 1e-8;  // 1e9 substeps
  o.ground.enabled = false;
  MassProperties mp;
  mp.mass = 1.0;
  mp.com.setZero();
  mp.inertia = Eigen::Matrix3d::Identity() * 1e-3;
  const RigidInertia<double> I = toInertia(mp);
  RigidState<double> s0;
  s0.position.setZero();
  s0.velocity.setZero();
  s0.angular_velocity.setZero();
  s0.orientation.setIdentity();
  const std::string e = errorOf([&] { simulateRigid(I, s0, {}, o); });
  EXPECT_NE(e.find("1e+09 steps"), std::string::npos) << e;

  // Soft: steps × particles over kMaxParticleSteps (1000 particles × 1e9 steps).
  const VolumeCloud box = topo_test::boxCloud(0.1, 0.1, 0.1, 0.01);
  SoftBodySimulator sim(CorotatedSph::fromCloud(box, lameFromYoung(1e6, 0.3)));
  SoftRolloutOptions ro;
  ro.integrator = SoftIntegrator::ImplicitEuler;
  ro.dt = 1e-9;
  ro.steps = 1000000000;
  const std::string es = errorOf([&] { SoftRollout r(&sim, ro); });
  EXPECT_NE(es.find("particle-steps"), std::string::npos) << es;
  EXPECT_NE(es.find("dt_s >="), std::string::npos) << es;
}

TEST(MemoryBudget, TinySamplingStepIsRefusedWithTheEstimateNotBadAlloc) {
  const VolumeCloud cloud = topo_test::tumblerCloud(0.05, 0.5, 0.01);
  for (const char* dt : {"1e-6", "1e-7"}) {
    TaskConfig c = tumblerConfig();
    c.set("duration_s", "2");
    c.set("dt_s", dt);
    const auto t0 = Clock::now();
    const std::string e = errorOf([&] { simulateInterior(c, cloud, {}); });
    EXPECT_LT(secondsSince(t0), 5.0) << dt;
    EXPECT_NE(e.find("GB; the limit is 1.07 GB"), std::string::npos) << dt << ": " << e;
    EXPECT_NE(e.find("use a larger dt_s"), std::string::npos) << e;
    EXPECT_EQ(e.find("bad_alloc"), std::string::npos) << e;
  }
}

TEST(Cancel, AStopFlagEndsALongSimulationWithinASecondWithTheBestDesignSoFar) {
  const VolumeCloud cloud = topo_test::tumblerCloud(0.05, 0.5, 0.01);
  workflow::InferenceRunRequest rq;
  rq.config = tumblerConfig();
  rq.config.set("duration_s", "2");
  rq.config.set("max_substep_s", "2e-7");  // 1e7 substeps per simulation: tens of seconds
  rq.volume = std::make_shared<VolumeCloud>(cloud);
  rq.output_dir = tempDir("cancel");
  rq.export_files = false;
  std::atomic<bool> stop{false};
  rq.should_stop = [&] { return stop.load(); };
  Clock::time_point set_at;
  std::thread canceller([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    set_at = Clock::now();
    stop = true;
  });
  const auto t0 = Clock::now();
  const workflow::InferenceRunOutcome out = workflow::runInference(rq);
  const double total_s = secondsSince(t0);
  canceller.join();
  const double latency_s = std::chrono::duration<double>(Clock::now() - set_at).count();
  std::cout << "cancel latency " << latency_s << " s (run " << total_s << " s)\n";
  EXPECT_LT(latency_s, 1.0);
  EXPECT_TRUE(out.cancelled);
  EXPECT_TRUE(out.result.cancelled);
  // Inside the first simulation (1e7 substeps), not between evaluations.
  EXPECT_NE(out.result.message.find("cancelled during the first simulation"), std::string::npos) << out.result.message;
  EXPECT_EQ(out.result.theta.size(), 10);
  EXPECT_EQ(out.result.r.size(), cloud.size());
  EXPECT_TRUE(std::ifstream(rq.output_dir + "/interior.ply").good());  // nothing lost
}

TEST(Cancel, OptimiserStopsBetweenEvaluationsAndInsideOne) {
  const Objective slow = [](const Eigen::VectorXd& x, Eigen::VectorXd* g) {
    if (g) *g = 2 * x;
    return x.squaredNorm();
  };
  OptimizerOptions o;
  o.should_stop = [] { return true; };
  for (const char* method : {"lbfgs", "adam"}) {
    o.method = method;
    const OptimizerResult r = minimize(slow, Eigen::VectorXd::Constant(3, 1.0), {}, {}, o);
    EXPECT_TRUE(r.cancelled) << method;
    EXPECT_EQ(r.iterations, 0) << method;
    EXPECT_EQ(r.theta.size(), 3) << method;  // the start design
  }
  // A simulation that throws SimulationCancelled at the third evaluation: the best of the first two.
  int calls = 0;
  const Objective cancelling = [&](const Eigen::VectorXd& x, Eigen::VectorXd* g) {
    if (++calls == 3) throw SimulationCancelled();
    if (g) *g = 2 * x;
    return x.squaredNorm();
  };
  OptimizerOptions a;
  a.method = "adam";
  const OptimizerResult r = minimize(cancelling, Eigen::VectorXd::Constant(3, 1.0), {}, {}, a);
  EXPECT_TRUE(r.cancelled);
  EXPECT_EQ(r.iterations, 2);
  EXPECT_LT(r.loss, 3.0);
  EXPECT_NE(r.message.find("cancelled"), std::string::npos) << r.message;
}

TEST(IterationLimit, CountsEvaluationsForBothMethods) {
  const VolumeCloud cloud = topo_test::boxCloud(0.2, 0.1, 0.06, 0.01);
  for (const char* method : {"lbfgs", "adam"}) {
    for (int k : {1, 2, 3}) {
      TaskConfig c = TaskConfig::defaults("hanging");
      c.set("hanging_point", "0.05,0.02,0.03");
      c.set("representation", "quadric");
      c.set("optimizer", method);
      c.setNumber("max_evaluations", k);
      int evaluations = 0;
      const InferenceResult r = runInference(c, cloud, nullptr, [&](const ProblemEvaluation&) { ++evaluations; });
      EXPECT_EQ(r.theta.size(), 10) << method << " " << k;
      EXPECT_LE(evaluations, k) << method << " " << k;
      EXPECT_GE(evaluations, 1) << method << " " << k;
      EXPECT_LE(r.optimizer.evaluations, k) << method << " " << k;
      EXPECT_EQ(r.optimizer.iterations, evaluations) << method << " " << k;
      if (std::string(method) == "adam") EXPECT_EQ(evaluations, k);
    }
  }
}

TEST(SmallVolume, OneParticleIsRefusedWithTheCountAndTheFix) {
  VolumeCloud one;
  one.X = {Eigen::Vector3d(0, 0, 0)};
  one.V = {1e-6};
  one.surface = {1};
  one.spacing = 0.01;
  TaskConfig c = TaskConfig::defaults("hanging");
  c.set("hanging_point", "0,0,0.01");
  const std::string e = errorOf([&] { runInference(c, one); });
  EXPECT_NE(e.find("has 1 particle,"), std::string::npos) << e;
  EXPECT_NE(e.find("at least 8"), std::string::npos) << e;
  EXPECT_NE(e.find("topo fill"), std::string::npos) << e;
}

TEST(SmallVolume, SoftTaskRefusesParticlesOffALattice) {
  VolumeCloud box = topo_test::boxCloud(0.2, 0.02, 0.02, 0.004);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-0.4, 0.4);
  // An interior particle (a boundary one may sit up to 0.75 spacings off: topo fill puts it at the
  // centroid of its cut cell).
  std::size_t k = 0;  // the second interior particle (the first is the lattice's reference)
  while (box.surface[k]) ++k;
  ++k;
  while (box.surface[k]) ++k;
  box.X[k] += Eigen::Vector3d(u(rng), u(rng), 0.45) * box.spacing;
  TaskConfig c = TaskConfig::defaults("cantilever");
  const std::string e = errorOf([&] { simulateInterior(c, box, {}); });
  EXPECT_NE(e.find("particle " + std::to_string(k) + " is"), std::string::npos) << e;
  EXPECT_NE(e.find("off the lattice"), std::string::npos) << e;
}

TEST(PointOutside, HangingPointFarFromTheObjectIsAWarningAndNamedInTheMessage) {
  const VolumeCloud cloud = topo_test::boxCloud(0.2, 0.1, 0.06, 0.01);
  TaskConfig c = TaskConfig::defaults("hanging");
  c.set("hanging_point", "0.5,0,0.03");
  c.set("max_evaluations", "20");
  const InferenceResult r = runInference(c, cloud);
  ASSERT_EQ(r.warnings.size(), 1u);
  EXPECT_NE(r.warnings[0].find("hanging_point"), std::string::npos) << r.warnings[0];
  EXPECT_NE(r.message.find("may be unreachable because the hanging_point lies outside the object"), std::string::npos)
      << r.message;
  // Inside: no warning.
  c.set("hanging_point", "0.015,0.005,0.03");
  EXPECT_TRUE(runInference(c, cloud).warnings.empty());
}

// ------------------------------------------------------------------ the same through `topo`

namespace {

struct CliFiles {
  std::string dir, volume, interior;
  VolumeCloud cloud;
};

const CliFiles& cliFiles() {
  static const CliFiles f = [] {
    CliFiles c;
    c.dir = tempDir("cli");
    std::system(("mkdir -p '" + c.dir + "'").c_str());
    c.cloud = topo_test::tumblerCloud(0.05, 0.5, 0.01);
    c.volume = c.dir + "/volume.ply";
    c.interior = c.dir + "/interior.ply";
    io::writeVolumePly(c.cloud, c.volume);
    const std::vector<double> r(c.cloud.size(), 1.0), rho(c.cloud.size(), 1000.0);
    io::writeInteriorPly(c.interior, c.cloud, r, rho, false);
    return c;
  }();
  return f;
}

}  // namespace

TEST(Cli, BudgetsAreRefusedWithTheNumbersNotBadAlloc) {
  const CliFiles& f = cliFiles();
  const std::string base = "simulate --task tumbler --volume " + f.volume + " --target period_s=0.5 ";
  const topo_test::ToolRun steps = topo_test::runTopo(base + "--set duration_s=2 --set max_substep_s=1e-12");
  EXPECT_EQ(steps.code, 1) << steps.out;
  EXPECT_NE(steps.out.find("2e+12 steps; the limit is 1e+08"), std::string::npos) << steps.out;
  const topo_test::ToolRun memory = topo_test::runTopo(base + "--set duration_s=2 --set dt_s=1e-7");
  EXPECT_EQ(memory.code, 1) << memory.out;
  EXPECT_NE(memory.out.find("GB; the limit is 1.07 GB"), std::string::npos) << memory.out;
  EXPECT_EQ(memory.out.find("bad_alloc"), std::string::npos) << memory.out;
}

TEST(Cli, InteriorOfAnotherVolumeOrWithNaNIsRefusedNamingTheParticle) {
  const CliFiles& f = cliFiles();
  VolumeCloud moved = f.cloud;
  for (auto& x : moved.X) x.x() += 1.0;
  const std::vector<double> r(f.cloud.size(), 1.0), rho(f.cloud.size(), 1000.0);
  io::writeInteriorPly(f.dir + "/moved.ply", moved, r, rho, false);
  std::vector<double> r_nan = r;
  r_nan[7] = std::nan("");
  io::writeInteriorPly(f.dir + "/nan.ply", f.cloud, r_nan, rho, false);
  for (const char* cmd : {"simulate --task tumbler --target period_s=0.5", "export --output /tmp/unused_export"}) {
    const std::string base = std::string(cmd) + " --volume " + f.volume + " --interior " + f.dir;
    const topo_test::ToolRun m = topo_test::runTopo(base + "/moved.ply");
    EXPECT_EQ(m.code, 1) << cmd << ": " << m.out;
    EXPECT_NE(m.out.find("particle 0 is at"), std::string::npos) << cmd << ": " << m.out;
    EXPECT_NE(m.out.find("computed on another volume"), std::string::npos) << cmd << ": " << m.out;
    const topo_test::ToolRun n = topo_test::runTopo(base + "/nan.ply");
    EXPECT_EQ(n.code, 1) << cmd << ": " << n.out;
    EXPECT_NE(n.out.find("particle 7 has r = nan"), std::string::npos) << cmd << ": " << n.out;
  }
  // The interior of this volume is accepted.
  const topo_test::ToolRun ok = topo_test::runTopo("simulate --task tumbler --target period_s=0.5 --volume " +
                                                   f.volume + " --interior " + f.interior);
  EXPECT_EQ(ok.code, 0) << ok.out;
}

TEST(Cli, ATaskThatIsADirectoryOrAMapValueIsNamedWithFileAndKey) {
  const CliFiles& f = cliFiles();
  const topo_test::ToolRun d =
      topo_test::runTopo("infer --task " + f.dir + " --volume " + f.volume + " --output " + f.dir + "/run_dir");
  EXPECT_EQ(d.code, 1) << d.out;
  EXPECT_NE(d.out.find(f.dir + ": is a directory, not a task file"), std::string::npos) << d.out;
  const std::string yaml = f.dir + "/map_value.yaml";
  std::ofstream(yaml) << "task: tumbler\ngravity: {x: 1}\n";
  const topo_test::ToolRun m = topo_test::runTopo("simulate --task " + yaml + " --volume " + f.volume);
  EXPECT_EQ(m.code, 1) << m.out;
  EXPECT_NE(m.out.find(yaml + " gravity: is a map, not a value"), std::string::npos) << m.out;
  std::ofstream(yaml) << "task: {name: tumbler}\n";
  const topo_test::ToolRun t = topo_test::runTopo("simulate --task " + yaml + " --volume " + f.volume);
  EXPECT_EQ(t.code, 1) << t.out;
  EXPECT_NE(t.out.find(yaml + " task: is a map"), std::string::npos) << t.out;
}

TEST(Cli, OneIterationRunsAndAPointOutsideIsAWarningLine) {
  const CliFiles& f = cliFiles();
  const topo_test::ToolRun r = topo_test::runTopo("infer --task hanging --volume " + f.volume +
                                                  " --set max_evaluations=1 --set hanging_point=0.5,0,0.02 " +
                                                  "--no-export --output " + f.dir + "/one");
  EXPECT_EQ(r.code, 3) << r.out;  // ran, target not reached
  EXPECT_EQ(r.out.find("0 values"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("[topo infer] warning: hanging_point"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("may be unreachable"), std::string::npos) << r.out;
}
