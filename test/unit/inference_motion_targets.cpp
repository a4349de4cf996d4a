// The targets an inference task takes from observed motion (inference/motion_targets.h): each task's
// registered rule on motion::MotionFeatures built directly (no ROS message): the tumbler's own
// oscillation analysis of a signal that starts at a release, the tracker's numbers mid-swing, the
// release tilt as the floor of the max tilt, the static tasks' equilibrium, the finger's bending, and
// the note for tasks without a rule.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "test_clouds.h"
#include "topo_gaussian/common/motion_features.h"
#include "topo_gaussian/inference/motion_targets.h"
#include "topo_gaussian/inference/pipeline.h"
#include "topo_gaussian/inference/task_config.h"

using namespace topo_gaussian;

TEST(MotionTargets, TumblerSignalGetsTheTasksOwnAnalysis) {
  // The simulated tilt of a tumbler, sampled as a 60 fps tracker would, must give back the task's own
  // period and max tilt (same analysis), not the tracker's whole-window numbers.
  const VolumeCloud cloud = topo_test::tumblerCloud(0.05, 0.4, 0.006);
  inference::TaskConfig c = inference::TaskConfig::defaults("tumbler");
  c.set("dt_s", "0.0166666666666667");
  const inference::ProblemEvaluation ev = inference::simulateInterior(c, cloud, {});
  double period = 0, tilt = 0, amplitude = 0;
  for (const auto& f : ev.task.features) {
    if (f.name == "period_s") period = f.value;
    if (f.name == "max_tilt_deg") tilt = f.value;
    if (f.name == "amplitude_deg") amplitude = f.value;
  }
  motion::MotionFeatures m;
  m.kind = "tilt";
  m.oscillation_found = true;
  m.period_s = 0.5 * period;  // a different whole-window number the mapping must not use
  m.max_tilt_deg = 1.0;
  m.amplitude_confidence = 1.0;
  for (std::size_t k = 0; k < ev.task.signal.size(); ++k) {
    m.time_s.push_back(100.0 + ev.task.signal_time_s[k]);  // stamps need not start at 0
    m.angle_deg.push_back(-ev.task.signal[k]);             // the image angle may have the other sign
  }
  const inference::MotionTargets t = inference::targetsFromMotion(c, m);
  ASSERT_EQ(t.targets.size(), 3u) << t.note;
  EXPECT_EQ(t.targets[0].first, "period_s");
  EXPECT_NEAR(t.targets[0].second, period, 1e-9 * period);
  EXPECT_EQ(t.targets[1].first, "max_tilt_deg");
  EXPECT_NEAR(t.targets[1].second, tilt, 1e-9);
  // measured as the task measures it, so the amplitude (where the doll rests) is a target too
  EXPECT_EQ(t.targets[2].first, "amplitude_deg");
  EXPECT_GT(amplitude, 1.0);
  EXPECT_NEAR(t.targets[2].second, amplitude, 1e-9);
  std::printf("[targets] tumbler: task %.5f s %.4f deg; from the observed signal %.5f s %.4f deg\n", period, tilt,
              t.targets[0].second, t.targets[1].second);
  // the tilt it rocks about, when the tracker measured it (confidence > 0), is a target too
  auto with_eq = m;
  with_eq.equilibrium_deg = 0.031;
  with_eq.equilibrium_confidence = 0.9;
  const inference::MotionTargets te = inference::targetsFromMotion(c, with_eq);
  ASSERT_EQ(te.targets.size(), 4u) << te.note;
  // the window starts at the release: the task's analysis gives it signed towards the release's side,
  // the simulation's own equilibrium although the image angle has the other sign
  double eq_sim = NAN;
  for (const auto& f : ev.task.features)
    if (f.name == "equilibrium_tilt_deg") eq_sim = f.value;
  EXPECT_EQ(te.targets[3].first, "equilibrium_from_release_deg");
  EXPECT_NEAR(te.targets[3].second, eq_sim, 1e-9);
  EXPECT_NE(te.note.find("towards the release's side"), std::string::npos) << te.note;
  // a tracker that could not tell the absolute tilt (an axis known only modulo 90 deg: confidence 0
  // for the angles) gives the period only; its signal, largest tilt and equilibrium are left out
  auto ambiguous = with_eq;
  ambiguous.amplitude_confidence = 0.0;
  ambiguous.equilibrium_confidence = 0.0;
  for (double& a : ambiguous.angle_deg) a += 90.0;
  const inference::MotionTargets ta = inference::targetsFromMotion(c, ambiguous);
  ASSERT_EQ(ta.targets.size(), 2u) << ta.note;
  EXPECT_DOUBLE_EQ(ta.targets[0].second, 0.5 * period) << ta.note;  // the tracker's own period
  EXPECT_EQ(ta.targets[1].first, "max_tilt_deg");
  EXPECT_DOUBLE_EQ(ta.targets[1].second, 10.0) << ta.note;  // the release tilt, which the task knows
  EXPECT_NE(ta.note.find("no absolute tilt"), std::string::npos) << ta.note;
  // a window that starts mid-swing (a steady rocking seen from a quarter period in): the tracker's
  // own numbers over the window
  auto later = m;
  later.time_s.clear();
  later.angle_deg.clear();
  for (int k = 0; k < 180; ++k) {
    const double tk = k / 60.0;
    later.time_s.push_back(tk);
    later.angle_deg.push_back(4.0 + 9.0 * std::sin(2 * M_PI * tk / 0.4));
  }
  later.period_s = 0.401;  // the tracker's whole-window numbers are used
  later.max_tilt_deg = 12.9;
  const inference::MotionTargets mid = inference::targetsFromMotion(c, later);
  ASSERT_EQ(mid.targets.size(), 2u) << mid.note;
  EXPECT_NE(mid.note.find("mid-swing"), std::string::npos) << mid.note;
  EXPECT_NE(t.note.find("starts at a release"), std::string::npos) << t.note;
  EXPECT_DOUBLE_EQ(mid.targets[0].second, 0.401) << mid.note;
  EXPECT_DOUBLE_EQ(mid.targets[1].second, 12.9) << mid.note;
  // a largest tilt below the release tilt (10 deg; tracking error) becomes the release tilt
  later.max_tilt_deg = 9.9;
  const inference::MotionTargets low = inference::targetsFromMotion(c, later);
  ASSERT_EQ(low.targets.size(), 2u) << low.note;
  EXPECT_DOUBLE_EQ(low.targets[1].second, 10.0) << low.note;
  EXPECT_NE(low.note.find("does not exceed the release tilt"), std::string::npos) << low.note;
  // a release window read 2 % high at the release (10.2 deg for the 10 the task knows: a silhouette's
  // axis seen in perspective) that never swings past it: its largest tilt is read against the tracker's
  // own reading at the release, so the target is the release tilt, not an unreachable 10.2 deg
  auto high = m;
  high.time_s.clear();
  high.angle_deg.clear();
  for (int k = 0; k < 180; ++k) {
    high.time_s.push_back(k / 60.0);
    high.angle_deg.push_back(2.0 + 8.2 * std::cos(2 * M_PI * (k / 60.0) / 0.5));
  }
  const inference::MotionTargets th = inference::targetsFromMotion(c, high);
  ASSERT_GE(th.targets.size(), 2u) << th.note;
  EXPECT_NE(th.note.find("starts at a release"), std::string::npos) << th.note;
  EXPECT_DOUBLE_EQ(th.targets[1].second, 10.0) << th.note;
  EXPECT_NE(th.note.find("as the tracker read it"), std::string::npos) << th.note;
  // without a signal: the tracker's numbers; without an oscillation: nothing, with the reason
  m.time_s.clear();
  m.angle_deg.clear();
  const auto scalar = inference::targetsFromMotion(c, m);
  ASSERT_EQ(scalar.targets.size(), 2u);
  EXPECT_DOUBLE_EQ(scalar.targets[0].second, 0.5 * period);
  m.oscillation_found = false;
  m.message = "stale: no image";
  const auto none = inference::targetsFromMotion(c, m);
  EXPECT_TRUE(none.targets.empty());
  EXPECT_NE(none.note.find("stale: no image"), std::string::npos) << none.note;
  // other tasks
  motion::MotionFeatures bend;
  bend.bending_angle_deg = -12.5;  // counter-clockwise on screen: the magnitude is the target
  bend.bending_confidence = 0.9;
  const auto finger = inference::targetsFromMotion(inference::TaskConfig::defaults("finger"), bend);
  ASSERT_EQ(finger.targets.size(), 1u);
  EXPECT_EQ(finger.targets[0].first, "bend_angle_deg");
  EXPECT_DOUBLE_EQ(finger.targets[0].second, 12.5);
  EXPECT_TRUE(finger.list_targets.empty());  // no profile measured
  // the tracker's bend profile is not taken as a target (its silhouette centreline differs from the
  // task's where the chamber bulges), and the note says so
  bend.bend_profile_deg = {-0.5, -1, -2, -3, -5, -7, -9, -12};
  bend.profile_segments = 8;
  bend.bend_profile_confidence = 0.8;
  const auto profiled = inference::targetsFromMotion(inference::TaskConfig::defaults("finger"), bend);
  EXPECT_TRUE(profiled.list_targets.empty());
  ASSERT_EQ(profiled.targets.size(), 1u);
  EXPECT_NE(profiled.note.find("not a target"), std::string::npos) << profiled.note;
  EXPECT_NE(inference::targetsFromMotion(inference::TaskConfig::defaults("qiqi"), bend).note.find("goal's targets"),
            std::string::npos);
}

TEST(MotionTargets, StaticTasksTakeTheEquilibriumAsTheTargetRoll) {
  motion::MotionFeatures m;
  m.kind = "pendulum";
  m.source = "rig.mp4";
  m.equilibrium_deg = -4.5;
  m.equilibrium_confidence = 0.8;
  for (const char* task : {"hanging", "balance", "stand"}) {
    const auto t = inference::targetsFromMotion(inference::TaskConfig::defaults(task), m);
    ASSERT_EQ(t.targets.size(), 1u) << task;
    EXPECT_EQ(t.targets[0].first, "target_roll_deg") << task;
    EXPECT_DOUBLE_EQ(t.targets[0].second, -4.5) << task;
  }
  m.equilibrium_confidence = 0.0;
  const auto none = inference::targetsFromMotion(inference::TaskConfig::defaults("hanging"), m);
  EXPECT_TRUE(none.targets.empty());
  EXPECT_NE(none.note.find("no measured equilibrium angle"), std::string::npos) << none.note;
  EXPECT_NE(none.note.find("rig.mp4"), std::string::npos) << none.note;
  const auto finger = inference::targetsFromMotion(inference::TaskConfig::defaults("finger"), m);
  EXPECT_TRUE(finger.targets.empty());
  EXPECT_NE(finger.note.find("no measured bending angle"), std::string::npos) << finger.note;
}
