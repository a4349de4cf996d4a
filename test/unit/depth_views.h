// Test helper: a structured-light depth camera looking at an analytic solid (a sphere or a box), so
// the view fusion and cloud_ingest's depth path are tested against known surfaces and volumes.
// Noise model: depth noise along the ray with sigma = sigma_per_m2 * z^2 (structured light: the
// disparity error grows the depth error with z^2), no return where the ray meets the surface at more
// than max_incidence_deg from its normal (edge dropouts), and random dropouts.
#pragma once

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <random>
#include <vector>

#include "topo_gaussian/geometry/view_fusion.h"

namespace topo_test {

/// A ray hit: distance along the (unit) ray and the outward normal; t < 0 for a miss.
struct RayHit {
  double t = -1.0;
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
};
using Solid = std::function<RayHit(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir)>;

inline Solid sphereSolid(const Eigen::Vector3d& centre, double R) {
  return [=](const Eigen::Vector3d& o, const Eigen::Vector3d& d) {
    const Eigen::Vector3d oc = o - centre;
    const double b = oc.dot(d), c = oc.squaredNorm() - R * R, disc = b * b - c;
    RayHit h;
    if (disc < 0.0) return h;
    const double t = -b - std::sqrt(disc);
    if (t <= 0.0) return h;
    h.t = t;
    h.normal = (o + t * d - centre).normalized();
    return h;
  };
}

/// An axis-aligned box centre ± half.
inline Solid boxSolid(const Eigen::Vector3d& centre, const Eigen::Vector3d& half) {
  return [=](const Eigen::Vector3d& o, const Eigen::Vector3d& d) {
    double t0 = -std::numeric_limits<double>::infinity(), t1 = std::numeric_limits<double>::infinity();
    int axis = 0;
    double sign = 1.0;
    for (int k = 0; k < 3; ++k) {
      const double lo = centre[k] - half[k], hi = centre[k] + half[k];
      if (std::abs(d[k]) < 1e-15) {
        if (o[k] < lo || o[k] > hi) return RayHit{};
        continue;
      }
      double a = (lo - o[k]) / d[k], b = (hi - o[k]) / d[k];
      const double s = d[k] > 0 ? -1.0 : 1.0;  // the face entered first faces the ray
      if (a > b) std::swap(a, b);
      if (a > t0) t0 = a, axis = k, sign = s;
      t1 = std::min(t1, b);
    }
    RayHit h;
    if (t0 > t1 || t0 <= 0.0) return h;
    h.t = t0;
    h.normal = Eigen::Vector3d::Zero();
    h.normal[axis] = sign;
    return h;
  };
}

struct DepthCamera {
  int width = 160, height = 120;
  double focal_px = 300.0;
  double sigma_per_m2 = 5e-3;       ///< depth sigma = this * z^2 [m]
  double max_incidence_deg = 75.0;  ///< no return beyond (edge dropouts)
  double dropout = 0.03;            ///< random missing returns
};

/// world <- camera optical frame (z forward, x right, y down) for a camera at `eye` looking at `target`.
inline Eigen::Isometry3d lookAt(const Eigen::Vector3d& eye, const Eigen::Vector3d& target) {
  const Eigen::Vector3d z = (target - eye).normalized();
  const Eigen::Vector3d hint = std::abs(z.z()) > 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d x = z.cross(hint).normalized(), y = z.cross(x);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear().col(0) = x;
  T.linear().col(1) = y;
  T.linear().col(2) = z;
  T.translation() = eye;
  return T;
}

/// One depth view of `solid` from `eye` towards `target`, points in the camera's optical frame
/// (a missing return is a NaN point, as an organised depth cloud has it).
inline topo_gaussian::geometry::DepthView depthView(const Solid& solid, const Eigen::Vector3d& eye,
                                                     const Eigen::Vector3d& target, const DepthCamera& cam,
                                                     std::mt19937& rng) {
  topo_gaussian::geometry::DepthView v;
  v.world_from_sensor = lookAt(eye, target);
  const Eigen::Matrix3d R = v.world_from_sensor.linear();
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  const double cos_max = std::cos(cam.max_incidence_deg * M_PI / 180.0);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (int row = 0; row < cam.height; ++row)
    for (int col = 0; col < cam.width; ++col) {
      const Eigen::Vector3d ray_cam((col + 0.5 - 0.5 * cam.width) / cam.focal_px,
                                    (row + 0.5 - 0.5 * cam.height) / cam.focal_px, 1.0);
      const Eigen::Vector3d dir = (R * ray_cam).normalized();
      const RayHit h = solid(eye, dir);
      const bool edge = h.t > 0.0 && -h.normal.dot(dir) < cos_max;
      if (h.t <= 0.0 || edge || uni(rng) < cam.dropout) {
        v.points.emplace_back(nan, nan, nan);
        continue;
      }
      const double z = h.t * dir.dot(R.col(2));  // depth along the optical axis
      const double noisy = z + cam.sigma_per_m2 * z * z * gauss(rng);
      v.points.push_back(ray_cam * noisy);
    }
  return v;
}

/// The 14 directions of a cube's faces and corners (unit), for viewpoints all round an object.
inline std::vector<Eigen::Vector3d> allRoundDirections() {
  std::vector<Eigen::Vector3d> d;
  for (int k = 0; k < 3; ++k)
    for (int s : {-1, 1}) {
      Eigen::Vector3d e = Eigen::Vector3d::Zero();
      e[k] = s;
      d.push_back(e);
    }
  for (int sx : {-1, 1})
    for (int sy : {-1, 1})
      for (int sz : {-1, 1}) d.push_back(Eigen::Vector3d(sx, sy, sz).normalized());
  return d;
}

}  // namespace topo_test
