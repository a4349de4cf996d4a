// The peer world's soft finger (bench/peer_world/calculix_finger.h) held to what does not come from it:
//  - the surface it extracts from the C3D10 mesh is the finger's closed box (every edge shared by two
//    triangles, the enclosed volume L W H by signed tetrahedra) and renders, through the rig's camera,
//    as the near face's closed-form projection: area fx² L H / d², centroid at the principal point;
//  - the motion tracker (kind finger, silhouette) on the rendered CalculiX surface reads CalculiX's own
//    centroid bend (the finger task's definition, exact over the quadratic tetrahedra).
//  - bench_peer_soft without ccx on PATH says so and exits 2; on one case (slow: test/slow_tests.txt) it
//    runs the user path and calls the chamber determined exactly when the goal holds.
// The CalculiX cases need ccx (Debian calculix-ccx) and skip with the reason without it.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>
#include <vector>

#include <sys/wait.h>

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

#ifdef TOPO_BENCH_PEER_SOFT_PATH
namespace {

/// Runs the bench, with `env` (e.g. "PATH=/nonexistent") when not empty; its output and exit status.
std::string runBench(const std::string& env, const std::string& args, int* status) {
  std::string out;
  const std::string cmd = (env.empty() ? "" : "env " + env + " ") + TOPO_BENCH_PEER_SOFT_PATH + " " + args + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return out;
  char buf[4096];
  while (std::fgets(buf, sizeof buf, p)) out += buf;
  const int rc = pclose(p);
  *status = WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
  return out;
}

/// The numbers after "key": in the JSON line (one number, true/false as 1/0, or a list).
std::vector<double> jsonNumbers(const std::string& line, const std::string& key) {
  std::vector<double> v;
  std::size_t at = line.find("\"" + key + "\": ");
  if (at == std::string::npos) return v;
  at += key.size() + 4;
  if (line.compare(at, 4, "true") == 0) return {1.0};
  if (line.compare(at, 5, "false") == 0) return {0.0};
  const bool list = line[at] == '[';
  const char* c = line.c_str() + at + (list ? 1 : 0);
  for (;;) {
    char* end = nullptr;
    const double x = std::strtod(c, &end);
    if (end == c) break;
    v.push_back(x);
    if (!list || *end != ',') break;
    c = end + 1;
  }
  return v;
}

}  // namespace

TEST(PeerCalculixFinger, BenchWithoutCalculixSaysSoAndExits2) {
  int status = 0;
  const std::string out = runBench("PATH=/nonexistent", "default_chamber", &status);
  EXPECT_EQ(status, 2) << out;
  EXPECT_NE(out.find("CalculiX (ccx) is not installed"), std::string::npos) << out;
  EXPECT_NE(out.find("calculix-ccx"), std::string::npos) << out;
}

// The bench end to end on one case at 30 evaluations (minutes: test/slow_tests.txt): the user path runs,
// the tracker reads CalculiX's bend at the top pressure within 0.1 deg, the result reproduces the tracked
// bend, and the chamber is called determined exactly when the goal holds (IoU >= 0.8, volume
// within 5 %).
TEST(PeerCalculixFinger, BenchRunsTheUserPathOnTheDefaultChamber) {
  std::string why;
  if (!peer::calculixAvailable(&why)) GTEST_SKIP() << why;
  int status = 0;
  const std::string out = runBench("", "--max-evaluations 30 default_chamber", &status);
  ASSERT_EQ(status, 0) << out;
  const std::size_t at = out.find("{\"bench\": \"peer_soft\", \"case\": \"default_chamber\"");
  ASSERT_NE(at, std::string::npos) << out;
  const std::string line = out.substr(at, out.find('\n', at) - at);
  ASSERT_EQ(line.find("\"error\""), std::string::npos) << line;
  const auto ccx = jsonNumbers(line, "ccx_bend_deg"), tracked = jsonNumbers(line, "tracked_bend_deg"),
             result = jsonNumbers(line, "result_bend_deg");
  ASSERT_EQ(ccx.size(), 3u) << line;
  ASSERT_EQ(tracked.size(), 3u) << line;
  ASSERT_EQ(result.size(), 3u) << line;
  EXPECT_NEAR(tracked.back(), ccx.back(), 0.1) << line;
  EXPECT_NEAR(result.back(), tracked.back(), 0.02 * tracked.back()) << line;
  const double iou = jsonNumbers(line, "chamber_iou").at(0), volume = jsonNumbers(line, "chamber_volume_error").at(0);
  const bool called = jsonNumbers(line, "called_determined").at(0) > 0.5;
  std::printf("[calculix finger] bench: chamber IoU %.3f, volume %+.1f %%, called %s\n", iou, 100 * volume,
              called ? "determined" : "not determined");
  EXPECT_EQ(called, iou >= 0.8 && std::abs(volume) <= 0.05) << line;
}
#endif
