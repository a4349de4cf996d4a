// The peer world's soft finger (bench/peer_world/calculix_finger.h) held to what does not come from it:
//  - the surface it extracts from the C3D10 mesh is the finger's closed box (every edge shared by two
//    triangles, the enclosed volume L W H by signed tetrahedra) and renders, through the rig's camera,
//    as the near face's closed-form projection: area fx² L H / d², centroid at the principal point;
//  - the motion tracker (kind finger, silhouette) on the rendered CalculiX surface reads CalculiX's own
//    centroid bend (the finger task's definition, exact over the quadratic tetrahedra).
// The second needs ccx (Debian calculix-ccx) and skips with the reason without it.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>

#include "peer_world/calculix_finger.h"
#include "topo_gaussian/vision/motion_tracker.h"

using namespace topo_gaussian;

TEST(PeerCalculixFinger, SurfaceIsTheClosedBoxAndRendersAsItsProjection) {
  const peer::CalculixFinger finger{peer::CalculixFingerOptions{}};
  const auto& x = finger.restSurface();
  const auto& tri = finger.triangles();
  std::map<std::pair<int, int>, int> edges;  // directed edge → count: each once, its reverse once
  double volume = 0.0;
  for (const auto& t : tri) {
    for (int k = 0; k < 3; ++k) ++edges[{t[k], t[(k + 1) % 3]}];
    volume += x[t[0]].dot(x[t[1]].cross(x[t[2]])) / 6.0;
  }
  int bad = 0;
  for (const auto& [e, n] : edges) bad += n != 1 || !edges.count({e.second, e.first});
  EXPECT_EQ(bad, 0) << "the surface is closed and consistently oriented";
  const Eigen::Vector3d s = finger.options().size_m;
  EXPECT_NEAR(volume, s.prod(), 1e-12 * s.prod()) << "outward, enclosing the box";

  // The rig's camera, noise and blur off: the near face (y = −W/2, depth d = 0.5 − W/2) is the silhouette.
  const peer::PeerCamera cam = peer::fingerRigCamera();
  peer::RenderStyle style = peer::fingerRigStyle();
  style.noise_sigma = 0.0;
  style.blur_px = 0.0;
  style.supersample = 8;  // an axis-aligned edge's coverage comes in steps of 1/8 px
  peer::CalculixFingerState rest;
  rest.surface_m = x;
  const cv::Mat img = peer::renderPressureWindow(finger, rest, cam, style, 1, 0).front();
  // coverage per pixel from the grey level between the backdrop (235) and the near face's flat shade
  const Eigen::Vector3d l = style.light_towards_world.normalized();
  const double shade = std::round(60.0 * (style.ambient + (1 - style.ambient) * std::max(0.0, -l.y())));  // 8-bit
  double area = 0, cu = 0, cv_ = 0, width = 0, height = 0;
  for (int v = 0; v < img.rows; ++v)
    for (int u = 0; u < img.cols; ++u) {
      const double c = std::clamp((235.0 - img.at<cv::Vec3b>(v, u)[1]) / (235.0 - shade), 0.0, 1.0);
      area += c;
      cu += c * u;
      cv_ += c * v;
      if (v == img.rows / 2) width += c;
      if (u == img.cols / 2) height += c;
    }
  const double fx = cam.K(0, 0), d = 0.5 - 0.5 * s.y();
  const double w_px = fx * s.x() / d, h_px = fx * s.z() / d, expected = w_px * h_px;
  std::printf("[calculix finger] silhouette %.3f x %.3f px (closed form %.3f x %.3f)\n", width, height, w_px, h_px);
  // two edges, each within half a supersampling step (1/16 px) and a grey level's rounding
  EXPECT_NEAR(width, w_px, 0.15);
  EXPECT_NEAR(height, h_px, 0.15);
  std::printf("[calculix finger] %zu surface vertices, %zu triangles; silhouette %.1f px² (closed form %.1f), "
              "centroid (%.2f, %.2f) px\n",
              x.size(), tri.size(), area, expected, cu / area, cv_ / area);
  EXPECT_NEAR(area, expected, 0.15 * (w_px + h_px));
  EXPECT_NEAR(cu / area, cam.K(0, 2), 0.1);
  EXPECT_NEAR(cv_ / area, cam.K(1, 2), 0.1);
}

TEST(PeerCalculixFinger, TrackerReadsCalculixsOwnBendOnTheRenderedSurface) {
  std::string why;
  if (!peer::calculixAvailable(&why)) GTEST_SKIP() << why;
  peer::CalculixFingerOptions o;
  o.cell_m = 0.005;  // coarse (the chamber's and segments' planes still carry nodes): the tracker is the subject
  const peer::CalculixFinger finger{o};
  double seconds = 0;
  const auto states = finger.solve({1e5}, &seconds);
  std::printf("[calculix finger] %zu nodes, %zu C3D10, %zu pressure faces: ccx %.1f s\n", finger.mesh().nodes.size(),
              finger.mesh().tets.size(), finger.mesh().void_faces.size(), seconds);
  for (const auto& s : states) {
    vision::TrackOptions o;
    o.kind = "finger";
    o.tracker.method = "silhouette";
    vision::MotionTracker mt(o);
    const auto frames = peer::renderPressureWindow(finger, s, peer::fingerRigCamera(), peer::fingerRigStyle());
    for (std::size_t k = 0; k < frames.size(); ++k) mt.addFrame(frames[k], k / 30.0);
    const vision::TrackResult r = mt.finish();
    ASSERT_FALSE(r.refused) << r.message;
    std::printf("[calculix finger] %.3g Pa: CalculiX %.3f deg, tracker %.3f deg (confidence %.2f)\n", s.pressure_pa,
                s.bend_deg, -r.bend_held_deg, r.confidence.at("bend_deg"));
    EXPECT_GT(s.bend_deg, 0.5) << "bends towards +z (the thin lower wall stretches)";
    // the silhouette's chord against the material's centroid chord: within 0.2 deg or 4 % (README)
    EXPECT_NEAR(-r.bend_held_deg, s.bend_deg, std::max(0.2, 0.04 * s.bend_deg)) << r.message;
  }
}
