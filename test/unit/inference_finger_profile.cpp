// Chamber IoU = |found ∩ true| / |found ∪ true| by volume, each inference particle labelled by its
// nearest twin particle (inference::interiorIou): the finger's chamber found from (a) the tip's bend
// angle at the full pressure, (b) the bend profile (bend_profile_deg, finger_task.cpp's header) at the
// full pressure, (c) the profile at 1/3, 2/3 and 1 of it (three experiments of one object, one design).
// Observations: the finger twin (workflow/finger_twin.h: the default finger at 2 mm, its surface on the
// true boundary, its true chamber, walls 2 MPa as config/rigs/finger_twin.yaml) solved at each pressure.
// Inference: the default 2.5 mm lattice (another discretisation than the twin's: no inverse crime) at
// the twin's task config (the rig's goal: the finger's defaults, 200 evaluations, no restarts).
// The default run is (a) against (b), at most 30 evaluations each: (b) has by then the IoU it stalls
// at (92 evaluations). (c) costs three solves per evaluation (6 min on 2 cores, 24 loaded); it runs,
// with (a) and (b) at the task's defaults, under TOPO_FINGER_PROFILE_FULL=1. Measured: (a) 0.284,
// (b) 0.361, (c) 0.253 (stalled after 151 evaluations); the truth rasterised on the 2.5 mm lattice
// reaches 0.706, but it bends 22 % more than the twin (there its 3 mm lower wall is one 2.5 mm
// layer), so it is not the design that fits the twin's data, and the search from the solid start
// lands elsewhere.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "topo_gaussian/inference/interior_problem.h"
#include "topo_gaussian/inference/pipeline.h"
#include "topo_gaussian/inference/truth_comparison.h"
#include "topo_gaussian/physics/default_shapes.h"
#include "topo_gaussian/workflow/finger_twin.h"
#include "user_path_helpers.h"

using namespace topo_gaussian;
using namespace topo_gaussian::inference;

namespace {

bool fullRun() {
  const char* e = std::getenv("TOPO_FINGER_PROFILE_FULL");
  return e && std::string(e) == "1";
}

const workflow::FingerTwin& twin() {
  static const workflow::FingerTwin t{[] {
    workflow::FingerTwinOptions o;
    o.overrides = {"youngs_modulus_solid=2e6"};  // config/rigs/finger_twin.yaml
    o.pressure_levels = 2;                       // the full pressure; the others are solved below
    return o;
  }()};
  return t;
}

/// What the twin shows at pressure p: its tip angle and profile (the task's own definitions on the
/// twin's 2 mm cloud).
struct Seen {
  double pressure_pa = 0.0, bend_deg = 0.0;
  std::vector<double> profile_deg;
};

Seen observe(double p) {
  const auto& t = twin();
  TaskConfig c = t.config();
  c.setNumber("pressure_pa", p);
  const ProblemEvaluation ev = InteriorProblem(c, t.cloud()).evaluateIndicator(t.indicator(), nullptr);
  Seen s;
  s.pressure_pa = p;
  s.bend_deg = topo_test::feature(ev.task, "bend_angle_deg");
  for (int k = 0; k < c.integer("profile_segments"); ++k)
    s.profile_deg.push_back(topo_test::feature(ev.task, "bend_profile_deg[" + std::to_string(k) + "]"));
  return s;
}

struct Found {
  double iou = NAN, seconds = 0.0, evaluation_s = 0.0, chamber_fraction = NAN;
  int evaluations = 0;
};

/// The inference on the default lattice from config c; the chamber IoU against the twin's.
Found infer(const TaskConfig& c, const std::string& label) {
  const auto t0 = std::chrono::steady_clock::now();
  const VolumeCloud cloud = defaultShapeCloud("finger", c.number("default_spacing_m"));
  const InferenceResult res = runInference(c, cloud);
  Found f;
  f.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  f.evaluation_s = res.evaluation_s;
  f.evaluations = res.optimizer.evaluations;
  std::vector<double> solid(res.r.size());
  double chamber = 0.0, total = 0.0;
  for (std::size_t i = 0; i < res.r.size(); ++i) {
    solid[i] = res.r[i] >= 0.5 ? 1.0 : 0.0;
    chamber += (1.0 - solid[i]) * cloud.V[i];
    total += cloud.V[i];
  }
  f.chamber_fraction = chamber / total;
  f.iou = interiorIou(cloud.X, solid, cloud.V, twin().cloud().X, twin().indicator()).cavity;
  std::printf(
      "[finger profile] (%s) chamber IoU %.3f, chamber fraction %.4f (twin %.4f), %d evaluations "
      "(%.2f s each), %.0f s; %s\n",
      label.c_str(), f.iou, f.chamber_fraction, 1.0 - twin().solidFraction(), f.evaluations, f.evaluation_s, f.seconds,
      res.message.substr(0, 160).c_str());
  return f;
}

TaskConfig inferenceConfig() {
  TaskConfig c = twin().config();  // the rig's goal: the finger task with the twin's materials
  if (!fullRun()) c.set("max_evaluations", "30");
  return c;
}

/// The twin's profiles at the full pressure (the twin's truth) and, when `all`, at 1/3 and 2/3 of it
/// before it; printed, and checked for their shape: growing from the clamp to the tip (level beyond
/// the chamber, which ends before the last 30 % of the length) and with the pressure, the last chord
/// at the tip angle.
std::vector<Seen> observedProfiles(bool all) {
  std::vector<Seen> seen;
  if (all)
    for (double f : {1.0 / 3.0, 2.0 / 3.0}) seen.push_back(observe(f * twin().maxPressurePa()));
  Seen full;
  full.pressure_pa = twin().maxPressurePa();
  full.bend_deg = topo_test::feature(twin().truth().task, "bend_angle_deg");
  for (int k = 0; k < twin().config().integer("profile_segments"); ++k)
    full.profile_deg.push_back(topo_test::feature(twin().truth().task, "bend_profile_deg[" + std::to_string(k) + "]"));
  seen.push_back(full);
  for (const Seen& s : seen) {
    std::printf("[finger profile] twin at %.4g Pa: tip %.3f deg, profile", s.pressure_pa, s.bend_deg);
    for (double v : s.profile_deg) std::printf(" %.3f", v);
    std::printf(" deg\n");
  }
  for (std::size_t k = 1; k < full.profile_deg.size(); ++k)
    EXPECT_GT(full.profile_deg[k], full.profile_deg[k - 1] - 0.01) << k;
  EXPECT_NEAR(full.profile_deg.back(), full.bend_deg, 0.02 * full.bend_deg);
  for (std::size_t e = 1; e < seen.size(); ++e)
    EXPECT_GT(seen[e].profile_deg.back(), 1.5 * seen[e - 1].profile_deg.back());
  return seen;
}

}  // namespace

TEST(FingerProfile, TheProfilePlacesTheChamberBetterThanOneTipAngle) {
  const std::vector<Seen> seen = observedProfiles(fullRun());
  const Seen& full = seen.back();
  // (a) today: the tip angle at the full pressure.
  TaskConfig a = inferenceConfig();
  a.setNumber("bend_angle_deg", full.bend_deg);
  const Found fa = infer(a, "a: tip angle, 1 pressure");
  // (b) the profile at the full pressure.
  TaskConfig b = inferenceConfig();
  b.setList("bend_profile_deg", full.profile_deg);
  const Found fb = infer(b, "b: profile, 1 pressure");
  Found fc;
  if (fullRun()) {  // (c) the profile at three pressures: three experiments of one object
    TaskConfig c = TaskConfig::common();
    for (const Seen& s : seen) {
      TaskConfig e = inferenceConfig();
      e.setNumber("pressure_pa", s.pressure_pa);
      e.setList("bend_profile_deg", s.profile_deg);
      c.addExperiment("p" + std::to_string(static_cast<int>(std::lround(s.pressure_pa / 1e3))) + "kpa", 1.0, e);
    }
    fc = infer(c, "c: profile, 3 pressures");
  }
  std::printf("[finger profile] chamber IoU: (a) %.3f  (b) %.3f  (c) %.3f; %.0f / %.0f / %.0f s\n", fa.iou, fb.iou,
              fc.iou, fa.seconds, fb.seconds, fc.seconds);
  EXPECT_GE(fb.iou, fa.iou + 0.05);  // measured 0.361 against 0.284
  EXPECT_GE(fb.iou, 0.33);
  if (fullRun()) EXPECT_GE(fc.iou, 0.2);  // measured 0.253: below (a), see the header
}
