// Misleading messages for bad video input: an empty frame is called empty (with its size), not "not
// an 8-bit BGR image"; a video that stops decoding before its announced length is called truncated
// after frame N, not "record a longer clip". A video path is never a printf format (only one %d /
// %0Nd makes an image-sequence pattern), and an output of `topo track` that is one of its inputs is
// refused before any work (issue 52 §2).
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <string>

#include "test_util.h"
#include "topo_gaussian/io/motion_features_json.h"
#include "topo_gaussian/vision/motion_features.h"
#include "topo_gaussian/vision/motion_tracker.h"
#include "topo_gaussian/vision/synthetic_video.h"
#include "topo_gaussian/vision/video_source.h"

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

namespace {

/// A fresh folder with a 1 s pendulum video pend.avi and its first 5 frames as frame_0000.png ...
/// frame_0004.png and as f0.png ... f4.png.
std::string clipFolder(const std::string& name) {
  const std::string dir = ::testing::TempDir() + "/topo_vision_faults_" + name + "_" + std::to_string(::getpid());
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  vision::PendulumScene s;
  s.duration_s = 1.0;
  s.width = 160;
  s.height = 120;
  const std::vector<cv::Mat> frames = vision::renderPendulum(s);
  vision::writeVideo(frames, s.fps, dir + "/pend.avi");
  for (int i = 0; i < 5; ++i) {
    char name4[32];
    std::snprintf(name4, sizeof(name4), "/frame_%04d.png", i);
    cv::imwrite(dir + name4, frames[i]);
    cv::imwrite(dir + "/f" + std::to_string(i) + ".png", frames[i]);
  }
  return dir;
}

std::string contents(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream os;
  os << in.rdbuf();
  return os.str();
}

}  // namespace

TEST(VisionFaults, OnlyOneDOrZeroPaddedDIsASequencePatternNeverAPrintfFormat) {
  const std::string dir = clipFolder("pattern");
  vision::VideoOptions o;
  EXPECT_EQ(vision::VideoSource(dir + "/frame_%04d.png", o).frameCount(), 5);
  EXPECT_EQ(vision::VideoSource(dir + "/f%d.png", o).frameCount(), 5);
  EXPECT_TRUE(vision::VideoSource(dir + "/f%d.png", o).isSequence());
  // Other conversions were handed to snprintf as the format (%s read garbage, %n wrote: a crash).
  for (const std::string bad : {"/frame_%s%s%s.png", "/frame_%n.png", "/frame_%04d%s.png", "/frame_%x.png",
                                "/frame_%%04d.png", "/frame_%-4d.png", "/frame_%0123d.png"}) {
    const std::string e = errorOf([&] { vision::VideoSource(dir + bad, o); });
    EXPECT_NE(e.find(dir + bad + ": video file does not exist or cannot be read"), std::string::npos) << bad << ": " << e;
  }
  // A real file with a '%' in its name is that file, not a sequence.
  std::filesystem::copy_file(dir + "/pend.avi", dir + "/run_100%full.avi");
  const vision::VideoSource v(dir + "/run_100%full.avi", o);
  EXPECT_FALSE(v.isSequence());
  EXPECT_GE(v.frameCount(), 25);
  // ... also when its name happens to look like a pattern.
  std::filesystem::copy_file(dir + "/pend.avi", dir + "/take_%d.avi");
  EXPECT_FALSE(vision::VideoSource(dir + "/take_%d.avi", o).isSequence());
  // The CLI: exit 1 with the message, no crash.
  for (const std::string bad : {"/frame_%s%s%s.png", "/frame_%n.png"}) {
    const topo_test::ToolRun r = topo_test::runTopo("track --video '" + dir + bad + "'");
    EXPECT_EQ(r.code, 1) << bad << ": " << r.out;
    EXPECT_NE(r.out.find("does not exist or cannot be read"), std::string::npos) << bad << ": " << r.out;
  }
  const topo_test::ToolRun ok = topo_test::runTopo("track --json --video '" + dir + "/run_100%full.avi'");
  EXPECT_EQ(ok.code, 0) << ok.out;
}

TEST(VisionFaults, TrackRefusesAnOutputThatIsAnInputBeforeAnyWork) {
  const std::string dir = clipFolder("same");
  const std::string video = contents(dir + "/pend.avi"), frame = contents(dir + "/frame_0002.png");
  std::filesystem::create_symlink(dir + "/pend.avi", dir + "/link.avi");
  for (const std::string& out : {dir + "/pend.avi", dir + "/./pend.avi", dir + "/../" +
                                     std::filesystem::path(dir).filename().string() + "/pend.avi",
                                 dir + "/link.avi"}) {
    const topo_test::ToolRun d = topo_test::runTopo("track --video " + dir + "/pend.avi --debug-video " + out);
    EXPECT_EQ(d.code, 2) << out << ": " << d.out;
    EXPECT_NE(d.out.find("is the input video itself"), std::string::npos) << out << ": " << d.out;
    const topo_test::ToolRun p = topo_test::runTopo("track --video " + dir + "/link.avi --plot " + out);
    EXPECT_EQ(p.code, 2) << out << ": " << p.out;
    EXPECT_NE(p.out.find("--plot " + out + " is the input video itself"), std::string::npos) << out << ": " << p.out;
  }
  EXPECT_EQ(contents(dir + "/pend.avi"), video) << "the input video was changed";
  // A frame of an image sequence (pattern or directory) is an input too.
  for (const std::string seq : {"/frame_%04d.png", ""}) {
    const topo_test::ToolRun r =
        topo_test::runTopo("track --video '" + dir + seq + "' --plot " + dir + "/frame_0002.png");
    EXPECT_EQ(r.code, 2) << seq << ": " << r.out;
    EXPECT_NE(r.out.find("is a frame of the input image sequence"), std::string::npos) << seq << ": " << r.out;
  }
  EXPECT_EQ(contents(dir + "/frame_0002.png"), frame) << "an input frame was changed";
  const topo_test::ToolRun both = topo_test::runTopo("track --video " + dir + "/pend.avi --plot " + dir +
                                                     "/out.png --debug-video " + dir + "/out.png");
  EXPECT_EQ(both.code, 2) << both.out;
  // Other names are written as before.
  const topo_test::ToolRun ok =
      topo_test::runTopo("track --video " + dir + "/pend.avi --plot " + dir + "/plot.png --debug-video " + dir +
                         "/overlay.avi");
  EXPECT_EQ(ok.code, 0) << ok.out;
  EXPECT_TRUE(std::filesystem::is_regular_file(dir + "/plot.png")) << ok.out;
  EXPECT_TRUE(std::filesystem::is_regular_file(dir + "/overlay.avi")) << ok.out;
}

// Issue 52 §1: a refusal's motion-features JSON printed `equilibrium_deg: 0.0` (the rest pose's
// default), where a refusal has every feature null (README, docs/cli.md). The same through the
// library document and `topo track --json`.
TEST(VisionFaults, ARefusalsEquilibriumIsNullNotZero) {
  const std::string dir = clipFolder("refusal");
  vision::TrackOptions o;
  o.tracker.hsv = {vision::HsvRange{cv::Scalar(100, 150, 50), cv::Scalar(130, 255, 255)}};  // blue: not in the clip
  const vision::TrackResult r = vision::trackVideo(dir + "/pend.avi", o);
  ASSERT_TRUE(r.refused) << r.message;
  const nlohmann::json doc = nlohmann::json::parse(io::motionFeaturesJson(vision::toMotionFeatures(r), false));
  EXPECT_TRUE(doc["features"]["equilibrium_deg"].is_null()) << doc.dump();
  const topo_test::ToolRun cli = topo_test::runTopo("track --json --video " + dir +
                                                        "/pend.avi --hsv-lower 100,150,50 --hsv-upper 130,255,255",
                                                    topo_test::Stderr::Discard);
  ASSERT_EQ(cli.code, 0) << cli.out;
  const nlohmann::json j = nlohmann::json::parse(cli.out);
  EXPECT_TRUE(j["tracker"]["refused"].get<bool>()) << cli.out;
  for (const auto& [name, value] : j["features"].items())
    if (name != "oscillation_found" && name != "profile_segments")
      EXPECT_TRUE(value.is_null()) << name << " of a refusal is " << value.dump();
}

// Issue 52 §2: a valid video with no frames was called "the first frame cannot be decoded (unsupported
// codec or damaged file)". It is called empty: the container holds no frames.
TEST(VisionFaults, AVideoWithoutFramesIsCalledEmptyNotDamaged) {
  const std::string dir = ::testing::TempDir() + "/topo_vision_faults_empty_" + std::to_string(::getpid());
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  int tried = 0;
  for (const std::string ext : {".avi", ".mp4"}) {
    const std::string path = dir + "/empty" + ext;
    {
      const int fourcc = ext == ".avi" ? cv::VideoWriter::fourcc('M', 'J', 'P', 'G')
                                       : cv::VideoWriter::fourcc('m', 'p', '4', 'v');
      cv::VideoWriter w(path, cv::CAP_FFMPEG, fourcc, 30.0, cv::Size(64, 48));  // released with no frame
      ASSERT_TRUE(w.isOpened()) << path;
    }
    const std::string e = errorOf([&] { vision::VideoSource(path, vision::VideoOptions()); });
    SCOPED_TRACE(ext + ": " + e);
    std::printf("[empty video] %s: %s\n", ext.c_str(), e.c_str());
    if (e.find("cannot be opened as a video") != std::string::npos) continue;  // no container written
    ++tried;
    EXPECT_NE(e.find("holds no frames"), std::string::npos);
    EXPECT_EQ(e.find("damaged"), std::string::npos);
  }
  EXPECT_GT(tried, 0) << "no empty video opened: the case was not exercised";
}
