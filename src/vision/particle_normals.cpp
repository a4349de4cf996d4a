// Outward normals from neighbour centroids (grid hashing).
#include "topo_gaussian/vision/particle_normals.h"

#include <cmath>
#include <string>
#include <unordered_map>

#include "topo_gaussian/common/error.h"

namespace topo_gaussian::vision {
namespace {

struct CellKeyHash {
  std::size_t operator()(const Eigen::Vector3i& k) const {
    return static_cast<std::size_t>(k.x()) * 73856093u ^ static_cast<std::size_t>(k.y()) * 19349663u ^
           static_cast<std::size_t>(k.z()) * 83492791u;
  }
};
struct CellKeyEq {
  bool operator()(const Eigen::Vector3i& a, const Eigen::Vector3i& b) const { return a == b; }
};

}  // namespace

std::vector<Eigen::Vector3d> estimateOutwardNormals(const std::vector<Eigen::Vector3d>& particles,
                                                    const std::vector<Eigen::Vector3d>& query, double radius_m) {
  if (!(radius_m > 0) || !std::isfinite(radius_m))
    throw TopoError("normal estimation radius", "must be positive (got " + std::to_string(radius_m) + " m)",
                    "use 2 to 3 particle spacings");
  auto key = [&](const Eigen::Vector3d& p) {
    return Eigen::Vector3i(static_cast<int>(std::floor(p.x() / radius_m)),
                           static_cast<int>(std::floor(p.y() / radius_m)),
                           static_cast<int>(std::floor(p.z() / radius_m)));
  };
  std::unordered_map<Eigen::Vector3i, std::vector<int>, CellKeyHash, CellKeyEq> grid;
  for (std::size_t i = 0; i < particles.size(); ++i) {
    if (!particles[i].allFinite())
      throw TopoError("particle " + std::to_string(i), "has a non-finite position", "remove NaN/Inf particles first");
    grid[key(particles[i])].push_back(static_cast<int>(i));
  }
  const double r2 = radius_m * radius_m;
  std::vector<Eigen::Vector3d> normals(query.size(), Eigen::Vector3d::Zero());
  for (std::size_t q = 0; q < query.size(); ++q) {
    const Eigen::Vector3d& p = query[q];
    if (!p.allFinite()) throw TopoError("query point " + std::to_string(q), "has a non-finite position", "remove it");
    const Eigen::Vector3i k = key(p);
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    int count = 0;
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = -1; dz <= 1; ++dz) {
          const auto it = grid.find(k + Eigen::Vector3i(dx, dy, dz));
          if (it == grid.end()) continue;
          for (int j : it->second) {
            if ((particles[j] - p).squaredNorm() > r2) continue;
            sum += particles[j];
            ++count;
          }
        }
    if (count == 0) continue;
    const Eigen::Vector3d d = p - sum / count;
    if (d.norm() > 1e-3 * radius_m) normals[q] = d.normalized();
  }
  return normals;
}

}  // namespace topo_gaussian::vision
