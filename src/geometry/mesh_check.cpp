#include "topo_gaussian/geometry/mesh_check.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cstdint>
#include <limits>
#include <numeric>
#include <sstream>
#include <unordered_map>
#include <vector>

namespace topo_gaussian::geometry {

namespace {

struct EdgeUse {
  int forward = 0;   ///< used as (low → high)
  int backward = 0;  ///< used as (high → low)
};

int findRoot(std::vector<int>& parent, int x) {
  while (parent[x] != x) x = parent[x] = parent[parent[x]];
  return x;
}

}  // namespace

std::string ManifoldCheck::summary() const {
  std::ostringstream s;
  if (watertight()) {
    s << "watertight (" << triangles << " triangles, " << vertices << " vertices, " << bodies
      << (bodies == 1 ? " solid body" : " solid bodies") << ", " << voids
      << (voids == 1 ? " enclosed void" : " enclosed voids") << ", Euler characteristic " << euler_characteristic
      << ")";
    return s.str();
  }
  s << "not watertight:";
  if (triangles == 0) s << " no triangles";
  if (boundary_edges) s << " " << boundary_edges << " boundary edges (holes)";
  if (nonmanifold_edges) s << " " << nonmanifold_edges << " edges shared by 3+ triangles";
  if (misoriented_edges) s << " " << misoriented_edges << " edges with inconsistent orientation";
  if (nonmanifold_vertices) s << " " << nonmanifold_vertices << " vertices joining separate fans";
  if (degenerate_triangles) s << " " << degenerate_triangles << " degenerate triangles";
  return s.str();
}

ManifoldCheck checkManifold(const SurfaceData& mesh) {
  ManifoldCheck c;
  const std::size_t nv = mesh.points.size();
  c.triangles = mesh.triangles.size();
  c.min_triangle_area = c.triangles ? std::numeric_limits<double>::infinity() : 0.0;
  std::unordered_map<std::uint64_t, EdgeUse> edges;
  edges.reserve(c.triangles * 3 / 2 + 1);
  std::vector<int> parent(nv);
  std::iota(parent.begin(), parent.end(), 0);
  std::vector<std::uint32_t> degree(nv, 0);
  std::vector<char> valid(c.triangles, 0);
  for (std::size_t t = 0; t < c.triangles; ++t) {
    const Eigen::Vector3i& tri = mesh.triangles[t];
    bool in_range = true;
    for (int k = 0; k < 3; ++k) in_range = in_range && tri[k] >= 0 && std::size_t(tri[k]) < nv;
    if (!in_range || tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2]) {
      ++c.degenerate_triangles;
      continue;
    }
    const Eigen::Vector3d& a = mesh.points[tri[0]];
    const Eigen::Vector3d& b = mesh.points[tri[1]];
    const Eigen::Vector3d& d = mesh.points[tri[2]];
    const double area = 0.5 * (b - a).cross(d - a).norm();
    const double longest = std::max({(b - a).squaredNorm(), (d - b).squaredNorm(), (a - d).squaredNorm()});
    c.min_triangle_area = std::min(c.min_triangle_area, area);
    if (!(area > 1e-12 * longest)) ++c.degenerate_triangles;  // collinear (or NaN) corners
    valid[t] = 1;
    for (int k = 0; k < 3; ++k) {
      const int u = tri[k], v = tri[(k + 1) % 3];
      const std::uint64_t key = std::uint64_t(std::min(u, v)) * nv + std::uint64_t(std::max(u, v));
      EdgeUse& e = edges[key];
      (u < v ? e.forward : e.backward) += 1;
      ++degree[u];
      parent[findRoot(parent, u)] = findRoot(parent, v);
    }
  }
  c.edges = edges.size();
  for (const auto& kv : edges) {
    const int uses = kv.second.forward + kv.second.backward;
    if (uses == 1)
      ++c.boundary_edges;
    else if (uses > 2)
      ++c.nonmanifold_edges;
    else if (kv.second.forward != 1)
      ++c.misoriented_edges;
  }

  // Fans: around a vertex v every triangle (v, a, b) gives the link edge a → b. On a closed oriented
  // manifold the link edges of v form one cycle; two cones touching at v give two.
  std::vector<std::size_t> start(nv + 1, 0);
  for (std::size_t v = 0; v < nv; ++v) start[v + 1] = start[v] + degree[v];
  std::vector<std::pair<int, int>> link(start[nv]);
  std::vector<std::size_t> fill(start.begin(), start.end() - 1);
  for (std::size_t t = 0; t < c.triangles; ++t) {
    if (!valid[t]) continue;
    const Eigen::Vector3i& tri = mesh.triangles[t];
    for (int k = 0; k < 3; ++k) link[fill[tri[k]]++] = {tri[(k + 1) % 3], tri[(k + 2) % 3]};
  }
  for (std::size_t v = 0; v < nv; ++v) {
    const std::size_t m = degree[v];
    if (m == 0) {
      ++c.unused_vertices;
      continue;
    }
    ++c.vertices;
    auto* L = &link[start[v]];
    std::sort(L, L + m);
    bool permutation = true;  // every link vertex starts exactly one link edge and ends exactly one
    for (std::size_t k = 1; k < m; ++k) permutation = permutation && L[k].first != L[k - 1].first;
    std::vector<int> ends(m);
    for (std::size_t k = 0; k < m; ++k) ends[k] = L[k].second;
    std::sort(ends.begin(), ends.end());
    for (std::size_t k = 0; k < m && permutation; ++k) permutation = ends[k] == L[k].first;
    if (!permutation) continue;  // a boundary or non-manifold edge at v, counted above
    std::size_t steps = 0;
    int at = L[0].first;
    do {
      at = std::lower_bound(L, L + m, std::make_pair(at, std::numeric_limits<int>::min()))->second;
      ++steps;
    } while (at != L[0].first && steps <= m);
    if (steps < m) ++c.nonmanifold_vertices;
  }

  // Pieces, and the sign of the volume each encloses (divergence theorem per piece).
  std::vector<double> piece_volume(nv, 0.0);
  for (std::size_t t = 0; t < c.triangles; ++t) {
    if (!valid[t]) continue;
    const Eigen::Vector3i& tri = mesh.triangles[t];
    piece_volume[findRoot(parent, tri[0])] +=
        mesh.points[tri[0]].dot(mesh.points[tri[1]].cross(mesh.points[tri[2]])) / 6.0;
  }
  std::vector<char> root_seen(nv, 0);
  for (std::size_t v = 0; v < nv; ++v) {
    const int root = findRoot(parent, int(v));
    if (degree[v] && !root_seen[root]) {
      root_seen[root] = 1;
      ++c.components;
      if (piece_volume[root] > 0.0)
        ++c.bodies;
      else if (piece_volume[root] < 0.0)
        ++c.voids;
    }
  }
  const long faces = long(std::count(valid.begin(), valid.end(), char(1)));
  c.euler_characteristic = long(c.vertices) - long(c.edges) + faces;
  return c;
}

}  // namespace topo_gaussian::geometry
