// Marker, silhouette and KLT trackers.
#include "topo_gaussian/vision/trackers.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <opencv2/video.hpp>

#include "topo_gaussian/common/error.h"

namespace topo_gaussian::vision {
namespace {

constexpr double kPi = 3.14159265358979323846;

std::string rectText(const cv::Rect& r) {
  return std::to_string(r.x) + "," + std::to_string(r.y) + "," + std::to_string(r.width) + "," +
         std::to_string(r.height);
}

/// Largest external contour of a binary mask (ROI coordinates); index −1 when none is big enough.
int largestContour(const std::vector<std::vector<cv::Point>>& contours, double min_area, double& area) {
  int best = -1;
  area = 0;
  for (int i = 0; i < static_cast<int>(contours.size()); ++i) {
    const double a = cv::contourArea(contours[i]);
    if (a >= min_area && a > area) {
      area = a;
      best = i;
    }
  }
  return best;
}

void fillAxis(const cv::Moments& m, Measurement& out) {
  const double mu20 = m.mu20 / m.m00, mu02 = m.mu02 / m.m00, mu11 = m.mu11 / m.m00;
  const double theta = 0.5 * std::atan2(2.0 * mu11, mu20 - mu02);  // major axis from image +x
  double dx = std::cos(theta), dy = std::sin(theta);
  if (dy > 0 || (dy == 0 && dx < 0)) {  // make it point image-up
    dx = -dx;
    dy = -dy;
  }
  out.axis_angle_deg = std::atan2(dx, -dy) * 180.0 / kPi;
  const double common = std::sqrt(std::max(0.0, 0.25 * (mu20 - mu02) * (mu20 - mu02) + mu11 * mu11));
  const double l1 = 0.5 * (mu20 + mu02) + common, l2 = 0.5 * (mu20 + mu02) - common;
  out.elongation = l2 > 1e-12 ? std::sqrt(l1 / l2) : 1e6;
}

/// Follows one blob from frame to frame: the first time (or after a loss) the largest blob; then the blob
/// nearest the constant-velocity prediction whose area is within a factor 4 of the last one, inside a
/// gate of max(4 sizes, 3 × the last step + 20 px); the largest again when none qualifies. So a small
/// moving bob is not traded for a bigger static mark beside its path.
class BlobFollower {
 public:
  int choose(const std::vector<std::vector<cv::Point>>& contours, double min_area, const cv::Point& offset) {
    double area = 0;
    const int largest = largestContour(contours, min_area, area);
    if (!have_ || largest < 0) return largest;
    const cv::Point2d pred = c_ + v_;
    const double gate = std::max(4.0 * std::sqrt(area_), 3.0 * cv::norm(v_) + 20.0);
    int best = -1;
    double best_score = 1e300;
    for (int i = 0; i < static_cast<int>(contours.size()); ++i) {
      const cv::Moments m = cv::moments(contours[i]);
      const double a = std::abs(m.m00);
      if (a < min_area || !(a > 0)) continue;
      const cv::Point2d c(m.m10 / m.m00 + offset.x, m.m01 / m.m00 + offset.y);
      const double ratio = std::max(a / area_, area_ / a), d = cv::norm(c - pred);
      if (ratio > 4.0 || d > gate) continue;
      const double score = (d + 1.0) * ratio;
      if (score < best_score) best_score = score, best = i;
    }
    return best >= 0 ? best : largest;
  }
  void update(const Measurement& m) {
    if (!m.found) {
      have_ = false;
      return;
    }
    v_ = have_ ? m.centroid - c_ : cv::Point2d(0, 0);
    c_ = m.centroid;
    area_ = std::max(1.0, m.area_px);
    have_ = true;
  }

 private:
  bool have_ = false;
  cv::Point2d c_, v_;
  double area_ = 1.0;
};

/// Fills `out` from the chosen blob `best` of `mask` (ROI-sized): centroid, area, axis, contour, mask,
/// and the mask statistics the object checks use. Returns false when the blob is empty.
bool describeBlob(const cv::Mat& mask, const std::vector<std::vector<cv::Point>>& contours, int best,
                  const cv::Mat& view, const cv::Rect& roi, double min_area, bool keep_mask, Measurement& out) {
  // everything on the blob's bounding box (a full-frame mask per frame would cost a third of the speed)
  const cv::Rect br = cv::boundingRect(contours[best]);
  cv::Mat blob = cv::Mat::zeros(br.size(), CV_8U);
  cv::drawContours(blob, contours, best, cv::Scalar(255), cv::FILLED, cv::LINE_8, cv::noArray(), 0, -br.tl());
  cv::bitwise_and(blob, mask(br), blob);
  const cv::Moments m = cv::moments(blob, true);
  if (m.m00 <= 0) return false;
  out.found = true;
  out.area_px = m.m00;
  out.centroid = cv::Point2d(m.m10 / m.m00 + br.x + roi.x, m.m01 / m.m00 + br.y + roi.y);
  fillAxis(m, out);
  const double all = cv::countNonZero(mask);
  out.mask_fraction = all / static_cast<double>(mask.total());
  out.largest_share = all > 0 ? m.m00 / all : 1.0;
  out.pieces = 0;
  for (const auto& c : contours)
    if (cv::contourArea(c) >= min_area) ++out.pieces;
  std::vector<cv::Point> hull;
  cv::convexHull(contours[best], hull);
  const double hull_area = cv::contourArea(hull);
  out.solidity = hull_area > 0 ? std::min(1.0, m.m00 / hull_area) : 1.0;
  out.touches_border = br.x <= 0 || br.y <= 0 || br.br().x >= mask.cols || br.br().y >= mask.rows;
  const cv::Scalar c = cv::mean(view(br), blob);
  out.mean_bgr = cv::Vec3d(c[0], c[1], c[2]);
  out.contour = contours[best];
  for (auto& p : out.contour) p += roi.tl();
  if (keep_mask) {
    out.mask = cv::Mat::zeros(mask.size(), CV_8U);
    blob.copyTo(out.mask(br));
  }
  return true;
}

class MarkerTracker : public Tracker {
 public:
  MarkerTracker(const TrackerOptions& o, const cv::Rect& roi) : o_(o), roi_(roi) {
    if (o_.hsv.empty()) o_.hsv = defaultRedRanges();
    if (o_.morph_kernel_px > 0)
      kernel_ = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(o_.morph_kernel_px, o_.morph_kernel_px));
  }
  std::string name() const override { return "marker"; }
  Measurement track(const cv::Mat& bgr) override {
    Measurement out;
    const cv::Mat view = bgr(roi_);
    cv::cvtColor(view, hsv_, cv::COLOR_BGR2HSV);
    mask_.create(hsv_.size(), CV_8U);
    mask_.setTo(0);
    for (const auto& r : o_.hsv) {
      cv::inRange(hsv_, r.lower, r.upper, part_);
      cv::bitwise_or(mask_, part_, mask_);
    }
    if (!kernel_.empty()) cv::morphologyEx(mask_, mask_, cv::MORPH_OPEN, kernel_);
    std::vector<std::vector<cv::Point>> contours;
    cv::findContours(mask_, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
    const int best = follow_.choose(contours, o_.min_area_px, roi_.tl());
    if (best < 0 || !describeBlob(mask_, contours, best, view, roi_, o_.min_area_px, o_.keep_mask, out))
      out = Measurement();
    follow_.update(out);
    return out;
  }

 private:
  TrackerOptions o_;
  cv::Rect roi_;
  cv::Mat kernel_, hsv_, mask_, part_;
  BlobFollower follow_;
};

class SilhouetteTracker : public Tracker {
 public:
  SilhouetteTracker(const TrackerOptions& o, const cv::Rect& roi) : o_(o), roi_(roi) {
    if (o_.foreground == "auto") o_.foreground = "mog2";  // MotionTracker resolves auto per kind first
    if (o_.foreground != "mog2" && o_.foreground != "otsu")
      throw TopoError("--foreground " + o_.foreground, "is not a silhouette method", "use mog2, otsu or auto");
    if (o_.polarity != "auto" && o_.polarity != "darker" && o_.polarity != "brighter")
      throw TopoError("--polarity " + o_.polarity, "is not an object polarity",
                      "use darker (object darker than its background), brighter, or auto");
    if (o_.foreground == "mog2") mog_ = cv::createBackgroundSubtractorMOG2(200, 16.0, false);
    if (o_.morph_kernel_px > 0)
      kernel_ = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(o_.morph_kernel_px, o_.morph_kernel_px));
  }
  std::string name() const override { return "silhouette"; }
  Measurement track(const cv::Mat& bgr) override {
    Measurement out;
    const cv::Mat view = bgr(roi_);
    if (mog_) {
      // MOG2 on a half-resolution grey image (≈8x faster than full-size BGR), mask scaled back
      cv::cvtColor(view, grey_, cv::COLOR_BGR2GRAY);
      if (view.cols >= 320 && view.rows >= 240) {
        cv::resize(grey_, small_, cv::Size(), 0.5, 0.5, cv::INTER_AREA);
        mog_->apply(small_, small_fg_);
        cv::resize(small_fg_, fg_, view.size(), 0, 0, cv::INTER_LINEAR);
      } else {
        mog_->apply(grey_, fg_);
      }
      cv::threshold(fg_, fg_, 127, 255, cv::THRESH_BINARY);
    } else {
      cv::cvtColor(view, grey_, cv::COLOR_BGR2GRAY);
      cv::GaussianBlur(grey_, grey_, cv::Size(5, 5), 0);
      cv::threshold(grey_, fg_, 0, 255, cv::THRESH_BINARY | cv::THRESH_OTSU);  // 255 = the brighter side
      bool object_is_bright = true;
      if (o_.polarity == "darker") {
        object_is_bright = false;
      } else if (o_.polarity == "auto") {
        // the background is the side that touches the region's border more (the object sits inside)
        const int W = fg_.cols, H = fg_.rows;
        double bright_border = 0, border = 0;
        for (int x = 0; x < W; ++x) bright_border += (fg_.at<uchar>(0, x) > 0) + (fg_.at<uchar>(H - 1, x) > 0);
        for (int y = 1; y + 1 < H; ++y) bright_border += (fg_.at<uchar>(y, 0) > 0) + (fg_.at<uchar>(y, W - 1) > 0);
        border = 2.0 * W + 2.0 * std::max(0, H - 2);
        const double share = bright_border / std::max(1.0, border);
        if (std::abs(share - 0.5) > 0.1)
          object_is_bright = share < 0.5;
        else  // ambiguous border: the smaller side is the object
          object_is_bright = static_cast<std::size_t>(cv::countNonZero(fg_)) <= fg_.total() / 2;
      }
      if (!object_is_bright) cv::bitwise_not(fg_, fg_);
    }
    if (!kernel_.empty()) cv::morphologyEx(fg_, fg_, cv::MORPH_OPEN, kernel_);
    std::vector<std::vector<cv::Point>> contours;
    cv::findContours(fg_, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
    const int best = follow_.choose(contours, o_.min_area_px, roi_.tl());
    if (best < 0 || !describeBlob(fg_, contours, best, view, roi_, o_.min_area_px, o_.keep_mask, out))
      out = Measurement();
    follow_.update(out);
    return out;
  }

 private:
  TrackerOptions o_;
  cv::Rect roi_;
  cv::Ptr<cv::BackgroundSubtractorMOG2> mog_;
  cv::Mat kernel_, grey_, fg_, small_, small_fg_;
  BlobFollower follow_;
};

class KltTracker : public Tracker {
 public:
  KltTracker(const TrackerOptions& o, const cv::Rect& roi) : o_(o), roi_(roi) {}
  std::string name() const override { return "klt"; }
  Measurement track(const cv::Mat& bgr) override {
    Measurement out;
    cv::cvtColor(bgr, grey_, cv::COLOR_BGR2GRAY);
    if (!prev_.empty() && !pts_.empty()) {
      std::vector<cv::Point2f> fwd, back;
      std::vector<unsigned char> st1, st2;
      std::vector<float> err;
      const cv::Size win(21, 21);
      cv::calcOpticalFlowPyrLK(prev_, grey_, pts_, fwd, st1, err, win, 3);
      cv::calcOpticalFlowPyrLK(grey_, prev_, fwd, back, st2, err, win, 3);
      std::vector<cv::Point2f> keep;
      std::vector<int> ids;
      for (std::size_t i = 0; i < pts_.size(); ++i) {
        if (!st1[i] || !st2[i]) continue;
        const cv::Point2f d = back[i] - pts_[i];
        if (std::hypot(d.x, d.y) > o_.klt_fb_max_px) continue;
        if (fwd[i].x < 0 || fwd[i].y < 0 || fwd[i].x >= grey_.cols || fwd[i].y >= grey_.rows) continue;
        keep.push_back(fwd[i]);
        ids.push_back(ids_[i]);
      }
      pts_.swap(keep);
      ids_.swap(ids);
    }
    if (static_cast<int>(pts_.size()) < o_.klt_min_points) seed();
    grey_.copyTo(prev_);
    if (pts_.empty()) return out;
    out.found = true;
    cv::Point2d c(0, 0);
    for (const auto& p : pts_) c += cv::Point2d(p.x, p.y);
    out.centroid = c * (1.0 / pts_.size());
    out.points = pts_;
    out.point_ids = ids_;
    out.area_px = static_cast<double>(pts_.size());
    return out;
  }

 private:
  void seed() {
    // re-seed around where the points were (or in the ROI at the start)
    cv::Rect area = roi_;
    if (!pts_.empty()) {
      cv::Rect b = cv::boundingRect(pts_);
      b.x -= 20;
      b.y -= 20;
      b.width += 40;
      b.height += 40;
      area = b & cv::Rect(0, 0, grey_.cols, grey_.rows);
      if (area.area() < 100) area = roi_;
    }
    cv::Mat mask = cv::Mat::zeros(grey_.size(), CV_8U);
    mask(area).setTo(255);
    for (const auto& p : pts_) cv::circle(mask, p, 7, cv::Scalar(0), cv::FILLED);
    std::vector<cv::Point2f> fresh;
    const int want = o_.klt_max_points - static_cast<int>(pts_.size());
    if (want <= 0) return;
    cv::goodFeaturesToTrack(grey_, fresh, want, 0.01, 7, mask, 5);
    for (const auto& p : fresh) {
      pts_.push_back(p);
      ids_.push_back(next_id_++);
    }
  }

  TrackerOptions o_;
  cv::Rect roi_;
  cv::Mat grey_, prev_;
  std::vector<cv::Point2f> pts_;
  std::vector<int> ids_;
  int next_id_ = 0;
};

}  // namespace

std::vector<HsvRange> defaultRedRanges() {
  return {HsvRange{cv::Scalar(0, 90, 60), cv::Scalar(10, 255, 255)},
          HsvRange{cv::Scalar(170, 90, 60), cv::Scalar(180, 255, 255)}};
}

void validateHsvRange(const HsvRange& r, const std::string& option) {
  const char* names[3] = {"H", "S", "V"};
  const double top[3] = {180, 255, 255};
  for (int i = 0; i < 3; ++i) {
    for (double v : {r.lower[i], r.upper[i]})
      if (!(v >= 0 && v <= top[i]))
        throw TopoError(option + " " + names[i] + " " + std::to_string(static_cast<int>(v)),
                        std::string("is outside OpenCV's HSV range (H 0..180, S and V 0..255)"),
                        std::string("give ") + names[i] + " in 0.." + std::to_string(static_cast<int>(top[i])) +
                            " (OpenCV halves the hue: a hue of 350 degrees is H 175)");
    if (r.lower[i] > r.upper[i])
      throw TopoError(option + " " + names[i] + " " + std::to_string(static_cast<int>(r.lower[i])) + ".." +
                          std::to_string(static_cast<int>(r.upper[i])),
                      "has its lower bound above the upper one",
                      std::string("give lower <= upper; a red hue that wraps around 180 is the default colour "
                                  "(leave --hsv-lower/--hsv-upper out), or track one side of it (H 170..180)"));
  }
}

cv::Rect validRoi(const cv::Rect& roi, const cv::Size& frame_size, bool roi_given) {
  const cv::Rect frame(0, 0, frame_size.width, frame_size.height);
  const std::string size = std::to_string(frame_size.width) + "x" + std::to_string(frame_size.height);
  if (!roi_given) return frame;
  if (roi.width <= 0 || roi.height <= 0)
    throw TopoError("--roi " + rectText(roi), "is empty (width and height must be positive; the frame is " + size + ")",
                    "give --roi x,y,w,h inside the " + size + " frame, or leave --roi out for the whole frame");
  if ((roi & frame) != roi)
    throw TopoError(
        "--roi " + rectText(roi),
        (roi & frame).area() == 0 ? "lies outside the " + size + " frame" : "reaches outside the " + size + " frame",
        "give --roi x,y,w,h with x + w <= " + std::to_string(frame_size.width) +
            " and y + h <= " + std::to_string(frame_size.height) + " (x, y >= 0)");
  if (roi.area() < 16)
    throw TopoError("--roi " + rectText(roi), "is smaller than 16 pixels",
                    "give a region that holds the object's whole motion");
  return roi;
}

std::unique_ptr<Tracker> makeTracker(const TrackerOptions& options, const cv::Size& frame_size) {
  const cv::Rect roi = validRoi(options.roi, frame_size, options.roi_given || options.roi != cv::Rect());
  if (options.method == "marker") return std::make_unique<MarkerTracker>(options, roi);
  if (options.method == "silhouette") return std::make_unique<SilhouetteTracker>(options, roi);
  if (options.method == "klt") return std::make_unique<KltTracker>(options, roi);
  throw TopoError("--method " + options.method, "is not a tracking method", "use marker, silhouette or klt");
}

}  // namespace topo_gaussian::vision
