// Misleading messages for bad video input: an empty frame is called empty (with its size), not "not
// an 8-bit BGR image"; a video that stops decoding before its announced length is called truncated
// after frame N, not "record a longer clip".
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <string>

#include "test_util.h"
#include "topo_gaussian/vision/motion_tracker.h"
#include "topo_gaussian/vision/synthetic_video.h"

using namespace topo_gaussian;
using topo_test::errorOf;

TEST(VisionFaults, EmptyFrameIsCalledEmptyWithItsSize) {
  vision::MotionTracker mt{vision::TrackOptions()};
  const std::string e = errorOf([&] { mt.addFrame(cv::Mat(), 0.5); });
  EXPECT_NE(e.find("empty"), std::string::npos) << e;
  EXPECT_NE(e.find("0x0 pixels"), std::string::npos) << e;
  EXPECT_EQ(e.find("8-bit BGR"), std::string::npos) << "an empty frame is not a wrong format: " << e;
  const std::string grey = errorOf([&] { mt.addFrame(cv::Mat(48, 64, CV_8UC1, cv::Scalar(0)), 0.5); });
  EXPECT_NE(grey.find("not an 8-bit BGR image (1 channels of 8 bits)"), std::string::npos) << grey;
}

TEST(VisionFaults, TruncatedVideoIsCalledTruncatedAfterFrameN) {
  vision::PendulumScene s;
  s.duration_s = 5.0;  // 150 frames
  const std::string dir = ::testing::TempDir();
  int decoded_partly = 0;  // containers whose cut copy still opened: the case this test is about
  for (const std::string ext : {".avi", ".mp4"}) {
    const std::string full = dir + "/topo_vision_faults_full_" + std::to_string(::getpid()) + ext;
    const std::string cut = dir + "/topo_vision_faults_cut_" + std::to_string(::getpid()) + ext;
    vision::writeVideo(vision::renderPendulum(s), s.fps, full);
    std::filesystem::copy_file(full, cut, std::filesystem::copy_options::overwrite_existing);
    std::filesystem::resize_file(cut, std::filesystem::file_size(full) / 20);  // the first ~7 frames' bytes
    std::string message;
    try {
      message = vision::trackVideo(cut, vision::TrackOptions()).message;
    } catch (const std::exception& e) {
      message = e.what();
    }
    std::filesystem::remove(full);
    std::filesystem::remove(cut);
    SCOPED_TRACE(ext + ": " + message);
    if (message.find("cannot be opened") != std::string::npos) {
      // The container's index went with the tail (mp4: the 'moov' atom): refused at open, saying so.
      EXPECT_NE(message.find("cut off before its index"), std::string::npos);
      continue;
    }
    ++decoded_partly;
    EXPECT_NE(message.find("truncated or unreadable after frame"), std::string::npos);
    EXPECT_EQ(message.find("record a longer clip"), std::string::npos);
  }
  EXPECT_GT(decoded_partly, 0) << "no cut video opened: the truncation case was not exercised";
}
