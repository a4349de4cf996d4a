// Frames from a video file (mp4/avi/gif, OpenCV FFMPEG backend) or an image sequence (a pattern with
// one %d or %0Nd such as frames/frame_%04d.png, or a directory of images sorted by name; any other '%'
// is part of a plain file name, never a printf format), restricted to a
// time range and a frame stride. Every returned frame carries its timestamp: the container's
// CAP_PROP_POS_MSEC when it is valid (increasing), else index / fps — so dropped frames appear as
// gaps in the timestamps.
#pragma once

#include <opencv2/core.hpp>
#include <opencv2/videoio.hpp>

#include <algorithm>
#include <string>
#include <vector>

namespace topo_gaussian::vision {

/// The spacing of a clip's frame times (FrameSteps analyseFrameSteps).
struct FrameSteps {
  /// the frames' step [s]: 1 / the announced rate, unless the median step contradicts it by more than
  /// a factor 1.5 (a container announcing its time base, e.g. 1000 fps), then the median step
  double step_s = 0.0;
  double min_step_s = 0.0, median_step_s = 0.0, max_step_s = 0.0;
  /// a variable frame rate: more than 10 % of the steps are not within 15 % of a whole multiple of
  /// the median step (a phone slowing down in dim light, a screen recorder); no frame counts as dropped
  bool variable = false;
  int dropped_frames = 0;  ///< constant rate: frames missing in steps > 1.5 step_s (round(step / step_s) − 1 each)
  int gaps = 0;            ///< the steps holding dropped frames
};

/// The spacing of the frame times `t` [s] (increasing); `announced_fps` the rate the container or the
/// user announces per returned frame (0: none, the median step is used).
FrameSteps analyseFrameSteps(const std::vector<double>& t, double announced_fps);

struct VideoOptions {
  double start_s = 0.0;        ///< first time used
  double end_s = -1.0;         ///< last time used (< 0: to the end)
  int stride = 1;              ///< use every stride-th frame in the range
  double sequence_fps = 30.0;  ///< frame rate of an image sequence (files carry none)
};

class VideoSource {
 public:
  /// Throws TopoError naming the path for a missing/unreadable file, an unsupported codec (the
  /// first frame cannot be decoded), an empty image sequence or bad options.
  explicit VideoSource(const std::string& path, const VideoOptions& options = VideoOptions());

  /// Next frame in [start, end] honouring the stride; false at the end. `t_s` is its timestamp.
  bool read(cv::Mat& bgr, double& t_s);

  const std::string& path() const { return path_; }
  bool isSequence() const { return sequence_; }
  /// The files frames are read from: the video file, or every image of the sequence.
  std::vector<std::string> inputFiles() const { return sequence_ ? files_ : std::vector<std::string>{path_}; }
  double fps() const { return fps_; }
  /// Frames in the whole file as reported by the container (sequence: number of images); may be
  /// an estimate for some containers.
  int frameCount() const { return frame_count_; }
  cv::Size frameSize() const { return size_; }
  /// Rotation stored in the container's metadata (degrees; a phone's portrait video), already applied
  /// to the frames (OpenCV's CAP_PROP_ORIENTATION_AUTO); 0 for image sequences.
  int orientationDeg() const { return orientation_deg_; }
  /// The frame rate the timestamps of the frames returned so far show (1 / median step, per source
  /// frame); fps() when fewer than 3 were returned. A container may announce a wrong rate (a file
  /// that says 31.47 fps whose frames are 40 ms apart).
  double timestampFps() const;
  /// Frames decoded so far (including skipped ones) and the index of the last returned frame.
  int framesDecoded() const { return decoded_; }
  /// True once decoding stopped (end of data, or a frame that does not decode) clearly before the
  /// frame count the container announces AND before 90 % of the duration it announces (frame count /
  /// fps): the file is truncated or damaged after framesDecoded() frames. False for a file read to its
  /// announced end, for one whose end was never reached, and for a complete file with fewer frames
  /// than announced whose timestamps reach its end (a variable frame rate: Matroska announces duration
  /// x nominal rate; or a wrong announced rate).
  bool endedEarly() const {
    return stopped_ && !sequence_ && frame_count_ > 0 && decoded_ + std::max(2, frame_count_ / 50) < frame_count_ &&
           !(last_decoded_t_ >= 0.9 * frame_count_ / fps_);
  }
  int lastIndex() const { return last_index_; }
  /// Timestamps of every frame returned so far.
  const std::vector<double>& timestamps() const { return times_; }
  const std::vector<int>& indices() const { return indices_; }

 private:
  bool decodeNext(cv::Mat& bgr, double& t_s, int& index);

  std::string path_;
  VideoOptions opt_;
  bool sequence_ = false;
  std::vector<std::string> files_;
  cv::VideoCapture cap_;
  std::vector<std::pair<cv::Mat, double>> pending_;  // the first frames, decoded while opening
  int handed_ = 0;                                   // pending frames handed out so far
  bool first_stamp_bogus_ = false;
  bool opening_ = true;  // the constructor decodes; read() hands out pending_ first
  double fps_ = 30.0;
  int orientation_deg_ = 0;
  int frame_count_ = 0;
  cv::Size size_;
  int decoded_ = 0;
  int next_index_ = 0;
  int last_index_ = -1;
  int used_in_range_ = 0;
  double last_msec_ = -1.0;
  int last_msec_index_ = -1;
  bool msec_ok_ = true;
  bool stopped_ = false;  ///< the decoder gave no more frames
  double last_decoded_t_ = -1.0;  ///< timestamp of the last frame decoded [s]
  std::vector<double> times_;
  std::vector<int> indices_;
};

}  // namespace topo_gaussian::vision
