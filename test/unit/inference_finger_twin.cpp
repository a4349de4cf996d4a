// The finger twin (workflow/finger_twin.h): the default finger with its true chamber,
// solved at a ladder of pressures. Checked: the ladder against direct solves between its levels
// (linear interpolation in p), the bend's direction and growth, the tracker's bend on the twin's
// rendered side view against the twin's truth, and the options' refusals.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/inference/interior_problem.h"
#include "topo_gaussian/vision/motion_tracker.h"
#include "topo_gaussian/vision/splat_renderer.h"
#include "topo_gaussian/workflow/finger_twin.h"

using namespace topo_gaussian;

namespace {

/// The twin as config/rigs/finger_twin.yaml sets it up: a soft elastomer (walls 2 MPa).
workflow::FingerTwinOptions rigOptions() {
  workflow::FingerTwinOptions o;
  o.overrides = {"youngs_modulus_solid=2e6"};
  return o;
}

const workflow::FingerTwin& twin() {
  static const workflow::FingerTwin t{rigOptions()};
  return t;
}

double directBend(const workflow::FingerTwin& t, double p) {
  inference::TaskConfig c = t.config();
  c.setNumber("pressure_pa", p);
  const auto ev = inference::InteriorProblem(c, t.cloud()).evaluateIndicator(t.indicator(), nullptr);
  for (const auto& f : ev.task.features)
    if (f.name == "bend_angle_deg") return f.value;
  return NAN;
}

}  // namespace

TEST(FingerTwin, LadderOfPressuresMatchesDirectSolvesBetweenItsLevels) {
  const auto& t = twin();
  std::printf(
      "[finger twin] %zu particles at %.4g m, chamber %.3g cm3 (solid fraction %.3f), levels %zu to %.3g Pa, "
      "set up in %.2f s\n",
      t.cloud().size(), t.options().spacing_m, 1e6 * t.chamberVolumeM3(), t.solidFraction(),
      t.pressureLevelsPa().size(), t.maxPressurePa(), t.setupSeconds());
  ASSERT_EQ(t.pressureLevelsPa().size(), 6u);
  EXPECT_DOUBLE_EQ(t.maxPressurePa(), 5e5);  // the task's pressure_pa
  EXPECT_DOUBLE_EQ(t.bendDeg(0.0), 0.0);
  double last = 0.0;
  for (double p : t.pressureLevelsPa()) {
    const double b = t.bendDeg(p);
    std::printf("[finger twin] %.3g Pa: bend %.4f deg\n", p, b);
    if (p > 0) EXPECT_GT(b, last) << "the bend grows with the pressure, towards +z (the task's bend_normal)";
    last = b;
  }
  EXPECT_GT(t.bendDeg(5e5), 3.0);  // measured 6.65 deg: a bend a side camera resolves to ~0.05 deg
  EXPECT_LT(t.bendDeg(5e5), 10.0);
  // between levels: interpolation against a direct equilibrium
  for (double p : {0.5e5, 2.5e5, 4.5e5}) {
    const double direct = directBend(t, p), interpolated = t.bendDeg(p);
    std::printf("[finger twin] %.3g Pa: direct %.4f, interpolated %.4f deg\n", p, direct, interpolated);
    EXPECT_NEAR(interpolated, direct, 0.02 * t.bendDeg(5e5));
  }
  // out of the ladder: clamped
  EXPECT_DOUBLE_EQ(t.bendDeg(9e9), t.bendDeg(5e5));
  EXPECT_DOUBLE_EQ(t.bendDeg(-1.0), 0.0);
  const auto rest = t.positionsAt(0.0);
  for (std::size_t i = 0; i < rest.size(); ++i) ASSERT_EQ(rest[i], t.cloud().X[i]);
}

/// The rig's side camera (soft_finger_rig.launch's pose, config/rigs/finger_twin.yaml's image).
vision::SplatCamera sideCamera() {
  vision::SplatCamera cam;
  cam.width = 640;
  cam.height = 480;
  const Eigen::Vector3d centre(0.05, 0, 0), eye(0.05, -0.5, 0);
  cam.R_wc = vision::lookAtRotation(eye, centre, Eigen::Vector3d::UnitZ());
  cam.t_wc = eye;
  cam.fx = cam.fy = 0.5 * 640 / std::tan(0.5 * 16.0 * M_PI / 180);
  cam.cx = 319.5;
  cam.cy = 239.5;
  return cam;
}

/// The twin's surface particles as splats (positions filled per frame).
vision::Splats twinSplats(const workflow::FingerTwin& t) {
  vision::Splats s;
  s.radius_m = 0.8 * t.options().spacing_m;
  s.colours = {cv::Vec3b(40, 40, 150)};
  s.normals = t.surfaceNormals();
  return s;
}

TEST(FingerTwin, TrackerMeasuresTheTwinsBendOnItsRenderedSideView) {
  const auto& t = twin();
  const vision::SplatCamera cam = sideCamera();
  vision::SplatShading shading;
  shading.noise_sigma = 2.0;
  vision::Splats s = twinSplats(t);
  for (double p : {2e5, 5e5}) {
    vision::TrackOptions o;
    o.kind = "finger";
    o.tracker.method = "silhouette";
    vision::MotionTracker mt(o);
    for (int k = 0; k < 30; ++k) {
      const auto x = t.positionsAt(k < 10 ? 0.0 : p);
      s.positions.clear();
      for (auto i : t.surfaceIndex()) s.positions.push_back(x[i]);
      shading.noise_seed = static_cast<unsigned>(k + 1);
      mt.addFrame(vision::renderSplats(cam, s, shading), k / 30.0);
    }
    const vision::TrackResult r = mt.finish();
    ASSERT_FALSE(r.refused) << r.message;
    std::printf("[finger twin] %.3g Pa: truth %.3f deg, tracker %.3f deg on screen (confidence %.2f)\n", p,
                t.bendDeg(p), r.bend_held_deg, r.confidence.at("bend_deg"));
    EXPECT_NEAR(-r.bend_held_deg, t.bendDeg(p), 0.15) << r.message;
  }
}

// A live window that starts while the finger is held bent has no rest frame: its base line has
// turned with the bend, so the bend it measures is too small and must not come with confidence.
TEST(FingerTwin, AWindowWithoutRestFramesIsNotConfident) {
  const auto& t = twin();
  const vision::SplatCamera cam = sideCamera();
  vision::SplatShading shading;
  shading.noise_sigma = 2.0;
  vision::Splats s = twinSplats(t);
  vision::TrackOptions o;
  o.kind = "finger";
  o.tracker.method = "silhouette";
  vision::MotionTracker mt(o);
  const auto x = t.positionsAt(5e5);
  for (auto i : t.surfaceIndex()) s.positions.push_back(x[i]);
  for (int k = 0; k < 20; ++k) {
    shading.noise_seed = static_cast<unsigned>(k + 1);
    mt.addFrame(vision::renderSplats(cam, s, shading), k / 30.0);
  }
  const vision::TrackResult r = mt.finish();
  std::printf("[finger twin] held bent only: truth %.3f deg, tracker %.3f deg (confidence %.2f)\n", t.bendDeg(5e5),
              r.bend_held_deg, r.confidence.count("bend_deg") ? r.confidence.at("bend_deg") : -1.0);
  ASSERT_TRUE(r.confidence.count("bend_deg"));
  EXPECT_LT(r.confidence.at("bend_deg"), 0.3) << r.message;
  EXPECT_NE(r.message.find("never straight"), std::string::npos) << r.message;
}

TEST(FingerTwin, RefusesBadOptionsNamingThem) {
  const auto refuses = [](const workflow::FingerTwinOptions& o, const std::string& what) {
    try {
      workflow::FingerTwin t(o);
      ADD_FAILURE() << "accepted: " << what;
    } catch (const TopoError& e) {
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
  };
  workflow::FingerTwinOptions o;
  o.pressure_levels = 1;
  refuses(o, "pressure levels");
  o = {};
  o.task = "tumbler";
  refuses(o, "finger twin task");
  o = {};
  o.interior_quadric = Eigen::VectorXd::Ones(3);
  refuses(o, "chamber quadric");
  o = {};
  o.interior_quadric = Eigen::VectorXd::Zero(10);
  o.interior_quadric[0] = o.interior_quadric[1] = o.interior_quadric[2] = 1.0;
  o.interior_quadric[9] = 5.0;  // s > 0 everywhere: no chamber
  refuses(o, "holds no particle");
  o = {};
  o.max_pressure_pa = -1.0;
  refuses(o, "must be a gauge pressure");
}
