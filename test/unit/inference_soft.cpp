// Soft-body tasks: the pneumatic finger (static and implicit modes) and the bouncing
// pear on their default shapes. Physics checks: a closed chamber inflates monotonically with the
// pressure; a chamber offset to one side bends the finger towards the other side. Whole-task
// gradients dL/dr against central differences. Recovery from a known design: the finger's bending
// angle within 1°, the pear's pivot trajectories within 2 % (RMS relative to their extent).
#include <gtest/gtest.h>
#include <algorithm>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/inference/interior_problem.h"
#include "topo_gaussian/inference/pipeline.h"
#include "topo_gaussian/physics/default_shapes.h"

using namespace topo_gaussian;
using namespace topo_gaussian::inference;

namespace {

double feature(const TaskEvaluation& ev, const std::string& name) {
  for (const auto& f : ev.features)
    if (f.name == name) return f.value;
  ADD_FAILURE() << "no feature " << name;
  return NAN;
}

// Chamber (r = 0) in an inner box of the finger, everything else solid.
std::vector<double> chamber(const VolumeCloud& c, double x0, double x1, double z0, double z1) {
  std::vector<double> r(c.size(), 1.0);
  for (std::size_t i = 0; i < c.size(); ++i) {
    const auto& p = c.X[i];
    if (!c.surface[i] && p.x() > x0 && p.x() < x1 && p.z() > z0 && p.z() < z1 && std::abs(p.y()) < 0.006) r[i] = 0.0;
  }
  return r;
}

TaskConfig fingerConfig() {
  TaskConfig c = TaskConfig::defaults("finger");
  return c;
}

}  // namespace

TEST(SoftTasks, ClosedChamberInflatesMonotonicallyWithPressure) {
  const VolumeCloud cloud = defaultShapeCloud("finger", 0.004);
  const auto r = chamber(cloud, 0.03, 0.08, -0.004, 0.004);  // centred: no bending
  double prev = 1.0, prev_angle = 0.0;
  for (double p : {5e4, 1e5, 2e5, 4e5}) {
    TaskConfig c = fingerConfig();
    c.setNumber("pressure_pa", p);
    const auto task = makeTask(c, cloud);
    const TaskEvaluation ev = task->evaluate(r, nullptr);
    const double infl = feature(ev, "chamber_inflation"), angle = feature(ev, "bend_angle_deg");
    std::printf("[inflate] p = %.0f Pa: chamber volume x %.5f, bend %.3f deg\n", p, infl, angle);
    EXPECT_GT(infl, prev);
    prev = infl;
    prev_angle = angle;
  }
  EXPECT_GT(prev, 1.01);
  EXPECT_LT(std::abs(prev_angle), 1.0);  // a centred chamber hardly bends the finger
}

TEST(SoftTasks, ChamberOffsetToOneSideBendsTowardsTheOther) {
  const VolumeCloud cloud = defaultShapeCloud("finger", 0.004);
  const auto task = makeTask(fingerConfig(), cloud);
  const double down = feature(task->evaluate(chamber(cloud, 0.02, 0.085, -0.006, -0.0005), nullptr), "bend_angle_deg");
  const double up = feature(task->evaluate(chamber(cloud, 0.02, 0.085, 0.0005, 0.006), nullptr), "bend_angle_deg");
  std::printf("[bend] chamber below the axis: %+.2f deg; above: %+.2f deg\n", down, up);
  EXPECT_GT(down, 0.1);  // chamber on the -z side: the tip turns towards +z
  EXPECT_LT(up, -0.1);
  EXPECT_NEAR(down, -up, 0.05 * std::abs(down));  // mirror-symmetric shape
}

// The shapes a replay shows (TaskEvaluation::shapes): the rest shape is the cloud, the deformed one
// is the solved equilibrium, whose tip moved by the tip_displacement_m feature and whose clamped base
// stayed put.
TEST(SoftTasks, FingerShapesForTheReplay) {
  const VolumeCloud cloud = defaultShapeCloud("finger", 0.004);
  const auto task = makeTask(fingerConfig(), cloud);
  const TaskEvaluation ev = task->evaluate(chamber(cloud, 0.02, 0.085, -0.006, -0.0005), nullptr);
  ASSERT_EQ(ev.shapes.size(), 2u);
  ASSERT_EQ(ev.shape_time_s.size(), 2u);
  EXPECT_LT(ev.shape_time_s[0], ev.shape_time_s[1]);
  ASSERT_EQ(ev.shapes[0].size(), cloud.size());
  ASSERT_EQ(ev.shapes[1].size(), cloud.size());
  double rest = 0, moved_max = 0, base_max = 0, xmin = 1e300;
  for (const auto& x : cloud.X) xmin = std::min(xmin, x.x());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    rest = std::max(rest, (ev.shapes[0][i] - cloud.X[i]).norm());
    const double d = (ev.shapes[1][i] - cloud.X[i]).norm();
    moved_max = std::max(moved_max, d);
    if (cloud.X[i].x() < xmin + 0.5 * cloud.spacing) base_max = std::max(base_max, d);
  }
  EXPECT_EQ(rest, 0.0);
  EXPECT_GE(moved_max, 0.9 * feature(ev, "tip_displacement_m"));
  EXPECT_GT(feature(ev, "tip_displacement_m"), 1e-4);
  EXPECT_LT(base_max, 0.01 * moved_max);  // the clamped end stays
}

// dL/dr of the whole task (materials, chamber weights, equilibrium or rollout) vs central differences.
void taskGradientCheck(TaskConfig c, const VolumeCloud& cloud, const std::vector<double>& r0, const char* name) {
  const auto task = makeTask(c, cloud);
  std::vector<double> g;
  const double L0 = task->evaluate(r0, &g).loss;
  ASSERT_GT(L0, 0.0);
  double gmax = 0.0;
  for (double v : g) gmax = std::max(gmax, std::abs(v));
  const std::size_t n = cloud.size();
  for (std::size_t i : {n / 3, n / 2, (2 * n) / 3, n / 5}) {
    // Step 1e-4 (r is in [0, 1]): a bouncing pear's loss carries ~1e-16 of chaotic noise (contact
    // onsets move by a step with the last bits of the forces), which at h = 1e-6 is 1e-10 in the
    // quotient, i.e. 1e-3 of a 1e-7 entry; at 1e-4 it is 100× smaller and the truncation error
    // O(h²) is still far below it (measured on the pear: worst entry 3.3e-5 at h = 1e-4, 1.5e-3 at 1e-6).
    const double h = 1e-4;
    auto rp = r0, rm = r0;
    rp[i] += h;
    rm[i] -= h;
    const double fd = (task->evaluate(rp, nullptr).loss - task->evaluate(rm, nullptr).loss) / (2 * h);
    // Relative to max(|fd|, 0.1 % of the largest component), to 1e-4.
    const double rel = std::abs(fd - g[i]) / std::max(std::abs(fd), 1e-3 * gmax);
    std::printf("[task fd %s] r_%zu: adjoint %.8g fd %.8g rel %.2g\n", name, i, g[i], fd, rel);
    EXPECT_LT(rel, 1e-4) << name << " particle " << i;
  }
}

TEST(SoftTasks, FingerGradientMatchesFiniteDifferences) {
  const VolumeCloud cloud = defaultShapeCloud("finger", 0.004);
  std::vector<double> r = chamber(cloud, 0.02, 0.085, -0.006, -0.0005);
  for (std::size_t i = 0; i < r.size(); ++i) r[i] = 0.3 + 0.4 * r[i] + 0.1 * std::sin(3.0 * i);
  for (const char* mode : {"static", "implicit"}) {
    TaskConfig c = fingerConfig();
    c.set("mode", mode);
    c.set("duration_s", "0.05");
    c.set("dt_s", "0.01");
    c.setNumber("bend_angle_deg", 25.0);
    c.setNumber("newton_tolerance", 1e-12);
    taskGradientCheck(c, cloud, r, mode);
  }
}

// The bend profile (bend_profile_deg, finger_task.cpp's header) in the loss: alone, beside the tip
// angle with its own weight, and in implicit mode (the rollout's final state).
TEST(SoftTasks, FingerProfileGradientMatchesFiniteDifferences) {
  const VolumeCloud cloud = defaultShapeCloud("finger", 0.004);
  std::vector<double> r = chamber(cloud, 0.02, 0.085, -0.006, -0.0005);
  for (std::size_t i = 0; i < r.size(); ++i) r[i] = 0.3 + 0.4 * r[i] + 0.1 * std::sin(3.0 * i);
  struct Case {
    const char *name, *mode;
    bool tip;
  };
  for (const Case& k : {Case{"profile static", "static", false}, Case{"profile+tip static", "static", true},
                        Case{"profile+tip implicit", "implicit", true}}) {
    TaskConfig c = fingerConfig();
    c.set("mode", k.mode);
    c.set("duration_s", "0.05");
    c.set("dt_s", "0.01");
    c.set("profile_segments", "6");
    c.setList("bend_profile_deg", {1.0, 3.0, 6.0, 9.0, 14.0, 20.0});
    if (k.tip) {
      c.setNumber("bend_angle_deg", 25.0);
      c.setNumber("weight_profile", 3.0);
    }
    c.setNumber("newton_tolerance", 1e-12);
    taskGradientCheck(c, cloud, r, k.name);
  }
}

// A profile of another length than profile_segments is refused naming both; a finger without either
// target is refused naming both targets.
TEST(SoftTasks, FingerProfileTargetsAreCheckedAgainstTheSegments) {
  const VolumeCloud cloud = defaultShapeCloud("finger", 0.004);
  const auto refusal = [&](const TaskConfig& c) -> std::string {
    try {
      makeTask(c, cloud)->requireTargets();
    } catch (const TopoError& e) {
      return e.what();
    }
    return "accepted";
  };
  TaskConfig c = fingerConfig();
  c.setList("bend_profile_deg", {1.0, 2.0, 3.0});
  const std::string wrong = refusal(c);
  EXPECT_NE(wrong.find("bend_profile_deg"), std::string::npos) << wrong;
  EXPECT_NE(wrong.find("profile_segments 8"), std::string::npos) << wrong;
  c.set("profile_segments", "3");
  EXPECT_EQ(refusal(c), "accepted");
  const std::string none = refusal(fingerConfig());
  EXPECT_NE(none.find("neither bend_angle_deg nor bend_profile_deg"), std::string::npos) << none;
}

// warm_start (the default): each design's equilibrium is solved from the last design's, and its
// adjoint from the last adjoint (the tip angle's, scaled; with the bend profile, whose dL/dx changes
// direction with the residuals, the last adjoint times its energy-optimal factor). Design B evaluated
// after A gives the loss, the angle and dL/dr of B evaluated alone from rest (warm_start 0) to the
// solver's tolerances; a design without a chamber after them rests unbent, its profile straight.
TEST(SoftTasks, FingerWarmStartGivesTheSameDesignAsFromRest) {
  const VolumeCloud cloud = defaultShapeCloud("finger", 0.004);
  std::vector<double> a = chamber(cloud, 0.02, 0.085, -0.006, -0.0005), b = a;
  for (std::size_t i = 0; i < a.size(); ++i) {
    a[i] = 0.3 + 0.4 * a[i] + 0.1 * std::sin(3.0 * i);
    b[i] = std::clamp(a[i] + 0.05 * std::cos(1.3 * i), 0.0, 1.0);
  }
  for (const bool with_profile : {false, true}) {
    TaskConfig c = fingerConfig();
    if (with_profile)
      c.setList("bend_profile_deg", {0.5, 1.0, 2.0, 4.0, 6.0, 9.0, 12.0, 15.0});
    else
      c.setNumber("bend_angle_deg", 25.0);
    const auto warm = makeTask(c, cloud);
    c.set("warm_start", "0");
    const auto cold = makeTask(c, cloud);
    std::vector<double> ga, gw, gc;
    warm->evaluate(a, &ga);
    const TaskEvaluation ew = warm->evaluate(b, &gw), ec = cold->evaluate(b, &gc);
    const double tw = feature(ew, "bend_angle_deg"), tc = feature(ec, "bend_angle_deg");
    double gmax = 0.0, dmax = 0.0;
    for (std::size_t i = 0; i < gc.size(); ++i) {
      gmax = std::max(gmax, std::abs(gc[i]));
      dmax = std::max(dmax, std::abs(gw[i] - gc[i]));
    }
    std::printf(
        "[warm start%s] bend %.12f deg (from rest %.12f), loss %.10g (%.10g), dL/dr max difference %.2e of %.3e\n",
        with_profile ? ", profile" : "", tw, tc, ew.loss, ec.loss, dmax, gmax);
    EXPECT_GT(std::abs(tw - feature(warm->evaluate(a, nullptr), "bend_angle_deg")), 1e-3);  // B is another design
    EXPECT_NEAR(tw, tc, 1e-8 * std::abs(tc));
    EXPECT_NEAR(ew.loss, ec.loss, 1e-7 * ec.loss);
    EXPECT_LT(dmax, 1e-6 * gmax);
    const TaskEvaluation solid = warm->evaluate(std::vector<double>(cloud.size(), 1.0), nullptr);
    EXPECT_EQ(feature(solid, "bend_angle_deg"), 0.0);
    EXPECT_EQ(feature(solid, "tip_displacement_m"), 0.0);
    for (int k = 0; k < 8; ++k)
      EXPECT_NEAR(feature(solid, "bend_profile_deg[" + std::to_string(k) + "]"), 0.0, 1e-9) << k;
  }
}

TEST(SoftTasks, PearGradientMatchesFiniteDifferences) {
  const VolumeCloud cloud = defaultShapeCloud("pear", 0.012);
  TaskConfig c = TaskConfig::defaults("pear");
  c.set("duration_s", "0.06");
  std::vector<double> r(cloud.size());
  for (std::size_t i = 0; i < r.size(); ++i) r[i] = 0.5 + 0.3 * std::sin(2.0 * i);
  // Target: the trajectory of another design.
  std::vector<double> r_gt(cloud.size(), 0.2);
  const auto probe = makeTask(c, cloud)->evaluate(r_gt, nullptr);
  const std::string csv = ::testing::TempDir() + "pear_fd.csv";
  {
    std::ofstream out(csv);
    for (const auto& row : probe.trajectory_rows) {
      for (std::size_t k = 0; k < row.size(); ++k) out << (k ? "," : "") << row[k];
      out << "\n";
    }
  }
  c.set("target_trajectory_file", csv);
  EXPECT_GT(feature(probe, "steps"), 50.0);
  taskGradientCheck(c, cloud, r, "pear");
}

// Recovery (finger): ground truth = a chamber filling the finger below z = -1.5 mm (quadric
// s = k (z_n + 0.03) in the representation's normalised frame, hollow where s < 0); its bending
// angle at 5e5 Pa is the target. Inference starts from the chamber elsewhere: a slab around the
// axis (|z_n| < 0.05, which hardly bends the finger) and must reach the target angle within 1°.
// The wall material is a softer silicone than the default (2 MPa) so the angle is tens of degrees.
TEST(SoftTasks, FingerRecoveryReachesTheBendingAngle) {
  const VolumeCloud cloud = defaultShapeCloud("finger", 0.003);
  TaskConfig c = fingerConfig();
  c.setNumber("youngs_modulus_solid", 2e6);
  c.setNumber("youngs_modulus_hollow", 2e5);
  std::vector<double> truth(10, 0.0), start(10, 0.0);
  truth[8] = 3.0, truth[9] = 0.09;     // hollow below z_n = -0.03
  start[2] = 100.0, start[9] = -0.25;  // hollow where |z_n| < 0.05
  c.setList("initial_parameters", truth);
  InteriorProblem gt(c, cloud);
  ProblemEvaluation ev;
  gt.evaluate(gt.initialParameters(), nullptr, &ev);
  const double target = feature(ev.task, "bend_angle_deg");
  c.setNumber("bend_angle_deg", target);
  c.setList("initial_parameters", start);
  c.set("max_evaluations", "30");
  const InferenceResult res = runInference(c, cloud);
  const double a0 = feature(res.initial.task, "bend_angle_deg"), a1 = feature(res.final.task, "bend_angle_deg");
  std::printf(
      "[recovery finger] %zu particles: target %.3f deg; start %.3f deg -> %.3f deg (%d evaluations, %.1f s, "
      "%.2f s each); %s\n",
      cloud.size(), target, a0, a1, res.optimizer.iterations, res.optimize_s, res.evaluation_s, res.message.c_str());
  EXPECT_GT(target, 5.0);                 // a real bend, not round-off
  EXPECT_LT(std::abs(a0), 0.2 * target);  // the start hardly bends
  EXPECT_LT(std::abs(a1 - target), 1.0);
}

// A finger fitted to one bend: its result says, in the message the report and the action carry, that one
// observed number cannot determine the chamber (not only "All targets reached").
TEST(SoftTasks, AFingerResultSaysOneBendCannotDetermineTheChamber) {
  const VolumeCloud cloud = defaultShapeCloud("finger", 0.005);
  TaskConfig c = fingerConfig();
  c.setNumber("bend_angle_deg", 0.2);
  c.set("max_evaluations", "2");
  const InferenceResult res = runInference(c, cloud);
  EXPECT_FALSE(res.identifiability.available);
  EXPECT_NE(res.message.find("1 observed number (bend_angle_deg) cannot determine the"), std::string::npos)
      << res.message;
  EXPECT_NE(res.message.find("not the interior"), std::string::npos) << res.message;
}

// Recovery (pear): ground truth = a stiff spherical insert in the bulb; its pivot trajectories are
// the target; inference starts from a fully stiff pear (quadric representation). The inferred
// design must reproduce the trajectories within 2 % (RMS over all samples and pivots, relative to
// their largest extent), and do better than the start.
TEST(SoftTasks, PearRecoveryReproducesTrajectories) {
  const VolumeCloud cloud = defaultShapeCloud("pear", 0.01);
  TaskConfig c = TaskConfig::defaults("pear");
  c.set("duration_s", "0.08");
  std::vector<double> gt(cloud.size(), 0.0);
  for (std::size_t i = 0; i < cloud.size(); ++i)
    if ((cloud.X[i] - Eigen::Vector3d(0, 0, 0.04)).norm() < 0.022) gt[i] = 1.0;
  const ProblemEvaluation truth = simulateInterior(c, cloud, gt);
  const std::string csv = ::testing::TempDir() + "pear_target.csv";
  {
    std::ofstream out(csv);
    for (const auto& row : truth.task.trajectory_rows) {
      for (std::size_t k = 0; k < row.size(); ++k) out << (k ? "," : "") << row[k];
      out << "\n";
    }
  }
  c.set("target_trajectory_file", csv);
  c.set("max_evaluations", "40");
  c.set("initial_field", "0.0");  // r = 0.5 everywhere: the sigmoid is not saturated
  const InferenceResult res = runInference(c, cloud);
  const double rel0 = feature(res.initial.task, "trajectory_rms_relative");
  const double rel1 = feature(res.final.task, "trajectory_rms_relative");
  std::printf("[recovery pear] %zu particles: trajectory RMS / extent %.4f -> %.4f (%d iterations, %.1f s); %s\n",
              cloud.size(), rel0, rel1, res.optimizer.iterations, res.optimize_s, res.message.c_str());
  EXPECT_LT(rel1, 0.02);
  EXPECT_LT(rel1, 0.5 * rel0);
}
