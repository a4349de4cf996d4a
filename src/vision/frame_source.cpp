#include "topo_gaussian/vision/frame_source.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <mutex>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/number_text.h"
#include "topo_gaussian/common/statistics.h"

namespace topo_gaussian::vision {
namespace {

std::map<std::string, RecordingOpener>& openers() {
  static std::map<std::string, RecordingOpener> o;
  return o;
}

std::mutex& openersMutex() {
  static std::mutex m;
  return m;
}

}  // namespace

bool registerRecordingOpener(const std::string& format, RecordingOpener opener) {
  std::lock_guard<std::mutex> lock(openersMutex());
  openers()[format] = std::move(opener);
  return true;
}

std::unique_ptr<FrameSource> openRecording(const std::string& format, const RecordingRequest& request) {
  RecordingOpener opener;
  {
    std::lock_guard<std::mutex> lock(openersMutex());
    const auto it = openers().find(format);
    if (it != openers().end()) opener = it->second;
  }
  if (!opener)
    throw TopoError(request.path, "no reader for the format '" + format + "' is linked into this program",
                    "use the `topo` of the catkin package (it links the rosbag reader, library topo_rosbag), or "
                    "export the frames first, e.g. as images with `rosrun image_view extract_images`");
  return opener(request);
}

TrackResult trackFrames(FrameSource& src, const TrackOptions& options,
                        const std::function<void(const cv::Mat&)>& overlay_sink) {
  TrackOptions o = options;
  if (!(o.fps > 0)) o.fps = src.fps();
  MotionTracker mt(o);
  cv::Mat frame;
  double t = 0;
  while (src.read(frame, t)) mt.addFrame(frame, t);
  if (mt.framesAdded() == 0)
    throw TopoError(src.name(),
                    "no frames in the requested time range (" + fixedText(options.video.start_s, 2) + " s to " +
                        (options.video.end_s < 0 ? std::string("end") : fixedText(options.video.end_s, 2) + " s") +
                        " from the first frame; the topic holds " + std::to_string(src.frameCount()) + " frames)",
                    "check --start/--end against the recording's length");
  TrackResult r = mt.finish();
  for (const std::string& note : src.notes()) r.message += "; " + note;
  if (overlay_sink) {
    // the debug video: a second pass, every frame drawn with the final result (the JSON's pivot and values)
    auto again = src.reopen();
    int index = 0;
    while (again->read(frame, t) && index < mt.framesAdded()) overlay_sink(mt.overlayWithResult(frame, index++, r));
  }
  r.source = src.name();
  if (!r.variable_frame_rate) r.fps = src.fps();
  r.frames_total = src.frameCount();
  r.first_frame = src.indices().front();
  r.last_frame = src.indices().back();
  return r;
}

TagValue tagInWindow(const std::vector<TagSample>& samples, double t0, double t1) {
  TagValue v;
  std::vector<double> inside;
  const TagSample* before = nullptr;
  for (const TagSample& s : samples) {
    if (s.t_s < t0) before = &s;
    if (s.t_s < t0 || s.t_s > t1) continue;
    if (!inside.empty() && s.value != inside.back() && !v.changes) {
      v.changes = true;
      v.change_t_s = s.t_s;
      v.before = inside.back();
      v.after = s.value;
    }
    inside.push_back(s.value);
  }
  if (!inside.empty()) {
    v.found = true;
    v.value = median(inside);
    v.samples = static_cast<int>(inside.size());
  } else if (before) {
    v.found = true;
    v.value = before->value;
  } else {
    v.value = std::numeric_limits<double>::quiet_NaN();
  }
  return v;
}

}  // namespace topo_gaussian::vision
