// analysePendulumPath: pivot, arc and hanging checks and the unwrapped angle (vision/pendulum_path.h).
#include "topo_gaussian/vision/pendulum_path.h"

#include <algorithm>
#include <cmath>

#include "topo_gaussian/common/number_text.h"

namespace topo_gaussian::vision {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = 180.0 / kPi;

/// Angles about `pivot` from gravity, unwrapped (successive differences brought into ±180°).
std::vector<double> unwrappedAngles(const std::vector<cv::Point2d>& pts, const cv::Point2d& pivot, const cv::Vec2d& g) {
  std::vector<double> a;
  for (const auto& p : pts) {
    const cv::Point2d d = p - pivot;
    double v = std::atan2(g[1] * d.x - g[0] * d.y, g[0] * d.x + g[1] * d.y) * kDeg;
    if (!a.empty()) v += 360.0 * std::round((a.back() - v) / 360.0);
    a.push_back(v);
  }
  return a;
}

}  // namespace

double pointSpreadPx(const std::vector<cv::Point2d>& pts) {
  if (pts.empty()) return 0.0;
  cv::Point2d m(0, 0);
  for (const auto& p : pts) m += p;
  m *= 1.0 / pts.size();
  double s = 0;
  for (const auto& p : pts) s += (p - m).dot(p - m);
  return std::sqrt(s / pts.size());
}

bool fitCircleKasa(const std::vector<cv::Point2d>& pts, cv::Point2d& centre, double& radius, double& rms) {
  if (pts.size() < 3) return false;
  cv::Point2d m(0, 0);
  for (const auto& p : pts) m += p;
  m *= 1.0 / pts.size();
  const double scale = std::max(1e-9, pointSpreadPx(pts));
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

PendulumPath analysePendulumPath(const std::vector<cv::Point2d>& pts, const cv::Vec2d& gravity,
                                 const cv::Point2d* pivot_given) {
  PendulumPath r;
  const double gn = std::hypot(gravity[0], gravity[1]);
  const cv::Vec2d g = gn > 0 ? gravity / gn : cv::Vec2d(0, 1);
  if (pts.empty()) {
    r.problem = "no positions";
    return r;
  }
  cv::Point2d mean(0, 0);
  for (const auto& p : pts) mean += p;
  mean *= 1.0 / pts.size();
  const double sd = pointSpreadPx(pts);
  // principal direction of the path
  double sxx = 0, syy = 0, sxy = 0;
  for (const auto& p : pts) {
    const cv::Point2d d = p - mean;
    sxx += d.x * d.x;
    syy += d.y * d.y;
    sxy += d.x * d.y;
  }
  const double th = 0.5 * std::atan2(2 * sxy, sxx - syy);
  const cv::Vec2d e1(std::cos(th), std::sin(th));
  const double tr = sxx + syy, det = sxx * syy - sxy * sxy;
  const double l1 = 0.5 * tr + std::sqrt(std::max(0.0, 0.25 * tr * tr - det)), l2 = std::max(0.0, tr - l1);
  double smin = 1e300, smax = -1e300;
  for (const auto& p : pts) {
    const double s = (p - mean).x * e1[0] + (p - mean).y * e1[1];
    smin = std::min(smin, s);
    smax = std::max(smax, s);
  }
  const double extent = smax - smin;

  if (sd < 2.0 && !pivot_given) {
    // barely moving: a hanging object at rest; the angle is relative to straight along gravity
    r.valid = true;
    r.pivot = mean - cv::Point2d(g[0], g[1]) * 1000.0;
    r.angles_known = true;
    r.note =
        "the pivot could not be estimated (the object barely moves); assumed along gravity above it, so "
        "angles are relative: give --pivot x,y";
    r.signal = unwrappedAngles(pts, r.pivot, g);
    return r;
  }
  const double along_gravity = std::abs(e1.dot(g));
  if (along_gravity > std::cos(45.0 / kDeg) && l1 > 4.0 * l2 && sd >= 2.0) {
    r.problem = "the object moves along gravity (its path is " +
                fixedText(std::acos(std::min(1.0, along_gravity)) * kDeg, 0) + " deg from the gravity direction, " +
                fixedText(extent, 0) +
                " px long), not across it as a pendulum swings: a bounce or a vertical oscillation; use --kind "
                "trajectory for a ball, or give --gravity x,y / --rotate if the video is rotated";
    return r;
  }
  if (pivot_given) {
    r.pivot = *pivot_given;
    r.angles_known = true;
    r.pivot_confidence = 1.0;
  } else {
    double radius = 0, rms = 0;
    cv::Point2d c;
    const bool ok = fitCircleKasa(pts, c, radius, rms);
    if (!ok || radius > 30.0 * std::max(extent, 1.0)) {
      // straight path: the period is measurable from the displacement, the angle is not
      r.valid = true;
      r.angles_known = false;
      r.pivot = mean - cv::Point2d(g[0], g[1]) * 1e4;
      r.note = "the path is too straight to locate the pivot (" + fixedText(extent, 0) +
               " px long); period from the displacement along it, no angles: give --pivot x,y for the amplitude";
      for (const auto& p : pts) r.signal.push_back((p - mean).x * e1[0] + (p - mean).y * e1[1]);
      return r;
    }
    r.pivot = c;
    r.pivot_estimated = true;
    r.radius_px = radius;
    r.fit_rms_px = rms;
    const double rms_limit = std::max(3.0, 0.1 * sd);
    if (rms > rms_limit) {
      r.problem = "the path is not an arc: the circle fit leaves " + fixedText(rms, 1) + " px rms (limit " +
                  fixedText(rms_limit, 1) +
                  " px); the object is not swinging about one pivot, or the tracker follows something else";
      return r;
    }
    // How well the radius is known: circle fits to 4 groups of 10-frame blocks (each group spans the
    // whole arc over the cycles; blocks keep a shaking camera's correlated error inside one group).
    // The angle scales as 1/R, so the relative spread of R is the amplitude's relative uncertainty.
    std::vector<double> radii;
    for (int grp = 0; grp < 4; ++grp) {
      std::vector<cv::Point2d> sub;
      for (std::size_t i = 0; i < pts.size(); ++i)
        if ((i / 10) % 4 == static_cast<std::size_t>(grp)) sub.push_back(pts[i]);
      cv::Point2d cg;
      double rg = 0, rmsg = 0;
      if (sub.size() >= 10 && fitCircleKasa(sub, cg, rg, rmsg)) radii.push_back(rg);
    }
    double rel_sd = 1.0;  // unknown: as bad as it gets
    if (radii.size() >= 3) {
      double mean_r = 0, var = 0;
      for (double v : radii) mean_r += v / radii.size();
      for (double v : radii) var += (v - mean_r) * (v - mean_r) / (radii.size() - 1);
      rel_sd = std::sqrt(var / radii.size()) / radius;  // standard error of the mean of the groups
    }
    r.radius_rel_uncertainty = rel_sd;
    r.pivot_confidence = std::max(0.0, 1.0 - rms / rms_limit) / (1.0 + (rel_sd / 0.08) * (rel_sd / 0.08));
  }
  const cv::Point2d to_pivot = r.pivot - mean;
  if (to_pivot.x * g[0] + to_pivot.y * g[1] >= 0.0) {
    r.problem = std::string(pivot_given ? "the given pivot" : "the fitted pivot") + " (" + fixedText(r.pivot.x, 0) +
                ", " + fixedText(r.pivot.y, 0) +
                ") lies below the path (along gravity): the path curves the wrong way for a hanging pendulum; give "
                "--pivot x,y, or --gravity/--rotate if the video is rotated";
    return r;
  }
  r.signal = unwrappedAngles(pts, r.pivot, g);
  const double span =
      *std::max_element(r.signal.begin(), r.signal.end()) - *std::min_element(r.signal.begin(), r.signal.end());
  if (span > 170.0) {
    r.problem = "the path spans " + fixedText(span, 0) + " deg about the " +
                std::string(pivot_given ? "given" : "fitted") + " pivot (" + fixedText(r.pivot.x, 0) + ", " +
                fixedText(r.pivot.y, 0) +
                "): the pivot lies inside the path, so the angle is meaningless; give --pivot x,y";
    r.signal.clear();
    return r;
  }
  r.angles_known = true;
  r.valid = true;
  return r;
}

}  // namespace topo_gaussian::vision
