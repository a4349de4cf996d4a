// The finger tracker's bend profile θ_k (vision/finger_profile.h, vision/finger_centreline.h) on
// fingers of known shape drawn here with OpenCV, independently of the tracker: a centreline c(s) from
// the clamp's edge (s = 0) integrated from a given curvature κ(s), its outline c(s) ± w/2 n(s) filled as
// a polygon at 4x and area-averaged (exact pixel coverage), the part inside the clamp hidden under a
// light clamp block, on a textured background (smooth blotches, stripes and grain), blurred (σ 0.8 px)
// and with camera noise (σ 3 grey levels) drawn anew in every frame. Clip: 6 rest frames (straight), 3
// frames of the pressure ramp, 12 held at the full bend. Truth: a finger bent with uniform curvature κ
// over its length L has θ_k = κ L (k − ½) / K (closed form, a flat tip); for other shapes the chords
// between stations at equal arc length k (L + tip cap) / K along the drawn centreline.
// Tolerance 0.5 deg everywhere: for a finger 300 px long, 40 px wide at 640x480 and K = 8 (segments of
// 37.5 px) it is 0.33 px of sideways offset between two stations. Measured largest errors: uniform arc
// 0.16 deg (K 8) and 0.11 deg (K 4), from the frame's edge 0.32, 600 x 80 px at 1280x960 0.13, ribbed
// outline 0.40, stiff base with a round tip 0.24, the generated two-segment finger 0.05.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <functional>
#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/io/motion_features_json.h"
#include "topo_gaussian/vision/motion_features.h"
#include "topo_gaussian/vision/motion_tracker.h"
#include "topo_gaussian/vision/synthetic_video.h"

using namespace topo_gaussian;

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = 180.0 / kPi;

/// A finger seen from the side: its centreline starts at the clamp's edge `base` along base_dir_deg
/// (image angle) and turns with curvature κ(s) [rad/px, + clockwise on screen] over length_px; a
/// round tip adds a half-disc cap (the centreline runs on straight for half the width). Ribs (a
/// PneuNet's chambers) widen both sides alike by rib_px (1 − cos(2π s / 16 px))/2: the centreline
/// stays the midline, the outline and the end face's corners get bumps.
struct DrawnFinger {
  cv::Point2d base{120, 140};
  double base_dir_deg = 8.0;
  double length_px = 300.0;
  double width_px = 40.0;
  bool round_tip = false;
  double rib_px = 0.0;
  std::function<double(double)> curvature = [](double) { return 0.0; };
};

/// The centreline from s = s0 (negative: inside the clamp, straight) to the tip, every ds.
struct Centreline {
  std::vector<cv::Point2d> p;
  std::vector<double> phi, s;
};

Centreline integrate(const DrawnFinger& f, double s0, double ds) {
  Centreline c;
  const double phi0 = f.base_dir_deg / kDeg;
  const double end = f.length_px + (f.round_tip ? 0.5 * f.width_px : 0.0);
  cv::Point2d p = f.base + s0 * cv::Point2d(std::cos(phi0), std::sin(phi0));
  double phi = phi0;
  for (double s = s0;; s += ds) {
    c.p.push_back(p);
    c.phi.push_back(phi);
    c.s.push_back(s);
    if (s >= end - 1e-9) break;
    const double h = std::min(ds, end - s);
    const double kappa = s >= 0 && s < f.length_px ? f.curvature(s + 0.5 * h) : 0.0;
    const double mid = phi + 0.5 * h * kappa;  // midpoint rule
    p += h * cv::Point2d(std::cos(mid), std::sin(mid));
    phi += h * kappa;
  }
  return c;
}

/// θ_k of the drawn centreline: chords between K + 1 stations at equal arc length from the clamp's
/// edge to the tip, against the base direction.
std::vector<double> trueProfile(const DrawnFinger& f, int K) {
  const double ds = 0.01;
  const Centreline c = integrate(f, 0.0, ds);
  const double total = c.s.back();
  auto at = [&](double s) {
    const std::size_t i = std::min(c.p.size() - 2, static_cast<std::size_t>(s / ds));
    const double t = (s - c.s[i]) / (c.s[i + 1] - c.s[i]);
    return c.p[i] + t * (c.p[i + 1] - c.p[i]);
  };
  std::vector<double> theta;
  for (int k = 1; k <= K; ++k) {
    const cv::Point2d d = at(total * k / K) - at(total * (k - 1) / K);
    theta.push_back(std::atan2(d.y, d.x) * kDeg - f.base_dir_deg);
  }
  return theta;
}

constexpr int kSuper = 4;  ///< supersampling: outlines are drawn at 4x and area-averaged (exact coverage)

/// A vertex at kSuper times the frame's scale, with 1/16 px precision there.
cv::Point fixedPoint(const cv::Point2d& p) {
  return cv::Point(std::lround((p.x + 0.5) * kSuper * 16 - 8), std::lround((p.y + 0.5) * kSuper * 16 - 8));
}

/// The fraction of each pixel inside the polygon (0..1).
cv::Mat coverage(const std::vector<cv::Point>& polygon, const cv::Size& size) {
  cv::Mat big = cv::Mat::zeros(size * kSuper, CV_8U);
  cv::fillPoly(big, std::vector<std::vector<cv::Point>>{polygon}, cv::Scalar(255), cv::LINE_8, 4);
  cv::Mat alpha;
  cv::resize(big, alpha, size, 0, 0, cv::INTER_AREA);
  alpha.convertTo(alpha, CV_32F, 1.0 / 255.0);
  return alpha;
}

/// img ← img (1 − α) + colour α
void paint(cv::Mat& img, const cv::Mat& alpha, const cv::Scalar& colour) {
  for (int y = 0; y < img.rows; ++y)
    for (int x = 0; x < img.cols; ++x) {
      const float a = alpha.at<float>(y, x);
      if (a <= 0.0f) continue;
      cv::Vec3b& p = img.at<cv::Vec3b>(y, x);
      for (int ch = 0; ch < 3; ++ch) p[ch] = cv::saturate_cast<uchar>(p[ch] * (1.0f - a) + colour[ch] * a);
    }
}

/// Smooth blotches, stripes and grain, light (about 180..240) so the dark finger stands out.
cv::Mat texturedBackground(const cv::Size& size) {
  cv::RNG rng(7);
  cv::Mat low(9, 12, CV_32FC3);
  rng.fill(low, cv::RNG::UNIFORM, cv::Scalar::all(190), cv::Scalar::all(232));
  cv::Mat bg;
  cv::resize(low, bg, size, 0, 0, cv::INTER_CUBIC);
  cv::Mat grain(size, CV_32FC3);
  rng.fill(grain, cv::RNG::NORMAL, cv::Scalar::all(0), cv::Scalar::all(4));
  bg += grain;
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x) bg.at<cv::Vec3f>(y, x) += cv::Vec3f::all(6.0f * std::sin(x / 7.0 + y / 11.0));
  cv::Mat out;
  bg.convertTo(out, CV_8UC3);
  return out;
}

cv::Mat drawFrame(const DrawnFinger& f, const cv::Mat& background, unsigned seed) {
  cv::Mat img = background.clone();
  const Centreline c = integrate(f, -40.0, 0.5);  // 40 px of it inside the clamp
  const double h = 0.5 * f.width_px;
  auto side = [&](std::size_t i) {  // the half-width, with the ribs, beyond the clamp
    return h + (c.s[i] > 0 ? f.rib_px * 0.5 * (1 - std::cos(2 * kPi * c.s[i] / 16.0)) : 0.0);
  };
  std::vector<cv::Point> outline;
  const std::size_t body = f.round_tip ? c.p.size() - static_cast<std::size_t>(std::lround(h / 0.5)) : c.p.size();
  for (std::size_t i = 0; i < body; ++i)
    outline.push_back(fixedPoint(c.p[i] + side(i) * cv::Point2d(-std::sin(c.phi[i]), std::cos(c.phi[i]))));
  if (f.round_tip) {  // a half disc about the end of the body
    const cv::Point2d centre = c.p[body - 1];
    const double phi = c.phi[body - 1];
    for (int a = 0; a <= 180; a += 2) {
      const double ang = phi + kPi / 2 - a / kDeg;
      outline.push_back(fixedPoint(centre + h * cv::Point2d(std::cos(ang), std::sin(ang))));
    }
  }
  for (std::size_t i = body; i-- > 0;)
    outline.push_back(fixedPoint(c.p[i] - side(i) * cv::Point2d(-std::sin(c.phi[i]), std::cos(c.phi[i]))));
  paint(img, coverage(outline, img.size()), cv::Scalar(55, 60, 50));
  // the clamp: a light block whose edge, across the base direction, is the finger's s = 0
  const double phi0 = f.base_dir_deg / kDeg;
  const cv::Point2d t(std::cos(phi0), std::sin(phi0)), n(-t.y, t.x);
  const double across = h + 25;
  std::vector<cv::Point> clamp = {fixedPoint(f.base + across * n), fixedPoint(f.base - across * n),
                                  fixedPoint(f.base - across * n - 70 * t), fixedPoint(f.base + across * n - 70 * t)};
  paint(img, coverage(clamp, img.size()), cv::Scalar(165, 170, 172));
  cv::GaussianBlur(img, img, cv::Size(0, 0), 0.8);
  cv::Mat noise(img.size(), CV_16SC3);
  cv::RNG(seed).fill(noise, cv::RNG::NORMAL, cv::Scalar::all(0), cv::Scalar::all(3));
  cv::Mat out;
  cv::add(img, noise, out, cv::noArray(), CV_8UC3);
  return out;
}

/// 6 rest frames, a ramp of 3 (a third, two thirds, 90 % of the curvature), 12 held at the full bend.
vision::TrackResult trackBend(const DrawnFinger& bent, int K, const cv::Size& frame = cv::Size(640, 480)) {
  const cv::Mat background = texturedBackground(frame);
  vision::TrackOptions o;
  o.kind = "finger";
  o.tracker.method = "silhouette";
  o.profile_segments = K;
  vision::MotionTracker mt(o);
  int index = 0;
  auto add = [&](const DrawnFinger& f) {
    mt.addFrame(drawFrame(f, background, 100 + index), index / 30.0);
    ++index;
  };
  DrawnFinger straight = bent;
  straight.curvature = [](double) { return 0.0; };
  for (int i = 0; i < 6; ++i) add(straight);
  for (double part : {1.0 / 3, 2.0 / 3, 0.9}) {
    DrawnFinger ramp = bent;
    ramp.curvature = [&bent, part](double s) { return part * bent.curvature(s); };
    add(ramp);
  }
  for (int i = 0; i < 12; ++i) add(bent);
  return mt.finish();
}

void expectProfile(const vision::TrackResult& tr, const std::vector<double>& truth, double tol_deg,
                   const std::string& what) {
  ASSERT_FALSE(tr.refused) << tr.message;
  ASSERT_EQ(tr.bend_profile_deg.size(), truth.size()) << what << "\n" << tr.message;
  double worst = 0;
  for (std::size_t k = 0; k < truth.size(); ++k) {
    const double err = tr.bend_profile_deg[k] - truth[k];
    worst = std::max(worst, std::abs(err));
    std::printf("[finger profile] %s k=%zu: true %8.3f  tracked %8.3f  error %+.3f deg\n", what.c_str(), k + 1,
                truth[k], tr.bend_profile_deg[k], err);
    EXPECT_NEAR(tr.bend_profile_deg[k], truth[k], tol_deg) << what << " segment " << k + 1;
  }
  std::printf("[finger profile] %s: largest error %.3f deg, confidence %.3f, length rest %.1f / held %.1f px\n",
              what.c_str(), worst, tr.confidence.at("bend_profile_deg"), tr.profile_rest_length_px,
              tr.profile_held_length_px);
  EXPECT_GT(tr.confidence.at("bend_profile_deg"), 0.5) << what << "\n" << tr.message;
}

/// Bent with uniform curvature by total_bend_deg over its length (flat tip).
DrawnFinger uniformArc(double total_bend_deg, double length_px = 300.0) {
  DrawnFinger f;
  f.length_px = length_px;
  const double kappa = total_bend_deg / kDeg / length_px;
  f.curvature = [kappa](double) { return kappa; };
  return f;
}

/// θ_k = κ L (k − ½) / K of a uniform bend κ L = total_bend_deg.
std::vector<double> closedForm(double total_bend_deg, int K) {
  std::vector<double> theta;
  for (int k = 1; k <= K; ++k) theta.push_back(total_bend_deg * (k - 0.5) / K);
  return theta;
}

/// Stiff for its first 40 %, then bending with uniform curvature to −60 deg (up on screen); round tip.
DrawnFinger stiffBaseBendingTip() {
  DrawnFinger f;
  f.base = cv::Point2d(100, 330);
  f.base_dir_deg = -5.0;
  f.round_tip = true;
  const double s1 = 0.4 * f.length_px, kappa = -60.0 / kDeg / (f.length_px - s1);
  f.curvature = [s1, kappa](double s) { return s < s1 ? 0.0 : kappa; };
  return f;
}

}  // namespace

TEST(VisionFingerProfile, UniformCurvatureGivesTheClosedFormChords) {
  const int K = 8;
  const DrawnFinger f = uniformArc(90.0);
  const vision::TrackResult tr = trackBend(f, K);
  const std::vector<double> closed = closedForm(90.0, K);
  // the renderer's centreline is the arc: its own chords are the closed form
  const std::vector<double> drawn = trueProfile(f, K);
  for (int k = 0; k < K; ++k) ASSERT_NEAR(drawn[k], closed[k], 1e-3);
  EXPECT_EQ(tr.profile_segments, K);
  expectProfile(tr, closed, 0.5, "arc 90 deg, K 8");
  // every frame has a profile; the rest frames are straight
  ASSERT_EQ(tr.bend_profile_series_deg.size(), tr.t.size());
  for (int i = 0; i < 6; ++i)
    for (double v : tr.bend_profile_series_deg[i]) EXPECT_NEAR(v, 0.0, 0.5) << "rest frame " << i;
}

TEST(VisionFingerProfile, AnotherSegmentCountGivesItsOwnChords) {
  const int K = 4;
  const vision::TrackResult tr = trackBend(uniformArc(90.0), K);
  EXPECT_EQ(tr.profile_segments, K);
  expectProfile(tr, closedForm(90.0, K), 0.5, "arc 90 deg, K 4");
  for (int bad : {1, 0, 65}) {
    vision::TrackOptions o;
    o.kind = "finger";
    o.tracker.method = "silhouette";
    o.profile_segments = bad;
    try {
      vision::MotionTracker mt(o);
      ADD_FAILURE() << "profile_segments " << bad << " was accepted";
    } catch (const TopoError& e) {
      EXPECT_NE(std::string(e.what()).find("--profile-segments"), std::string::npos) << e.what();
    }
  }
}

TEST(VisionFingerProfile, ClampOutOfViewTheBaseIsTheFrameEdge) {
  DrawnFinger f = uniformArc(90.0);
  f.base = cv::Point2d(-0.5, 150);  // the image's left edge: the clamp is outside the view
  f.base_dir_deg = 0.0;
  expectProfile(trackBend(f, 8), closedForm(90.0, 8), 0.5, "arc 90 deg from the frame's edge, K 8");
}

TEST(VisionFingerProfile, AWideFingerIsMeasuredShrunkAsWell) {
  // 600 x 80 px at 1280x960: worked on at half-width 24 px (shrunk 1.67 times)
  DrawnFinger f = uniformArc(90.0, 600.0);
  f.base = cv::Point2d(240, 280);
  f.width_px = 80.0;
  expectProfile(trackBend(f, 8, cv::Size(1280, 960)), closedForm(90.0, 8), 0.5, "arc 90 deg, 600 x 80 px, K 8");
}

TEST(VisionFingerProfile, RibbedOutlineWithBumpyEndCorners) {
  // ribs 4 px high every 16 px on both sides, ending at the flat tip half-way up a rib: the cuts at
  // the end face's bumpy corners are not bisected by the midline, and the end tangent leaves them out
  DrawnFinger f = uniformArc(90.0, 292.0);
  f.rib_px = 4.0;
  expectProfile(trackBend(f, 8), closedForm(90.0, 8), 0.5, "ribbed arc 90 deg, K 8");
}

TEST(VisionFingerProfile, StiffBaseAndBendingTipWithARoundTip) {
  const int K = 8;
  const DrawnFinger f = stiffBaseBendingTip();
  const vision::TrackResult tr = trackBend(f, K);
  const std::vector<double> truth = trueProfile(f, K);
  EXPECT_NEAR(truth[0], 0.0, 1e-9);  // the stiff base
  EXPECT_LT(truth[K - 1], -50.0);    // bends up on screen: counter-clockwise, negative
  expectProfile(tr, truth, 0.5, "stiff base, bending tip, K 8");
  EXPECT_LT(tr.bend_held_deg, 0.0) << "the profile is signed as the bending angle";
}

TEST(VisionFingerProfile, SyntheticTwoSegmentFinger) {
  vision::FingerScene scene;
  scene.noise_sigma = 3.0;
  const std::vector<cv::Mat> frames = vision::renderFinger(scene);
  vision::TrackOptions o;
  o.kind = "finger";
  o.tracker.method = "silhouette";
  vision::MotionTracker mt(o);
  for (std::size_t i = 0; i < frames.size(); ++i) mt.addFrame(frames[i], i / scene.fps);
  const vision::TrackResult tr = mt.finish();
  // truth: the polyline base → joint → tip → the round cap's extremity, in 8 equal pieces
  const double a0 = scene.base_angle_deg / kDeg, a1 = (scene.base_angle_deg + scene.final_bend_deg) / kDeg;
  const cv::Point2d d0(std::cos(a0), std::sin(a0)), d1(std::cos(a1), std::sin(a1));
  const double L = 2 * scene.segment_px + 0.5 * scene.width_px;
  auto at = [&](double s) {
    return s <= scene.segment_px ? scene.base + s * d0
                                 : scene.base + scene.segment_px * d0 + (s - scene.segment_px) * d1;
  };
  std::vector<double> truth;
  for (int k = 1; k <= 8; ++k) {
    const cv::Point2d d = at(L * k / 8) - at(L * (k - 1) / 8);
    truth.push_back(std::atan2(d.y, d.x) * kDeg - scene.base_angle_deg);
  }
  expectProfile(tr, truth, 0.5, "synthetic two-segment finger, 40 deg kink");
}

TEST(VisionFingerProfile, AFingerLeavingTheFrameGivesNoConfidentProfile) {
  DrawnFinger f = uniformArc(90.0, 500.0);  // at rest inside the frame; bent, its tip runs ~40 px past the bottom
  f.base = cv::Point2d(40, 200);
  f.base_dir_deg = 0.0;
  const vision::TrackResult tr = trackBend(f, 8);
  std::printf("[finger profile] leaving the frame: confidence %.3f, profile of %zu angles, lengths %.1f / %.1f px\n",
              tr.confidence.at("bend_profile_deg"), tr.bend_profile_deg.size(), tr.profile_rest_length_px,
              tr.profile_held_length_px);
  EXPECT_EQ(tr.confidence.at("bend_profile_deg"), 0.0) << tr.message;
  EXPECT_TRUE(tr.bend_profile_deg.empty()) << "a cut finger's profile is not a measurement";
  EXPECT_NE(tr.message.find("bend profile not measured"), std::string::npos) << tr.message;
  const motion::MotionFeatures m = vision::toMotionFeatures(tr);
  EXPECT_TRUE(m.bend_profile_deg.empty());
  EXPECT_EQ(m.bend_profile_confidence, 0.0);
}

TEST(VisionFingerProfile, TravelsToTheFeaturesAndTheJson) {
  const vision::TrackResult tr = trackBend(uniformArc(60.0), 8);
  const motion::MotionFeatures m = vision::toMotionFeatures(tr);
  ASSERT_EQ(m.bend_profile_deg.size(), 8u);
  EXPECT_EQ(m.profile_segments, 8);
  EXPECT_EQ(m.bend_profile_deg, tr.bend_profile_deg);
  EXPECT_EQ(m.bend_profile_confidence, tr.confidence.at("bend_profile_deg"));
  EXPECT_GT(m.bend_profile_confidence, 0.5);
  const motion::MotionFeatures g = io::parseMotionFeaturesJson(io::motionFeaturesJson(m, false), "profile");
  EXPECT_EQ(g.bend_profile_deg, m.bend_profile_deg);
  EXPECT_EQ(g.profile_segments, 8);
  EXPECT_EQ(g.bend_profile_confidence, m.bend_profile_confidence);
  const nlohmann::json tracker = nlohmann::json::parse(vision::trackerJson(tr, true));
  EXPECT_EQ(tracker.at("profile_segments").get<int>(), 8);
  EXPECT_EQ(tracker.at("bend_profile_deg").size(), 8u);
  EXPECT_EQ(tracker.at("bend_profile_series_deg").size(), tr.t.size());
  // a profile of the wrong length is refused when read
  EXPECT_THROW(io::parseMotionFeaturesJson(
                   R"({"kind": "finger", "features": {"bend_profile_deg": [1, 2, 3], "profile_segments": 8}})", "bad"),
               TopoError);
}
