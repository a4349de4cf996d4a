#include "topo_gaussian/geometry/view_coverage.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/number_text.h"

namespace topo_gaussian::geometry {

namespace {

constexpr double kPi = 3.14159265358979323846;

std::string vec(const Eigen::Vector3d& v, int digits) {
  return "(" + numberText(v.x(), digits) + ", " + numberText(v.y(), digits) + ", " + numberText(v.z(), digits) + ")";
}

/// "+x", "-z", ... when `d` is within 30 deg of an axis, else "".
std::string axisName(const Eigen::Vector3d& d) {
  int k = 0;
  d.cwiseAbs().maxCoeff(&k);
  if (std::abs(d[k]) < std::cos(30.0 * kPi / 180.0)) return "";
  return std::string(d[k] > 0 ? "+" : "-") + "xyz"[k];
}

std::string percent(double f) { return numberText(100.0 * f, 3) + " %"; }

}  // namespace

std::string CoverageHole::text(const std::string& frame) const {
  const std::string axis = axisName(direction);
  return "a hole of " + percent(fraction) + " of the surface facing " + vec(direction, 2) +
         (axis.empty() ? "" : " (" + axis + ")") + ", ~" + numberText(2.0 * half_angle_deg, 3) +
         " deg across, around " + vec(position, 3) + " m in frame " + frame;
}

std::string ViewCoverage::summary(const std::string& frame) const {
  std::string s = "coverage " + percent(fraction) + " (" + std::to_string(bins) + " directions from the centre " +
                  vec(centre, 3) + " m, radius " + numberText(radius, 3) + " m, frame " + frame + ")";
  if (holes.empty()) return s + ", no hole";
  s += "; " + std::to_string(holes.size()) + (holes.size() == 1 ? " hole" : " holes") + ", the largest: ";
  for (std::size_t i = 0; i < holes.size() && i < 3; ++i) s += (i ? "; " : "") + holes[i].text(frame);
  return s;
}

ViewCoverage viewCoverage(const std::vector<Eigen::Vector3d>& points, int bins) {
  ViewCoverage c;
  const int m = std::max(bins, 20);
  c.bins = std::size_t(m);
  // Equal-area directions (Fibonacci lattice) and which of them touch.
  std::vector<Eigen::Vector3d> dirs(m);
  const double golden = kPi * (3.0 - std::sqrt(5.0));
  for (int i = 0; i < m; ++i) {
    const double z = 1.0 - (2.0 * i + 1.0) / m, rho = std::sqrt(std::max(0.0, 1.0 - z * z));
    dirs[i] = Eigen::Vector3d(rho * std::cos(golden * i), rho * std::sin(golden * i), z);
  }
  std::vector<char> seen(m, 0);
  if (points.size() >= 4) {
    Eigen::Vector3d lo = points.front(), hi = points.front();
    for (const auto& p : points) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
    c.centre = 0.5 * (lo + hi);
    for (const auto& p : points) {
      const Eigen::Vector3d d = p - c.centre;
      const double r = d.norm();
      c.radius = std::max(c.radius, r);
      if (!(r > 0.0)) continue;
      int best = 0;
      double best_dot = -2.0;
      for (int i = 0; i < m; ++i) {
        const double dot = dirs[i].dot(d);
        if (dot > best_dot) best_dot = dot, best = i;
      }
      seen[best] = 1;
    }
  }
  const double spacing = std::sqrt(4.0 * kPi / m);  // mean angle between neighbouring directions
  const double touch = std::cos(1.8 * spacing);
  int n_seen = 0;
  for (char s : seen) n_seen += s;
  c.fraction = double(n_seen) / m;
  // Unseen directions that touch: one hole each group.
  std::vector<int> group(m, -1);
  for (int start = 0; start < m; ++start) {
    if (seen[start] || group[start] >= 0) continue;
    const int g = int(c.holes.size());
    std::vector<int> stack{start}, members;
    group[start] = g;
    while (!stack.empty()) {
      const int i = stack.back();
      stack.pop_back();
      members.push_back(i);
      for (int j = 0; j < m; ++j)
        if (!seen[j] && group[j] < 0 && dirs[i].dot(dirs[j]) >= touch) group[j] = g, stack.push_back(j);
    }
    CoverageHole h;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (int i : members) sum += dirs[i];
    h.direction = sum.norm() > 1e-9 ? Eigen::Vector3d(sum.normalized()) : dirs[start];
    h.fraction = double(members.size()) / m;
    h.half_angle_deg = std::acos(std::clamp(1.0 - 2.0 * h.fraction, -1.0, 1.0)) * 180.0 / kPi;
    h.position = c.centre + c.radius * h.direction;
    h.viewpoint = c.centre + 3.0 * c.radius * h.direction;
    c.holes.push_back(h);
  }
  std::sort(c.holes.begin(), c.holes.end(),
            [](const CoverageHole& a, const CoverageHole& b) { return a.fraction > b.fraction; });
  return c;
}

void requireCoverage(const ViewCoverage& c, double min_fraction, const std::string& input, const std::string& frame) {
  if (c.fraction >= min_fraction) return;
  std::string problem = "the views cover " + percent(c.fraction) + " of the object's outside, below the " +
                        percent(min_fraction) + " asked for";
  std::string fix = "add views, then finish again";
  if (!c.holes.empty()) {
    const CoverageHole& h = c.holes.front();
    problem += "; the largest unseen part is " + h.text(frame);
    fix = "add a view from around " + vec(h.viewpoint, 3) + " m in frame " + frame + " looking at " +
          vec(c.centre, 3) + " (or turn the object so that side faces the camera), then finish again; " +
          "a shape with a through hole (a torus, a handle) has directions with no surface: lower the minimum "
          "coverage for it";
  }
  throw TopoError(input, problem, fix);
}

}  // namespace topo_gaussian::geometry
