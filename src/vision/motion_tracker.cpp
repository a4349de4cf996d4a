// MotionTracker: frames → tracker → angle signal / trajectories → features.
#include "topo_gaussian/vision/motion_tracker.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numeric>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/json.h"
#include "topo_gaussian/common/number_text.h"
#include "topo_gaussian/common/statistics.h"
#include "topo_gaussian/vision/finger_centreline.h"
#include "topo_gaussian/vision/finger_profile.h"

namespace topo_gaussian::vision {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = 180.0 / kPi;

/// Lines of text at the top left, on a dark band, scaled with the frame (readable at 1080p, wrapped to
/// the frame's width at 400 px).
void drawText(cv::Mat& img, const std::vector<std::string>& lines_in) {
  const double fs = std::max(0.4, img.rows / 900.0);
  const int thick = std::max(1, static_cast<int>(std::lround(fs * 1.5)));
  const int font = cv::FONT_HERSHEY_SIMPLEX;
  std::vector<std::string> lines;
  for (const auto& text : lines_in) {
    std::string line;
    std::istringstream words(text);
    std::string w;
    while (words >> w) {
      const std::string tryline = line.empty() ? w : line + " " + w;
      int base = 0;
      if (!line.empty() && cv::getTextSize(tryline, font, fs, thick, &base).width > img.cols - 20) {
        lines.push_back(line);
        line = w;
      } else {
        line = tryline;
      }
    }
    if (!line.empty()) lines.push_back(line);
  }
  if (lines.size() > 8) lines.resize(8);
  int base = 0;
  const int h = cv::getTextSize("Ag", font, fs, thick, &base).height + base + 6;
  cv::Mat band = img(cv::Rect(0, 0, img.cols, std::min(img.rows, h * static_cast<int>(lines.size()) + 8)));
  band *= 0.45;
  for (std::size_t i = 0; i < lines.size(); ++i)
    cv::putText(img, lines[i], cv::Point(10, 4 + h * static_cast<int>(i + 1) - base), font, fs,
                cv::Scalar(255, 255, 255), thick, cv::LINE_AA);
}

/// The frame rotated clockwise by 0/90/180/270 degrees.
cv::Mat rotated(const cv::Mat& bgr, int deg) {
  if (deg == 0) return bgr;
  cv::Mat out;
  cv::rotate(bgr, out,
             deg == 90    ? cv::ROTATE_90_CLOCKWISE
             : deg == 180 ? cv::ROTATE_180
                          : cv::ROTATE_90_COUNTERCLOCKWISE);
  return out;
}

double wrapDeg(double a) {
  while (a > 180.0) a -= 360.0;
  while (a <= -180.0) a += 360.0;
  return a;
}

/// Vertex of the parabola through three (t, y) samples; falls back to the middle sample.
void parabolicVertex(double t0, double y0, double t1, double y1, double t2, double y2, double& tv, double& yv) {
  tv = t1;
  yv = y1;
  const double d0 = (y1 - y0) / (t1 - t0), d1 = (y2 - y1) / (t2 - t1);
  const double a = (d1 - d0) / (t2 - t0);
  if (!(std::abs(a) > 1e-12)) return;
  const double b = d0 - a * (t0 + t1);  // y = a t² + b t + c
  double t = -b / (2 * a);
  t = std::min(std::max(t, t0), t2);
  const double c = y1 - a * t1 * t1 - b * t1;
  tv = t;
  yv = a * t * t + b * t + c;
}

struct EndFit {
  bool ok = false;
  double bend_a = 0.0;  ///< bend if end A (low s) is the base
  cv::Point2d ca, cb;   ///< centroids of the end regions
  cv::Point2d pa, pb;   ///< line points, for the overlay
  cv::Vec2d va, vb;     ///< line directions (along +u)
  /// Chords from the centroid of the segment before the tip to the tip segment's (each tip_fraction of
  /// the length), for the tip at end B (along +u) and at end A (along −u): the finger task's bend.
  cv::Vec2d chord_b, chord_a;
};

/// The chord from the centroid of the segment before the tip to the tip segment's centroid, each
/// `segment_px` long, the tip being the far end along `towards`. The task cuts its segments across
/// the rest axis, i.e. across the bent finger's own centreline at the cuts; here the cuts are across
/// the chord itself, found by iterating from `towards` (a cut across the principal axis of a finger
/// bent by θ is θ/2 oblique, which moves the end segment's centroid and the chord by ~10 %).
bool tipChord(const std::vector<cv::Point>& px, cv::Vec2d towards, double segment_px, cv::Vec2d* chord) {
  cv::Vec2d d = towards;
  for (int iteration = 0; iteration < 4; ++iteration) {
    double smax = -1e300;
    for (const auto& p : px) smax = std::max(smax, p.x * d[0] + p.y * d[1]);
    cv::Point2d tip(0, 0), pre(0, 0);
    int nt = 0, np = 0;
    for (const auto& p : px) {
      const double s = p.x * d[0] + p.y * d[1];
      if (s > smax - segment_px)
        tip += cv::Point2d(p), ++nt;
      else if (s > smax - 2 * segment_px)
        pre += cv::Point2d(p), ++np;
    }
    if (nt < 5 || np < 5) return false;
    const cv::Point2d c = tip * (1.0 / nt) - pre * (1.0 / np);
    const double norm = std::hypot(c.x, c.y);
    if (!(norm > 0)) return false;
    d = cv::Vec2d(c.x / norm, c.y / norm);
    *chord = cv::Vec2d(c.x, c.y);
  }
  return true;
}

/// Lines through the medial band of the silhouette in the two end thirds of its principal axis.
EndFit fitEnds(const cv::Mat& mask, const cv::Point& offset, double tip_fraction, cv::Vec2d& u_prev) {
  EndFit f;
  const cv::Moments m = cv::moments(mask, true);
  if (m.m00 < 50) return f;
  const double theta = 0.5 * std::atan2(2.0 * m.mu11, m.mu20 - m.mu02);
  cv::Vec2d u(std::cos(theta), std::sin(theta));
  if (u_prev[0] != 0 || u_prev[1] != 0) {
    if (u.dot(u_prev) < 0) u = -u;
  }
  u_prev = u;
  const cv::Point2d c(m.m10 / m.m00, m.m01 / m.m00);
  cv::Mat dt;
  cv::distanceTransform(mask, dt, cv::DIST_L2, 5);
  std::vector<cv::Point> px;
  cv::findNonZero(mask, px);
  double smin = 1e300, smax = -1e300;
  for (const auto& p : px) {
    const double s = (p.x - c.x) * u[0] + (p.y - c.y) * u[1];
    smin = std::min(smin, s);
    smax = std::max(smax, s);
  }
  const double L = smax - smin;
  if (!(L > 10)) return f;
  double maxa = 0, maxb = 0;
  for (const auto& p : px) {
    const double s = (p.x - c.x) * u[0] + (p.y - c.y) * u[1];
    const float d = dt.at<float>(p);
    if (s < smin + L / 3) maxa = std::max(maxa, double(d));
    if (s > smax - L / 3) maxb = std::max(maxb, double(d));
  }
  std::vector<cv::Point2f> ra, rb;
  cv::Point2d sa(0, 0), sb(0, 0);
  int na = 0, nb = 0;
  for (const auto& p : px) {
    const double s = (p.x - c.x) * u[0] + (p.y - c.y) * u[1];
    const float d = dt.at<float>(p);
    if (s < smin + L / 3) {
      sa += cv::Point2d(p);
      ++na;
      if (d >= 0.7 * maxa) ra.emplace_back(float(p.x), float(p.y));
    }
    if (s > smax - L / 3) {
      sb += cv::Point2d(p);
      ++nb;
      if (d >= 0.7 * maxb) rb.emplace_back(float(p.x), float(p.y));
    }
  }
  if (ra.size() < 5 || rb.size() < 5 || na == 0 || nb == 0) return f;
  if (!tipChord(px, u, tip_fraction * L, &f.chord_b) || !tipChord(px, -u, tip_fraction * L, &f.chord_a)) return f;
  cv::Vec4f la, lb;
  cv::fitLine(ra, la, cv::DIST_L2, 0, 0.01, 0.01);
  cv::fitLine(rb, lb, cv::DIST_L2, 0, 0.01, 0.01);
  f.va = cv::Vec2d(la[0], la[1]);
  f.vb = cv::Vec2d(lb[0], lb[1]);
  if (f.va.dot(u) < 0) f.va = -f.va;
  if (f.vb.dot(u) < 0) f.vb = -f.vb;
  f.bend_a = wrapDeg((std::atan2(f.vb[1], f.vb[0]) - std::atan2(f.va[1], f.va[0])) * kDeg);
  f.ca = sa * (1.0 / na) + cv::Point2d(offset);
  f.cb = sb * (1.0 / nb) + cv::Point2d(offset);
  f.pa = cv::Point2d(la[2], la[3]) + cv::Point2d(offset);
  f.pb = cv::Point2d(lb[2], lb[3]) + cv::Point2d(offset);
  f.ok = true;
  return f;
}

/// A pixel "changes" between two frames when its grey level moves by more than this (well above the
/// sensor noise of a still picture) [grey levels].
constexpr double kChangeGrey = 40.0;
/// A tracked centre that stays within this of its median position in 95 % of the frames does not
/// move: a still blob's centroid wanders this much when its mask's edge follows a noisy, blurred or
/// moving background (a static red patch in noise 8, blur 1.5 and a drifting texture: 0.66 px; a
/// static bob there: 0.97 px), while a swing of 1 deg at 300 px moves it by 5 px [px].
constexpr double kStillPx = 1.0;

/// A tilt whose rest lies further than this from TrackOptions::tilt_reference_deg is ambiguous: the
/// other principal axis is then within 90° − this of the reference, about as plausible [deg].
constexpr double kTiltAmbiguityDeg = 30.0;

/// Tilt axis of a silhouette: of its two principal axes (the major one at `major_deg`, both taken
/// pointing image-up, degrees from image-up), the one nearest `reference_deg` (TrackOptions::
/// tilt_reference_deg, image vertical by default) at the first frame and after that the one nearest
/// the previous frame's axis, unwrapped by ±180° for continuity. So an object wider than tall (a
/// tumbler) is followed by its upright (minor) axis.
double followTiltAxis(double major_deg, bool have_prev, double prev_deg, double reference_deg) {
  const double candidates[2] = {major_deg, major_deg > 0 ? major_deg - 90.0 : major_deg + 90.0};
  const double ref = have_prev ? prev_deg : reference_deg;
  double best = candidates[0], best_d = 1e300;
  for (double c : candidates) {
    const double a = c + 180.0 * std::round((ref - c) / 180.0);  // an axis is a line: c ≡ c ± 180°
    if (std::abs(a - ref) < best_d) best_d = std::abs(a - ref), best = a;
  }
  return best;
}

}  // namespace

struct MotionTracker::Impl {
  TrackOptions opt;
  std::unique_ptr<Tracker> tracker;
  cv::Size frame_size;
  cv::Rect roi;
  std::vector<double> t_all;
  std::vector<char> found;
  std::vector<cv::Point2d> centroid;
  std::vector<double> axis_deg;
  std::vector<std::shared_ptr<const PlaneView>> views;  ///< per frame; null: none given
  std::vector<EndFit> ends;
  /// finger: each frame's centreline, from the end it starts at (oriented base first in finish(),
  /// once the base end is known)
  std::vector<ProfileFrame> centrelines;
  std::vector<Measurement> meas;  ///< per frame, without the mask (object checks, overlays)
  std::map<int, std::vector<TrajectorySample>> klt_tracks;
  cv::Vec2d u_prev{0, 0};
  bool have_tilt_axis = false;  ///< tilt: the axis followed so far (followTiltAxis)
  double tilt_axis_deg = 0.0;
  cv::Mat last_frame;
  /// pendulum/tilt: the previous frame in grey at most 320 px wide, and per frame the pixels of it that
  /// changed by more than kChangeGrey outside the tracked object's box (does anything else move?)
  cv::Mat prev_small;
  double small_scale = 1.0;
  std::vector<int> changed_elsewhere;
  Measurement last;
  double last_t = 0;
  /// marker with the default colour: a few frames kept to suggest another colour when it refuses
  std::unique_ptr<ColourSurvey> survey;

  double currentAngle(const cv::Point2d& c, const cv::Point2d& pivot) const {
    const cv::Vec2d g = opt.gravity / std::max(1e-12, cv::norm(opt.gravity));
    const cv::Point2d d = c - pivot;
    return std::atan2(g[1] * d.x - g[0] * d.y, g[0] * d.x + g[1] * d.y) * kDeg;
  }
};

void validateTrackOptions(const TrackOptions& o) {
  const std::string& k = o.kind;
  const std::string& m = o.tracker.method;
  if (k != "pendulum" && k != "tilt" && k != "trajectory" && k != "finger")
    throw TopoError("--kind " + k, "is not a motion kind", "use pendulum, tilt, trajectory or finger");
  if (m != "marker" && m != "silhouette" && m != "klt")
    throw TopoError("--method " + m, "is not a tracking method", "use marker, silhouette or klt");
  if ((k == "tilt" || k == "finger") && m == "klt")
    throw TopoError("--kind " + k + " with --method " + m, "needs a silhouette (its principal axis and outline)",
                    "use --method silhouette, or --method marker with the object's colour (--hsv-lower/--hsv-upper)");
  const std::string& fg = o.tracker.foreground;
  if (fg != "auto" && fg != "mog2" && fg != "otsu")
    throw TopoError("--foreground " + fg, "is not a silhouette method", "use auto, mog2 or otsu");
  const std::string& pol = o.tracker.polarity;
  if (pol != "auto" && pol != "darker" && pol != "brighter")
    throw TopoError("--polarity " + pol, "is not an object polarity",
                    "use darker (object darker than its background), brighter, or auto");
  if (!(o.tip_fraction > 0.0 && o.tip_fraction <= 0.25))
    throw TopoError("--tip_fraction " + numberText(o.tip_fraction), "must be in (0, 0.25]",
                    "use the finger task's tip_fraction (default 0.15)");
  if (o.profile_segments < 2 || o.profile_segments > 64)
    throw TopoError("--profile-segments " + std::to_string(o.profile_segments), "must be a whole number in 2..64",
                    "use the finger task's profile_segments (default 8)");
  if (!(std::abs(o.tilt_reference_deg) <= 180.0))
    throw TopoError("--tilt-reference " + numberText(o.tilt_reference_deg), "must be a tilt in -180..180 deg",
                    "give roughly the tilt the object starts near (0: upright), e.g. 50 for a doll hung off its axis");
  if (o.rotate_deg != 0 && o.rotate_deg != 90 && o.rotate_deg != 180 && o.rotate_deg != 270)
    throw TopoError("--rotate " + std::to_string(o.rotate_deg), "is not a quarter turn",
                    "use 90, 180 or 270 (degrees clockwise), or leave it out");
  if (!(std::isfinite(o.gravity[0]) && std::isfinite(o.gravity[1])) || cv::norm(o.gravity) < 1e-9)
    throw TopoError("--gravity", "is zero or not finite",
                    "give the image direction of gravity, e.g. --gravity 0,1 (down) or 1,0 (towards image-right)");
  for (const auto& r : o.tracker.hsv) validateHsvRange(r, "--hsv-lower/--hsv-upper");
  if (o.pivot_given && !(std::isfinite(o.pivot.x) && std::isfinite(o.pivot.y)))
    throw TopoError("--pivot", "is not finite", "give the pivot in pixels, e.g. --pivot 320,-150");
  if (!(o.tracker.min_area_px >= 0))
    throw TopoError("--min-area " + std::to_string(o.tracker.min_area_px), "is negative", "give an area >= 0 px");
}

MotionTracker::MotionTracker(const TrackOptions& options) : impl_(new Impl) {
  validateTrackOptions(options);
  impl_->opt = options;
}

MotionTracker::~MotionTracker() = default;

int MotionTracker::framesAdded() const { return static_cast<int>(impl_->t_all.size()); }

void MotionTracker::addFrame(const cv::Mat& frame_in, double t_s) { addFrame(frame_in, t_s, nullptr); }

void MotionTracker::addFrame(const cv::Mat& frame_in, double t_s, const PlaneView* view) {
  Impl& s = *impl_;
  if (frame_in.empty())
    throw TopoError("frame at t = " + fixedText(t_s, 3) + " s",
                    "is empty (" + std::to_string(frame_in.cols) + "x" + std::to_string(frame_in.rows) + " pixels)",
                    "pass the camera's frames as they are; check the driver or the decoder that produced an empty one");
  if (frame_in.type() != CV_8UC3)
    throw TopoError("frame at t = " + fixedText(t_s, 3) + " s",
                    "is not an 8-bit BGR image (" + std::to_string(frame_in.channels()) + " channels of " +
                        std::to_string(8 * frame_in.elemSize1()) + " bits)",
                    "pass CV_8UC3 frames");
  const cv::Mat bgr = rotated(frame_in, s.opt.rotate_deg);
  if (!s.t_all.empty() && !(t_s > s.t_all.back()))
    throw TopoError("frame at t = " + fixedText(t_s, 3) + " s",
                    "timestamps must increase (previous " + fixedText(s.t_all.back(), 3) + " s)",
                    "pass frames in time order");
  if (!s.tracker) {
    s.frame_size = bgr.size();
    TrackerOptions to = s.opt.tracker;
    if (to.foreground == "auto") to.foreground = s.opt.kind == "tilt" || s.opt.kind == "finger" ? "otsu" : "mog2";
    to.keep_mask = s.opt.kind == "finger";
    s.tracker = makeTracker(to, s.frame_size);
    s.roi = validRoi(to.roi, s.frame_size, to.roi_given || to.roi != cv::Rect());
    if (to.method == "marker" && to.hsv.empty()) s.survey = std::make_unique<ColourSurvey>(s.roi, to.min_area_px);
  } else if (bgr.size() != s.frame_size) {
    throw TopoError(
        "frame at t = " + fixedText(t_s, 3) + " s",
        "changes size from " + std::to_string(s.frame_size.width) + "x" + std::to_string(s.frame_size.height),
        "keep the frame size constant");
  }
  Measurement me = s.tracker->track(bgr);
  if (s.survey) s.survey->addFrame(bgr);
  if (me.found && s.opt.kind == "tilt") {
    me.axis_angle_deg = followTiltAxis(me.axis_angle_deg, s.have_tilt_axis, s.tilt_axis_deg, s.opt.tilt_reference_deg);
    s.have_tilt_axis = true;
    s.tilt_axis_deg = me.axis_angle_deg;
  }
  s.t_all.push_back(t_s);
  s.found.push_back(me.found ? 1 : 0);
  s.centroid.push_back(me.centroid);
  s.axis_deg.push_back(me.axis_angle_deg);
  s.views.push_back(view ? std::make_shared<const PlaneView>(*view) : nullptr);
  if (s.opt.kind == "finger") {
    s.ends.push_back(me.found ? fitEnds(me.mask, s.roi.tl(), s.opt.tip_fraction, s.u_prev) : EndFit());
    ProfileFrame pf;
    if (me.found) {
      const FingerCentreline c = fingerCentreline(me.mask, s.roi.tl(), CentrelineOptions(), bgr(s.roi));
      pf.ok = c.ok;
      if (c.ok) pf.centreline = c.points;
      pf.length_px = c.length_px;
      pf.base_at_border = c.start_at_border;
      pf.tip_at_border = c.end_at_border;
    }
    s.centrelines.push_back(std::move(pf));
  }
  if (me.found && s.opt.tracker.method == "klt") {
    for (std::size_t i = 0; i < me.points.size(); ++i)
      s.klt_tracks[me.point_ids[i]].push_back({t_s, me.points[i].x, me.points[i].y});
  }
  if (s.opt.kind == "pendulum" || s.opt.kind == "tilt") {
    s.small_scale = std::min(1.0, 320.0 / bgr.cols);
    cv::Mat grey, small;
    cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
    cv::resize(grey, small, cv::Size(), s.small_scale, s.small_scale, cv::INTER_AREA);
    if (!s.prev_small.empty()) {
      cv::Mat changed;
      cv::absdiff(small, s.prev_small, changed);
      cv::threshold(changed, changed, kChangeGrey, 255, cv::THRESH_BINARY);
      if (me.found && !me.contour.empty()) {  // the object's own box (a pixel wider) is not "elsewhere"
        const cv::Rect box = cv::boundingRect(me.contour);
        const cv::Rect small_box(cv::Point(static_cast<int>(box.x * s.small_scale) - 2,
                                           static_cast<int>(box.y * s.small_scale) - 2),
                                 cv::Point(static_cast<int>(box.br().x * s.small_scale) + 3,
                                           static_cast<int>(box.br().y * s.small_scale) + 3));
        changed(small_box & cv::Rect(0, 0, changed.cols, changed.rows)).setTo(0);
      }
      s.changed_elsewhere.push_back(cv::countNonZero(changed));
    }
    s.prev_small = small;
  }
  s.last_frame = bgr;
  s.meas.push_back(me);
  s.meas.back().mask.release();
  s.last = std::move(me);
  s.last.mask.release();
  s.last_t = t_s;
}

cv::Mat MotionTracker::overlay() const {
  const Impl& s = *impl_;
  if (s.last_frame.empty()) return cv::Mat();
  cv::Mat img = s.last_frame.clone();
  cv::rectangle(img, s.roi, cv::Scalar(255, 128, 0), 1);
  std::string text = "t " + fixedText(s.last_t, 2) + " s";
  // trail of the last centroids
  const int n = static_cast<int>(s.t_all.size());
  for (int i = std::max(1, n - 60); i < n; ++i)
    if (s.found[i] && s.found[i - 1])
      cv::line(img, s.centroid[i - 1], s.centroid[i], cv::Scalar(0, 200, 255), 1, cv::LINE_AA);
  if (s.last.found) {
    if (!s.last.contour.empty())
      cv::drawContours(img, std::vector<std::vector<cv::Point>>{s.last.contour}, 0, cv::Scalar(0, 200, 0), 2);
    for (const auto& p : s.last.points) cv::circle(img, p, 3, cv::Scalar(255, 0, 255), cv::FILLED);
    cv::circle(img, s.last.centroid, 5, cv::Scalar(0, 0, 255), cv::FILLED);
    if (s.opt.kind == "pendulum") {
      cv::Point2d pivot = s.opt.pivot;
      bool have = s.opt.pivot_given;
      if (!have) {
        std::vector<cv::Point2d> pts;
        for (int i = 0; i < n; ++i)
          if (s.found[i]) pts.push_back(s.centroid[i]);
        double r, rms;
        have = pts.size() >= 10 && fitCircleKasa(pts, pivot, r, rms);
      }
      if (have) {
        cv::circle(img, pivot, 5, cv::Scalar(255, 0, 255), cv::FILLED);
        cv::line(img, pivot, s.last.centroid, cv::Scalar(255, 0, 255), 1, cv::LINE_AA);
        text += "  angle " + fixedText(s.currentAngle(s.last.centroid, pivot), 1) + " deg";
      }
    } else if (s.opt.kind == "tilt") {
      const double a = s.last.axis_angle_deg / kDeg;
      const cv::Point2d d(std::sin(a), -std::cos(a));
      cv::line(img, s.last.centroid - 100 * d, s.last.centroid + 100 * d, cv::Scalar(255, 0, 0), 2, cv::LINE_AA);
      text += "  tilt " + fixedText(s.last.axis_angle_deg, 1) + " deg";
    } else if (s.opt.kind == "finger" && !s.ends.empty() && s.ends.back().ok) {
      const EndFit& f = s.ends.back();
      for (int e = 0; e < 2; ++e) {
        const cv::Point2d p = e ? f.pb : f.pa;
        const cv::Vec2d v = e ? f.vb : f.va;
        cv::line(img, p - 80 * cv::Point2d(v[0], v[1]), p + 80 * cv::Point2d(v[0], v[1]), cv::Scalar(255, 0, 0), 2,
                 cv::LINE_AA);
      }
      text += "  bend " + fixedText(std::abs(f.bend_a), 1) + " deg";
    } else if (s.opt.kind == "trajectory") {
      text += "  y " + fixedText(s.last.centroid.y, 1) + " px";
    }
  } else {
    text += "  (lost)";
  }
  drawText(img, {text});
  return img;
}

cv::Mat MotionTracker::overlayWithResult(const cv::Mat& frame_in, int index, const TrackResult& r) const {
  const Impl& s = *impl_;
  if (index < 0 || index >= static_cast<int>(s.t_all.size()) || frame_in.empty()) return cv::Mat();
  cv::Mat img = rotated(frame_in, s.opt.rotate_deg).clone();
  const double scale = std::max(1.0, img.rows / 480.0);
  const int thick = std::max(1, static_cast<int>(std::lround(scale)));
  cv::rectangle(img, s.roi, cv::Scalar(255, 128, 0), thick);
  const double t = s.t_all[index];
  std::vector<std::string> lines{"t " + fixedText(t, 2) + " s  " + r.kind + " / " + r.method};
  for (int i = std::max(1, index - 60); i <= index; ++i)
    if (s.found[i] && s.found[i - 1])
      cv::line(img, s.centroid[i - 1], s.centroid[i], cv::Scalar(0, 200, 255), thick, cv::LINE_AA);
  const Measurement& m = s.meas[index];
  // the result's signal at this frame (same time stamp)
  double value = std::numeric_limits<double>::quiet_NaN();
  const auto it = std::lower_bound(r.t.begin(), r.t.end(), t - 1e-9);
  if (it != r.t.end() && std::abs(*it - t) < 1e-9) value = r.angle_deg[it - r.t.begin()];
  if (m.found) {
    if (!m.contour.empty())
      cv::drawContours(img, std::vector<std::vector<cv::Point>>{m.contour}, 0, cv::Scalar(0, 200, 0), thick + 1);
    for (const auto& p : m.points) cv::circle(img, p, 3 * thick, cv::Scalar(255, 0, 255), cv::FILLED);
    cv::circle(img, m.centroid, 4 * thick, cv::Scalar(0, 0, 255), cv::FILLED);
  } else {
    lines.back() += "  (lost)";
  }
  if (r.refused) {
    lines.push_back(r.message);
  } else if (r.kind == "pendulum") {
    cv::circle(img, r.pivot, 5 * thick, cv::Scalar(255, 0, 255), cv::FILLED);
    if (m.found) cv::line(img, r.pivot, m.centroid, cv::Scalar(255, 0, 255), thick, cv::LINE_AA);
    if (std::isfinite(value))
      lines.push_back(
          (r.angles_known ? "angle " + fixedText(value, 1) + " deg" : "along path " + fixedText(value, 1) + " px") +
          (r.signal.oscillation_found ? "  period " + fixedText(r.signal.period_s, 3) + " s" : std::string()));
  } else if (r.kind == "tilt") {
    if (m.found && std::isfinite(value)) {
      const double a = m.axis_angle_deg / kDeg;
      const cv::Point2d d(std::sin(a), -std::cos(a));
      cv::line(img, m.centroid - 100 * scale * d, m.centroid + 100 * scale * d, cv::Scalar(255, 0, 0), 2 * thick,
               cv::LINE_AA);
      lines.push_back("tilt " + fixedText(value, 1) + " deg");
    }
  } else if (r.kind == "finger") {
    if (index < static_cast<int>(s.ends.size()) && s.ends[index].ok) {
      const EndFit& f = s.ends[index];
      for (int e = 0; e < 2; ++e) {
        const cv::Point2d p = e ? f.pb : f.pa;
        const cv::Vec2d v = e ? f.vb : f.va;
        cv::line(img, p - 80 * scale * cv::Point2d(v[0], v[1]), p + 80 * scale * cv::Point2d(v[0], v[1]),
                 cv::Scalar(255, 0, 0), 2 * thick, cv::LINE_AA);
      }
    }
    if (index < static_cast<int>(s.centrelines.size()) && s.centrelines[index].ok) {  // the profile's stations
      const std::vector<cv::Point2d> st = equalArcStations(s.centrelines[index].centreline, s.opt.profile_segments);
      for (std::size_t k = 0; k < st.size(); ++k) {
        if (k > 0) cv::line(img, st[k - 1], st[k], cv::Scalar(0, 140, 255), thick, cv::LINE_AA);
        cv::circle(img, st[k], 3 * thick, cv::Scalar(0, 140, 255), cv::FILLED, cv::LINE_AA);
      }
    }
    if (std::isfinite(value)) lines.push_back("bend " + fixedText(value, 1) + " deg (signed)");
  } else if (r.kind == "trajectory") {
    if (std::isfinite(r.floor_y_px)) {
      // the floor line, perpendicular to gravity through the mean bounce
      const cv::Point2d gd(r.gravity[0], r.gravity[1]), across(-r.gravity[1], r.gravity[0]);
      const cv::Point2d c = gd * r.floor_y_px + cv::Point2d(img.cols / 2.0, img.rows / 2.0) -
                            gd * (gd.dot(cv::Point2d(img.cols / 2.0, img.rows / 2.0)));
      cv::line(img, c - across * 4000.0, c + across * 4000.0, cv::Scalar(0, 160, 0), thick, cv::LINE_AA);
    }
    int bounces = 0;
    for (double tb : r.bounce_times_s)
      if (tb <= t) ++bounces;
    lines.push_back("bounces so far " + std::to_string(bounces) + " of " + std::to_string(r.bounce_times_s.size()));
  }
  drawText(img, lines);
  return img;
}

TrackResult MotionTracker::finish() const {
  const Impl& s = *impl_;
  TrackResult r;
  r.method = s.opt.tracker.method;
  r.kind = s.opt.kind;
  r.rotate_deg = s.opt.rotate_deg;
  r.gravity = s.opt.gravity / std::max(1e-12, cv::norm(s.opt.gravity));
  const cv::Vec2d g = r.gravity;
  const int n = static_cast<int>(s.t_all.size());
  r.frames_used = n;
  r.frames_total = n;
  r.last_frame = n - 1;
  std::vector<std::string> notes;
  const double kNaN = std::numeric_limits<double>::quiet_NaN();
  if (n == 0) {
    r.message = "no frames were tracked";
    r.refused = true;
    return r;
  }
  r.t_start_s = s.t_all.front();
  r.t_end_s = s.t_all.back();
  // frame rate and dropped frames (timestamp gaps > 1.5 nominal frame intervals), or a variable rate
  const int stride = std::max(1, s.opt.video.stride);
  const FrameSteps steps = analyseFrameSteps(s.t_all, s.opt.fps > 0 ? s.opt.fps / stride : 0.0);
  r.fps = s.opt.fps > 0 && !steps.variable ? s.opt.fps : 1.0 / steps.step_s;
  r.variable_frame_rate = steps.variable;
  r.dropped_frames = steps.dropped_frames;
  if (steps.variable)
    notes.push_back("variable frame rate: the frames are " + fixedText(1000.0 * steps.min_step_s, 1) + "–" +
                    fixedText(1000.0 * steps.max_step_s, 1) + " ms apart (median " +
                    fixedText(1000.0 * steps.median_step_s, 1) +
                    " ms), not whole multiples of one frame interval, so no frame counts as dropped; the features "
                    "use each frame's own timestamp");
  if (r.dropped_frames > 0)
    notes.push_back(std::to_string(r.dropped_frames) + " dropped frame(s) in " + std::to_string(steps.gaps) +
                    " timestamp gap(s) longer than 1.5/fps (features use the true timestamps)");
  // lost frames and where
  std::vector<double> t, axis;
  std::vector<cv::Point2d> pts;
  std::vector<const PlaneView*> views;
  for (int i = 0; i < n; ++i) {
    if (!s.found[i]) {
      ++r.lost_frames;
      continue;
    }
    t.push_back(s.t_all[i]);
    pts.push_back(s.centroid[i]);
    axis.push_back(s.axis_deg[i]);
    views.push_back(s.views[i].get());
  }
  r.object_found = !t.empty();
  const double tracking = n ? 1.0 - double(r.lost_frames) / n : 0.0;
  r.confidence["tracking"] = tracking;
  // every feature this kind gives, at 0 until measured
  const std::vector<std::string> keys = r.kind == "trajectory" ? std::vector<std::string>{"bounces", "restitution"}
                                        : r.kind == "finger"
                                            ? std::vector<std::string>{"bend_deg", "bend_profile_deg"}
                                            : std::vector<std::string>{"period_s", "amplitude_deg", "static_angle_deg"};
  for (const auto& k : keys) r.confidence[k] = 0.0;
  if (r.kind == "pendulum") r.confidence["pivot"] = 0.0;
  r.signal.period_s = r.signal.amplitude_deg = r.signal.equilibrium_deg = r.signal.max_tilt_deg = kNaN;
  r.signal.log_decrement = r.signal.damping_ratio = kNaN;
  // the rest pose too: a refusal (or a kind that never measures it) gives null, never 0 deg
  r.static_pose.angle_deg = r.static_pose.spread_deg = kNaN;
  r.bend_final_deg = r.bend_max_deg = r.bend_t_max_s = r.bend_held_deg = kNaN;
  if (r.kind == "finger") r.profile_segments = s.opt.profile_segments;
  auto refuse = [&](const std::string& why) {
    r.refused = true;
    notes.insert(notes.begin(), "refused: " + why);
    if (s.survey) {
      r.suggestion = s.survey->suggest();
      notes.insert(notes.begin() + 1, "the default marker colour (red) did not find the object; " + r.suggestion.text);
    }
    for (std::size_t i = 0; i < notes.size(); ++i) r.message += (i ? "; " : "") + notes[i];
    return r;
  };
  if (!r.object_found)
    return refuse("object never found in " + std::to_string(n) + " frames (" + fixedText(r.t_start_s, 2) + "–" +
                  fixedText(r.t_end_s, 2) + " s) by the " + r.method +
                  " tracker; check the colour range (--hsv-lower/--hsv-upper), the --roi or try another --method");
  if (r.lost_frames > s.opt.lost_warn_fraction * n) {
    // runs of lost frames
    std::string runs;
    int shown = 0;
    for (int i = 0; i < n;) {
      if (s.found[i]) {
        ++i;
        continue;
      }
      int j = i;
      while (j < n && !s.found[j]) ++j;
      if (shown < 4)
        runs += std::string(shown ? ", " : "") + fixedText(s.t_all[i], 2) + "–" + fixedText(s.t_all[j - 1], 2) + " s";
      ++shown;
      i = j;
    }
    if (shown > 4) runs += " and " + std::to_string(shown - 4) + " more";
    notes.push_back("object lost (left the frame or hidden) in " + std::to_string(r.lost_frames) + " of " +
                    std::to_string(n) + " frames (" + fixedText(100.0 * r.lost_frames / n, 1) + " %): " + runs);
  }
  // trajectories
  if (s.opt.tracker.method == "klt") {
    for (const auto& kv : s.klt_tracks) r.trajectories.push_back(kv.second);
  } else {
    std::vector<TrajectorySample> tr;
    for (std::size_t i = 0; i < t.size(); ++i) tr.push_back({t[i], pts[i].x, pts[i].y});
    r.trajectories.push_back(tr);
  }
  // one rigid object?
  r.object = checkOneObject(s.meas, r.method, s.opt.checks);
  if (!r.object.valid) return refuse(r.object.problem);
  const double base = tracking * r.object.score;

  // A tracked region whose centre does not move (within max(kStillPx, 3 × its frame-to-frame noise)
  // of one point) is not a small swing: it is something static (and when other parts of the frame
  // change, the object is elsewhere: the ROI or the colour picked the background or a fixed part).
  auto stillRegion = [&]() -> std::string {
    if (pts.size() < 8) return "";
    std::vector<double> xs, ys, dist;
    for (const auto& p : pts) xs.push_back(p.x), ys.push_back(p.y);
    const cv::Point2d mid(median(xs), median(ys));
    for (const auto& p : pts) dist.push_back(cv::norm(p - mid));
    std::sort(dist.begin(), dist.end());
    const double spread = dist[static_cast<std::size_t>(0.95 * (dist.size() - 1))];
    // the centre's white noise from its second differences (a smooth motion hardly has any): per axis
    // σ = 1.4826 MAD / √6
    auto noise = [](const std::vector<double>& v) {
      std::vector<double> d2;
      for (std::size_t i = 1; i + 1 < v.size(); ++i) d2.push_back(std::abs(v[i - 1] - 2 * v[i] + v[i + 1]));
      return 1.4826 * median(d2) / std::sqrt(6.0);
    };
    const double jitter = std::hypot(noise(xs), noise(ys));
    if (spread > std::max(kStillPx, 3.0 * jitter)) return "";
    int moving = 0;
    const double object_small_px = std::max(4.0, 0.2 * r.object.median_area_px * s.small_scale * s.small_scale);
    for (int c : s.changed_elsewhere)
      if (c >= object_small_px) ++moving;
    const std::string where = "the tracked region does not move (its centre stays within " + fixedText(spread, 2) +
                              " px of one point in 95 % of " + std::to_string(pts.size()) +
                              " frames: a blob tracker's noise level, its frame-to-frame noise is " +
                              fixedText(jitter, 2) + " px)";
    if (moving >= std::max<std::size_t>(2, s.changed_elsewhere.size() / 5))
      return "no oscillation found: " + where + " while other parts of the frame change (in " +
             std::to_string(moving) + " of " + std::to_string(s.changed_elsewhere.size()) +
             " frame steps): it follows something static; if the object moved, this is the background or a fixed "
             "part, not the object: put the region of interest on the object's path (--roi x,y,w,h, the node's "
             "~roi) or give the object's colour (--hsv-lower/--hsv-upper)";
    return "no oscillation found: " + where +
           " and nothing else in view moves: the object did not swing in this clip (if it did, it is not in view or "
           "not in the region of interest, --roi)";
  };

  auto oscillation = [&](const std::vector<double>& tt, const std::vector<double>& a, bool angles_known) {
    r.t = tt;
    r.angle_deg = a;
    r.static_pose = analyseStatic(a);
    try {
      r.signal = analyseSignal(tt, a, s.opt.signal);
    } catch (const TopoError& e) {
      r.signal = SignalFeatures();
      r.signal.message = e.what();
    }
    if (!r.signal.oscillation_found) {
      r.signal.period_s = r.signal.amplitude_deg = r.signal.log_decrement = r.signal.damping_ratio = kNaN;
      r.signal.max_tilt_deg = kNaN;
      const std::string still = stillRegion();
      if (!still.empty()) r.signal.message = still;
    }
    if (!angles_known) {  // a displacement in px: the period only
      r.signal.amplitude_deg = r.signal.equilibrium_deg = r.signal.max_tilt_deg = kNaN;
      r.static_pose = StaticPose();
      r.static_pose.angle_deg = kNaN;
    }
    const double pivot_factor = r.kind == "pendulum" ? r.confidence["pivot"] : 1.0;
    // the period rests on the timing of the crossings, which a biased centroid (a blob whose size
    // varies with blur or highlights) hardly shifts: it takes the object score's square root
    r.confidence["period_s"] =
        r.signal.oscillation_found ? tracking * std::sqrt(r.object.score) * r.signal.confidence : 0.0;
    r.confidence["amplitude_deg"] =
        r.signal.oscillation_found && angles_known ? base * r.signal.confidence * pivot_factor : 0.0;
    r.confidence["static_angle_deg"] = angles_known ? base * r.static_pose.confidence * pivot_factor : 0.0;
    if (r.signal.oscillation_found) {
      notes.insert(notes.begin(),
                   "period " + fixedText(r.signal.period_s, 4) + " s over " + std::to_string(r.signal.cycles) +
                       " cycles" +
                       (angles_known ? ", amplitude " + fixedText(r.signal.amplitude_deg, 2) + " deg, equilibrium " +
                                           fixedText(r.signal.equilibrium_deg, 2) + " deg"
                                     : std::string()) +
                       (r.signal.message.empty() ? "" : " (" + r.signal.message + ")"));
      if (r.confidence["period_s"] < 0.3)
        notes.insert(notes.begin(), "unreliable: an oscillation was fitted, but with confidence " +
                                        fixedText(r.confidence["period_s"], 2) +
                                        " (< 0.3: irregular, noisy or few swings, or a doubtful object); do not use "
                                        "these numbers");
    } else {
      const bool said = r.signal.message.find("no oscillation") != std::string::npos;
      notes.insert(notes.begin(), std::string(said ? "" : "no oscillation found: ") + r.signal.message +
                                      (angles_known ? "; static angle " + fixedText(r.static_pose.angle_deg, 2) + " deg"
                                                    : std::string()));
    }
  };

  if (s.opt.kind == "pendulum") {
    const PendulumPath path = analysePendulumPath(pts, g, s.opt.pivot_given ? &s.opt.pivot : nullptr);
    r.pivot = path.pivot;
    r.pivot_estimated = path.pivot_estimated;
    r.pivot_fit_rms_px = path.fit_rms_px;
    r.pivot_radius_rel_uncertainty = path.radius_rel_uncertainty;
    r.angles_known = path.angles_known;
    r.confidence["pivot"] = path.pivot_confidence;
    if (!path.valid) return refuse(path.problem);
    if (!path.note.empty()) notes.push_back(path.note);
    oscillation(t, path.signal, path.angles_known);
  } else if (s.opt.kind == "tilt") {
    // in the motion plane through the camera where every frame has its view, else from −gravity
    // instead of image-up
    const std::size_t without_view = std::count(views.begin(), views.end(), nullptr);
    std::string view_problem;
    if (!views.empty() && without_view == 0) {
      if (s.opt.rotate_deg != 0) view_problem = "the frames are rotated (rotate_deg), the camera model is not";
      std::vector<double> in_plane;
      for (std::size_t i = 0; i < axis.size() && view_problem.empty(); ++i) {
        try {
          in_plane.push_back(tiltInPlaneDeg(*views[i], pts[i], axis[i]));
        } catch (const TopoError& e) {
          view_problem = "at t = " + fixedText(t[i], 3) + " s: " + e.what();
        }
      }
      if (view_problem.empty()) {
        axis = in_plane;
        r.perspective = true;
        notes.push_back("tilt in the motion plane through the camera model (perspective)");
      }
    } else if (!views.empty() && without_view < views.size()) {
      view_problem = std::to_string(without_view) + " of " + std::to_string(views.size()) +
                     " frames have no camera pose or camera_info";
    }
    if (!r.perspective) {
      const double up_deg = std::atan2(-g[0], g[1]) * kDeg;
      for (double& a : axis) a -= up_deg;
      if (!view_problem.empty())
        notes.push_back("image angles, not the motion plane's (" + view_problem + ")");
    }
    oscillation(t, axis, true);
    // The axes are a line pair known modulo 90° (followTiltAxis): the one nearest the reference was
    // followed. An object resting far from the reference rests about as near the other axis, so its
    // absolute tilt (equilibrium, static angle, largest tilt) is not known; the period and the swing
    // are the same about either axis.
    const double rest = r.signal.oscillation_found ? r.signal.equilibrium_deg : r.static_pose.angle_deg;
    const double off = std::isfinite(rest) ? std::abs(wrapDeg(rest - s.opt.tilt_reference_deg)) : 0.0;
    r.tilt_axis_ambiguous = off > kTiltAmbiguityDeg;
    if (r.tilt_axis_ambiguous) {
      const double other = rest > s.opt.tilt_reference_deg ? rest - 90.0 : rest + 90.0;
      r.confidence["static_angle_deg"] = 0.0;
      r.confidence["amplitude_deg"] = 0.0;
      r.confidence["equilibrium_deg"] = 0.0;
      notes.insert(notes.begin(),
                   "the absolute tilt is ambiguous: the silhouette's axes are known only modulo 90 deg and the "
                   "object rests " +
                       fixedText(off, 1) + " deg from the tilt reference " + fixedText(s.opt.tilt_reference_deg, 1) +
                       " deg, so it reads " + fixedText(rest, 2) + " deg but may rest at " + fixedText(other, 2) +
                       " deg (the other axis); the equilibrium, static angle and largest tilt are given with "
                       "confidence 0 (the period holds). Pass the tilt it rests near, within " +
                       fixedText(kTiltAmbiguityDeg, 0) +
                       " deg (topo track --tilt-reference DEG, the node's ~tilt_reference_deg)");
    } else {
      r.confidence["equilibrium_deg"] =
          r.signal.oscillation_found ? r.confidence["period_s"] : r.confidence["static_angle_deg"];
    }
  } else if (s.opt.kind == "trajectory") {
    std::vector<double> hs;
    for (const auto& p : pts) hs.push_back(-(p.x * g[0] + p.y * g[1]));
    // the frame's extent along −gravity (apexes outside it are not kept)
    double h_lo = 1e300, h_hi = -1e300;
    for (const cv::Point2d c :
         {cv::Point2d(0, 0), cv::Point2d(s.frame_size.width, 0), cv::Point2d(0, s.frame_size.height),
          cv::Point2d(s.frame_size.width, s.frame_size.height)}) {
      const double hc = -(c.x * g[0] + c.y * g[1]);
      h_lo = std::min(h_lo, hc);
      h_hi = std::max(h_hi, hc);
    }
    r.t = t;
    for (double v : hs) r.angle_deg.push_back(-v);
    BounceOptions bo;
    bo.min_prominence_px = s.opt.min_prominence_px;
    if (r.method != "klt") bo.object_diameter_px = 2.0 * std::sqrt(r.object.median_area_px / kPi);
    std::vector<double> across;
    for (const auto& p : pts) across.push_back(-p.x * g[1] + p.y * g[0]);
    r.bounces = analyseBounces(t, hs, h_lo, h_hi, bo, &across);
    const BounceFeatures& b = r.bounces;
    r.bounce_times_s = b.bounce_times_s;
    for (double v : b.bounce_h_px) r.bounce_y_px.push_back(-v);
    r.apex_times_s = b.apex_times_s;
    for (double v : b.apex_h_px) r.apex_y_px.push_back(-v);
    r.apex_heights_px = b.apex_heights_px;
    r.floor_y_px = b.bounce_times_s.empty() ? kNaN : -b.floor_h_px;
    r.confidence["bounces"] = b.bounce_times_s.empty() ? 0.0 : base * b.confidence;
    r.confidence["restitution"] = std::isfinite(b.restitution_heights_mean) ? base * b.confidence : 0.0;
    notes.insert(notes.begin(), b.message);
  } else {  // finger
    std::vector<cv::Point2d> ca, cb;
    std::vector<double> tb, bend;
    std::vector<int> frame_of;  // the frame of each bend sample
    for (int i = 0; i < n; ++i)
      if (s.found[i] && s.ends[i].ok) {
        frame_of.push_back(i);
        ca.push_back(s.ends[i].ca);
        cb.push_back(s.ends[i].cb);
        tb.push_back(s.t_all[i]);
        bend.push_back(s.ends[i].bend_a);
      }
    if (bend.size() < 3) return refuse("the silhouette was too small or short to fit the base and tip segments");
    // a finger is long and thin: a compact blob (a servo, a hand, the background) is not one
    std::vector<double> elong;
    int at_border = 0, found_n = 0;
    for (const auto& m : s.meas)
      if (m.found) {
        elong.push_back(m.elongation);
        at_border += m.touches_border ? 1 : 0;
        ++found_n;
      }
    const double elongation = median(elong);
    if (elongation < 2.0)
      return refuse("the silhouette is not finger-like: its length is only " + fixedText(elongation, 1) +
                    " times its width (a finger's is at least 2); the tracker sees another object (set --roi around "
                    "the finger alone, --polarity, or --method marker with the finger's colour)");
    const bool cut = at_border > found_n / 2;
    if (cut)
      notes.push_back(
          "the silhouette touches the edge of the region in most frames: part of the finger (or of "
          "something else) is cut off; widen --roi if the finger is not clamped there");
    const bool base_is_a = pointSpreadPx(ca) <= pointSpreadPx(cb);
    if (!base_is_a)
      for (double& v : bend) v = -v;
    // The finger task's bend (finger_task.cpp): the chord from the segment before the tip to the tip
    // segment, against the rest axis. The clamp holds the base still in a fixed camera, so the rest
    // axis is the base line of the straightest frames (smallest tip-minus-base line angle, within
    // 0.15 deg of the least); the base line of a bent frame has turned with the free part of its third.
    double least = INFINITY;
    for (double v : bend) least = std::min(least, std::abs(v));
    std::vector<double> rest_dirs;
    std::vector<double> chord_dirs;
    std::vector<std::size_t> rest_samples;  // the straightest frames' bend samples
    for (std::size_t j = 0; j < frame_of.size(); ++j) {
      const EndFit& e = s.ends[frame_of[j]];
      const cv::Vec2d base = base_is_a ? e.va : -e.vb, chord = base_is_a ? e.chord_b : e.chord_a;
      const double base_dir = std::atan2(base[1], base[0]) * kDeg;
      chord_dirs.push_back(std::atan2(chord[1], chord[0]) * kDeg);
      if (std::abs(bend[j]) <= least + 0.15) {
        rest_dirs.push_back(base_dir);
        rest_samples.push_back(j);
      }
    }
    // the median of angles near one another (unwrapped about the first)
    for (double& v : rest_dirs) v = rest_dirs.front() + wrapDeg(v - rest_dirs.front());
    const double rest_dir = median(rest_dirs);
    for (std::size_t j = 0; j < bend.size(); ++j) bend[j] = wrapDeg(chord_dirs[j] - rest_dir);
    r.bend_rest_axis_deg = rest_dir;
    r.bend_straightest_deg = least;
    r.t = tb;
    r.angle_deg = bend;
    const std::size_t k = std::max<std::size_t>(3, bend.size() / 10);
    const std::vector<double> tail(bend.end() - std::min(k, bend.size()), bend.end());
    r.bend_final_deg = median(tail);
    // the maximum |bend|: the median of the 3 samples around the largest one (one-frame outliers)
    std::size_t im = 0;
    for (std::size_t i = 1; i < bend.size(); ++i)
      if (std::abs(bend[i]) > std::abs(bend[im])) im = i;
    const std::size_t lo = im > 0 ? im - 1 : 0, hi = std::min(bend.size() - 1, im + 1);
    std::vector<double> around(bend.begin() + lo, bend.begin() + hi + 1);
    r.bend_max_deg = median(around);
    r.bend_t_max_s = tb[im];
    // the bend at the full pressure: the median of the held frames, those within max(0.2 deg, 10 %)
    // of the largest |bend| on its side (a step or ramp to the full pressure and back: the plateau,
    // whatever part of the cycle the window ends in)
    std::vector<double> held;
    std::vector<std::size_t> held_samples;
    const double held_tol = std::max(0.2, 0.1 * std::abs(r.bend_max_deg));
    for (std::size_t j = 0; j < bend.size(); ++j)
      if (bend[j] * r.bend_max_deg >= 0 && std::abs(bend[j]) >= std::abs(r.bend_max_deg) - held_tol) {
        held.push_back(bend[j]);
        held_samples.push_back(j);
      }
    r.bend_held_deg = median(held);
    r.bend_held_frames = static_cast<int>(held.size());
    double mad = 0;  // spread of the held frames about their median
    for (double v : held) mad += std::abs(v - r.bend_held_deg);
    mad /= static_cast<double>(held.size());
    // frame-to-frame jitter of the bend (robust): a steady silhouette gives a smooth signal
    std::vector<double> jumps;
    for (std::size_t i = 1; i < bend.size(); ++i) jumps.push_back(std::abs(bend[i] - bend[i - 1]));
    const double jitter = median(jumps);
    // A window in which the finger never leaves its rest shape holds no bend at the full pressure (a
    // partial window before the pressure step, a stuck valve): refused as a feature, not a bend of 0.
    // One without straight frames measures from a bent base line, which has turned with the bend, so
    // its bend is too small (the finger twin held at its full pressure: -3.4 %): at most 0.25, below
    // the 0.3 under which a value may be outside its tolerance.
    const bool bent = std::abs(r.bend_max_deg) >= std::max(0.5, 3.0 * jitter);
    r.confidence["bend_deg"] = bent ? base * (cut ? 0.5 : 1.0) * (least > 2.0 ? 0.25 : 1.0) *
                                          std::max(0.0, 1.0 - mad / 5.0) / (1.0 + (jitter / 3.0) * (jitter / 3.0))
                                    : 0.0;
    if (!bent)
      notes.push_back("the finger did not bend in this window (largest |bend| " +
                      fixedText(std::abs(r.bend_max_deg), 2) + " deg, frame-to-frame jitter " + fixedText(jitter, 2) +
                      " deg): no bend at the full pressure was seen (confidence 0); record the pressure step");
    notes.insert(
        notes.begin(),
        "bending angle at the full pressure " + fixedText(r.bend_held_deg, 2) + " deg (median of " +
            std::to_string(held.size()) + " held frames), final " + fixedText(r.bend_final_deg, 2) + " deg, maximum " +
            fixedText(r.bend_max_deg, 2) + " deg at " + fixedText(r.bend_t_max_s, 2) +
            " s (direction of the tip chord, from the centroid of the segment before the tip to the tip segment's, "
            "each " +
            fixedText(100.0 * s.opt.tip_fraction, 0) +
            " % of the length, minus the rest axis, + clockwise on screen (image y points down); base = the " +
            std::string(base_is_a ? "first" : "second") +
            " end along the principal axis, the one that moves least; rest axis = its base line in the "
            "straightest frames, " +
            fixedText(least, 1) + " deg from straight)");
    if (least > 2.0)
      notes.push_back("the finger is never straight in this clip (its least curl is " + fixedText(least, 1) +
                      " deg): the bend is measured from the straightest frame's base line, not from rest; record "
                      "the finger at zero pressure first");
    // The bend profile at the same held frames, from the same straightest frames' base: each frame's
    // centreline base first (the end nearer that frame's base-end centroid), and the profile's
    // confidence the bend's (less its cut-silhouette halving: the profile checks its own ends) times
    // its own factor.
    std::vector<ProfileFrame> profile_frames;
    for (int i : frame_of) {
      ProfileFrame pf = s.centrelines[i];
      const cv::Point2d base_centroid = base_is_a ? s.ends[i].ca : s.ends[i].cb;
      if (pf.ok && cv::norm(pf.centreline.back() - base_centroid) < cv::norm(pf.centreline.front() - base_centroid)) {
        std::reverse(pf.centreline.begin(), pf.centreline.end());
        std::swap(pf.base_at_border, pf.tip_at_border);
      }
      profile_frames.push_back(std::move(pf));
    }
    const BendProfile profile =
        analyseBendProfile(profile_frames, rest_samples, held_samples, rest_dir, s.opt.profile_segments);
    r.bend_profile_deg = profile.held_deg;
    r.bend_profile_series_deg = profile.frames_deg;
    r.profile_rest_length_px = profile.rest_length_px;
    r.profile_rest_axis_deg = profile.rest_axis_deg;
    r.profile_held_length_px = profile.held_length_px;
    r.confidence["bend_profile_deg"] =
        bent && !profile.held_deg.empty() ? base * (least > 2.0 ? 0.25 : 1.0) * profile.confidence_factor : 0.0;
    notes.insert(notes.end(), profile.notes.begin(), profile.notes.end());
  }
  for (std::size_t i = 0; i < notes.size(); ++i) r.message += (i ? "; " : "") + notes[i];
  return r;
}

TrackResult trackVideo(const std::string& path, const TrackOptions& options,
                       const std::function<void(const cv::Mat&)>& overlay_sink) {
  VideoSource src(path, options.video);
  TrackOptions o = options;
  if (!(o.fps > 0)) o.fps = src.fps();
  MotionTracker mt(o);
  cv::Mat frame;
  double t = 0;
  while (src.read(frame, t)) mt.addFrame(frame, t);
  // A file that stops decoding well before its announced length is truncated or damaged: say so,
  // instead of the analysis's "too few frames" advice about the recording.
  const std::string truncated =
      src.endedEarly() ? "the file is truncated or unreadable after frame " + std::to_string(src.framesDecoded()) +
                             " (" + fixedText(src.framesDecoded() / src.timestampFps(), 2) +
                             " s; the container announces " + std::to_string(src.frameCount()) + " frames)"
                       : std::string();
  const std::string repair =
      "copy the complete file again or re-encode what is left, e.g. `ffmpeg -err_detect ignore_err -i IN -c:v libx264 "
      "OUT.mp4`";
  if (!truncated.empty() && mt.framesAdded() == 0) throw TopoError(path, truncated, repair);
  if (mt.framesAdded() == 0)
    throw TopoError(path,
                    "no frames in the requested time range (" + fixedText(options.video.start_s, 2) + " s to " +
                        (options.video.end_s < 0 ? std::string("end") : fixedText(options.video.end_s, 2) + " s") + ")",
                    "check --start/--end against the video's length");
  TrackResult r;
  try {
    r = mt.finish();
  } catch (const TopoError& e) {
    if (truncated.empty()) throw;
    throw TopoError(path, truncated + ", so the motion cannot be analysed (" + e.what() + ")", repair);
  }
  if (!truncated.empty()) r.message = "warning: " + truncated + "; " + r.message;
  if (src.orientationDeg() != 0)
    r.message += "; the container's rotation (" + std::to_string(src.orientationDeg()) + " deg) was applied";
  if (overlay_sink) {
    // the debug video: a second pass, every frame drawn with the final result (the JSON's pivot and values)
    VideoSource again(path, options.video);
    int index = 0;
    while (again.read(frame, t) && index < mt.framesAdded()) overlay_sink(mt.overlayWithResult(frame, index++, r));
  }
  r.source = path;
  r.fps = src.fps();
  const double stamped = src.timestampFps();
  if (r.variable_frame_rate) {
    r.fps = stamped;
    r.message += "; the container announces " + fixedText(src.fps(), 2) + " fps and " +
                 std::to_string(src.frameCount()) + " frames, " + std::to_string(src.framesDecoded()) +
                 " frames with timestamps to " + fixedText(src.timestamps().back(), 2) +
                 " s were read: a variable frame rate, read by its timestamps";
  } else if (!src.isSequence() && std::abs(stamped - src.fps()) > 0.02 * src.fps()) {
    r.fps = stamped;
    r.message += "; the container announces " + fixedText(src.fps(), 2) + " fps but the frames are stamped " +
                 fixedText(1000.0 / stamped, 1) + " ms apart (" + fixedText(stamped, 2) +
                 " fps): the timestamps are used";
  }
  r.frames_total = std::max(src.frameCount(), src.framesDecoded());
  r.first_frame = src.indices().front();
  r.last_frame = src.indices().back();
  return r;
}

std::string trackerJson(const TrackResult& r, bool with_series) {
  using json::num;
  using json::quote;
  auto array = [](const std::vector<double>& v) {
    std::string o = "[";
    for (std::size_t i = 0; i < v.size(); ++i) o += (i ? "," : "") + num(v[i]);
    return o + "]";
  };
  std::ostringstream o;
  o << "{\"fps\":" << num(r.fps) << ",\"frames_total\":" << r.frames_total
    << ",\"object_found\":" << (r.object_found ? "true" : "false") << ",\"refused\":" << (r.refused ? "true" : "false")
    << ",\"lost_frames\":" << r.lost_frames << ",\"dropped_frames\":" << r.dropped_frames
    << ",\"rotate_deg\":" << r.rotate_deg << ",\"gravity_image\":[" << num(r.gravity[0]) << "," << num(r.gravity[1])
    << "]";
  // What was not measured is null, not 0: the object checks run only once the object was found, the
  // signal and the pivot only when the clip was not refused before them.
  const bool checked = r.object.frames > 0;
  auto measured = [&](bool known, double v) { return num(known ? v : NAN); };
  o << ",\"object\":{\"valid\":" << (r.object.valid ? "true" : "false")
    << ",\"score\":" << measured(checked, r.object.score) << ",\"frames\":" << r.object.frames
    << ",\"median_area_px\":" << measured(checked, r.object.median_area_px)
    << ",\"area_spread\":" << measured(checked, r.object.area_spread)
    << ",\"jump_fraction\":" << measured(checked, r.object.jump_fraction)
    << ",\"median_mask_fraction\":" << measured(checked, r.object.median_mask_fraction)
    << ",\"median_solidity\":" << measured(checked, r.object.median_solidity)
    << ",\"colour_spread\":" << measured(checked, r.object.colour_spread) << ",\"problem\":" << quote(r.object.problem)
    << "}";
  if (r.kind == "pendulum" || r.kind == "tilt") {
    o << ",\"cycles\":" << (r.refused ? std::string("null") : std::to_string(r.signal.cycles))
      << ",\"static_angle_deg\":" << num(r.refused ? NAN : r.static_pose.angle_deg)
      << ",\"static_spread_deg\":" << num(r.refused ? NAN : r.static_pose.spread_deg);
    const bool pivot_known = r.pivot_estimated || !r.refused;
    if (r.kind == "pendulum")
      o << ",\"pivot_px\":" << (pivot_known ? "[" + num(r.pivot.x) + "," + num(r.pivot.y) + "]" : std::string("null"))
        << ",\"pivot_estimated\":" << (r.pivot_estimated ? "true" : "false")
        << ",\"pivot_fit_rms_px\":" << measured(r.pivot_estimated, r.pivot_fit_rms_px)
        << ",\"pivot_radius_rel_uncertainty\":" << measured(r.pivot_estimated, r.pivot_radius_rel_uncertainty)
        << ",\"angles_known\":" << (r.angles_known ? "true" : "false");
    else
      o << ",\"tilt_axis_ambiguous\":" << (r.tilt_axis_ambiguous ? "true" : "false");
  } else if (r.kind == "trajectory") {
    const BounceFeatures& b = r.bounces;
    o << ",\"bounce_times_s\":" << array(r.bounce_times_s) << ",\"bounce_y_px\":" << array(r.bounce_y_px)
      << ",\"apex_times_s\":" << array(r.apex_times_s) << ",\"apex_heights_px\":" << array(r.apex_heights_px)
      << ",\"floor_y_px\":" << num(r.bounce_times_s.empty() ? NAN : r.floor_y_px)
      << ",\"release_height_px\":" << num(r.bounce_times_s.empty() ? NAN : b.release_height_px)
      << ",\"restitution_from_heights\":" << array(b.restitution_from_heights)
      << ",\"restitution_from_flight_times\":" << array(b.restitution_from_times)
      << ",\"restitution_heights_mean\":" << num(b.restitution_heights_mean)
      << ",\"restitution_flight_times_mean\":" << num(b.restitution_times_mean)
      << ",\"gravity_px_s2\":" << num(r.bounce_times_s.empty() ? NAN : b.gravity_px_s2)
      << ",\"end_time_s\":" << num(b.end_time_s) << ",\"end_reason\":" << quote(b.end_reason);
    o << ",\"arcs\":[";
    for (std::size_t k = 0; k < b.arcs.size(); ++k) {
      const FlightArc& a = b.arcs[k];
      o << (k ? "," : "") << "{\"t0_s\":" << num(a.t0) << ",\"t1_s\":" << num(a.t1)
        << ",\"accel_px_s2\":" << num(a.accel_px_s2) << ",\"rms_px\":" << num(a.rms_px)
        << ",\"free_flight\":" << (a.flight ? "true" : "false") << "}";
    }
    o << "]";
  } else if (r.kind == "finger") {
    o << ",\"bend_held_deg\":" << num(r.bend_held_deg) << ",\"bend_final_deg\":" << num(r.bend_final_deg)
      << ",\"bend_max_deg\":" << num(r.bend_max_deg) << ",\"bend_t_max_s\":" << num(r.bend_t_max_s);
    auto profile = [&](const std::vector<double>& v) { return v.empty() ? std::string("null") : array(v); };
    const bool profiled = r.profile_held_length_px > 0;  // a held frame had a centreline
    o << ",\"profile_segments\":" << r.profile_segments << ",\"bend_profile_deg\":" << profile(r.bend_profile_deg)
      << ",\"profile_rest_axis_deg\":" << measured(profiled, r.profile_rest_axis_deg)
      << ",\"profile_rest_length_px\":" << measured(r.profile_rest_length_px > 0, r.profile_rest_length_px)
      << ",\"profile_held_length_px\":" << measured(profiled, r.profile_held_length_px);
    if (with_series) {
      o << ",\"bend_profile_series_deg\":[";
      for (std::size_t i = 0; i < r.bend_profile_series_deg.size(); ++i)
        o << (i ? "," : "") << profile(r.bend_profile_series_deg[i]);
      o << "]";
    }
  }
  o << ",\"confidence\":{";
  bool first = true;
  for (const auto& kv : r.confidence) {
    o << (first ? "" : ",") << quote(kv.first) << ":" << num(kv.second);
    first = false;
  }
  o << "}";
  const ColourSuggestion& sg = r.suggestion;
  o << ",\"suggestion\":";
  if (!sg.available)
    o << "null";
  else
    o << "{\"method\":" << quote(sg.method) << ",\"args\":" << quote(sg.args)
      << ",\"frames_found\":" << sg.frames_found << ",\"frames_tried\":" << sg.frames_tried
      << ",\"coloured_share\":" << num(sg.coloured_share) << ",\"hue_share\":" << num(sg.hue_share)
      << ",\"text\":" << quote(sg.text) << "}";
  o << "}";
  return o.str();
}

}  // namespace topo_gaussian::vision
