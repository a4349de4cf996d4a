#include "topo_gaussian/geometry/mesh_fill.h"

#include <algorithm>
#include <cmath>
#include <utility>

namespace topo_gaussian::geometry {

MeshTopology analyseMesh(const SurfaceData& mesh) {
  struct Edge {
    int u, v;
    bool forward;  // the triangle runs u → v (u < v)
    bool operator<(const Edge& o) const { return u != o.u ? u < o.u : v != o.v ? v < o.v : forward < o.forward; }
  };
  std::vector<Edge> e;
  e.reserve(mesh.triangles.size() * 3);
  for (const auto& t : mesh.triangles)
    for (int a = 0; a < 3; ++a) {
      const int u = t[a], v = t[(a + 1) % 3];
      if (u != v) e.push_back(Edge{std::min(u, v), std::max(u, v), u < v});
    }
  std::sort(e.begin(), e.end());
  MeshTopology topo;
  for (std::size_t i = 0; i < e.size();) {
    std::size_t j = i, forward = 0;
    while (j < e.size() && e[j].u == e[i].u && e[j].v == e[i].v) forward += e[j++].forward;
    ++topo.edges;
    const std::size_t uses = j - i;
    if (uses == 1) {
      ++topo.boundary_edges;
      topo.boundary_length += (mesh.points[e[i].u] - mesh.points[e[i].v]).norm();
    } else if (uses > 2) {
      ++topo.nonmanifold_edges;
    } else if (forward != 1) {
      ++topo.misoriented_edges;
    }
    i = j;
  }
  return topo;
}

namespace {

struct Hit {
  double z;
};

// Which side of the directed edge a→b the column point p lies on, never 0: the point is taken as
// p + (ε, ε²) (simulation of simplicity). The edge is evaluated in a canonical endpoint order so
// that the two triangles sharing an edge compute bit-identical values and agree.
int edgeSide(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& p) {
  const bool swap = (b.x() < a.x()) || (b.x() == a.x() && b.y() < a.y());
  const Eigen::Vector2d& u = swap ? b : a;
  const Eigen::Vector2d& v = swap ? a : b;
  double o = (v.x() - u.x()) * (p.y() - u.y()) - (v.y() - u.y()) * (p.x() - u.x());
  if (o == 0.0) o = -(v.y() - u.y());
  if (o == 0.0) o = v.x() - u.x();
  if (o == 0.0) return 0;  // degenerate edge (u == v)
  const int s = o > 0.0 ? 1 : -1;
  return swap ? -s : s;
}

}  // namespace

std::vector<std::uint8_t> meshInside(const SurfaceData& mesh, const Lattice& L, InsideRule rule) {
  const int nx = L.n[0], ny = L.n[1], nz = L.n[2];
  // Per column the crossings of the upward ray: height, and +1 where the face looks up, −1 down.
  std::vector<std::vector<std::pair<double, int>>> columns(std::size_t(nx) * ny);
  const double h = L.h;
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3d& A = mesh.points[t[0]];
    const Eigen::Vector3d& B = mesh.points[t[1]];
    const Eigen::Vector3d& C = mesh.points[t[2]];
    const Eigen::Vector2d a = A.head<2>(), b = B.head<2>(), c = C.head<2>();
    const double area2 = (b.x() - a.x()) * (c.y() - a.y()) - (b.y() - a.y()) * (c.x() - a.x());
    if (area2 == 0.0) continue;  // vertical in projection: no column crosses its interior
    const int want = area2 > 0.0 ? 1 : -1;
    const double x0 = std::min({a.x(), b.x(), c.x()}), x1 = std::max({a.x(), b.x(), c.x()});
    const double y0 = std::min({a.y(), b.y(), c.y()}), y1 = std::max({a.y(), b.y(), c.y()});
    const int i0 = std::max(0, int(std::floor((x0 - L.origin.x()) / h - 0.5)));
    const int i1 = std::min(nx - 1, int(std::ceil((x1 - L.origin.x()) / h - 0.5)));
    const int j0 = std::max(0, int(std::floor((y0 - L.origin.y()) / h - 0.5)));
    const int j1 = std::min(ny - 1, int(std::ceil((y1 - L.origin.y()) / h - 0.5)));
    for (int j = j0; j <= j1; ++j)
      for (int i = i0; i <= i1; ++i) {
        const Eigen::Vector2d p(L.origin.x() + (i + 0.5) * h, L.origin.y() + (j + 0.5) * h);
        if (edgeSide(a, b, p) != want || edgeSide(b, c, p) != want || edgeSide(c, a, p) != want) continue;
        // barycentric interpolation of z at p
        const double wa = ((b.x() - p.x()) * (c.y() - p.y()) - (b.y() - p.y()) * (c.x() - p.x())) / area2;
        const double wb = ((c.x() - p.x()) * (a.y() - p.y()) - (c.y() - p.y()) * (a.x() - p.x())) / area2;
        const double wc = 1.0 - wa - wb;
        columns[std::size_t(j) * nx + i].emplace_back(wa * A.z() + wb * B.z() + wc * C.z(), want);
      }
  }
  std::vector<std::uint8_t> inside(L.cells(), 0);
  const bool parity = rule == InsideRule::Parity;
#pragma omp parallel for schedule(dynamic, 64)
  for (long col = 0; col < long(columns.size()); ++col) {
    auto& zs = columns[col];
    if (zs.size() < 2) continue;
    std::sort(zs.begin(), zs.end());
    const int i = int(col % nx), j = int(col / nx);
    int winding = 0;  // of the crossings above the cell centre
    for (const auto& z : zs) winding += z.second;
    std::size_t below = 0;  // crossings with z <= cell centre
    for (int k = 0; k < nz; ++k) {
      const double z = L.origin.z() + (k + 0.5) * h;
      while (below < zs.size() && zs[below].first <= z) winding -= zs[below++].second;
      const bool in = parity ? (zs.size() - below) % 2 == 1 : winding != 0;
      if (in) inside[L.index(i, j, k)] = 1;
    }
  }
  return inside;
}

std::vector<std::uint8_t> meshInsideParity(const SurfaceData& mesh, const Lattice& L) {
  return meshInside(mesh, L, InsideRule::Parity);
}

}  // namespace topo_gaussian::geometry
