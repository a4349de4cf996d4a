// Signal analysis (period, amplitude, equilibrium, damping, confidence) on sampled synthetic signals,
// and the synthetic pendulum/finger scenes and the video writer.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <random>
#include <string>
#include <vector>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/vision/signal_analysis.h"
#include "topo_gaussian/vision/synthetic_video.h"

using namespace topo_gaussian;
using namespace topo_gaussian::vision;

namespace {

constexpr double kPi = 3.14159265358979323846;

/// Samples pendulumAngleDeg at scene.fps, with Gaussian noise and randomly dropped samples.
void sample(const PendulumScene& scene, double noise_deg, double drop_fraction, unsigned seed, std::vector<double>& t,
            std::vector<double>& y) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, noise_deg);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  t.clear();
  y.clear();
  const int n = static_cast<int>(std::lround(scene.fps * scene.duration_s));
  for (int k = 0; k < n; ++k) {
    if (uni(rng) < drop_fraction) continue;
    const double tk = k / scene.fps;
    t.push_back(tk);
    y.push_back(pendulumAngleDeg(scene, tk) + (noise_deg > 0.0 ? noise(rng) : 0.0));
  }
}

PendulumScene baseScene() {
  PendulumScene s;
  s.fps = 30.0;
  s.duration_s = 6.0;
  s.period_s = 1.2;
  s.amplitude_deg = 15.0;
  s.equilibrium_deg = 4.0;
  return s;
}

}  // namespace

TEST(VisionSignal, UndampedNoisyDroppedSamples) {
  const PendulumScene scene = baseScene();
  double worst_period = 0.0, worst_amp = 0.0, worst_eq = 0.0, worst_tilt = 0.0, min_conf = 1.0;
  for (unsigned seed = 1; seed <= 5; ++seed) {
    std::vector<double> t, y;
    sample(scene, 0.3, 0.05, seed, t, y);
    const SignalFeatures f = analyseSignal(t, y);
    ASSERT_TRUE(f.oscillation_found) << f.message;
    const double perr = std::abs(f.period_s - scene.period_s) / scene.period_s;
    EXPECT_LT(perr, 0.005) << "period " << f.period_s << " seed " << seed;
    EXPECT_NEAR(f.amplitude_deg, 15.0, 1.0);
    EXPECT_NEAR(f.equilibrium_deg, 4.0, 1.0);
    EXPECT_NEAR(f.max_tilt_deg, 19.0, 1.0);
    EXPECT_NEAR(f.log_decrement, 0.0, 0.05);
    EXPECT_GE(f.cycles, 4);
    EXPECT_GT(f.confidence, 0.6) << f.message;
    EXPECT_LE(f.confidence, 1.0);
    EXPECT_FALSE(f.crossing_times_s.empty());
    worst_period = std::max(worst_period, perr);
    worst_amp = std::max(worst_amp, std::abs(f.amplitude_deg - 15.0));
    worst_eq = std::max(worst_eq, std::abs(f.equilibrium_deg - 4.0));
    worst_tilt = std::max(worst_tilt, std::abs(f.max_tilt_deg - 19.0));
    min_conf = std::min(min_conf, f.confidence);
    if (seed == 1) std::printf("[ info ] %s\n", f.message.c_str());
  }
  std::printf(
      "[ info ] undamped: worst period error %.4f %%, amplitude %.3f deg, equilibrium %.3f deg, "
      "max tilt %.3f deg, min confidence %.3f\n",
      100.0 * worst_period, worst_amp, worst_eq, worst_tilt, min_conf);
}

TEST(VisionSignal, CleanSignalIsExact) {
  PendulumScene scene = baseScene();
  scene.period_s = 0.87;  // not a multiple of the frame interval
  std::vector<double> t, y;
  sample(scene, 0.0, 0.0, 1, t, y);
  const SignalFeatures f = analyseSignal(t, y);
  ASSERT_TRUE(f.oscillation_found) << f.message;
  EXPECT_NEAR(f.period_s, 0.87, 0.87 * 0.001);
  EXPECT_NEAR(f.amplitude_deg, 15.0, 0.3);
  EXPECT_NEAR(f.equilibrium_deg, 4.0, 0.1);
  EXPECT_GT(f.confidence, 0.8);
}

TEST(VisionSignal, DampedLogDecrement) {
  PendulumScene scene = baseScene();
  scene.damping_ratio = 0.03;
  const double delta_true = 2.0 * kPi * 0.03 / std::sqrt(1.0 - 0.03 * 0.03);
  double worst_delta = 0.0, worst_zeta = 0.0, worst_period = 0.0;
  for (unsigned seed = 1; seed <= 5; ++seed) {
    std::vector<double> t, y;
    sample(scene, 0.3, 0.05, seed, t, y);
    const SignalFeatures f = analyseSignal(t, y);
    ASSERT_TRUE(f.oscillation_found) << f.message;
    EXPECT_NEAR(f.log_decrement, delta_true, 0.1 * delta_true);
    EXPECT_NEAR(f.damping_ratio, 0.03, 0.003);
    EXPECT_NEAR(f.period_s, 1.2, 1.2 * 0.005);
    EXPECT_NEAR(f.equilibrium_deg, 4.0, 1.0);
    EXPECT_NEAR(f.max_tilt_deg, 19.0, 1.0);
    worst_delta = std::max(worst_delta, std::abs(f.log_decrement - delta_true) / delta_true);
    worst_zeta = std::max(worst_zeta, std::abs(f.damping_ratio - 0.03) / 0.03);
    worst_period = std::max(worst_period, std::abs(f.period_s - 1.2) / 1.2);
  }
  std::printf("[ info ] damped: worst log decrement error %.2f %%, damping ratio %.2f %%, period %.4f %%\n",
              100.0 * worst_delta, 100.0 * worst_zeta, 100.0 * worst_period);
}

TEST(VisionSignal, PhaseShiftedSlowFpsHeavierNoise) {
  // Starts mid-swing, 20 fps, 0.8 deg noise, 10 % dropped: still within the stated tolerances.
  PendulumScene scene = baseScene();
  scene.fps = 20.0;
  scene.duration_s = 8.0;
  scene.period_s = 1.37;
  std::mt19937 rng(11);
  std::normal_distribution<double> noise(0.0, 0.8);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  std::vector<double> t, y;
  for (int k = 0; k < 160; ++k) {
    if (uni(rng) < 0.1) continue;
    const double tk = k / scene.fps;
    t.push_back(tk);
    y.push_back(pendulumAngleDeg(scene, tk + 0.31) + noise(rng));
  }
  const SignalFeatures f = analyseSignal(t, y);
  ASSERT_TRUE(f.oscillation_found) << f.message;
  EXPECT_NEAR(f.period_s, 1.37, 1.37 * 0.005);
  EXPECT_NEAR(f.amplitude_deg, 15.0, 1.0);
  EXPECT_NEAR(f.equilibrium_deg, 4.0, 1.0);
  EXPECT_GT(f.confidence, 0.5);
  std::printf("[ info ] phase-shifted 20 fps noise 0.8: period %.4f s, amplitude %.2f, confidence %.3f\n", f.period_s,
              f.amplitude_deg, f.confidence);
}

TEST(VisionSignal, MonotonicRampIsNoOscillation) {
  FingerScene finger;
  std::vector<double> t, y;
  for (int k = 0; k < 60; ++k) {
    t.push_back(k / 30.0);
    y.push_back(fingerBendDeg(finger, k / 30.0));
  }
  const SignalFeatures f = analyseSignal(t, y);
  EXPECT_FALSE(f.oscillation_found);
  EXPECT_LT(f.confidence, 0.2);
  EXPECT_EQ(f.period_s, 0.0);
  EXPECT_NE(f.message.find("no oscillation"), std::string::npos) << f.message;
}

TEST(VisionSignal, StaticSignalIsNoOscillation) {
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 0.2);
  std::vector<double> t, y;
  for (int k = 0; k < 180; ++k) {
    t.push_back(k / 30.0);
    y.push_back(3.0 + noise(rng));
  }
  const SignalFeatures f = analyseSignal(t, y);
  EXPECT_FALSE(f.oscillation_found);
  EXPECT_LT(f.confidence, 0.2);
  EXPECT_NE(f.message.find("no oscillation"), std::string::npos) << f.message;
  EXPECT_EQ(f.period_s, 0.0);
  EXPECT_NEAR(f.equilibrium_deg, 3.0, 0.1);
  std::printf("[ info ] static: confidence %.3f, message: %s\n", f.confidence, f.message.c_str());

  const StaticPose p = analyseStatic(y);
  EXPECT_NEAR(p.angle_deg, 3.0, 0.1);
  EXPECT_NEAR(p.spread_deg, 0.2, 0.08);
  EXPECT_GT(p.confidence, 0.9);
  std::vector<double> wobbly;
  for (int k = 0; k < 100; ++k) wobbly.push_back(10.0 + 6.0 * ((k % 2) ? 1.0 : -1.0));
  EXPECT_LT(analyseStatic(wobbly).confidence, p.confidence);
  EXPECT_THROW(analyseStatic({}), TopoError);
  EXPECT_THROW(analyseStatic({1.0, std::numeric_limits<double>::quiet_NaN()}), TopoError);
}

TEST(VisionSignal, TooShortClip) {
  PendulumScene scene = baseScene();
  scene.duration_s = 1.5 * scene.period_s;
  std::vector<double> t, y;
  sample(scene, 0.3, 0.0, 3, t, y);
  const SignalFeatures f = analyseSignal(t, y);
  EXPECT_FALSE(f.oscillation_found);
  EXPECT_NE(f.message.find("fewer than"), std::string::npos) << f.message;
  EXPECT_LT(f.confidence, 0.2);
  std::printf("[ info ] too short: confidence %.3f, message: %s\n", f.confidence, f.message.c_str());
}

TEST(VisionSignal, BadInputThrows) {
  EXPECT_THROW(analyseSignal({0.0, 0.1, 0.2}, {1.0, 2.0}), TopoError);
  EXPECT_THROW(analyseSignal({0.0, 0.2, 0.1}, {1.0, 2.0, 3.0}), TopoError);
  EXPECT_THROW(analyseSignal({0.0, 0.1, 0.1}, {1.0, 2.0, 3.0}), TopoError);
  EXPECT_THROW(analyseSignal({0.0, 0.1, 0.2}, {1.0, std::numeric_limits<double>::quiet_NaN(), 3.0}), TopoError);
  EXPECT_THROW(analyseSignal({0.0, std::numeric_limits<double>::quiet_NaN(), 0.2}, {1.0, 2.0, 3.0}), TopoError);
  EXPECT_THROW(analyseSignal({}, {}), TopoError);
  try {
    analyseSignal({0.0, 0.1}, {1.0});
  } catch (const TopoError& e) {
    EXPECT_NE(std::string(e.what()).find("differ in size"), std::string::npos);
  }
}

TEST(VisionSignal, RenderPendulumBobPosition) {
  PendulumScene scene = baseScene();
  scene.duration_s = 1.0;
  const std::vector<cv::Mat> frames = renderPendulum(scene);
  ASSERT_EQ(frames.size(), 30u);
  double worst = 0.0;
  for (size_t k : {0u, 4u, 9u, 17u, 26u}) {
    const cv::Mat& f = frames[k];
    ASSERT_EQ(f.rows, scene.height);
    ASSERT_EQ(f.cols, scene.width);
    ASSERT_EQ(f.type(), CV_8UC3);
    // red: R high, G and B low
    cv::Mat mask;
    cv::inRange(f, cv::Scalar(0, 0, 150), cv::Scalar(100, 100, 255), mask);
    const cv::Moments m = cv::moments(mask, true);
    ASSERT_GT(m.m00, 100.0);
    const cv::Point2d c(m.m10 / m.m00, m.m01 / m.m00);
    const double th = pendulumAngleDeg(scene, k / scene.fps) * kPi / 180.0;
    const cv::Point2d expect = scene.pivot + scene.length_px * cv::Point2d(std::sin(th), std::cos(th));
    const double err = std::hypot(c.x - expect.x, c.y - expect.y);
    EXPECT_LT(err, 1.5) << "frame " << k;
    worst = std::max(worst, err);
  }
  std::printf("[ info ] bob centroid worst error %.3f px\n", worst);

  // noise, blur and moving background keep size and type
  scene.noise_sigma = 5.0;
  scene.blur_px = 1.0;
  scene.moving_background = true;
  scene.duration_s = 0.2;
  const std::vector<cv::Mat> noisy = renderPendulum(scene);
  ASSERT_EQ(noisy.size(), 6u);
  EXPECT_EQ(noisy[0].type(), CV_8UC3);
  EXPECT_EQ(noisy[0].size(), cv::Size(scene.width, scene.height));
}

TEST(VisionSignal, RenderFingerAndWriteVideo) {
  FingerScene scene;
  scene.width = 320;
  scene.height = 240;
  scene.base = cv::Point2d(60, 120);
  scene.segment_px = 90;
  scene.width_px = 20;
  scene.duration_s = 1.0;
  scene.fps = 20.0;
  const std::vector<cv::Mat> frames = renderFinger(scene);
  ASSERT_EQ(frames.size(), 20u);
  EXPECT_EQ(frames[0].type(), CV_8UC3);
  EXPECT_NEAR(fingerBendDeg(scene, 0.0), 0.0, 1e-12);
  EXPECT_NEAR(fingerBendDeg(scene, 0.7 * scene.duration_s), scene.final_bend_deg, 1e-9);
  EXPECT_NEAR(fingerBendDeg(scene, scene.duration_s), scene.final_bend_deg, 1e-9);
  EXPECT_GT(fingerBendDeg(scene, 0.3), 0.0);
  EXPECT_LT(fingerBendDeg(scene, 0.3), scene.final_bend_deg);
  // the body colour is present and the tip moves
  cv::Mat m0, m1;
  cv::inRange(frames.front(), cv::Scalar(20, 130, 20), cv::Scalar(70, 190, 70), m0);
  cv::inRange(frames.back(), cv::Scalar(20, 130, 20), cv::Scalar(70, 190, 70), m1);
  EXPECT_GT(cv::countNonZero(m0), 1000);
  EXPECT_GT(cv::countNonZero(m0 != m1), 100);

  std::string dir = testing::TempDir();
  if (!dir.empty() && dir.back() != '/') dir += '/';
  const std::string path = dir + "topo_vision_signal_finger.avi";
  std::remove(path.c_str());
  writeVideo(frames, scene.fps, path);
  cv::VideoCapture cap(path);
  ASSERT_TRUE(cap.isOpened()) << path;
  int count = 0;
  cv::Mat frame;
  while (cap.read(frame)) {
    EXPECT_EQ(frame.size(), cv::Size(scene.width, scene.height));
    ++count;
  }
  EXPECT_EQ(count, 20);
  std::remove(path.c_str());

  const std::string bad = "/nonexistent_dir_topo_gaussian/sub/out.avi";
  try {
    writeVideo(frames, scene.fps, bad);
    FAIL() << "expected TopoError";
  } catch (const TopoError& e) {
    EXPECT_NE(std::string(e.what()).find(bad), std::string::npos) << e.what();
  }
  std::vector<cv::Mat> mixed = {frames[0], cv::Mat(10, 10, CV_8UC3, cv::Scalar::all(0))};
  EXPECT_THROW(writeVideo(mixed, 20.0, dir + "mixed.avi"), TopoError);
}

// The messages say what was wrong: a signal of jumps is "mostly noise" (not "below min_amplitude_deg");
// a small swing is below min_amplitude_deg; neither has a period.
TEST(SignalAnalysis, NoiseAndSmallSwingsAreToldApart) {
  std::vector<double> t, jumps, small;
  unsigned x = 12345;
  for (int i = 0; i < 300; ++i) {
    t.push_back(i / 30.0);
    x = x * 1103515245u + 12345u;
    jumps.push_back(((x >> 8) % 360) - 180.0);  // an angle that jumps anywhere from frame to frame
    small.push_back(0.3 * std::sin(2 * M_PI * i / 30.0));
  }
  const SignalFeatures n = analyseSignal(t, jumps);
  EXPECT_FALSE(n.oscillation_found);
  EXPECT_NE(n.message.find("mostly noise"), std::string::npos) << n.message;
  EXPECT_EQ(n.message.find("min_amplitude_deg"), std::string::npos) << n.message;
  const SignalFeatures s = analyseSignal(t, small);
  EXPECT_FALSE(s.oscillation_found);
  EXPECT_NE(s.message.find("below min_amplitude_deg"), std::string::npos) << s.message;
}
