// VideoSource: video files through cv::VideoCapture (FFMPEG backend) and image sequences.
#include "topo_gaussian/vision/video_source.h"

#include <dirent.h>
#include <sys/stat.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>

#include "topo_gaussian/common/error.h"

namespace topo_gaussian::vision {
namespace {

bool isDirectory(const std::string& p) {
  struct stat st {};
  return ::stat(p.c_str(), &st) == 0 && S_ISDIR(st.st_mode);
}

bool isReadableFile(const std::string& p) {
  struct stat st {};
  if (::stat(p.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) return false;
  FILE* f = std::fopen(p.c_str(), "rb");
  if (!f) return false;
  std::fclose(f);
  return true;
}

std::string lower(std::string s) {
  for (auto& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

bool hasImageExtension(const std::string& name) {
  const std::string n = lower(name);
  for (const char* ext : {".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".ppm", ".pgm", ".webp"}) {
    const std::string e(ext);
    if (n.size() > e.size() && n.compare(n.size() - e.size(), e.size(), e) == 0) return true;
  }
  return false;
}

/// An image-sequence pattern: exactly one '%' in the path, starting a `%d` or `%0Nd` conversion (N one
/// or two digits). Its text before and after the number, and the zero-padded width (0: none).
struct SequencePattern {
  bool valid = false;
  std::string before, after;
  int width = 0;
};

SequencePattern sequencePattern(const std::string& path) {
  SequencePattern p;
  const std::size_t at = path.find('%');
  if (at == std::string::npos || path.find('%', at + 1) != std::string::npos) return p;
  std::size_t k = at + 1;
  if (k < path.size() && path[k] == '0') {
    const std::size_t digits = k + 1;
    k = digits;
    while (k < path.size() && std::isdigit(static_cast<unsigned char>(path[k]))) ++k;
    if (k == digits || k - digits > 2) return p;  // "%0d" or a width of three digits or more
    p.width = std::stoi(path.substr(digits, k - digits));
  }
  if (k >= path.size() || path[k] != 'd') return p;
  p.before = path.substr(0, at);
  p.after = path.substr(k + 1);
  p.valid = true;
  return p;
}

/// The pattern's file name for frame number i (what snprintf would make of it, without the format).
std::string sequenceFile(const SequencePattern& p, int i) {
  std::string n = std::to_string(i);
  if (static_cast<int>(n.size()) < p.width) n.insert(0, p.width - n.size(), '0');
  return p.before + n + p.after;
}

cv::Mat toBgr(const cv::Mat& m) {
  if (m.channels() == 3) return m;
  cv::Mat out;
  if (m.channels() == 1)
    cv::cvtColor(m, out, cv::COLOR_GRAY2BGR);
  else if (m.channels() == 4)
    cv::cvtColor(m, out, cv::COLOR_BGRA2BGR);
  else
    out = m;
  return out;
}

}  // namespace

FrameSteps analyseFrameSteps(const std::vector<double>& t, double announced_fps) {
  FrameSteps f;
  f.step_s = announced_fps > 0 ? 1.0 / announced_fps : 1.0 / 30;
  std::vector<double> d;
  for (std::size_t i = 1; i < t.size(); ++i) d.push_back(t[i] - t[i - 1]);
  if (d.empty()) return f;
  std::vector<double> sorted = d;
  std::sort(sorted.begin(), sorted.end());
  f.min_step_s = sorted.front();
  f.max_step_s = sorted.back();
  f.median_step_s = sorted[sorted.size() / 2];
  if (!(f.median_step_s > 0)) return f;
  if (!(announced_fps > 0) || f.median_step_s > 1.5 * f.step_s || f.median_step_s < f.step_s / 1.5)
    f.step_s = f.median_step_s;
  int irregular = 0;
  for (double v : d) {
    const double r = v / f.median_step_s;
    if (r < 0.85 || std::abs(r - std::round(r)) > 0.15) ++irregular;
  }
  f.variable = irregular >= 2 && irregular > 0.1 * d.size();
  if (f.variable) return f;
  for (double v : d)
    if (v > 1.5 * f.step_s) {
      ++f.gaps;
      f.dropped_frames += std::max(1, static_cast<int>(std::lround(v / f.step_s)) - 1);
    }
  return f;
}

VideoSource::VideoSource(const std::string& path, const VideoOptions& options) : path_(path), opt_(options) {
  if (opt_.stride < 1)
    throw TopoError("stride " + std::to_string(opt_.stride), "must be at least 1", "give --stride 1 or more");
  if (opt_.end_s >= 0 && opt_.end_s <= opt_.start_s)
    throw TopoError("time range " + std::to_string(opt_.start_s) + ".." + std::to_string(opt_.end_s) + " s", "is empty",
                    "give --end larger than --start (or leave --end out)");
  // Only a single %d / %0Nd makes a pattern (and only when no file has that very name): any other
  // '%' (run_100%full.avi, frame_%s%n.png) is part of a plain file name, never a printf format.
  const SequencePattern pattern = sequencePattern(path);
  if ((pattern.valid && !isReadableFile(path)) || isDirectory(path)) {
    sequence_ = true;
    if (!(opt_.sequence_fps > 0))
      throw TopoError(path, "image sequence with a non-positive fps", "give a positive frame rate");
    fps_ = opt_.sequence_fps;
    if (isDirectory(path)) {
      DIR* d = ::opendir(path.c_str());
      if (!d) throw TopoError(path, "directory cannot be read", "check its permissions");
      while (dirent* e = ::readdir(d)) {
        const std::string n = e->d_name;
        if (hasImageExtension(n)) files_.push_back(path + "/" + n);
      }
      ::closedir(d);
      std::sort(files_.begin(), files_.end());
    } else {
      for (int start : {0, 1}) {
        for (int i = start;; ++i) {
          const std::string file = sequenceFile(pattern, i);
          if (!isReadableFile(file)) break;
          files_.push_back(file);
        }
        if (!files_.empty()) break;
      }
    }
    if (files_.empty())
      throw TopoError(path, "no images found for this image sequence",
                      "give a pattern with one %d or %0Nd, such as frames/frame_%04d.png (numbered from 0 or 1), "
                      "or a directory "
                      "of .png/.jpg images");
    frame_count_ = static_cast<int>(files_.size());
    cv::Mat first = cv::imread(files_[0], cv::IMREAD_COLOR);
    if (first.empty()) throw TopoError(files_[0], "cannot be decoded as an image", "check the image file");
    size_ = first.size();
    return;
  }
  if (!isReadableFile(path))
    throw TopoError(path, "video file does not exist or cannot be read",
                    "check the path (--video) and the file permissions");
  if (!cap_.open(path, cv::CAP_FFMPEG))
    throw TopoError(path,
                    "cannot be opened as a video: an unknown container or codec, or a file cut off before its "
                    "index (an .mp4/.mov copied or recorded only in part has no 'moov' index and cannot be read)",
                    "copy or record the file again; for an unknown format convert it, e.g. `ffmpeg -i IN -c:v "
                    "libx264 OUT.mp4`, or give an image sequence");
  // a phone's portrait video is stored landscape with a rotation in its metadata: frames come upright
  cap_.set(cv::CAP_PROP_ORIENTATION_AUTO, 1);
  const double meta = cap_.get(cv::CAP_PROP_ORIENTATION_META);
  orientation_deg_ = std::isfinite(meta) ? ((static_cast<int>(std::lround(meta)) % 360) + 360) % 360 : 0;
  const double fps = cap_.get(cv::CAP_PROP_FPS);
  fps_ = (std::isfinite(fps) && fps > 0.5 && fps < 10000) ? fps : opt_.sequence_fps;
  frame_count_ = static_cast<int>(std::max(0.0, cap_.get(cv::CAP_PROP_FRAME_COUNT)));
  double t = 0;
  int idx = 0;
  cv::Mat first;
  const bool decoded = decodeNext(first, t, idx) && !first.empty();
  if (!decoded && frame_count_ == 0)  // a valid container with nothing in it: not a codec problem
    throw TopoError(path, "holds no frames (the container announces 0 frames: an empty recording)",
                    "record the clip again (the recording stopped before its first frame was written)");
  if (!decoded)
    throw TopoError(path, "the first frame cannot be decoded (unsupported codec or damaged file)",
                    "convert it, e.g. `ffmpeg -i IN -c:v libx264 -pix_fmt yuv420p OUT.mp4`");
  size_ = first.size();
  pending_.push_back({first, t});
  // Two more frames: some files stamp their first frame wrongly (e.g. 600 ms, then 40, 80, ... ms);
  // such a stamp is replaced by the extrapolation of the next two, t0 = 2 t1 − t2.
  for (int k = 0; k < 2; ++k) {
    cv::Mat f;
    double tk = 0;
    int ik = 0;
    if (!decodeNext(f, tk, ik)) break;
    pending_.push_back({f, tk});
  }
  if (first_stamp_bogus_ && pending_.size() == 3)
    pending_[0].second = std::max(0.0, 2 * pending_[1].second - pending_[2].second);
  else if (first_stamp_bogus_ && pending_.size() == 2)
    pending_[0].second = std::max(0.0, pending_[1].second - 1.0 / fps_);
  next_index_ = 0;  // the frames are handed out again by read()
  opening_ = false;
}

double VideoSource::timestampFps() const {
  if (times_.size() < 3) return fps_;
  std::vector<double> d;
  for (std::size_t i = 1; i < times_.size(); ++i) d.push_back(times_[i] - times_[i - 1]);
  std::nth_element(d.begin(), d.begin() + d.size() / 2, d.end());
  const double step = d[d.size() / 2] / std::max(1, opt_.stride);
  return step > 0 ? 1.0 / step : fps_;
}

bool VideoSource::decodeNext(cv::Mat& bgr, double& t_s, int& index) {
  if (sequence_) {
    if (next_index_ >= static_cast<int>(files_.size())) return false;
    index = next_index_++;
    bgr = cv::imread(files_[index], cv::IMREAD_COLOR);
    if (bgr.empty())
      throw TopoError(files_[index], "cannot be decoded as an image", "remove or replace the damaged image");
    t_s = index / fps_;
    ++decoded_;
    return true;
  }
  if (!opening_ && !pending_.empty() && handed_ < static_cast<int>(pending_.size())) {
    bgr = pending_[handed_].first;
    t_s = pending_[handed_].second;
    index = handed_++;
    next_index_ = handed_;
    if (handed_ == static_cast<int>(pending_.size())) {
      next_index_ = decoded_;
      pending_.clear();
      handed_ = 0;
    }
    return true;
  }
  cv::Mat raw;
  if (!cap_.read(raw) || raw.empty()) {
    stopped_ = true;
    return false;
  }
  bgr = toBgr(raw);
  index = next_index_++;
  ++decoded_;
  const double msec = cap_.get(cv::CAP_PROP_POS_MSEC);
  if (index == 1 && msec_ok_ && std::isfinite(msec) && msec > 0 && msec < last_msec_) {
    first_stamp_bogus_ = true;  // frame 0 was stamped after frame 1: its stamp is replaced (constructor)
    last_msec_ = -1.0;
  }
  // The container timestamp is used while it is valid: finite and increasing (0 allowed first).
  // The FFMPEG backend reports 0 for the frames flushed from the decoder at the end of the stream;
  // from the first invalid value on, time continues from the last valid stamp at 1/fps per frame.
  if (msec_ok_ && std::isfinite(msec) && msec >= 0 && (index == 0 ? true : msec > last_msec_)) {
    last_msec_ = msec;
    last_msec_index_ = index;
    t_s = msec / 1000.0;
  } else {
    msec_ok_ = false;
    t_s = last_msec_index_ >= 0 ? last_msec_ / 1000.0 + (index - last_msec_index_) / fps_ : index / fps_;
  }
  last_decoded_t_ = std::max(last_decoded_t_, t_s);
  return true;
}

bool VideoSource::read(cv::Mat& bgr, double& t_s) {
  cv::Mat f;
  double t = 0;
  int idx = 0;
  while (decodeNext(f, t, idx)) {
    if (t + 1e-9 < opt_.start_s) continue;
    if (opt_.end_s >= 0 && t > opt_.end_s + 1e-9) return false;
    const int k = used_in_range_++;
    if (k % opt_.stride != 0) continue;
    bgr = f;
    t_s = t;
    last_index_ = idx;
    times_.push_back(t);
    indices_.push_back(idx);
    return true;
  }
  return false;
}

}  // namespace topo_gaussian::vision
