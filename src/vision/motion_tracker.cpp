// MotionTracker: frames → tracker → angle signal / trajectories → features.
#include "topo_gaussian/vision/motion_tracker.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/json.h"
#include "topo_gaussian/common/number_text.h"
#include "topo_gaussian/common/statistics.h"

namespace topo_gaussian::vision {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = 180.0 / kPi;

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
};

/// Lines through the medial band of the silhouette in the two end thirds of its principal axis.
EndFit fitEnds(const cv::Mat& mask, const cv::Point& offset, cv::Vec2d& u_prev) {
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

/// Tilt axis of a silhouette: of its two principal axes (the major one at `major_deg`, both taken
/// pointing image-up, degrees from image-up), the one nearest image vertical at the first frame and
/// after that the one nearest the previous frame's axis, unwrapped by ±180° for continuity. So an
/// object wider than tall (a tumbler) is followed by its upright (minor) axis.
double followTiltAxis(double major_deg, bool have_prev, double prev_deg) {
  const double candidates[2] = {major_deg, major_deg > 0 ? major_deg - 90.0 : major_deg + 90.0};
  const double ref = have_prev ? prev_deg : 0.0;
  double best = candidates[0], best_d = 1e300;
  for (double c : candidates) {
    const double a = c + 180.0 * std::round((ref - c) / 180.0);  // an axis is a line: c ≡ c ± 180°
    if (std::abs(a - ref) < best_d) best_d = std::abs(a - ref), best = a;
  }
  return best;
}

double spread(const std::vector<cv::Point2d>& pts) {
  if (pts.empty()) return 0.0;
  cv::Point2d m(0, 0);
  for (const auto& p : pts) m += p;
  m *= 1.0 / pts.size();
  double s = 0;
  for (const auto& p : pts) s += (p - m).dot(p - m);
  return std::sqrt(s / pts.size());
}

}  // namespace

bool fitCircleKasa(const std::vector<cv::Point2d>& pts, cv::Point2d& centre, double& radius, double& rms) {
  if (pts.size() < 3) return false;
  cv::Point2d m(0, 0);
  for (const auto& p : pts) m += p;
  m *= 1.0 / pts.size();
  const double scale = std::max(1e-9, spread(pts));
  if (scale < 2.0) return false;  // the points barely move: no circle
  cv::Mat A(static_cast<int>(pts.size()), 3, CV_64F), b(static_cast<int>(pts.size()), 1, CV_64F);
  for (int i = 0; i < A.rows; ++i) {
    const cv::Point2d q = (pts[i] - m) * (1.0 / scale);
    A.at<double>(i, 0) = q.x;
    A.at<double>(i, 1) = q.y;
    A.at<double>(i, 2) = 1.0;
    b.at<double>(i) = -(q.x * q.x + q.y * q.y);
  }
  cv::Mat w, u, vt;
  cv::SVD::compute(A, w, u, vt);
  if (w.at<double>(2) < 1e-9 * w.at<double>(0)) return false;  // collinear points
  cv::Mat s;
  cv::solve(A, b, s, cv::DECOMP_SVD);
  const double D = s.at<double>(0), E = s.at<double>(1), F = s.at<double>(2);
  const double cx = -D / 2, cy = -E / 2, r2 = cx * cx + cy * cy - F;
  if (!(r2 > 0) || !std::isfinite(r2)) return false;
  centre = m + cv::Point2d(cx, cy) * scale;
  radius = std::sqrt(r2) * scale;
  double e = 0;
  for (const auto& p : pts) {
    const double d = std::hypot(p.x - centre.x, p.y - centre.y) - radius;
    e += d * d;
  }
  rms = std::sqrt(e / pts.size());
  return radius < 1e6;
}

struct MotionTracker::Impl {
  TrackOptions opt;
  std::unique_ptr<Tracker> tracker;
  cv::Size frame_size;
  cv::Rect roi;
  std::vector<double> t_all;
  std::vector<char> found;
  std::vector<cv::Point2d> centroid;
  std::vector<double> axis_deg;
  std::vector<EndFit> ends;
  std::map<int, std::vector<TrajectorySample>> klt_tracks;
  cv::Vec2d u_prev{0, 0};
  bool have_tilt_axis = false;  ///< tilt: the axis followed so far (followTiltAxis)
  double tilt_axis_deg = 0.0;
  cv::Mat last_frame;
  Measurement last;
  double last_t = 0;

  double currentAngle(const cv::Point2d& c, const cv::Point2d& pivot) const {
    return std::atan2(c.x - pivot.x, c.y - pivot.y) * kDeg;
  }
};

MotionTracker::MotionTracker(const TrackOptions& options) : impl_(new Impl) {
  impl_->opt = options;
  const std::string& k = options.kind;
  const std::string& m = options.tracker.method;
  if (k != "pendulum" && k != "tilt" && k != "trajectory" && k != "finger")
    throw TopoError("--kind " + k, "is not a motion kind", "use pendulum, tilt, trajectory or finger");
  if (m != "marker" && m != "silhouette" && m != "klt")
    throw TopoError("--method " + m, "is not a tracking method", "use marker, silhouette or klt");
  if ((k == "tilt" || k == "finger") && m != "silhouette")
    throw TopoError("--kind " + k + " with --method " + m, "needs the silhouette's principal axis",
                    "use --method silhouette");
}

MotionTracker::~MotionTracker() = default;

int MotionTracker::framesAdded() const { return static_cast<int>(impl_->t_all.size()); }

void MotionTracker::addFrame(const cv::Mat& bgr, double t_s) {
  Impl& s = *impl_;
  if (bgr.empty())
    throw TopoError("frame at t = " + fixedText(t_s, 3) + " s",
                    "is empty (" + std::to_string(bgr.cols) + "x" + std::to_string(bgr.rows) + " pixels)",
                    "pass the camera's frames as they are; check the driver or the decoder that produced an empty one");
  if (bgr.type() != CV_8UC3)
    throw TopoError("frame at t = " + fixedText(t_s, 3) + " s",
                    "is not an 8-bit BGR image (" + std::to_string(bgr.channels()) + " channels of " +
                        std::to_string(8 * bgr.elemSize1()) + " bits)",
                    "pass CV_8UC3 frames");
  if (!s.t_all.empty() && !(t_s > s.t_all.back()))
    throw TopoError("frame at t = " + fixedText(t_s, 3) + " s",
                    "timestamps must increase (previous " + fixedText(s.t_all.back(), 3) + " s)",
                    "pass frames in time order");
  if (!s.tracker) {
    s.frame_size = bgr.size();
    TrackerOptions to = s.opt.tracker;
    if (s.opt.kind == "finger" && to.method == "silhouette") to.foreground = "otsu";
    if (to.foreground == "auto") to.foreground = s.opt.kind == "tilt" ? "otsu" : "mog2";
    s.tracker = makeTracker(to, s.frame_size);
    s.roi = validRoi(to.roi, s.frame_size, to.roi_given || to.roi != cv::Rect());
  } else if (bgr.size() != s.frame_size) {
    throw TopoError(
        "frame at t = " + fixedText(t_s, 3) + " s",
        "changes size from " + std::to_string(s.frame_size.width) + "x" + std::to_string(s.frame_size.height),
        "keep the frame size constant");
  }
  Measurement me = s.tracker->track(bgr);
  if (me.found && s.opt.kind == "tilt") {
    me.axis_angle_deg = followTiltAxis(me.axis_angle_deg, s.have_tilt_axis, s.tilt_axis_deg);
    s.have_tilt_axis = true;
    s.tilt_axis_deg = me.axis_angle_deg;
  }
  s.t_all.push_back(t_s);
  s.found.push_back(me.found ? 1 : 0);
  s.centroid.push_back(me.centroid);
  s.axis_deg.push_back(me.axis_angle_deg);
  if (s.opt.kind == "finger") {
    s.ends.push_back(me.found ? fitEnds(me.mask, s.roi.tl(), s.u_prev) : EndFit());
  }
  if (me.found && s.opt.tracker.method == "klt") {
    for (std::size_t i = 0; i < me.points.size(); ++i)
      s.klt_tracks[me.point_ids[i]].push_back({t_s, me.points[i].x, me.points[i].y});
  }
  s.last_frame = bgr;
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
  cv::putText(img, text, cv::Point(10, 25), cv::FONT_HERSHEY_SIMPLEX, 0.7, cv::Scalar(0, 0, 0), 3, cv::LINE_AA);
  cv::putText(img, text, cv::Point(10, 25), cv::FONT_HERSHEY_SIMPLEX, 0.7, cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
  return img;
}

TrackResult MotionTracker::finish() const {
  const Impl& s = *impl_;
  TrackResult r;
  r.method = s.opt.tracker.method;
  r.kind = s.opt.kind;
  const int n = static_cast<int>(s.t_all.size());
  r.frames_used = n;
  r.frames_total = n;
  r.last_frame = n - 1;
  std::vector<std::string> notes;
  if (n == 0) {
    r.message = "no frames were tracked";
    return r;
  }
  r.t_start_s = s.t_all.front();
  r.t_end_s = s.t_all.back();
  // frame rate and dropped frames (timestamp gaps > 1.5 nominal frame intervals)
  std::vector<double> dts;
  for (int i = 1; i < n; ++i) dts.push_back(s.t_all[i] - s.t_all[i - 1]);
  const double dt_nominal =
      s.opt.fps > 0 ? std::max(1, s.opt.video.stride) / s.opt.fps : (dts.empty() ? 1.0 / 30 : median(dts));
  r.fps = s.opt.fps > 0 ? s.opt.fps : 1.0 / dt_nominal;
  int gaps = 0;
  for (double dt : dts)
    if (dt > 1.5 * dt_nominal) {
      ++gaps;
      r.dropped_frames += std::max(1, static_cast<int>(std::lround(dt / dt_nominal)) - 1);
    }
  if (r.dropped_frames > 0)
    notes.push_back(std::to_string(r.dropped_frames) + " dropped frame(s) in " + std::to_string(gaps) +
                    " timestamp gap(s) longer than 1.5/fps (features use the true timestamps)");
  // lost frames and where
  std::vector<double> t, x, y, axis;
  std::vector<cv::Point2d> pts;
  for (int i = 0; i < n; ++i) {
    if (!s.found[i]) {
      ++r.lost_frames;
      continue;
    }
    t.push_back(s.t_all[i]);
    pts.push_back(s.centroid[i]);
    axis.push_back(s.axis_deg[i]);
  }
  r.object_found = !t.empty();
  r.confidence["tracking"] = n ? 1.0 - double(r.lost_frames) / n : 0.0;
  if (!r.object_found) {
    r.message = "object never found in " + std::to_string(n) + " frames (" + fixedText(r.t_start_s, 2) + "–" +
                fixedText(r.t_end_s, 2) + " s) by the " + r.method +
                " tracker; check the colour range (--hsv-lower/--hsv-upper), the --roi or try another --method";
    return r;
  }
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

  auto oscillation = [&](const std::vector<double>& tt, const std::vector<double>& a) {
    r.t = tt;
    r.angle_deg = a;
    r.static_pose = analyseStatic(a);
    try {
      r.signal = analyseSignal(tt, a, s.opt.signal);
    } catch (const TopoError& e) {
      r.signal = SignalFeatures();
      r.signal.message = e.what();
    }
    r.confidence["period_s"] = r.signal.oscillation_found ? r.signal.confidence : 0.0;
    r.confidence["amplitude_deg"] = r.signal.oscillation_found ? r.signal.confidence : 0.0;
    r.confidence["static_angle_deg"] = r.static_pose.confidence;
    if (r.signal.oscillation_found) {
      notes.insert(notes.begin(), "period " + fixedText(r.signal.period_s, 4) + " s over " +
                                      std::to_string(r.signal.cycles) + " cycles, amplitude " +
                                      fixedText(r.signal.amplitude_deg, 2) + " deg, equilibrium " +
                                      fixedText(r.signal.equilibrium_deg, 2) + " deg" +
                                      (r.signal.message.empty() ? "" : " (" + r.signal.message + ")"));
    } else {
      const bool said = r.signal.message.find("no oscillation") != std::string::npos;
      notes.insert(notes.begin(), std::string(said ? "" : "no oscillation found: ") + r.signal.message +
                                      "; static angle " + fixedText(r.static_pose.angle_deg, 2) + " deg");
    }
  };

  if (s.opt.kind == "pendulum") {
    double radius = 0, rms = 0;
    if (s.opt.pivot_given) {
      r.pivot = s.opt.pivot;
    } else if (fitCircleKasa(pts, r.pivot, radius, rms)) {
      r.pivot_estimated = true;
      r.pivot_fit_rms_px = rms;
      r.confidence["pivot"] = std::max(0.0, 1.0 - rms / 5.0);
    } else {
      r.pivot = cv::Point2d(pts[0].x, pts[0].y - s.frame_size.height);
      r.confidence["pivot"] = 0.0;
      notes.push_back(
          "the pivot could not be estimated (the marker barely moves); assumed straight above it, so "
          "angles are relative: give --pivot x,y");
    }
    std::vector<double> a;
    for (const auto& p : pts) a.push_back(s.currentAngle(p, r.pivot));
    oscillation(t, a);
  } else if (s.opt.kind == "tilt") {
    oscillation(t, axis);
  } else if (s.opt.kind == "trajectory") {
    std::vector<double> ys;
    for (const auto& p : pts) ys.push_back(p.y);
    r.t = t;
    r.angle_deg = ys;
    const double ymin = *std::min_element(ys.begin(), ys.end()), ymax = *std::max_element(ys.begin(), ys.end());
    const double h = s.opt.min_prominence_px > 0 ? s.opt.min_prominence_px : std::max(3.0, 0.05 * (ymax - ymin));
    const int m = static_cast<int>(ys.size());
    std::vector<std::pair<int, int>> ext;  // index, +1 = max y (bounce), −1 = min y (apex)
    int dir = 0, cand = 0, lo = 0, hi = 0;
    for (int i = 1; i < m; ++i) {
      if (dir == 0) {
        if (ys[i] > ys[hi]) hi = i;
        if (ys[i] < ys[lo]) lo = i;
        if (ys[hi] - ys[lo] >= h) {
          if (hi > lo) {
            if (lo > 0) ext.push_back({lo, -1});
            dir = +1;
            cand = hi;
          } else {
            if (hi > 0) ext.push_back({hi, +1});
            dir = -1;
            cand = lo;
          }
        }
      } else if (dir > 0) {
        if (ys[i] > ys[cand])
          cand = i;
        else if (ys[cand] - ys[i] >= h) {
          ext.push_back({cand, +1});
          dir = -1;
          cand = i;
        }
      } else {
        if (ys[i] < ys[cand])
          cand = i;
        else if (ys[i] - ys[cand] >= h) {
          ext.push_back({cand, -1});
          dir = +1;
          cand = i;
        }
      }
    }
    for (const auto& e : ext) {
      const int i = e.first;
      double tv = t[i], yv = ys[i];
      if (i > 0 && i + 1 < m) parabolicVertex(t[i - 1], ys[i - 1], t[i], ys[i], t[i + 1], ys[i + 1], tv, yv);
      if (e.second > 0) {
        r.bounce_times_s.push_back(tv);
        r.bounce_y_px.push_back(yv);
      } else {
        r.apex_times_s.push_back(tv);
        r.apex_y_px.push_back(yv);
      }
    }
    if (!r.bounce_y_px.empty()) {
      r.floor_y_px = std::accumulate(r.bounce_y_px.begin(), r.bounce_y_px.end(), 0.0) / r.bounce_y_px.size();
      for (double ay : r.apex_y_px) r.apex_heights_px.push_back(r.floor_y_px - ay);
    }
    r.confidence["bounces"] = r.bounce_times_s.empty() ? 0.0 : r.confidence["tracking"];
    std::string b = std::to_string(r.bounce_times_s.size()) + " bounce(s)";
    if (!r.bounce_times_s.empty()) {
      b += " at";
      for (double v : r.bounce_times_s) b += " " + fixedText(v, 3);
      b += " s";
    }
    b += ", " + std::to_string(r.apex_times_s.size()) + " apex(es)";
    if (!r.apex_heights_px.empty()) {
      b += " of height";
      for (double v : r.apex_heights_px) b += " " + fixedText(v, 1);
      b += " px above the bounce level";
    }
    notes.insert(notes.begin(), b);
  } else {  // finger
    std::vector<cv::Point2d> ca, cb;
    std::vector<double> tb, bend;
    for (int i = 0; i < n; ++i)
      if (s.found[i] && s.ends[i].ok) {
        ca.push_back(s.ends[i].ca);
        cb.push_back(s.ends[i].cb);
        tb.push_back(s.t_all[i]);
        bend.push_back(s.ends[i].bend_a);
      }
    if (bend.empty()) {
      notes.insert(notes.begin(), "the silhouette was too small or short to fit the base and tip segments");
      r.confidence["bend_deg"] = 0.0;
    } else {
      const bool base_is_a = spread(ca) <= spread(cb);
      if (!base_is_a)
        for (double& v : bend) v = -v;
      r.t = tb;
      r.angle_deg = bend;
      const std::size_t k = std::max<std::size_t>(3, bend.size() / 10);
      const std::vector<double> tail(bend.end() - std::min(k, bend.size()), bend.end());
      r.bend_final_deg = median(tail);
      double mad = 0;
      for (double v : tail) mad += std::abs(v - r.bend_final_deg);
      mad /= tail.size();
      r.confidence["bend_deg"] = r.confidence["tracking"] * std::max(0.0, 1.0 - mad / 5.0);
      notes.insert(notes.begin(), "final bending angle " + fixedText(r.bend_final_deg, 2) +
                                      " deg (tip minus base direction; base = the " +
                                      std::string(base_is_a ? "first" : "second") +
                                      " end along the principal axis, the one that moves least)");
    }
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
  while (src.read(frame, t)) {
    mt.addFrame(frame, t);
    if (overlay_sink) overlay_sink(mt.overlay());
  }
  // A file that stops decoding well before its announced length is truncated or damaged: say so,
  // instead of the analysis's "too few frames" advice about the recording.
  const std::string truncated =
      src.endedEarly() ? "the file is truncated or unreadable after frame " + std::to_string(src.framesDecoded()) +
                             " (" + fixedText(src.framesDecoded() / src.fps(), 2) + " s; the container announces " +
                             std::to_string(src.frameCount()) + " frames)"
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
  r.source = path;
  r.fps = src.fps();
  r.frames_total = std::max(src.frameCount(), src.framesDecoded());
  r.first_frame = src.indices().front();
  r.last_frame = src.indices().back();
  return r;
}

std::string trackerJson(const TrackResult& r) {
  using json::num;
  using json::quote;
  auto array = [](const std::vector<double>& v) {
    std::string o = "[";
    for (std::size_t i = 0; i < v.size(); ++i) o += (i ? "," : "") + num(v[i]);
    return o + "]";
  };
  std::ostringstream o;
  o << "{\"fps\":" << num(r.fps) << ",\"frames_total\":" << r.frames_total
    << ",\"object_found\":" << (r.object_found ? "true" : "false") << ",\"lost_frames\":" << r.lost_frames
    << ",\"dropped_frames\":" << r.dropped_frames;
  if (r.kind == "pendulum" || r.kind == "tilt") {
    o << ",\"cycles\":" << r.signal.cycles << ",\"static_angle_deg\":" << num(r.static_pose.angle_deg)
      << ",\"static_spread_deg\":" << num(r.static_pose.spread_deg);
    if (r.kind == "pendulum")
      o << ",\"pivot_px\":[" << num(r.pivot.x) << "," << num(r.pivot.y)
        << "],\"pivot_estimated\":" << (r.pivot_estimated ? "true" : "false")
        << ",\"pivot_fit_rms_px\":" << num(r.pivot_fit_rms_px);
  } else if (r.kind == "trajectory") {
    o << ",\"bounce_times_s\":" << array(r.bounce_times_s) << ",\"bounce_y_px\":" << array(r.bounce_y_px)
      << ",\"apex_times_s\":" << array(r.apex_times_s) << ",\"apex_heights_px\":" << array(r.apex_heights_px)
      << ",\"floor_y_px\":" << num(r.floor_y_px);
  }
  o << ",\"confidence\":{";
  bool first = true;
  for (const auto& kv : r.confidence) {
    o << (first ? "" : ",") << quote(kv.first) << ":" << num(kv.second);
    first = false;
  }
  o << "}}";
  return o.str();
}

}  // namespace topo_gaussian::vision
