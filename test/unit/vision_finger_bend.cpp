// The tracker's finger bend is the finger task's bending angle (the motion-targets rule hands the one
// to the other). The task simulates the default finger with an off-centre chamber at
// several pressures; its rest and deformed particles are rendered from the side (camera on −y looking
// +y, image-up = +z, as the finger twin's camera), and the tracker, kind finger, measures the bend
// on 5 rest frames followed by 10 bent ones. Truth: the task's own bend_angle_deg (a chord between
// particle centroids); the tracker sees only pixels. Measured (StVK, the task's default): within 0.1 deg from
// 0.37 to 4.5 deg (0.08 / 0.06 / 0.004 / 0.096 deg at 1 / 3 / 5 / 8e5 Pa; 0.05 deg with the corotated linear model).
// The 1e5 Pa bend (0.37 deg) is under the tracker's floor of 0.5 deg: its value is still right, but
// its confidence is 0 with "did not bend" (a real camera's jitter would swamp it).
// Why the chord: the tip-third minus base-third line angle reads 11–27 % larger.
// Limit (measured with this file's renderer): a chamber reaching into the last 30 % of the length
// (x < 0.09 instead of 0.065) bulges the silhouette's lower edge under the segment before the tip,
// and the silhouette's chord is 24 % steeper than the particles' (5e5 Pa: 4.25 vs 3.42 deg): a
// camera sees the envelope of the bulge, the task averages the material.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "topo_gaussian/inference/task.h"
#include "topo_gaussian/inference/task_config.h"
#include "topo_gaussian/physics/default_shapes.h"
#include "topo_gaussian/vision/motion_tracker.h"
#include "topo_gaussian/vision/splat_renderer.h"

using namespace topo_gaussian;

namespace {

struct Rendered {
  double task_bend_deg = 0;
  cv::Mat rest, bent;
};

Rendered renderFinger(double pressure_pa) {
  const double h = 0.0025;
  const VolumeCloud cloud = defaultShapeCloud("finger", h);
  // a chamber in the lower half (thin wall at −z), ending before the last 30 %: bends towards +z
  std::vector<double> r(cloud.size(), 1.0);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3d& p = cloud.X[i];
    if (!cloud.surface[i] && p.x() > 0.014 && p.x() < 0.065 && p.z() > -0.0055 && p.z() < 0.0 &&
        std::abs(p.y()) < 0.006)
      r[i] = 0.0;
  }
  inference::TaskConfig c = inference::TaskConfig::defaults("finger");
  c.setNumber("pressure_pa", pressure_pa);
  const auto task = inference::makeTask(c, cloud);
  const inference::TaskEvaluation ev = task->evaluate(r, nullptr);
  Rendered out;
  for (const auto& f : ev.features)
    if (f.name == "bend_angle_deg") out.task_bend_deg = f.value;
  vision::SplatCamera cam;
  cam.width = 640;
  cam.height = 480;
  const Eigen::Vector3d centre(0.05, 0, 0), eye = centre + Eigen::Vector3d(0, -0.5, 0);
  cam.R_wc = vision::lookAtRotation(eye, centre, Eigen::Vector3d::UnitZ());
  cam.t_wc = eye;
  cam.fx = cam.fy = 0.7 * 640 / (0.1 / 0.5);  // the finger spans 70 % of the width
  cam.cx = 320;
  cam.cy = 240;
  vision::Splats s;
  s.normals.assign(cloud.size(), Eigen::Vector3d::Zero());
  s.radius_m = 0.75 * h;
  s.colours = {cv::Vec3b(40, 40, 40)};
  const vision::SplatShading shading;
  s.positions = ev.shapes.at(0);
  out.rest = vision::renderSplats(cam, s, shading);
  s.positions = ev.shapes.at(1);
  out.bent = vision::renderSplats(cam, s, shading);
  return out;
}

}  // namespace

TEST(VisionFingerBend, TrackerMeasuresTheTasksBendOnARenderedSideView) {
  for (double p : {1e5, 3e5, 5e5, 8e5}) {
    const Rendered f = renderFinger(p);
    vision::TrackOptions o;
    o.kind = "finger";
    o.tracker.method = "silhouette";
    vision::MotionTracker mt(o);
    for (int k = 0; k < 15; ++k) mt.addFrame(k < 5 ? f.rest : f.bent, k / 30.0);
    const vision::TrackResult tr = mt.finish();
    ASSERT_FALSE(tr.refused) << tr.message;
    // bending towards +z is the tip turning up on screen: counter-clockwise, a negative image angle
    std::printf("[finger bend] %.0e Pa: task %.3f deg, tracker %.3f deg (straightest frame %.2f deg, rest axis %.3f)\n",
                p, f.task_bend_deg, tr.bend_final_deg, tr.bend_straightest_deg, tr.bend_rest_axis_deg);

    EXPECT_GT(f.task_bend_deg, 0.3) << p;
    EXPECT_NEAR(-tr.bend_final_deg, f.task_bend_deg, 0.1) << "pressure " << p << " Pa\n" << tr.message;
    EXPECT_LT(tr.bend_straightest_deg, 0.5) << "the rest frames are straight";
    if (f.task_bend_deg < 0.45) {
      // below the tracker's floor (0.5 deg): measured, but not claimed as a bend
      EXPECT_EQ(tr.confidence.at("bend_deg"), 0.0) << tr.message;
      EXPECT_NE(tr.message.find("did not bend"), std::string::npos) << tr.message;
    } else {
      EXPECT_GT(tr.confidence.at("bend_deg"), 0.5) << tr.message;
    }
  }
}

TEST(VisionFingerBend, RejectsATipFractionOutsideTheTasksRange) {
  vision::TrackOptions o;
  o.kind = "finger";
  o.tracker.method = "silhouette";
  o.tip_fraction = 0.4;
  try {
    vision::MotionTracker mt(o);
    FAIL() << "a tip fraction of 0.4 was accepted";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("tip_fraction"), std::string::npos) << e.what();
  }
}
