// A complete variable-frame-rate video (a phone lowers its rate in dim light; a screen recorder writes
// a frame only when the picture changes): its frames are unevenly spaced, and its container announces
// a nominal rate (and, in Matroska, a frame count of duration x that rate) that no frame keeps. Such a
// file is read by its timestamps: it is neither "truncated" nor full of "dropped frames", and the
// message names the variable frame rate. A pendulum rendered at 120 fps is kept at irregular steps of
// 2..6 frames and written with each kept frame's own time, so the true period is known.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "shared_data.h"
#include "topo_gaussian/vision/motion_tracker.h"
#include "topo_gaussian/vision/synthetic_video.h"
#include "topo_gaussian/vision/video_source.h"

#ifdef TOPO_HAVE_AVFORMAT
#include "av_remux.h"
#endif

using namespace topo_gaussian::vision;

namespace {

constexpr int kRenderFps = 120;

/// Frame indices (of a clip rendered at kRenderFps) kept at irregular steps of 2..6 frames.
std::vector<int> irregularIndices(int frames) {
  const int steps[] = {2, 3, 5, 4, 3, 6, 2, 4};
  std::vector<int> kept;
  for (int i = 0, k = 0; i < frames; i += steps[k++ % 8]) kept.push_back(i);
  return kept;
}

#ifdef TOPO_HAVE_AVFORMAT
/// Copies the video stream of `in` into `out` (container `format`, no re-encoding), giving packet k the
/// time kept[k] / kRenderFps s. Returns an empty string or what failed.
std::string remuxWithTimes(const std::string& in_path, const std::string& out_path, const char* format,
                           const std::vector<int>& kept) {
  return topo_test::remuxVideo(
      in_path, out_path, format, [](AVStream* s, const AVStream*) { s->time_base = AVRational{1, kRenderFps}; },
      [&](AVPacket* p, int k) {
        if (k >= static_cast<int>(kept.size())) return false;
        p->pts = p->dts = kept[k];
        p->duration = k + 1 < static_cast<int>(kept.size()) ? kept[k + 1] - kept[k] : 2;
        return true;
      });
}
#endif

}  // namespace

TEST(VisionVfrVideo, AVariableFrameRateVideoIsReadByItsTimestamps) {
#ifndef TOPO_HAVE_AVFORMAT
  GTEST_SKIP() << "libavformat-dev is missing (scripts/install_deps.sh installs it): cannot write a VFR container";
#else
  PendulumScene s;
  s.width = 320;
  s.height = 240;
  s.fps = kRenderFps;
  s.duration_s = 4.0;
  s.period_s = 1.2;
  s.amplitude_deg = 20.0;
  s.pivot = cv::Point2d(160, 20);
  s.length_px = 150.0;
  s.bob_radius_px = 12.0;
  const std::vector<cv::Mat> all = renderPendulum(s);
  const std::vector<int> kept = irregularIndices(static_cast<int>(all.size()));
  std::vector<cv::Mat> frames;
  for (int i : kept) frames.push_back(all[i]);
  const std::string dir = testing::TempDir();
  const std::string even = dir + "/topo_vfr_even.avi";
  writeVideo(frames, 30.0, even);  // every kept frame, evenly spaced: only the codec's packets are used
  for (const auto& [format, ext] : {std::pair<const char*, const char*>{"matroska", ".mkv"}, {"mp4", ".mp4"}}) {
    const std::string path = dir + "/topo_vfr" + ext;
    ASSERT_EQ(remuxWithTimes(even, path, format, kept), "") << format;
    // every frame comes with its own time
    VideoSource v(path);
    cv::Mat f;
    double t = 0;
    std::size_t k = 0;
    while (v.read(f, t)) {
      ASSERT_LT(k, kept.size()) << ext;
      EXPECT_NEAR(t, kept[k] / double(kRenderFps), 1.5e-3) << ext << " frame " << k;
      ++k;
    }
    EXPECT_EQ(k, kept.size()) << ext;
    const TrackResult r = trackVideo(path, TrackOptions());
    std::printf("%s (container: %.2f fps, %d frames; %zu frames in %.2f s): %s\n", ext, v.fps(), v.frameCount(),
                kept.size(), kept.back() / double(kRenderFps), r.message.c_str());
    EXPECT_FALSE(v.endedEarly()) << ext;
    EXPECT_EQ(r.message.find("truncated"), std::string::npos) << ext << ": " << r.message;
    EXPECT_EQ(r.dropped_frames, 0) << ext << ": " << r.message;
    EXPECT_NE(r.message.find("variable frame rate"), std::string::npos) << ext << ": " << r.message;
    ASSERT_TRUE(r.signal.oscillation_found) << ext << ": " << r.message;
    EXPECT_NEAR(r.signal.period_s, s.period_s, 0.01 * s.period_s) << ext;
  }
#endif
}

// The decision on a list of frame times: uneven steps that are not whole multiples of one step are a
// variable frame rate (no frame is missing); even steps with one gap of four steps are three dropped
// frames; an announced rate far above the frames' own does not turn every step into dropped frames.
TEST(VisionVfrVideo, FrameStepsTellAVariableRateFromDroppedFrames) {
  std::vector<double> vfr;
  for (int i : irregularIndices(480)) vfr.push_back(i / double(kRenderFps));
  const FrameSteps a = analyseFrameSteps(vfr, 1000.0);
  EXPECT_TRUE(a.variable);
  EXPECT_EQ(a.dropped_frames, 0);

  std::vector<double> cfr;
  for (int i = 0; i < 90; ++i)
    if (i < 10 || i > 12) cfr.push_back(i / 30.0);
  const FrameSteps b = analyseFrameSteps(cfr, 30.0);
  EXPECT_FALSE(b.variable);
  EXPECT_EQ(b.dropped_frames, 3);
  EXPECT_EQ(b.gaps, 1);
  const FrameSteps c = analyseFrameSteps(cfr, 1000.0);  // the container's rate is contradicted by the stamps
  EXPECT_FALSE(c.variable);
  EXPECT_EQ(c.dropped_frames, 3);
  EXPECT_NEAR(c.step_s, 1.0 / 30, 1e-9);
}

// A real clip whose container announces 31.47 fps and 411 frames while it holds 301 frames 40 ms
// apart (test/real_clips/pendulum_green_bg_small_bob.yaml, checked against a stopwatch in view): read
// to its end it is complete, not "truncated after frame 301".
TEST(VisionVfrVideo, AClipAnnouncingMoreFramesThanItHoldsIsNotTruncated) {
  TOPO_SHARED_FILE(path, "videos/pendulum_green_bg_small_bob.mp4");
  const YAML::Node truth =
      YAML::LoadFile(std::string(TOPO_SOURCE_DIR) + "/test/real_clips/pendulum_green_bg_small_bob.yaml");
  VideoSource v(path);
  cv::Mat f;
  double t = 0;
  while (v.read(f, t)) {
  }
  EXPECT_EQ(v.framesDecoded(), truth["frames"].as<int>());
  EXPECT_GT(v.frameCount(), v.framesDecoded());  // the container's count is too high
  EXPECT_FALSE(v.endedEarly()) << v.framesDecoded() << " frames to " << t << " s of an announced "
                               << v.frameCount() << " at " << v.fps() << " fps";
}
