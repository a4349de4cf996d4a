#include "topo_gaussian/geometry/mesh_metrics.h"

#include <Eigen/Geometry>
#include <limits>

namespace topo_gaussian::geometry {

MeshIntegrals meshIntegrals(const SurfaceData& mesh) {
  MeshIntegrals out;
  Eigen::Vector3d moment = Eigen::Vector3d::Zero();
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3d& a = mesh.points[t[0]];
    const Eigen::Vector3d& b = mesh.points[t[1]];
    const Eigen::Vector3d& c = mesh.points[t[2]];
    const double v = a.dot(b.cross(c)) / 6.0;  // signed volume of tetrahedron (0, a, b, c)
    out.volume += v;
    moment += v * (a + b + c) / 4.0;
    out.area += 0.5 * (b - a).cross(c - a).norm();
  }
  if (out.volume != 0.0) out.centroid = moment / out.volume;
  return out;
}

void surfaceBounds(const SurfaceData& s, Eigen::Vector3d* lo, Eigen::Vector3d* hi) {
  Eigen::Vector3d a = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()), b = -a;
  for (const auto& p : s.points)
    if (p.allFinite()) {
      a = a.cwiseMin(p);
      b = b.cwiseMax(p);
    }
  *lo = a;
  *hi = b;
}

}  // namespace topo_gaussian::geometry
