#include "topo_gaussian/geometry/mesh_smoothness.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

namespace topo_gaussian::geometry {

NormalSmoothness normalSmoothness(const SurfaceData& mesh, const std::vector<std::uint8_t>* only) {
  NormalSmoothness s;
  const std::size_t nv = mesh.points.size();
  std::vector<Eigen::Vector3d> normal(nv, Eigen::Vector3d::Zero());
  std::vector<std::pair<int, int>> edges;
  edges.reserve(mesh.triangles.size() * 3);
  for (const auto& t : mesh.triangles) {
    bool ok = true;
    for (int k = 0; k < 3; ++k) ok = ok && t[k] >= 0 && std::size_t(t[k]) < nv;
    if (!ok) continue;
    const Eigen::Vector3d& a = mesh.points[t[0]];
    const Eigen::Vector3d n = (mesh.points[t[1]] - a).cross(mesh.points[t[2]] - a);  // 2 × area × unit normal
    if (!n.allFinite()) continue;
    for (int k = 0; k < 3; ++k) {
      normal[t[k]] += n;
      const int u = t[k], v = t[(k + 1) % 3];
      if (u != v) edges.emplace_back(std::min(u, v), std::max(u, v));
    }
  }
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  std::vector<char> has(nv, 0);
  for (std::size_t v = 0; v < nv; ++v) {
    const double len = normal[v].norm();
    if (len > 0.0 && std::isfinite(len)) {
      normal[v] /= len;
      has[v] = 1;
    }
  }
  std::vector<Eigen::Vector3d> sum(nv, Eigen::Vector3d::Zero());
  std::vector<int> count(nv, 0);
  double length = 0.0;
  std::size_t counted = 0;
  auto selected = [&](int v) { return !only || (std::size_t(v) < only->size() && (*only)[v]); };
  for (const auto& e : edges) {
    if (selected(e.first) || selected(e.second)) {
      length += (mesh.points[e.first] - mesh.points[e.second]).norm();
      ++counted;
    }
    if (!has[e.first] || !has[e.second]) continue;
    sum[e.first] += normal[e.second];
    sum[e.second] += normal[e.first];
    ++count[e.first];
    ++count[e.second];
  }
  if (counted) s.mean_edge_length_m = length / double(counted);
  double total = 0.0, total2 = 0.0;
  for (std::size_t v = 0; v < nv; ++v) {
    if (!has[v] || count[v] == 0 || !selected(int(v))) continue;
    const double u = (sum[v] / double(count[v]) - normal[v]).norm();
    total += u;
    total2 += u * u;
    s.max = std::max(s.max, u);
    ++s.vertices;
  }
  if (s.vertices) {
    s.mean = total / double(s.vertices);
    s.rms = std::sqrt(total2 / double(s.vertices));
  }
  return s;
}

}  // namespace topo_gaussian::geometry
