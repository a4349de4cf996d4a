// Frames from a recording that is not a video file (a rosbag's image topic), read by a reader another
// library registers: the ROS-free vision library tracks them without knowing the format. The rosbag
// reader lives in the ROS module (src/ros/bag_frames.cpp, library topo_rosbag, which `topo` links)
// and registers itself as format "rosbag" when its library is loaded.
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "topo_gaussian/vision/motion_tracker.h"
#include "topo_gaussian/vision/video_source.h"

namespace topo_gaussian::vision {

/// What to read from a recording.
struct RecordingRequest {
  std::string path;                     ///< the recording (a .bag file)
  std::string topic;                    ///< the image topic
  std::vector<std::string> tag_topics;  ///< side data (numbers) read beside the frames, e.g. /pressure_pa
  VideoOptions video;                   ///< time range and stride (sequence_fps is not used: frames are stamped)
};

/// One number of side data at time t_s (the frames' clock: seconds from the recording's first frame).
struct TagSample {
  double t_s, value;
};

class FrameSource {
 public:
  virtual ~FrameSource() = default;
  /// The next frame in the requested range (stride honoured), BGR, with its time in seconds from
  /// the first frame of the topic; false at the end.
  virtual bool read(cv::Mat& bgr, double& t_s) = 0;
  /// Names the input in messages ("run.bag topic /camera/image_raw").
  virtual std::string name() const = 0;
  /// The files the frames come from (an output must not overwrite one).
  virtual std::vector<std::string> inputFiles() const = 0;
  /// Frame rate the timestamps show (1 / median step over the whole topic).
  virtual double fps() const = 0;
  /// Frames on the topic.
  virtual int frameCount() const = 0;
  virtual cv::Size frameSize() const = 0;
  /// Source indices (0-based, on the topic) of the frames returned so far.
  virtual const std::vector<int>& indices() const = 0;
  /// Remarks for the result's message: where the times came from, frames skipped and why.
  virtual std::vector<std::string> notes() const = 0;
  /// The same recording from its start (the debug video's second pass).
  virtual std::unique_ptr<FrameSource> reopen() const = 0;
  /// The samples of each requested tag topic, in time order.
  virtual const std::map<std::string, std::vector<TagSample>>& tags() const = 0;
};

using RecordingOpener = std::function<std::unique_ptr<FrameSource>(const RecordingRequest&)>;

/// Makes `format` ("rosbag") readable through openRecording; returns true (for a static initialiser).
bool registerRecordingOpener(const std::string& format, RecordingOpener opener);
/// Opens a recording; throws TopoError naming the path when no reader of `format` is linked in, or
/// what the reader throws (missing file, no such topic, ...).
std::unique_ptr<FrameSource> openRecording(const std::string& format, const RecordingRequest& request);

/// trackVideo for a FrameSource: every frame to MotionTracker, the source's notes in the message, the
/// debug video from a second pass (reopen). Throws TopoError naming the source when no frame is in range.
TrackResult trackFrames(FrameSource& source, const TrackOptions& options,
                        const std::function<void(const cv::Mat&)>& overlay_sink = nullptr);

/// The value of a tag in force over the window [t0, t1]: the median of its samples inside it, else
/// the last sample before t0 (samples == 0 then); NaN (found false) when there is none at or before t1.
struct TagValue {
  bool found = false;
  double value = 0.0;
  int samples = 0;  ///< samples inside the window
  /// the samples inside the window do not all hold one value (a pressure step inside it): the first
  /// change, at change_t_s from `before` to `after`
  bool changes = false;
  double change_t_s = 0.0, before = 0.0, after = 0.0;
};
TagValue tagInWindow(const std::vector<TagSample>& samples, double t0, double t1);

}  // namespace topo_gaussian::vision
