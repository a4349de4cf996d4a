// Tracking benchmark: frames per second of each method on a 640x480 synthetic pendulum video (noise,
// blur, moving background), on one core (cv::setNumThreads(1)), as a ratio to the video's own 30 fps.
// Two numbers per method: the tracker + features on decoded frames in memory, and the whole
// trackVideo() path including decoding the video file. One JSON line per method.
// Usage: bench_track [--quick]
#include <chrono>
#include <cstdio>
#include <cstring>
#include <opencv2/core.hpp>
#include <string>

#include "topo_gaussian/common/json.h"
#include "topo_gaussian/vision/motion_tracker.h"
#include "topo_gaussian/vision/synthetic_video.h"

using namespace topo_gaussian::vision;

int main(int argc, char** argv) {
  const bool quick = argc > 1 && std::strcmp(argv[1], "--quick") == 0;
  cv::setNumThreads(1);
  PendulumScene scene;
  scene.duration_s = quick ? 3.0 : 10.0;
  scene.noise_sigma = 8.0;
  scene.blur_px = 1.5;
  scene.moving_background = true;
  scene.amplitude_deg = 15.0;
  const std::vector<cv::Mat> frames = renderPendulum(scene);
  const std::string path = "/tmp/bench_track_pendulum.avi";
  writeVideo(frames, scene.fps, path);
  struct Case {
    const char* method;
    const char* kind;
    const char* foreground;
  };
  for (const Case c : {Case{"marker", "pendulum", "mog2"}, Case{"silhouette", "pendulum", "mog2"},
                       Case{"silhouette", "pendulum", "otsu"}, Case{"klt", "pendulum", "mog2"}}) {
    TrackOptions o;
    o.kind = c.kind;
    o.tracker.method = c.method;
    o.tracker.foreground = c.foreground;
    o.fps = scene.fps;
    if (std::strcmp(c.method, "klt") == 0) {
      o.tracker.roi = cv::Rect(260, 280, 120, 140);  // around the bob at rest
      o.tracker.roi_given = true;
    }
    const auto t0 = std::chrono::steady_clock::now();
    MotionTracker mt(o);
    for (std::size_t i = 0; i < frames.size(); ++i) mt.addFrame(frames[i], i / scene.fps);
    const TrackResult r = mt.finish();
    const auto t1 = std::chrono::steady_clock::now();
    const TrackResult rv = trackVideo(path, o);
    const auto t2 = std::chrono::steady_clock::now();
    const double s_mem = std::chrono::duration<double>(t1 - t0).count();
    const double s_file = std::chrono::duration<double>(t2 - t1).count();
    const double fps_mem = frames.size() / s_mem, fps_file = frames.size() / s_file;
    std::printf(
        "{\"bench\":\"track\",\"method\":\"%s\",\"foreground\":\"%s\",\"kind\":\"%s\",\"width\":%d,\"height\":%d,"
        "\"frames\":%zu,\"video_fps\":%.1f,\"threads\":1,\"fps_tracking\":%.1f,\"realtime_tracking\":%.2f,"
        "\"fps_with_decode\":%.1f,\"realtime_with_decode\":%.2f,\"period_s\":%s,\"period_true_s\":%.5f,"
        "\"oscillation_found\":%s,\"refused\":%s}\n",
        c.method, std::strcmp(c.method, "silhouette") == 0 ? c.foreground : "", c.kind, scene.width, scene.height,
        frames.size(), scene.fps, fps_mem, fps_mem / scene.fps, fps_file, fps_file / scene.fps,
        topo_gaussian::json::num(rv.signal.period_s).c_str(), scene.period_s,
        r.signal.oscillation_found ? "true" : "false", r.refused ? "true" : "false");
  }
  std::remove(path.c_str());
  return 0;
}
