// The rosbag reader behind `topo track --bag FILE --topic T` (vision/frame_source.h, format "rosbag"):
// sensor_msgs/Image (any encoding cv_bridge turns into bgr8) and sensor_msgs/CompressedImage (what
// cv::imdecode reads: jpeg, png), timed by the images' header stamps, or by the bag's receive times
// when a stamp is zero or the stamps do not increase (said in a note). Side data: std_msgs/Float64
// topics, timed by their receive times. Built as library topo_rosbag, which registers the reader
// when it is loaded; `topo` links it.
#include <cv_bridge/cv_bridge.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>
#include <std_msgs/Float64.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <set>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/number_text.h"
#include "topo_gaussian/common/statistics.h"
#include "topo_gaussian/vision/frame_source.h"

namespace topo_gaussian::ros_bag {
namespace {

const char* kImage = "sensor_msgs/Image";
const char* kCompressed = "sensor_msgs/CompressedImage";
const char* kFloat64 = "std_msgs/Float64";
constexpr int kNotesListed = 3;  // undecodable frames named one by one; the rest counted

/// Topic → message type of every connection in the bag, and the message count per topic.
struct BagTopics {
  std::map<std::string, std::string> type;
  std::map<std::string, std::size_t> count;

  explicit BagTopics(const rosbag::Bag& bag) {
    rosbag::View all(bag);
    for (const rosbag::ConnectionInfo* c : all.getConnections()) type[c->topic] = c->datatype;
    for (const auto& [topic, t] : type) count[topic] = rosbag::View(bag, rosbag::TopicQuery(topic)).size();
  }

  /// "/a (sensor_msgs/Image, 120 messages), /b (...)" for the topics of the given types; "none" else.
  std::string list(const std::set<std::string>& types) const {
    std::string out;
    for (const auto& [topic, t] : type)
      if (types.count(t))
        out += (out.empty() ? "" : ", ") + topic + " (" + t + ", " + std::to_string(count.at(topic)) + " messages)";
    return out.empty() ? "none" : out;
  }

  /// The bag's spelling of `topic` (a missing leading '/' is added); empty when absent.
  std::string find(const std::string& topic) const {
    if (type.count(topic)) return topic;
    if (!topic.empty() && topic[0] != '/' && type.count("/" + topic)) return "/" + topic;
    return "";
  }
};

class BagFrames : public vision::FrameSource {
 public:
  explicit BagFrames(const vision::RecordingRequest& rq) : rq_(rq) {
    const std::string& path = rq.path;
    if (!std::filesystem::is_regular_file(path))
      throw TopoError(path, "no such file", "give the path of a rosbag recorded with `rosbag record`");
    try {
      bag_.open(path, rosbag::bagmode::Read);
    } catch (const rosbag::BagException& e) {
      throw TopoError(path, std::string("is not a readable ROS 1 bag (") + e.what() + ")",
                      "give a .bag file written by `rosbag record`; an interrupted recording (.bag.active) needs "
                      "`rosbag reindex` first, and a ROS 2 bag (.db3, .mcap) a conversion, e.g. `rosbags-convert`");
    }
    const BagTopics topics(bag_);
    if (topics.type.empty())
      throw TopoError(path, "the bag holds no messages",
                      "record the camera's image topic, e.g. `rosbag record /camera/image_raw`");
    const std::string images = topics.list({kImage, kCompressed});
    topic_ = topics.find(rq.topic);
    if (topic_.empty())
      throw TopoError(path, "holds no topic " + rq.topic + "; its image topics: " + images,
                      images == "none" ? "record the camera's image topic (sensor_msgs/Image or CompressedImage)"
                                       : "give one of its image topics with --topic");
    const std::string type = topics.type.at(topic_);
    if (type != kImage && type != kCompressed)
      throw TopoError(path,
                      "topic " + topic_ + " carries " + type +
                          ", not images (sensor_msgs/Image or sensor_msgs/CompressedImage); its image topics: " + images,
                      "give an image topic with --topic");
    compressed_ = type == kCompressed;
    name_ = path + " topic " + topic_;
    timeFrames();
    readTags(topics);
    view_ = std::make_unique<rosbag::View>(bag_, rosbag::TopicQuery(topic_));
    it_ = view_->begin();
  }

  bool read(cv::Mat& bgr, double& t_s) override {
    const int stride = std::max(1, rq_.video.stride);
    for (; it_ != view_->end(); ++it_) {
      const int i = next_++;
      const double t = t_[i];
      if (t < rq_.video.start_s) continue;
      if (rq_.video.end_s >= 0 && t > rq_.video.end_s) {
        it_ = view_->end();
        break;
      }
      if (in_range_++ % stride != 0) continue;
      std::string why;
      cv::Mat frame = decode(*it_, why);
      if (frame.empty()) {
        if (++skipped_ <= kNotesListed)
          skipped_names_ += std::string(skipped_ > 1 ? ", " : "") + "frame " + std::to_string(i) + " at " +
                            fixedText(t, 3) + " s (" + why + ")";
        continue;
      }
      ++it_;
      bgr = frame;
      t_s = t;
      indices_.push_back(i);
      return true;
    }
    if (indices_.empty() && skipped_ > 0)
      throw TopoError(name_,
                      "none of its frames in the range decodes (" + std::to_string(skipped_) +
                          " tried: " + skipped_names_ + ")",
                      "check the recording, e.g. `rostopic echo -b " + rq_.path + " -n 1 " + topic_ +
                          "/format`; record the raw topic if the compressed one is broken");
    return false;
  }

  std::string name() const override { return name_; }
  std::vector<std::string> inputFiles() const override { return {rq_.path}; }
  double fps() const override { return fps_; }
  int frameCount() const override { return static_cast<int>(t_.size()); }
  cv::Size frameSize() const override { return size_; }
  const std::vector<int>& indices() const override { return indices_; }
  std::vector<std::string> notes() const override {
    std::vector<std::string> n = notes_;
    if (skipped_ > 0)
      n.push_back(std::to_string(skipped_) + " frame(s) of " + topic_ + " do not decode and were skipped (" +
                  skipped_names_ + (skipped_ > kNotesListed ? ", ..." : "") + "): they count as dropped");
    return n;
  }
  std::unique_ptr<vision::FrameSource> reopen() const override { return std::make_unique<BagFrames>(rq_); }
  const std::map<std::string, std::vector<vision::TagSample>>& tags() const override { return tags_; }

 private:
  /// The frame of one message, BGR; empty (with `why`) when it does not decode.
  cv::Mat decode(const rosbag::MessageInstance& m, std::string& why) const {
    if (compressed_) {
      const auto msg = m.instantiate<sensor_msgs::CompressedImage>();
      cv::Mat img;
      try {
        if (msg && !msg->data.empty()) img = cv::imdecode(msg->data, cv::IMREAD_COLOR);
      } catch (const cv::Exception&) {
        img.release();
      }
      if (img.empty()) why = "format '" + (msg ? msg->format : "?") + "', " +
                             std::to_string(msg ? msg->data.size() : 0) + " bytes, not an image OpenCV decodes";
      return img;
    }
    const auto msg = m.instantiate<sensor_msgs::Image>();
    if (!msg || msg->height == 0 || msg->width == 0 ||
        msg->data.size() < static_cast<std::size_t>(msg->step) * msg->height) {
      why = msg ? "its data holds " + std::to_string(msg->data.size()) + " bytes, fewer than step x height = " +
                      std::to_string(static_cast<std::size_t>(msg->step) * msg->height)
                : "not a sensor_msgs/Image";
      return cv::Mat();
    }
    try {
      return cv_bridge::toCvCopy(*msg, "bgr8")->image;
    } catch (const std::exception& e) {
      throw TopoError(name_, "its images have encoding '" + msg->encoding + "', which cv_bridge cannot turn into colour (" +
                                 e.what() + ")",
                      "give the camera's colour or grey image topic (e.g. image_raw, image_rect_color), not a depth "
                      "or label image");
    }
  }

  /// Every frame's time [s from the first frame], the frame rate and the frame size (first pass).
  void timeFrames() {
    rosbag::View view(bag_, rosbag::TopicQuery(topic_));
    std::vector<double> stamp, received;
    bool zero_stamp = false;
    for (const rosbag::MessageInstance& m : view) {
      received.push_back(m.getTime().toSec());
      ros::Time s;
      if (compressed_) {
        const auto msg = m.instantiate<sensor_msgs::CompressedImage>();
        if (msg) s = msg->header.stamp;
        if (size_.empty() && msg) {
          std::string why;
          const cv::Mat first = decode(m, why);
          if (!first.empty()) size_ = first.size();
        }
      } else {
        const auto msg = m.instantiate<sensor_msgs::Image>();
        if (msg) {
          s = msg->header.stamp;
          if (size_.empty()) {
            size_ = cv::Size(static_cast<int>(msg->width), static_cast<int>(msg->height));
            std::string why;
            decode(m, why);  // an encoding cv_bridge cannot convert is refused now, before any tracking
          }
        }
      }
      zero_stamp = zero_stamp || s.isZero();
      stamp.push_back(s.toSec());
    }
    if (stamp.empty())
      throw TopoError(name_, "the topic holds no messages", "give a topic the bag recorded images on");
    int not_increasing = -1;
    for (std::size_t i = 1; i < stamp.size() && not_increasing < 0; ++i)
      if (!(stamp[i] > stamp[i - 1])) not_increasing = static_cast<int>(i);
    const std::vector<double>* use = &stamp;
    if (zero_stamp) {
      use = &received;
      notes_.push_back("the images' header stamps are zero: the frames are timed by the bag's receive times");
    } else if (not_increasing >= 0) {
      use = &received;
      notes_.push_back("the images' header stamps do not increase (frame " + std::to_string(not_increasing) + " at " +
                       fixedText(stamp[not_increasing] - stamp[0], 3) + " s after its predecessor at " +
                       fixedText(stamp[not_increasing - 1] - stamp[0], 3) +
                       " s): the frames are timed by the bag's receive times");
    }
    for (std::size_t i = 1; i < use->size(); ++i)
      if (!((*use)[i] > (*use)[i - 1]))
        throw TopoError(name_,
                        "frames " + std::to_string(i - 1) + " and " + std::to_string(i) +
                            " have the same time (header stamps and receive times), so the motion cannot be timed",
                        "record with the camera driver's stamps (header.stamp set per image)");
    t0_abs_ = use->front();
    for (double v : *use) t_.push_back(v - t0_abs_);
    std::vector<double> steps;
    for (std::size_t i = 1; i < t_.size(); ++i) steps.push_back(t_[i] - t_[i - 1]);
    fps_ = steps.empty() ? 30.0 : 1.0 / median(steps);
    if (size_.empty())
      throw TopoError(name_, "none of its " + std::to_string(stamp.size()) + " images decodes",
                      "check the recording, e.g. `rostopic echo -b " + rq_.path + " -n 1 " + topic_ + "/format`");
  }

  /// The side data: every std_msgs/Float64 sample of each tag topic, on the frames' clock.
  void readTags(const BagTopics& topics) {
    for (const std::string& wanted : rq_.tag_topics) {
      const std::string numbers = topics.list({kFloat64});
      const std::string topic = topics.find(wanted);
      if (topic.empty())
        throw TopoError(rq_.path, "holds no topic " + wanted + " for --tag-topic; its std_msgs/Float64 topics: " + numbers,
                        "give one of them, or record the side data beside the images");
      if (topics.type.at(topic) != kFloat64)
        throw TopoError(rq_.path,
                        "the tag topic " + topic + " carries " + topics.type.at(topic) +
                            ", not std_msgs/Float64; its std_msgs/Float64 topics: " + numbers,
                        "give a std_msgs/Float64 topic with --tag-topic");
      std::vector<vision::TagSample>& out = tags_[topic];
      for (const rosbag::MessageInstance& m : rosbag::View(bag_, rosbag::TopicQuery(topic))) {
        const auto msg = m.instantiate<std_msgs::Float64>();
        if (msg && std::isfinite(msg->data)) out.push_back({m.getTime().toSec() - t0_abs_, msg->data});
      }
    }
  }

  vision::RecordingRequest rq_;
  rosbag::Bag bag_;
  std::string topic_, name_;
  bool compressed_ = false;
  std::vector<double> t_;
  double t0_abs_ = 0.0, fps_ = 30.0;
  cv::Size size_;
  std::vector<std::string> notes_;
  std::map<std::string, std::vector<vision::TagSample>> tags_;
  std::unique_ptr<rosbag::View> view_;
  rosbag::View::iterator it_;
  int next_ = 0, in_range_ = 0, skipped_ = 0;
  std::string skipped_names_;
  std::vector<int> indices_;
};

[[maybe_unused]] const bool kRegistered = vision::registerRecordingOpener("rosbag", [](const vision::RecordingRequest& rq) {
  return std::unique_ptr<vision::FrameSource>(std::make_unique<BagFrames>(rq));
});

}  // namespace
}  // namespace topo_gaussian::ros_bag
