// The tracker's refusals and checks against motions whose answer is known in closed form:
// one-object checks (vision/object_checks.h), the pendulum path (vision/pendulum_path.h), bounces
// between free-flight arcs (vision/bounce_analysis.h: a ball with restitution e falls, h = h0 − g t²/2,
// and rises to e² of its height, t_flight = 2e·√(2h/g)), the finger's signed bend with either
// polarity or a colour mask, the debug overlay drawn from the result, and `topo track`'s option checks.
#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "test_util.h"
#include "topo_gaussian/common/error.h"
#include "topo_gaussian/vision/bounce_analysis.h"
#include "topo_gaussian/vision/motion_tracker.h"
#include "topo_gaussian/vision/object_checks.h"
#include "topo_gaussian/vision/pendulum_path.h"
#include "topo_gaussian/vision/synthetic_video.h"

using namespace topo_gaussian;
using namespace topo_gaussian::vision;

namespace {

constexpr double kPi = 3.14159265358979323846;

Measurement blob(double x, double y, double area) {
  Measurement m;
  m.found = true;
  m.centroid = {x, y};
  m.area_px = area;
  m.mask_fraction = 0.01;
  m.largest_share = 0.95;
  m.pieces = 1;
  m.solidity = 0.95;
  m.mean_bgr = cv::Vec3d(20, 20, 200);
  return m;
}

/// A ball dropped from h0 [px] at t = 0 with restitution e, gravity g [px/s²], sampled at fps; heights
/// up positive. Returns the closed-form bounce times.
std::vector<double> bouncingBall(double h0, double e, double g, double fps, double duration, std::vector<double>& t,
                                 std::vector<double>& h) {
  std::vector<double> bounces;
  double tb = std::sqrt(2 * h0 / g), v = e * g * tb;  // first contact, rebound speed
  bounces.push_back(tb);
  while (bounces.back() < duration) {
    bounces.push_back(bounces.back() + 2 * v / g);
    v *= e;
  }
  for (int i = 0; i / fps < duration; ++i) {
    const double ti = i / fps;
    double hi = 0;
    if (ti < bounces[0]) {
      hi = h0 - 0.5 * g * ti * ti;
    } else {
      std::size_t k = 0;
      while (k + 1 < bounces.size() && bounces[k + 1] <= ti) ++k;
      const double vk = e * g * bounces[0] * std::pow(e, static_cast<double>(k)), s = ti - bounces[k];
      hi = vk * s - 0.5 * g * s * s;
    }
    t.push_back(ti);
    h.push_back(hi);
  }
  bounces.pop_back();
  while (!bounces.empty() && bounces.back() > duration) bounces.pop_back();
  return bounces;
}

}  // namespace

TEST(VisionObjectChecks, OneObjectPassesTexturesAndJumpsAreRefused) {
  std::vector<Measurement> good, texture, filling, jumping;
  for (int i = 0; i < 60; ++i) {
    const double x = 300 + 100 * std::sin(0.2 * i);
    good.push_back(blob(x, 200, 900 + 20 * std::sin(i)));
    Measurement t = blob(x, 200, 900);
    t.pieces = 40;
    t.largest_share = 0.1;  // one brick among many
    texture.push_back(t);
    Measurement f = blob(320, 240, 150000);
    f.mask_fraction = 0.7;
    f.largest_share = 0.9;
    filling.push_back(f);
    jumping.push_back(blob(i % 3 == 0 ? 50 : 500, i % 3 == 0 ? 400 : 100, 900));  // switches between two regions
  }
  const ObjectCheck ok = checkOneObject(good, "marker");
  EXPECT_TRUE(ok.valid) << ok.problem;
  EXPECT_GT(ok.score, 0.9);
  EXPECT_EQ(ok.frames, 60);
  const ObjectCheck tex = checkOneObject(texture, "marker");
  EXPECT_FALSE(tex.valid);
  EXPECT_NE(tex.problem.find("texture"), std::string::npos) << tex.problem;
  EXPECT_NE(tex.problem.find("--hsv-lower"), std::string::npos) << tex.problem;  // the fix
  const ObjectCheck fill = checkOneObject(filling, "silhouette");
  EXPECT_FALSE(fill.valid);
  EXPECT_NE(fill.problem.find("fills 70 %"), std::string::npos) << fill.problem;
  const ObjectCheck jump = checkOneObject(jumping, "marker");
  EXPECT_FALSE(jump.valid);
  EXPECT_NE(jump.problem.find("jumps"), std::string::npos) << jump.problem;
  EXPECT_FALSE(checkOneObject({}, "marker").valid);
}

TEST(VisionPendulumPath, AnglesFromAFittedPivotAndRefusals) {
  // a bob 400 px below a pivot at (320, −100), swinging ±12° with some pixel noise
  const cv::Point2d pivot(320, -100);
  std::vector<cv::Point2d> arc, vertical, around;
  std::vector<double> truth;
  for (int i = 0; i < 200; ++i) {
    const double a = 12.0 * std::cos(2 * kPi * i / 60.0) * kPi / 180;
    const double noise = 0.3 * std::sin(7.1 * i);
    arc.push_back(pivot + cv::Point2d(400 * std::sin(a) + noise, 400 * std::cos(a) - noise));
    truth.push_back(a * 180 / kPi);
    vertical.push_back(cv::Point2d(320 + 0.5 * std::sin(i), 200 + 80 * std::sin(2 * kPi * i / 40.0)));
    const double b = 2 * kPi * i / 50.0;  // a full circle: the pivot is inside the path
    around.push_back(cv::Point2d(320 + 100 * std::sin(b), 240 + 100 * std::cos(b)));
  }
  const PendulumPath p = analysePendulumPath(arc, cv::Vec2d(0, 1), nullptr);
  ASSERT_TRUE(p.valid) << p.problem;
  EXPECT_TRUE(p.angles_known);
  EXPECT_NEAR(p.pivot.x, pivot.x, 4.0);
  EXPECT_NEAR(p.pivot.y, pivot.y, 8.0);
  double worst = 0;
  for (std::size_t i = 0; i < truth.size(); ++i) worst = std::max(worst, std::abs(p.signal[i] - truth[i]));
  EXPECT_LT(worst, 0.3);
  EXPECT_LT(p.radius_rel_uncertainty, 0.02);
  EXPECT_GT(p.pivot_confidence, 0.8);
  // the same motion seen with gravity towards image-right (a video rotated 90° counter-clockwise):
  // points (x, y) → (y', −x') keep the angles when gravity is given as (1, 0)
  std::vector<cv::Point2d> turned;
  for (const auto& q : arc) turned.push_back(cv::Point2d(q.y, -q.x));
  const PendulumPath pt = analysePendulumPath(turned, cv::Vec2d(1, 0), nullptr);
  ASSERT_TRUE(pt.valid) << pt.problem;
  for (std::size_t i = 0; i < truth.size(); i += 17) EXPECT_NEAR(pt.signal[i], p.signal[i], 1e-6);
  // without the gravity option the turned path moves along gravity: refused
  EXPECT_FALSE(analysePendulumPath(turned, cv::Vec2d(0, 1), nullptr).valid);
  const PendulumPath v = analysePendulumPath(vertical, cv::Vec2d(0, 1), nullptr);
  EXPECT_FALSE(v.valid);
  EXPECT_NE(v.problem.find("along gravity"), std::string::npos) << v.problem;
  const PendulumPath c = analysePendulumPath(around, cv::Vec2d(0, 1), nullptr);
  EXPECT_FALSE(c.valid);
  EXPECT_FALSE(c.problem.empty());
  // a pivot given inside the path: the angle would jump by 180°, refused
  const cv::Point2d inside(320, 240);
  const PendulumPath g = analysePendulumPath(around, cv::Vec2d(0, 1), &inside);
  EXPECT_FALSE(g.valid);
  // unwrapping: a given pivot with the bob swinging across "straight up" (θ = ±180°) stays continuous
  std::vector<cv::Point2d> over;
  for (int i = 0; i < 50; ++i) {
    const double a = (170.0 + 20.0 * i / 49.0) * kPi / 180;  // 170° → 190°
    over.push_back(cv::Point2d(320 + 100 * std::sin(a), 400 + 100 * std::cos(a)));
  }
  const cv::Point2d below(320, 400);  // "pivot" below the path: refused as not hanging
  EXPECT_FALSE(analysePendulumPath(over, cv::Vec2d(0, 1), &below).valid);
  const PendulumPath un = analysePendulumPath(over, cv::Vec2d(0, -1), &below);  // gravity up: it hangs
  ASSERT_TRUE(un.valid) << un.problem;
  for (std::size_t i = 1; i < un.signal.size(); ++i) EXPECT_LT(std::abs(un.signal[i] - un.signal[i - 1]), 1.0);
}

TEST(VisionBounceAnalysis, ClosedFormBallRestitutionAndEnds) {
  const double g = 2000.0, h0 = 600.0, e = 0.8, fps = 120.0;
  std::vector<double> t, h;
  const std::vector<double> bounces = bouncingBall(h0, e, g, fps, 3.5, t, h);
  ASSERT_GE(bounces.size(), 3u);
  const BounceFeatures f = analyseBounces(t, h, -50, 1000);
  ASSERT_EQ(f.bounce_times_s.size(), bounces.size()) << f.message;
  for (std::size_t k = 0; k < bounces.size(); ++k) EXPECT_NEAR(f.bounce_times_s[k], bounces[k], 0.15 / fps);
  EXPECT_NEAR(f.floor_h_px, 0.0, 0.5);
  EXPECT_NEAR(f.gravity_px_s2, g, 0.01 * g);
  ASSERT_GE(f.apex_heights_px.size(), 2u);
  EXPECT_NEAR(f.apex_heights_px[0], h0 * e * e, 1.0);
  EXPECT_NEAR(f.apex_heights_px[1], h0 * std::pow(e, 4), 1.0);
  EXPECT_NEAR(f.release_height_px, h0, 1.0);
  EXPECT_NEAR(f.restitution_heights_mean, e, 0.005);
  EXPECT_NEAR(f.restitution_times_mean, e, 0.01);
  EXPECT_GT(f.confidence, 0.8);
  EXPECT_TRUE(f.end_reason.empty()) << f.end_reason;
  // picked up after the second bounce: the height rises steadily (a hand), not a parabola
  std::vector<double> tp, hp;
  for (std::size_t i = 0; i < t.size(); ++i) {
    if (t[i] > bounces[1] + 0.15) {
      const double s = t[i] - bounces[1] - 0.15;
      tp.push_back(t[i]);
      hp.push_back(hp.back() + 300.0 / fps + 40 * std::sin(9 * s) / fps);
      continue;
    }
    tp.push_back(t[i]);
    hp.push_back(h[i]);
  }
  const BounceFeatures p = analyseBounces(tp, hp, -50, 1000);
  EXPECT_EQ(p.bounce_times_s.size(), 2u) << p.message;
  EXPECT_NE(p.end_reason.find("not free flight"), std::string::npos) << p.message;
  // a swinging bob's height (two dips a period) is not a bounce: the arcs are not straight across
  // gravity, and at 50 px across they fall far slower than free fall
  std::vector<double> ts, hs, xs;
  for (int i = 0; i < 300; ++i) {
    const double a = 0.3 * std::cos(2 * kPi * i / 30.0 / 2.6);
    ts.push_back(i / 30.0);
    hs.push_back(-1500 * std::cos(a));
    xs.push_back(1500 * std::sin(a));
  }
  BounceOptions scale;
  scale.object_diameter_px = 50;
  const BounceFeatures s = analyseBounces(ts, hs, -2000, 0, scale, &xs);
  EXPECT_TRUE(s.bounce_times_s.empty()) << s.message;
  EXPECT_NE(s.message.find("no bounce"), std::string::npos);
  // a gap of lost frames ends the trajectory with the reason
  std::vector<double> tg, hg;
  for (std::size_t i = 0; i < t.size(); ++i)
    if (t[i] < 1.2 || t[i] > 1.6) tg.push_back(t[i]), hg.push_back(h[i]);
  const BounceFeatures lost = analyseBounces(tg, hg, -50, 1000);
  EXPECT_NE(lost.end_reason.find("lost"), std::string::npos) << lost.message;
  EXPECT_THROW(analyseBounces({0, 1}, {0}, 0, 1), TopoError);
}

TEST(VisionObjectChecks, FingerSignedBendEitherPolarityAndColourMask) {
  FingerScene sc;
  sc.final_bend_deg = -35.0;  // bends the other way: the sign must survive
  const std::vector<cv::Mat> frames = renderFinger(sc);
  auto run = [&](const std::vector<cv::Mat>& fr, const TrackOptions& o) {
    MotionTracker mt(o);
    for (std::size_t i = 0; i < fr.size(); ++i) mt.addFrame(fr[i], i / sc.fps);
    return mt.finish();
  };
  TrackOptions o;
  o.kind = "finger";
  o.tracker.method = "silhouette";
  const TrackResult r = run(frames, o);
  ASSERT_FALSE(r.refused) << r.message;
  EXPECT_NEAR(r.bend_final_deg, sc.final_bend_deg, 2.0) << r.message;
  EXPECT_NEAR(r.bend_max_deg, sc.final_bend_deg, 2.0);
  EXPECT_GT(r.bend_t_max_s, 0.6 * sc.duration_s);  // the ramp ends at 70 % of the clip
  EXPECT_GT(r.confidence.at("bend_deg"), 0.5);
  // the same finger bright on a dark background: auto polarity and --polarity brighter agree
  std::vector<cv::Mat> inverted;
  for (const auto& f : frames) inverted.push_back(cv::Scalar::all(255) - f);
  for (const std::string pol : {"auto", "brighter"}) {
    o.tracker.polarity = pol;
    const TrackResult ri = run(inverted, o);
    ASSERT_FALSE(ri.refused) << pol << ": " << ri.message;
    EXPECT_NEAR(ri.bend_final_deg, sc.final_bend_deg, 2.0) << pol;
  }
  // the wrong polarity takes the background: refused, not a bend
  o.tracker.polarity = "darker";
  EXPECT_TRUE(run(inverted, o).refused);
  // the colour mask (--method marker) as the silhouette: the finger is green
  TrackOptions m;
  m.kind = "finger";
  m.tracker.method = "marker";
  m.tracker.hsv = {HsvRange{cv::Scalar(45, 100, 80), cv::Scalar(75, 255, 255)}};
  const TrackResult rm = run(frames, m);
  ASSERT_FALSE(rm.refused) << rm.message;
  EXPECT_NEAR(rm.bend_final_deg, sc.final_bend_deg, 2.0);
}

TEST(VisionObjectChecks, DebugOverlayShowsTheResultsPivotAndReadableText) {
  PendulumScene s;
  s.duration_s = 3.0;
  s.pivot = cv::Point2d(320, 80);
  const std::vector<cv::Mat> frames = renderPendulum(s);
  TrackOptions o;
  MotionTracker mt(o);
  for (std::size_t i = 0; i < frames.size(); ++i) mt.addFrame(frames[i], i / s.fps);
  const TrackResult r = mt.finish();
  ASSERT_FALSE(r.refused) << r.message;
  // every frame draws the one pivot of the result (magenta dot), not a per-frame fit
  for (int i : {5, 40, 80}) {
    const cv::Mat img = mt.overlayWithResult(frames[i], i, r);
    const cv::Vec3b c = img.at<cv::Vec3b>(cv::Point(r.pivot));
    EXPECT_EQ(c, cv::Vec3b(255, 0, 255)) << "frame " << i;
  }
  // a narrow frame: the text wraps instead of running off the right edge
  cv::Mat narrow;
  cv::resize(frames[10], narrow, cv::Size(400, 300));
  TrackOptions on;
  MotionTracker small(on);
  for (int i = 0; i < 30; ++i) {
    cv::Mat f;
    cv::resize(frames[i], f, cv::Size(400, 300));
    small.addFrame(f, i / s.fps);
  }
  const TrackResult rs = small.finish();
  const cv::Mat img = small.overlayWithResult(narrow, 10, rs);
  int white_at_edge = 0;
  for (int y = 0; y < 60; ++y)
    for (int x = img.cols - 6; x < img.cols; ++x)
      if (img.at<cv::Vec3b>(y, x) == cv::Vec3b(255, 255, 255)) ++white_at_edge;
  EXPECT_EQ(white_at_edge, 0);
}

TEST(VisionObjectChecks, TrackOptionsAreCheckedWithTheFix) {
  TrackOptions o;
  o.tracker.hsv = {HsvRange{cv::Scalar(170, 50, 50), cv::Scalar(190, 255, 255)}};
  EXPECT_THROW(validateTrackOptions(o), TopoError);
  o.tracker.hsv = {HsvRange{cv::Scalar(20, 200, 50), cv::Scalar(30, 100, 255)}};
  try {
    validateTrackOptions(o);
    ADD_FAILURE() << "a lower S above the upper was accepted";
  } catch (const TopoError& e) {
    EXPECT_NE(std::string(e.what()).find("lower bound above the upper"), std::string::npos) << e.what();
  }
  TrackOptions r;
  r.rotate_deg = 45;
  EXPECT_THROW(validateTrackOptions(r), TopoError);
  TrackOptions g;
  g.gravity = cv::Vec2d(0, 0);
  EXPECT_THROW(validateTrackOptions(g), TopoError);
  TrackOptions p;
  p.tracker.polarity = "lighter";
  EXPECT_THROW(validateTrackOptions(p), TopoError);
  TrackOptions k;
  k.kind = "finger";
  k.tracker.method = "klt";
  EXPECT_THROW(validateTrackOptions(k), TopoError);
  TrackOptions t;
  t.tilt_reference_deg = std::nan("");
  try {
    validateTrackOptions(t);
    ADD_FAILURE() << "a tilt reference that is not a number was accepted";
  } catch (const TopoError& e) {
    EXPECT_NE(std::string(e.what()).find("--tilt-reference"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("the tilt the object starts near"), std::string::npos) << e.what();
  }
  t.tilt_reference_deg = 200;
  EXPECT_THROW(validateTrackOptions(t), TopoError);
  EXPECT_THROW(validRoi(cv::Rect(600, 0, 100, 100), cv::Size(640, 480), true), TopoError);  // reaches outside

  // the command line: every bad option is exit 2 with the fix, before any tracking
  PendulumScene s;
  s.duration_s = 1.0;
  const std::string path = testing::TempDir() + "/options_pendulum.avi";
  writeVideo(renderPendulum(s), s.fps, path);
  auto track = [&](const std::string& args) { return topo_test::runTopo("track --video " + path + " " + args); };
  for (const std::string bad :
       {"--roi 600,0,100,100", "--roi 700,500,10,10", "--hsv-lower 0,0,0 --hsv-upper 200,255,255",
        "--hsv-lower 20,200,0 --hsv-upper 30,100,255", "--series", "--fps 25", "--rotate 45", "--gravity 0,0",
        "--polarity darker", "--method silhouette --polarity sideways", "--kind finger --method klt",
        "--kind tilt --method silhouette --tilt-reference 270"}) {
    const topo_test::ToolRun run = track(bad);
    EXPECT_EQ(run.code, 2) << bad << "\n" << run.out;
    EXPECT_EQ(run.out.find("period_s"), std::string::npos) << bad;  // nothing was tracked
  }
  EXPECT_NE(track("--roi 600,0,100,100").out.find("640"), std::string::npos);  // names the frame size
  EXPECT_NE(track("--fps 25").out.find("image sequences"), std::string::npos);
  EXPECT_EQ(track("--rotate 180 --json").code, 0);
}
