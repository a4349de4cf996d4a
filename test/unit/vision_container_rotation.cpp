// A phone stores a portrait video as landscape frames plus a rotation in the container (a display
// matrix); players, and VideoSource through OpenCV's CAP_PROP_ORIENTATION_AUTO, turn the frames
// upright. Here the real pendulum clip's frames are stored turned 90° clockwise, and the container
// says to turn them back (FFmpeg's display matrix: 90° counter-clockwise): the tracker must see the
// upright clip and measure the clip's own period (test/real_clips/pendulum_bauble.yaml: 2.629 s),
// and say that it applied the container's rotation.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <string>

#include "shared_data.h"
#include "topo_gaussian/vision/motion_tracker.h"
#include "topo_gaussian/vision/video_source.h"

#ifdef TOPO_HAVE_AVFORMAT
#include "av_remux.h"
extern "C" {
#include <libavutil/display.h>
}
#endif

using namespace topo_gaussian::vision;

namespace {

#ifdef TOPO_HAVE_AVFORMAT
/// Copies the video stream of `in` into the MP4 `out` (no re-encoding) with a display matrix that
/// rotates by `ccw_deg` counter-clockwise. Returns an empty string or what failed.
std::string remuxWithRotation(const std::string& in_path, const std::string& out_path, double ccw_deg) {
  return topo_test::remuxVideo(
      in_path, out_path, "mp4",
      [&](AVStream* s, const AVStream*) {
        uint8_t* sd = av_stream_new_side_data(s, AV_PKT_DATA_DISPLAYMATRIX, sizeof(int32_t) * 9);
        av_display_rotation_set(reinterpret_cast<int32_t*>(sd), ccw_deg);
      },
      nullptr);
}
#endif

}  // namespace

TEST(VisionContainerRotation, APhonesPortraitVideoIsTurnedUpright) {
#ifndef TOPO_HAVE_AVFORMAT
  GTEST_SKIP() << "libavformat-dev is missing (scripts/install_deps.sh installs it): cannot write a rotated container";
#else
  TOPO_SHARED_FILE(src, "videos/pendulum_bauble.mp4");
  // the frames as a phone stores them: turned 90° clockwise (352 x 640)
  const std::string sideways = testing::TempDir() + "/bauble_sideways.mp4";
  {
    cv::VideoCapture cap(src, cv::CAP_FFMPEG);
    ASSERT_TRUE(cap.isOpened());
    cv::VideoWriter w;
    cv::Mat f, r;
    while (cap.read(f)) {
      cv::rotate(f, r, cv::ROTATE_90_CLOCKWISE);
      if (!w.isOpened())
        ASSERT_TRUE(w.open(sideways, cv::CAP_FFMPEG, cv::VideoWriter::fourcc('m', 'p', '4', 'v'),
                           cap.get(cv::CAP_PROP_FPS), r.size()));
      w.write(r);
    }
  }
  const std::string phone = testing::TempDir() + "/bauble_phone.mp4";
  ASSERT_EQ(remuxWithRotation(sideways, phone, 90.0), "");
  VideoSource v(phone);
  EXPECT_EQ(v.frameSize(), cv::Size(640, 352));  // upright again
  EXPECT_NE(v.orientationDeg(), 0);
  const TrackResult r = trackVideo(phone, TrackOptions());
  ASSERT_FALSE(r.refused) << r.message;
  ASSERT_TRUE(r.signal.oscillation_found) << r.message;
  EXPECT_NEAR(r.signal.period_s, 2.629, 0.02 * 2.629);
  EXPECT_NE(r.message.find("container's rotation"), std::string::npos) << r.message;
  // the stored (sideways) frames without the metadata: the path runs along gravity, refused
  const TrackResult s = trackVideo(sideways, TrackOptions());
  EXPECT_TRUE(s.refused) << s.message;
#endif
}
