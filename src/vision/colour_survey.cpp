#include "topo_gaussian/vision/colour_survey.h"

#include <algorithm>
#include <opencv2/imgproc.hpp>

#include "topo_gaussian/common/number_text.h"

namespace topo_gaussian::vision {
namespace {

constexpr int kMaxWidthPx = 320;
constexpr std::size_t kMaxFrames = 48;
constexpr int kDiffThreshold = 30;  // grey levels, any channel
constexpr int kMinS = 45, kMinV = 40;
constexpr int kBandWidth = 21;  // hue bins (OpenCV hue: 2 degrees a bin)
constexpr double kColouredEnough = 0.25;

/// The q-quantile (0..1) of a histogram of 256 values.
int quantile(const std::vector<double>& hist, double q) {
  double total = 0;
  for (double h : hist) total += h;
  double acc = 0;
  for (int i = 0; i < int(hist.size()); ++i) {
    acc += hist[i];
    if (acc >= q * total) return i;
  }
  return int(hist.size()) - 1;
}

std::string triple(const cv::Scalar& s) {
  return std::to_string(int(s[0])) + "," + std::to_string(int(s[1])) + "," + std::to_string(int(s[2]));
}

}  // namespace

ColourSurvey::ColourSurvey(cv::Rect roi, double min_area_px) : roi_(roi), min_area_px_(min_area_px) {}

void ColourSurvey::addFrame(const cv::Mat& bgr) {
  if (bgr.empty() || bgr.type() != CV_8UC3) return;
  if (offered_++ % stride_ != 0) return;
  const cv::Rect whole(0, 0, bgr.cols, bgr.rows);
  const cv::Rect region = roi_.area() > 0 ? (roi_ & whole) : whole;
  if (region.area() == 0) return;
  scale_ = std::min(1.0, double(kMaxWidthPx) / region.width);
  cv::Mat small;
  cv::resize(bgr(region), small, cv::Size(), scale_, scale_, cv::INTER_AREA);
  frames_.push_back(small);
  ++kept_;
  if (frames_.size() >= kMaxFrames) {  // keep every other one, sample half as often from now on
    std::vector<cv::Mat> kept;
    for (std::size_t i = 0; i < frames_.size(); i += 2) kept.push_back(frames_[i]);
    frames_.swap(kept);
    stride_ *= 2;
  }
}

ColourSuggestion ColourSurvey::suggest() const {
  if (suggested_at_ != kept_) {
    suggestion_ = compute();
    suggested_at_ = kept_;
  }
  return suggestion_;
}

ColourSuggestion ColourSurvey::compute() const {
  ColourSuggestion s;
  if (frames_.size() < 4) {
    s.text = "too few frames (" + std::to_string(frames_.size()) + ") to see what moves";
    return s;
  }
  // background: the per-pixel median of the kept frames
  const int n = int(frames_.size()), rows = frames_[0].rows, cols = frames_[0].cols;
  cv::Mat background(rows, cols, CV_8UC3);
  std::vector<uchar> v(n);
  for (int y = 0; y < rows; ++y)
    for (int x = 0; x < cols; ++x)
      for (int c = 0; c < 3; ++c) {
        for (int k = 0; k < n; ++k) v[k] = frames_[k].at<cv::Vec3b>(y, x)[c];
        std::nth_element(v.begin(), v.begin() + n / 2, v.end());
        background.at<cv::Vec3b>(y, x)[c] = v[n / 2];
      }
  cv::Mat bg_hsv;
  cv::cvtColor(background, bg_hsv, cv::COLOR_BGR2HSV);

  std::vector<double> hue(180, 0.0);
  std::vector<cv::Mat> hsv(n), fg(n);
  const cv::Mat open = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(3, 3));
  double foreground = 0, coloured = 0, fg_value = 0, bg_value = 0;
  for (int k = 0; k < n; ++k) {
    cv::Mat diff, channels[3];
    cv::absdiff(frames_[k], background, diff);
    cv::split(diff, channels);
    cv::Mat m = cv::max(cv::max(channels[0], channels[1]), channels[2]) > kDiffThreshold;
    cv::morphologyEx(m, fg[k], cv::MORPH_OPEN, open);
    cv::cvtColor(frames_[k], hsv[k], cv::COLOR_BGR2HSV);
    for (int y = 0; y < rows; ++y)
      for (int x = 0; x < cols; ++x) {
        if (!fg[k].at<uchar>(y, x)) continue;
        const cv::Vec3b p = hsv[k].at<cv::Vec3b>(y, x);
        foreground += 1;
        fg_value += p[2];
        bg_value += bg_hsv.at<cv::Vec3b>(y, x)[2];
        if (p[1] >= kMinS && p[2] >= kMinV) {
          coloured += 1;
          hue[std::min<int>(p[0], 179)] += 1;
        }
      }
  }
  s.moving_fraction = foreground / (double(n) * rows * cols);
  const double min_area_small = std::max(4.0, min_area_px_ * scale_ * scale_);
  if (foreground < min_area_small * n * 0.5) {
    s.text = "nothing moved in the region (" + fixedText(100.0 * s.moving_fraction, 2) +
             " % of the pixels differ from the clip's median frame)";
    return s;
  }
  s.coloured_share = coloured / foreground;

  auto tryOn = [&](const TrackerOptions& to) {
    auto tracker = makeTracker(to, frames_[0].size());
    int found = 0;
    for (const cv::Mat& f : frames_)
      if (tracker->track(f).found) ++found;
    return found;
  };
  TrackerOptions base;
  base.min_area_px = min_area_small;
  base.morph_kernel_px = 3;
  s.frames_tried = n;

  // the marker candidate: the dominant hue band of the coloured foreground
  ColourSuggestion marker = s;
  if (s.coloured_share >= kColouredEnough) {
    int best_start = 0;
    double best = -1;
    for (int a = 0; a + kBandWidth <= 180; ++a) {
      double sum = 0;
      for (int h = a; h < a + kBandWidth; ++h) sum += hue[h];
      if (sum > best) best = sum, best_start = a;
    }
    marker.hue_share = best / std::max(1.0, coloured);
    std::vector<double> sat(256, 0.0), val(256, 0.0);
    for (int k = 0; k < n; ++k)
      for (int y = 0; y < rows; ++y)
        for (int x = 0; x < cols; ++x) {
          if (!fg[k].at<uchar>(y, x)) continue;
          const cv::Vec3b p = hsv[k].at<cv::Vec3b>(y, x);
          if (p[1] < kMinS || p[2] < kMinV || p[0] < best_start || p[0] >= best_start + kBandWidth) continue;
          sat[p[1]] += 1;
          val[p[2]] += 1;
        }
    marker.method = "marker";
    marker.range.lower =
        cv::Scalar(best_start, std::max(kMinS, quantile(sat, 0.1)), std::max(kMinV, quantile(val, 0.1)));
    marker.range.upper = cv::Scalar(best_start + kBandWidth - 1, 255, 255);
    marker.args = "--hsv-lower " + triple(marker.range.lower) + " --hsv-upper " + triple(marker.range.upper);
    TrackerOptions to = base;
    to.method = "marker";
    to.hsv = {marker.range};
    marker.frames_found = tryOn(to);
    const int h0 = int(marker.range.lower[0]), h1 = int(marker.range.upper[0]);
    marker.text = "what moves is mostly hue " + std::to_string(2 * h0) + "-" + std::to_string(2 * h1) +
                  " deg (OpenCV H " + std::to_string(h0) + ".." + std::to_string(h1) + ", " +
                  fixedText(100.0 * marker.hue_share, 0) + " % of its coloured pixels)";
  }
  const bool marker_works = !marker.method.empty() && 2 * marker.frames_found >= n;

  // the silhouette candidate: an Otsu threshold on the side the moving pixels' brightness gives
  ColourSuggestion silhouette = s;
  silhouette.method = "silhouette";
  silhouette.polarity = fg_value < bg_value ? "darker" : "brighter";
  silhouette.args = "--method silhouette --polarity " + silhouette.polarity;
  silhouette.text = "what moves is " + fixedText(100.0 * s.coloured_share, 0) + " % coloured and " +
                    silhouette.polarity + " than the background";
  if (!marker_works) {
    TrackerOptions to = base;
    to.method = "silhouette";
    to.foreground = "otsu";
    to.polarity = silhouette.polarity;
    silhouette.frames_found = tryOn(to);
  }
  const ColourSuggestion& chosen =
      marker_works || (!marker.method.empty() && marker.frames_found >= silhouette.frames_found) ? marker : silhouette;
  s = chosen;
  s.available = true;
  const std::string tried =
      "found a blob in " + std::to_string(s.frames_found) + " of " + std::to_string(s.frames_tried) + " sampled frames";
  if (2 * s.frames_found >= n)
    s.text += ": try " + s.args + " (" + tried + ")";
  else
    s.text += "; neither a colour range nor a silhouette found it in most frames (" + s.args + " " + tried +
              "): give --roi around its motion, or a colour sampled from the object";
  return s;
}

}  // namespace topo_gaussian::vision
