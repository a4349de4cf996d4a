// `topo track --bag FILE --topic T` on rosbags written here (rosbag::Bag) from a synthetic pendulum:
// raw sensor_msgs/Image and CompressedImage (PNG, JPEG) give the period the same frames give as an
// image sequence; zero header stamps fall back to the bag's receive times; a tag topic's value in
// force reaches the features JSON; a wrong topic, a topic of another type, an empty bag and a frame
// that does not decode are named.
#include <cv_bridge/cv_bridge.h>
#include <gtest/gtest.h>
#include <rosbag/bag.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>
#include <std_msgs/Float64.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "test_util.h"
#include "topo_gaussian/io/motion_features_json.h"
#include "topo_gaussian/vision/synthetic_video.h"

using namespace topo_gaussian;

namespace {

enum class Encoding { Raw, Png, Jpeg };

vision::PendulumScene smallPendulum() {
  vision::PendulumScene s;
  s.width = 320;
  s.height = 240;
  s.fps = 30.0;
  s.duration_s = 4.0;
  s.period_s = 1.0;
  s.amplitude_deg = 15.0;
  s.pivot = cv::Point2d(160, 30);
  s.length_px = 150.0;
  s.bob_radius_px = 14.0;
  s.rod_width_px = 4.0;
  return s;
}

const std::vector<cv::Mat>& frames() {
  static const std::vector<cv::Mat> f = vision::renderPendulum(smallPendulum());
  return f;
}

struct BagSpec {
  Encoding encoding = Encoding::Raw;
  bool zero_stamps = false;
  std::vector<int> broken;  ///< frames whose compressed bytes are not an image
  bool pressure = false;    ///< /pressure_pa: 1e5 Pa for the first second, 3e5 Pa after (10 Hz)
};

const double kStart = 1700000000.25;  // the recording's wall-clock start [s]

std::string writeBag(const std::string& name, const BagSpec& spec) {
  const std::string path = testing::TempDir() + "/" + name;
  rosbag::Bag bag(path, rosbag::bagmode::Write);
  const double fps = smallPendulum().fps;
  for (std::size_t i = 0; i < frames().size(); ++i) {
    const ros::Time stamp(kStart + i / fps);
    const ros::Time received(kStart + i / fps + 0.004);  // the driver's latency
    std_msgs::Header header;
    header.seq = static_cast<unsigned>(i);
    header.frame_id = "camera_optical";
    if (!spec.zero_stamps) header.stamp = stamp;
    if (spec.encoding == Encoding::Raw) {
      bag.write("/camera/image_raw", received, *cv_bridge::CvImage(header, "bgr8", frames()[i]).toImageMsg());
    } else {
      sensor_msgs::CompressedImage msg;
      msg.header = header;
      msg.format = spec.encoding == Encoding::Png ? "png" : "jpeg";
      cv::imencode(spec.encoding == Encoding::Png ? ".png" : ".jpg", frames()[i], msg.data);
      if (std::find(spec.broken.begin(), spec.broken.end(), static_cast<int>(i)) != spec.broken.end())
        msg.data.assign(msg.data.size() / 3, 0x5a);  // truncated to garbage
      bag.write("/camera/image_raw/compressed", received, msg);
    }
  }
  if (spec.pressure)
    for (int k = 0; k < 40; ++k) {
      std_msgs::Float64 p;
      p.data = k < 10 ? 1e5 : 3e5;
      bag.write("/pressure_pa", ros::Time(kStart + 0.1 * k + 0.05), p);
    }
  bag.close();
  return path;
}

std::string topicOf(const BagSpec& spec) {
  return spec.encoding == Encoding::Raw ? "/camera/image_raw" : "/camera/image_raw/compressed";
}

/// `topo track ARGS --json`, parsed; the exit code must be 0.
nlohmann::json trackJson(const std::string& args) {
  const topo_test::ToolRun r = topo_test::runTopo("track " + args + " --json", topo_test::Stderr::Discard);
  EXPECT_EQ(r.code, 0) << args << "\n" << r.out;
  return r.code == 0 ? nlohmann::json::parse(r.out) : nlohmann::json::object();
}

/// The same frames as an image sequence, tracked: the reference the bags must reproduce.
const nlohmann::json& sequenceResult() {
  static const nlohmann::json doc = [] {
    const std::string dir = testing::TempDir() + "/bag_track_sequence";
    std::filesystem::create_directories(dir);
    for (std::size_t i = 0; i < frames().size(); ++i) {
      char name[64];
      std::snprintf(name, sizeof(name), "/frame_%04zu.png", i);
      cv::imwrite(dir + name, frames()[i]);
    }
    return trackJson("--video " + dir + "/frame_%04d.png --fps 30");
  }();
  return doc;
}

double period(const nlohmann::json& doc) { return doc.at("features").at("period_s").get<double>(); }

/// Tracks the frames written to a bag as `e` and compares with the image sequence.
void expectTheSequencesPeriod(Encoding e) {
  const double reference = period(sequenceResult());
  EXPECT_NEAR(reference, smallPendulum().period_s, 0.005 * smallPendulum().period_s);
  BagSpec spec;
  spec.encoding = e;
  const std::string name = e == Encoding::Raw ? "raw" : e == Encoding::Png ? "png" : "jpeg";
  const nlohmann::json doc = trackJson("--bag " + writeBag(name + ".bag", spec) + " --topic " + topicOf(spec));
  ASSERT_TRUE(doc.contains("features")) << name;
  EXPECT_EQ(doc["range"]["frames_used"], sequenceResult()["range"]["frames_used"]) << name;
  // raw and PNG: the same pixels, stamped to the nanosecond; JPEG: the same motion through lossy pixels
  const double tolerance = e == Encoding::Jpeg ? 0.005 : 1e-6;
  EXPECT_NEAR(period(doc), reference, tolerance * reference) << name;
  EXPECT_NEAR(doc["tracker"]["fps"].get<double>(), smallPendulum().fps, 1e-3) << name;
  EXPECT_NE(doc["source"].get<std::string>().find(topicOf(spec)), std::string::npos) << doc["source"];
}

}  // namespace

TEST(BagTrack, RawImagesGiveTheImageSequencesPeriod) { expectTheSequencesPeriod(Encoding::Raw); }

TEST(BagTrack, CompressedImagesGiveTheImageSequencesPeriod) {
  expectTheSequencesPeriod(Encoding::Png);
  expectTheSequencesPeriod(Encoding::Jpeg);
}

TEST(BagTrack, ZeroHeaderStampsAreTimedByTheBagAndSaidSo) {
  BagSpec spec;
  spec.encoding = Encoding::Png;
  spec.zero_stamps = true;
  const nlohmann::json doc = trackJson("--bag " + writeBag("zero_stamps.bag", spec) + " --topic " + topicOf(spec));
  ASSERT_TRUE(doc.contains("features"));
  EXPECT_NEAR(period(doc), period(sequenceResult()), 1e-6 * period(sequenceResult()));
  EXPECT_NE(doc["message"].get<std::string>().find("header stamps are zero"), std::string::npos) << doc["message"];
}

TEST(BagTrack, TheTagTopicsValueInForceReachesTheFeatures) {
  BagSpec spec;
  spec.encoding = Encoding::Png;
  spec.pressure = true;
  const std::string bag = writeBag("pressure.bag", spec);
  // the whole clip: 10 samples at 1e5 Pa, 30 at 3e5 Pa → the median, not the mean (2.5e5)
  const std::string out = testing::TempDir() + "/pressure_features.json";
  const topo_test::ToolRun whole = topo_test::runTopo(
      "track --bag " + bag + " --topic " + topicOf(spec) + " --tag-topic /pressure_pa --json > " + out,
      topo_test::Stderr::Discard);
  ASSERT_EQ(whole.code, 0) << whole.out;
  const motion::MotionFeatures f = io::readMotionFeaturesJson(out);
  ASSERT_EQ(f.side_data.count("pressure_pa"), 1u);
  EXPECT_EQ(f.side_data.at("pressure_pa"), 3e5);
  EXPECT_NEAR(f.period_s, period(sequenceResult()), 1e-6 * period(sequenceResult()));
  EXPECT_NE(f.message.find("the tag topic /pressure_pa changes within the window (100000 to 300000 at 1.050 s)"),
            std::string::npos)
      << f.message;
  // a window in the first second sees the first pressure only
  const nlohmann::json early = trackJson("--bag " + bag + " --topic " + topicOf(spec) +
                                         " --tag-topic pressure_pa --end 0.9 --kind pendulum");
  ASSERT_TRUE(early.contains("side_data")) << early.dump();
  EXPECT_EQ(early["side_data"]["pressure_pa"].get<double>(), 1e5);
  EXPECT_EQ(early["message"].get<std::string>().find("changes within the window"), std::string::npos)
      << early["message"];
  // a tag topic that is not in the bag: the bag's number topics are listed
  const topo_test::ToolRun missing =
      topo_test::runTopo("track --bag " + bag + " --topic " + topicOf(spec) + " --tag-topic /pressure");
  EXPECT_EQ(missing.code, 1) << missing.out;
  EXPECT_NE(missing.out.find("no topic /pressure for --tag-topic"), std::string::npos) << missing.out;
  EXPECT_NE(missing.out.find("/pressure_pa (std_msgs/Float64, 40 messages)"), std::string::npos) << missing.out;
}

TEST(BagTrack, AWrongTopicAndATopicOfAnotherTypeAreNamed) {
  BagSpec spec;
  spec.pressure = true;
  const std::string bag = writeBag("topics.bag", spec);
  const topo_test::ToolRun missing = topo_test::runTopo("track --bag " + bag + " --topic /camera/image");
  EXPECT_EQ(missing.code, 1) << missing.out;
  EXPECT_NE(missing.out.find("holds no topic /camera/image"), std::string::npos) << missing.out;
  EXPECT_NE(missing.out.find("/camera/image_raw (sensor_msgs/Image, 120 messages)"), std::string::npos)
      << missing.out;
  const topo_test::ToolRun numbers = topo_test::runTopo("track --bag " + bag + " --topic /pressure_pa");
  EXPECT_EQ(numbers.code, 1) << numbers.out;
  EXPECT_NE(numbers.out.find("carries std_msgs/Float64, not images"), std::string::npos) << numbers.out;
  const topo_test::ToolRun no_topic = topo_test::runTopo("track --bag " + bag);
  EXPECT_EQ(no_topic.code, 2) << no_topic.out;
  EXPECT_NE(no_topic.out.find("--bag needs --topic"), std::string::npos) << no_topic.out;
}

TEST(BagTrack, AnEmptyBagAndAFileThatIsNoBagAreNamed) {
  const std::string empty = testing::TempDir() + "/empty.bag";
  rosbag::Bag(empty, rosbag::bagmode::Write).close();
  const topo_test::ToolRun none = topo_test::runTopo("track --bag " + empty + " --topic /camera/image_raw");
  EXPECT_EQ(none.code, 1) << none.out;
  EXPECT_NE(none.out.find("the bag holds no messages"), std::string::npos) << none.out;

  const std::string text = testing::TempDir() + "/not_a.bag";
  std::ofstream(text) << "not a bag\n";
  const topo_test::ToolRun garbage = topo_test::runTopo("track --bag " + text + " --topic /camera/image_raw");
  EXPECT_EQ(garbage.code, 1) << garbage.out;
  EXPECT_NE(garbage.out.find("is not a readable ROS 1 bag"), std::string::npos) << garbage.out;
  // side data is a rosbag's: with a video it is a usage error
  const topo_test::ToolRun video = topo_test::runTopo("track --video x.avi --tag-topic /pressure_pa");
  EXPECT_EQ(video.code, 2) << video.out;
  EXPECT_NE(video.out.find("--tag-topic reads side data from a rosbag"), std::string::npos) << video.out;
}

TEST(BagTrack, ACompressedFrameThatDoesNotDecodeIsSkippedAndNamed) {
  BagSpec spec;
  spec.encoding = Encoding::Jpeg;
  spec.broken = {10};
  const nlohmann::json doc = trackJson("--bag " + writeBag("broken.bag", spec) + " --topic " + topicOf(spec));
  ASSERT_TRUE(doc.contains("features"));
  const std::string message = doc["message"];
  EXPECT_NE(message.find("1 frame(s) of /camera/image_raw/compressed do not decode and were skipped (frame 10 at "
                         "0.333 s"),
            std::string::npos)
      << message;
  EXPECT_EQ(doc["range"]["frames_used"].get<int>(), static_cast<int>(frames().size()) - 1);
  EXPECT_EQ(doc["tracker"]["dropped_frames"].get<int>(), 1);
  EXPECT_NEAR(period(doc), period(sequenceResult()), 0.005 * period(sequenceResult()));

  BagSpec all = spec;
  all.broken.clear();
  for (int i = 0; i < static_cast<int>(frames().size()); ++i) all.broken.push_back(i);
  const topo_test::ToolRun none =
      topo_test::runTopo("track --bag " + writeBag("all_broken.bag", all) + " --topic " + topicOf(all));
  EXPECT_EQ(none.code, 1) << none.out;
  EXPECT_NE(none.out.find("images decodes"), std::string::npos) << none.out;
}
