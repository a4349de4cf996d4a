// Tracking pipeline tests: synthetic videos with known motion (written to files and tracked back),
// the real pendulum and ball-drop videos from shared/data, error messages, the camera model and the
// `topo track` command.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>

#include "shared_data.h"
#include "test_util.h"
#include "topo_gaussian/common/error.h"
#include "topo_gaussian/io/motion_features_json.h"
#include "topo_gaussian/vision/camera_model.h"
#include "topo_gaussian/vision/motion_features.h"
#include "topo_gaussian/vision/motion_tracker.h"
#include "topo_gaussian/vision/synthetic_video.h"
#include "topo_gaussian/vision/video_source.h"

using namespace topo_gaussian;
using namespace topo_gaussian::vision;

namespace {

PendulumScene noisyScene() {
  PendulumScene s;
  s.period_s = 1.2;
  s.amplitude_deg = 15.0;
  s.equilibrium_deg = 5.0;
  s.noise_sigma = 8.0;
  s.blur_px = 1.5;
  s.moving_background = true;
  s.duration_s = 6.0;
  return s;
}

std::string writeScene(const std::vector<cv::Mat>& frames, double fps, const std::string& name) {
  const std::string path = testing::TempDir() + "/" + name;
  writeVideo(frames, fps, path);
  return path;
}

}  // namespace

TEST(VisionTracking, MarkerPendulumRecoversPeriodAmplitudeEquilibrium) {
  const PendulumScene scene = noisyScene();
  const std::string path = writeScene(renderPendulum(scene), scene.fps, "pendulum_marker.avi");
  TrackOptions o;
  o.kind = "pendulum";
  o.tracker.method = "marker";
  const TrackResult r = trackVideo(path, o);
  std::printf("marker pendulum: %s\n", r.message.c_str());
  std::printf("pivot (%.2f, %.2f) estimated %d rms %.3f\n", r.pivot.x, r.pivot.y, r.pivot_estimated,
              r.pivot_fit_rms_px);
  ASSERT_TRUE(r.signal.oscillation_found) << r.message;
  EXPECT_NEAR(r.signal.period_s, 1.2, 0.005 * 1.2);
  EXPECT_NEAR(r.signal.amplitude_deg, 15.0, 1.0);
  EXPECT_NEAR(r.signal.equilibrium_deg, 5.0, 1.0);
  EXPECT_EQ(r.lost_frames, 0);
  EXPECT_EQ(r.dropped_frames, 0);
  EXPECT_GT(r.confidence.at("period_s"), 0.5);
  const std::string json = io::motionFeaturesJson(toMotionFeatures(r), false);
  EXPECT_NE(json.find("\"period_s\""), std::string::npos);
  EXPECT_EQ(io::parseMotionFeaturesJson(json, "marker pendulum").period_s, r.signal.period_s);
}

TEST(VisionTracking, SilhouetteTiltOfAClearRod) {
  // a tumbler-like scene: the dark rod+bob seen as a silhouette on a plain wall (Otsu), its principal
  // axis swings with the pendulum angle: axis tilt from image-up = −angle (the body hangs down)
  PendulumScene s;
  s.period_s = 1.2;
  s.amplitude_deg = 15.0;
  s.equilibrium_deg = 5.0;
  s.noise_sigma = 4.0;
  s.bob_bgr = cv::Scalar(30, 30, 30);
  const std::string path = writeScene(renderPendulum(s), s.fps, "pendulum_silhouette.avi");
  TrackOptions o;
  o.kind = "tilt";
  o.tracker.method = "silhouette";
  o.tracker.foreground = "otsu";
  const TrackResult r = trackVideo(path, o);
  std::printf("silhouette tilt: %s\n", r.message.c_str());
  ASSERT_TRUE(r.signal.oscillation_found) << r.message;
  EXPECT_NEAR(r.signal.period_s, 1.2, 0.005 * 1.2);
  EXPECT_NEAR(r.signal.amplitude_deg, 15.0, 1.0);
  EXPECT_NEAR(r.signal.equilibrium_deg, -5.0, 1.0);
}

TEST(VisionTracking, FingerFinalBendingAngle) {
  FingerScene f;
  f.final_bend_deg = 40.0;
  const std::string path = writeScene(renderFinger(f), f.fps, "finger.avi");
  TrackOptions o;
  o.kind = "finger";
  o.tracker.method = "silhouette";
  const TrackResult r = trackVideo(path, o);
  std::printf("finger: %s\n", r.message.c_str());
  ASSERT_FALSE(r.angle_deg.empty());
  EXPECT_NEAR(r.bend_final_deg, 40.0, 1.0);
  EXPECT_NEAR(r.angle_deg.front(), 0.0, 1.0);
}

TEST(VisionTracking, StaticPendulumHasNoOscillation) {
  PendulumScene s = noisyScene();
  s.amplitude_deg = 0.0;
  s.duration_s = 3.0;
  const std::string path = writeScene(renderPendulum(s), s.fps, "pendulum_static.avi");
  TrackOptions o;
  o.pivot_given = true;
  o.pivot = s.pivot;
  const TrackResult r = trackVideo(path, o);
  std::printf("static: %s\n", r.message.c_str());
  EXPECT_FALSE(r.signal.oscillation_found);
  EXPECT_NE(r.message.find("no oscillation"), std::string::npos) << r.message;
  EXPECT_LT(r.confidence.at("period_s"), 0.2);
  EXPECT_LT(r.signal.confidence, 0.2);
  EXPECT_NEAR(r.static_pose.angle_deg, 5.0, 1.0);
  // without a pivot the tracker cannot estimate one and says so
  TrackOptions o2;
  const TrackResult r2 = trackVideo(path, o2);
  EXPECT_FALSE(r2.signal.oscillation_found);
  EXPECT_NE(r2.message.find("pivot"), std::string::npos) << r2.message;
}

// A region of interest on a fixed red part while the red bob swings elsewhere: the tracked region does
// not move at all, and the message says so (the ROI or the colour is wrong), instead of blaming the
// motion ("swings only ..."); the same bob tracked while it swings a little is still "swings only".
TEST(VisionTracking, AStaticRegionIsNamedNotASmallSwing) {
  PendulumScene s = noisyScene();  // noise, blur and a drifting background texture
  s.duration_s = 3.0;
  s.amplitude_deg = 20.0;
  PendulumScene clean = s;
  clean.noise_sigma = clean.blur_px = 0.0;  // added after the fixed part is drawn
  std::vector<cv::Mat> frames = renderPendulum(clean);
  const cv::Rect fixed_part(40, 390, 40, 40);
  cv::RNG rng(7);
  for (auto& f : frames) {
    cv::rectangle(f, fixed_part, s.bob_bgr, cv::FILLED);
    cv::GaussianBlur(f, f, cv::Size(0, 0), s.blur_px);
    cv::Mat noise(f.size(), CV_16SC3);
    rng.fill(noise, cv::RNG::NORMAL, 0, s.noise_sigma);
    cv::Mat f16;
    f.convertTo(f16, CV_16SC3);
    f16 += noise;
    f16.convertTo(f, CV_8UC3);
  }
  const std::string path = writeScene(frames, s.fps, "pendulum_static_region.avi");
  TrackOptions o;
  o.pivot_given = true;
  o.pivot = s.pivot;
  o.tracker.roi = cv::Rect(20, 370, 80, 80);
  o.tracker.roi_given = true;
  const TrackResult r = trackVideo(path, o);
  std::printf("static region: %s\n", r.message.c_str());
  ASSERT_TRUE(r.object_found) << r.message;
  EXPECT_FALSE(r.signal.oscillation_found);
  EXPECT_NE(r.message.find("does not move"), std::string::npos) << r.message;
  EXPECT_NE(r.message.find("--roi"), std::string::npos) << r.message;
  EXPECT_EQ(r.message.find("swings only"), std::string::npos) << r.message;

  PendulumScene small = s;
  small.amplitude_deg = 0.4;  // the bob moves about ±2 px: a small swing, not a static region
  const std::string small_path = writeScene(renderPendulum(small), small.fps, "pendulum_small_swing.avi");
  TrackOptions os;
  os.pivot_given = true;
  os.pivot = small.pivot;
  const TrackResult rs = trackVideo(small_path, os);
  std::printf("small swing: %s\n", rs.message.c_str());
  EXPECT_FALSE(rs.signal.oscillation_found);
  EXPECT_NE(rs.message.find("swings only"), std::string::npos) << rs.message;
  EXPECT_EQ(rs.message.find("does not move"), std::string::npos) << rs.message;
}

TEST(VisionTracking, MarkerLeavingTheFrameIsReported) {
  PendulumScene s;
  s.pivot = cv::Point2d(560, 40);
  s.amplitude_deg = 45.0;
  s.duration_s = 4.0;
  const std::string path = writeScene(renderPendulum(s), s.fps, "pendulum_leaves.avi");
  const TrackResult r = trackVideo(path, TrackOptions());
  std::printf("leaving: %s\n", r.message.c_str());
  EXPECT_GT(r.lost_frames, 0);
  EXPECT_NE(r.message.find("lost (left the frame"), std::string::npos) << r.message;
  EXPECT_NE(r.message.find(" s"), std::string::npos);
}

TEST(VisionTracking, NeverFoundAndDroppedFrames) {
  PendulumScene s;
  s.bob_bgr = cv::Scalar(200, 0, 0);  // blue: no red marker
  s.duration_s = 1.0;
  const std::vector<cv::Mat> frames = renderPendulum(s);
  MotionTracker mt{TrackOptions()};
  for (std::size_t i = 0; i < frames.size(); ++i) mt.addFrame(frames[i], i / 30.0);
  const TrackResult r = mt.finish();
  EXPECT_FALSE(r.object_found);
  EXPECT_NE(r.message.find("never found"), std::string::npos) << r.message;

  // dropped frames: skip frames 10..12 of a red pendulum
  PendulumScene red;
  red.duration_s = 3.0;
  const std::vector<cv::Mat> f2 = renderPendulum(red);
  TrackOptions o;
  o.fps = 30.0;
  MotionTracker m2(o);
  for (std::size_t i = 0; i < f2.size(); ++i)
    if (i < 10 || i > 12) m2.addFrame(f2[i], i / 30.0);
  EXPECT_FALSE(m2.overlay().empty());
  const TrackResult r2 = m2.finish();
  EXPECT_EQ(r2.dropped_frames, 3);
  EXPECT_NE(r2.message.find("3 dropped frame"), std::string::npos) << r2.message;
}

TEST(VisionTracking, ErrorsNameTheInput) {
  try {
    trackVideo("/nonexistent/clip.mp4", TrackOptions());
    FAIL() << "no error for a missing file";
  } catch (const TopoError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/clip.mp4"), std::string::npos) << e.what();
  }

  PendulumScene s;
  s.duration_s = 0.5;
  const std::string path = writeScene(renderPendulum(s), s.fps, "pendulum_short.avi");
  for (const cv::Rect& roi : {cv::Rect(10, 10, 0, 50), cv::Rect(2000, 2000, 50, 50)}) {
    TrackOptions o;
    o.tracker.roi = roi;
    o.tracker.roi_given = true;
    try {
      trackVideo(path, o);
      FAIL() << "no error for a bad ROI";
    } catch (const TopoError& e) {
      EXPECT_NE(std::string(e.what()).find("--roi"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("640x480"), std::string::npos) << e.what();
    }
  }
  // not a video
  const std::string junk = testing::TempDir() + "/junk.mp4";
  FILE* f = std::fopen(junk.c_str(), "w");
  std::fputs("this is not a video", f);
  std::fclose(f);
  EXPECT_THROW(VideoSource v(junk), TopoError);
}

TEST(VisionTracking, ImageSequenceSource) {
  PendulumScene s;
  s.duration_s = 0.5;
  const std::vector<cv::Mat> frames = renderPendulum(s);
  const std::string dir = testing::TempDir() + "/seq_";
  for (std::size_t i = 0; i < frames.size(); ++i) {
    char name[64];
    std::snprintf(name, sizeof(name), "frame_%04d.png", static_cast<int>(i));
    cv::imwrite(dir + name, frames[i]);
  }
  VideoOptions vo;
  vo.sequence_fps = 15;
  vo.stride = 2;
  VideoSource src(dir + "frame_%04d.png", vo);
  EXPECT_EQ(src.frameCount(), static_cast<int>(frames.size()));
  cv::Mat m;
  double t;
  int n = 0;
  while (src.read(m, t)) ++n;
  EXPECT_EQ(n, (static_cast<int>(frames.size()) + 1) / 2);
  EXPECT_NEAR(src.timestamps().at(1), 2.0 / 15.0, 1e-9);
}

// Real video: a red bauble on a string (640x352, 29.75 fps, 10.3 s, pivot above the frame).
// Independent measurement (done once, outside the tracker, with a separate probe program): the mean x
// coordinate of all "red" pixels (R > 80, R > 1.6 G, R > 1.6 B) per frame, no blobs, no pivot, no
// angles; its 7 turning points (local extrema over ±5 frames, refined by a least-squares parabola
// over ±6 frames) at 0.968, 2.296, 3.598, 4.924, 6.227, 7.551, 8.857 s; a straight-line fit of those
// times against the half-cycle index gives a half period of 1.3144 s → period 2.629 s. (The
// autocorrelation peak of the same x signal is at 77.77 frames = 2.614 s; its DFT peak 2.608 s is
// biased by the amplitude decay and the short window.)
TEST(VisionTracking, RealPendulumBaubleAgreesWithIndependentMeasurement) {
  TOPO_SHARED_FILE(path, "videos/pendulum_bauble.mp4");
  TrackOptions o;
  const TrackResult r = trackVideo(path, o);
  std::printf("bauble: %s\n", r.message.c_str());
  std::printf("bauble: fps %.3f frames %d/%d pivot (%.1f, %.1f) rms %.2f\n", r.fps, r.frames_used, r.frames_total,
              r.pivot.x, r.pivot.y, r.pivot_fit_rms_px);
  ASSERT_TRUE(r.signal.oscillation_found) << r.message;
  EXPECT_NEAR(r.signal.period_s, 2.629, 0.01 * 2.629);
  EXPECT_NEAR(r.fps, 29.75, 0.01);
  EXPECT_LT(r.lost_frames, 5);
  EXPECT_EQ(r.dropped_frames, 0) << r.message;
  EXPECT_NEAR(r.t.back(), 304 / 29.75, 1e-6);
}

// Real video: a tennis ball dropped onto a table (1080x1080, 30 fps, 3.7 s), released at rest near
// the top, two bounces, the clip ends near the third apex. The ball is pale yellow-green: sampled
// in the video at H 40..60, S 60..85, V 190..235 (motion blur lowers the saturation); the green box
// on the table is H 70..90 with S > 90 and the table H ~20, so H 35..65, S ≥ 45, V ≥ 150 isolates it.
// Measured (this tracker): bounces at 1.185 and 2.921 s on the same floor line (y ≈ 960 px), release
// 812 px above it, apex 461.6 px at 2.063 s, and ≥ 259 px at the end of the clip (rising stops at
// 3.60 s): restitution sqrt(461.6/812) = 0.754 and sqrt(259/461.6) = 0.749 agree.
TEST(VisionTracking, RealTennisBallBounces) {
  TOPO_SHARED_FILE(path, "videos/tennis_ball_drop.mp4");
  TrackOptions o;
  o.kind = "trajectory";
  o.tracker.hsv = {HsvRange{cv::Scalar(35, 45, 150), cv::Scalar(65, 255, 255)}};
  o.tracker.min_area_px = 300;
  const TrackResult r = trackVideo(path, o);
  std::printf("tennis: %s\n", r.message.c_str());
  for (std::size_t i = 0; i < r.bounce_times_s.size(); ++i)
    std::printf("  bounce %zu: t %.3f s y %.1f px\n", i, r.bounce_times_s[i], r.bounce_y_px[i]);
  for (std::size_t i = 0; i < r.apex_times_s.size(); ++i)
    std::printf("  apex %zu: t %.3f s height %.1f px\n", i, r.apex_times_s[i], r.apex_heights_px[i]);
  EXPECT_LT(r.lost_frames, 3);
  ASSERT_GE(r.bounce_times_s.size(), 2u);
  ASSERT_GE(r.apex_times_s.size(), 1u);
  // the bounces lie on one floor line
  for (double y : r.bounce_y_px) EXPECT_NEAR(y, r.floor_y_px, 10.0);
  // heights: release > apex between the bounces > rise after the last bounce
  const double release = r.floor_y_px - r.angle_deg.front();
  double last_rise = 0;
  for (std::size_t i = 0; i < r.t.size(); ++i)
    if (r.t[i] > r.bounce_times_s.back()) last_rise = std::max(last_rise, r.floor_y_px - r.angle_deg[i]);
  const double apex = r.apex_heights_px.front();
  std::printf("  release %.1f px, apex %.1f px, last rise %.1f px, restitution %.3f / %.3f\n", release, apex, last_rise,
              std::sqrt(apex / release), std::sqrt(last_rise / apex));
  EXPECT_GT(r.apex_times_s.front(), r.bounce_times_s[0]);
  EXPECT_LT(r.apex_times_s.front(), r.bounce_times_s[1]);
  EXPECT_GT(release, apex);
  EXPECT_GT(apex, last_rise);
  EXPECT_GT(last_rise, 0.0);
  // a ball keeps (roughly) its coefficient of restitution between bounces
  EXPECT_NEAR(std::sqrt(apex / release), std::sqrt(last_rise / apex), 0.05);
  // the apex between the bounces is half-way in time (symmetric flight)
  EXPECT_NEAR(r.apex_times_s.front(), 0.5 * (r.bounce_times_s[0] + r.bounce_times_s[1]), 0.05);
}

TEST(VisionTracking, CameraModelRoundTrip) {
  const cv::Matx33d K(800, 0, 320, 0, 780, 240, 0, 0, 1);
  const std::vector<double> dist{-0.12, 0.05, 0.001, -0.0005, 0.01};
  // camera 1.5 m above a table (z = 0), looking down and tilted 20° about x
  const double a = 200.0 * M_PI / 180.0;
  const cv::Matx33d R(1, 0, 0, 0, std::cos(a), -std::sin(a), 0, std::sin(a), std::cos(a));
  const CameraModel cam(K, dist, R, cv::Vec3d(0.1, -0.2, 1.5));
  for (const cv::Vec3d& w : {cv::Vec3d(0.1, 0.3, 0.0), cv::Vec3d(-0.2, 0.5, 0.0), cv::Vec3d(0.3, 0.1, 0.0)}) {
    const cv::Point2d px = cam.project(w);
    const cv::Vec3d back = cam.intersectPlane(px, cv::Vec3d(0, 0, 1), 0.0);
    EXPECT_LT(cv::norm(back - w), 1e-6) << px;
    const cv::Point2d again = cam.project(back);
    EXPECT_NEAR(std::hypot(again.x - px.x, again.y - px.y), 0.0, 1e-6);
  }
  EXPECT_THROW(CameraModel(K, {0.1, 0.2, 0.3}), TopoError);
}

TEST(VisionTracking, CliTrackJson) {
  PendulumScene s;
  s.duration_s = 4.0;
  const std::string path = writeScene(renderPendulum(s), s.fps, "cli_pendulum.avi");
  // stdout only (stderr discarded), so `out` holds just what the command prints as its result
  auto track = [](const std::string& args) { return topo_test::runTopo("track " + args, topo_test::Stderr::Discard); };
  const topo_test::ToolRun json = track("--video " + path + " --json");
  EXPECT_EQ(json.code, 0);
  EXPECT_NE(json.out.find("\"period_s\""), std::string::npos) << json.out;
  EXPECT_NE(json.out.find("\"tracker\""), std::string::npos) << json.out;
  // What `topo track --json > FILE` writes is what readMotionFeaturesJson (topo infer --features) reads.
  const std::string file = testing::TempDir() + "/cli_features.json";
  ASSERT_EQ(track("--video " + path + " --json --series > " + file).code, 0);
  TrackOptions o;
  const TrackResult direct = trackVideo(path, o);
  const topo_gaussian::motion::MotionFeatures read = io::readMotionFeaturesJson(file);
  ASSERT_TRUE(direct.signal.oscillation_found) << direct.message;
  EXPECT_TRUE(read.oscillation_found);
  EXPECT_EQ(read.kind, "pendulum");
  EXPECT_NEAR(read.period_s, direct.signal.period_s, 1e-9 * direct.signal.period_s);
  EXPECT_NEAR(read.period_s, s.period_s, 0.005 * s.period_s);
  EXPECT_GT(read.period_confidence, 0.5);
  EXPECT_EQ(read.time_s.size(), direct.t.size());
  EXPECT_EQ(track("--video /nonexistent/none.mp4 --json").code, 1);
  EXPECT_EQ(track("--video " + path + " --roi 0,0,0,0").code, 2);  // a bad option: exit 2 with the fix
  EXPECT_EQ(track("").code, 2);
  const std::string plot = testing::TempDir() + "/cli_plot.png";
  const std::string dbg = testing::TempDir() + "/cli_debug.avi";
  const topo_test::ToolRun plotted = track("--video " + path + " --plot " + plot + " --debug-video " + dbg);
  EXPECT_EQ(plotted.code, 0) << plotted.out;
  EXPECT_TRUE(topo_test::fileExists(plot));
  EXPECT_TRUE(topo_test::fileExists(dbg));
}
