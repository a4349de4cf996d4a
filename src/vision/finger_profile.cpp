// chordAnglesDeg, baseThirdDirectionDeg, analyseBendProfile (vision/finger_profile.h).
#include "topo_gaussian/vision/finger_profile.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "topo_gaussian/common/number_text.h"
#include "topo_gaussian/common/statistics.h"
#include "topo_gaussian/vision/finger_centreline.h"

namespace topo_gaussian::vision {
namespace {

constexpr double kDeg = 180.0 / M_PI;

double wrapDeg(double a) {
  a = std::fmod(a, 360.0);
  if (a > 180.0) a -= 360.0;
  if (a <= -180.0) a += 360.0;
  return a;
}

std::string degreesText(const std::vector<double>& v) {
  std::string s;
  for (std::size_t k = 0; k < v.size(); ++k) s += (k ? ", " : "") + fixedText(v[k], 2);
  return s;
}

/// The median of angles near one another (unwrapped about the first).
double medianDirectionDeg(std::vector<double> v) {
  for (double& a : v) a = v.front() + wrapDeg(a - v.front());
  return wrapDeg(median(v));
}

}  // namespace

std::vector<double> chordAnglesDeg(const std::vector<cv::Point2d>& st, double rest_dir_deg) {
  std::vector<double> theta;
  for (std::size_t k = 1; k < st.size(); ++k) {
    const cv::Point2d d = st[k] - st[k - 1];
    const double raw = wrapDeg(std::atan2(d.y, d.x) * kDeg - rest_dir_deg);
    theta.push_back(theta.empty() ? raw : theta.back() + wrapDeg(raw - theta.back()));
  }
  return theta;
}

double baseThirdDirectionDeg(const std::vector<cv::Point2d>& c) {
  if (c.size() < 2) return 0.0;
  double total = 0;
  for (std::size_t i = 1; i < c.size(); ++i) total += cv::norm(c[i] - c[i - 1]);
  std::vector<cv::Point2d> third{c.front()};
  double s = 0;
  for (std::size_t i = 1; i < c.size() && s + cv::norm(c[i] - c[i - 1]) <= total / 3.0; ++i) {
    s += cv::norm(c[i] - c[i - 1]);
    third.push_back(c[i]);
  }
  if (third.size() < 2) third.push_back(c[1]);
  const std::vector<cv::Point2f> pts(third.begin(), third.end());
  cv::Vec4f line;  // least squares (perpendicular distances): the principal axis
  cv::fitLine(pts, line, cv::DIST_L2, 0, 0.01, 0.01);
  cv::Point2d u(line[0], line[1]);
  if (u.dot(third.back() - third.front()) < 0) u = -u;
  return std::atan2(u.y, u.x) * kDeg;
}

BendProfile analyseBendProfile(const std::vector<ProfileFrame>& frames, const std::vector<std::size_t>& rest,
                               const std::vector<std::size_t>& held, double fallback_rest_dir_deg, int segments) {
  BendProfile p;
  p.segments = segments;
  auto ok = [&](std::size_t i) { return i < frames.size() && frames[i].ok && frames[i].centreline.size() >= 2; };
  // the rest axis: the base third's line in the rest frames
  std::vector<double> rest_dirs, rest_lengths;
  std::vector<double> rx, ry;
  for (std::size_t i : rest)
    if (ok(i)) {
      rest_dirs.push_back(baseThirdDirectionDeg(frames[i].centreline));
      rest_lengths.push_back(frames[i].length_px);
      rx.push_back(frames[i].centreline.front().x);
      ry.push_back(frames[i].centreline.front().y);
    }
  p.rest_axis_deg = rest_dirs.empty() ? fallback_rest_dir_deg : medianDirectionDeg(rest_dirs);
  for (std::size_t i = 0; i < frames.size(); ++i)
    p.frames_deg.push_back(ok(i) ? chordAnglesDeg(equalArcStations(frames[i].centreline, segments), p.rest_axis_deg)
                                 : std::vector<double>());
  std::vector<std::size_t> used;
  for (std::size_t i : held)
    if (ok(i)) used.push_back(i);
  p.held_frames_used = static_cast<int>(used.size());
  if (used.empty()) {
    p.notes.push_back("no bend profile: no centreline was found in the " + std::to_string(held.size()) +
                      " held frames");
    return p;
  }
  // the median of each θ_k over the held frames, and their spread about it
  std::vector<double> lengths, hx, hy;
  int tip_cut = 0;
  for (std::size_t i : used) {
    lengths.push_back(frames[i].length_px);
    hx.push_back(frames[i].centreline.front().x);
    hy.push_back(frames[i].centreline.front().y);
    tip_cut += frames[i].tip_at_border ? 1 : 0;
  }
  p.held_length_px = median(lengths);
  for (int k = 0; k < segments; ++k) {
    std::vector<double> v;
    for (std::size_t i : used) v.push_back(p.frames_deg[i][k]);
    const double m = median(v);
    double mad = 0;
    for (double x : v) mad += std::abs(x - m);
    p.spread_deg = std::max(p.spread_deg, mad / static_cast<double>(v.size()));
    p.held_deg.push_back(m);
  }
  // frame-to-frame jitter of each θ_k (consecutive frames with a centreline)
  for (int k = 0; k < segments; ++k) {
    std::vector<double> jumps;
    for (std::size_t i = 1; i < frames.size(); ++i)
      if (ok(i) && ok(i - 1)) jumps.push_back(std::abs(p.frames_deg[i][k] - p.frames_deg[i - 1][k]));
    p.jitter_deg = std::max(p.jitter_deg, median(jumps));
  }
  const double share = static_cast<double>(used.size()) / static_cast<double>(held.size());
  p.confidence_factor =
      share * std::max(0.0, 1.0 - p.spread_deg / 5.0) / (1.0 + (p.jitter_deg / 3.0) * (p.jitter_deg / 3.0));
  // the base is clamped and the finger does not shorten: compare the held frames with the rest frames
  const std::string refused = "bend profile not measured (confidence 0): ";
  bool failed = false;  // a check below refuses the profile
  if (rest_lengths.empty()) {
    p.confidence_factor *= 0.5;
    p.notes.push_back(
        "no centreline in the straightest frames: the bend profile is measured from the tracker's rest "
        "axis and its base and length are not checked against rest (confidence halved)");
  } else {
    p.rest_length_px = median(rest_lengths);
    p.base_shift_px = std::hypot(median(hx) - median(rx), median(hy) - median(ry));
    if (p.held_length_px < 0.95 * p.rest_length_px) {
      failed = true;
      p.notes.push_back(refused + "the finger's centreline is " + fixedText(p.held_length_px, 1) +
                        " px long at the held bend but " + fixedText(p.rest_length_px, 1) +
                        " px at rest: its tip is hidden or cut, or it bends out of the image plane; film it "
                        "whole, from the side");
    }
    const double base_tol = std::max(3.0, 0.03 * p.rest_length_px);
    if (p.base_shift_px > base_tol) {
      failed = true;
      p.notes.push_back(refused + "the base end of the finger moved by " + fixedText(p.base_shift_px, 1) +
                        " px between rest and the held bend (more than " + fixedText(base_tol, 1) +
                        " px): it is not held by the clamp in view (covered, or the camera moved); keep the "
                        "clamp's edge visible and the camera fixed");
    }
  }
  if (2 * tip_cut > static_cast<int>(used.size())) {
    failed = true;
    p.notes.push_back(refused + "the finger's tip reaches the edge of the region in " + std::to_string(tip_cut) +
                      " of " + std::to_string(used.size()) +
                      " held frames: the finger leaves the frame (or --roi); widen the view");
  }
  const double segment_px = p.held_length_px / segments;
  if (segment_px < 3.0) {
    failed = true;
    p.notes.push_back(refused + "its " + std::to_string(segments) + " segments are " + fixedText(segment_px, 1) +
                      " px long (under 3 px); use fewer segments (profile_segments) or a closer view");
  }
  if (failed) {
    p.confidence_factor = 0.0;
    p.held_deg.clear();  // what the checks refuse is not a measurement (null in the JSON)
    return p;
  }
  p.notes.push_back("bend profile (" + std::to_string(segments) + " equal arc-length segments, base to tip, " +
                    fixedText(segment_px, 1) + " px each, against the base third's line at rest, " +
                    fixedText(p.rest_axis_deg, 2) + " deg) " + degreesText(p.held_deg) + " deg (median of " +
                    std::to_string(used.size()) + " held frames)");
  return p;
}

}  // namespace topo_gaussian::vision
