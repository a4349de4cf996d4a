#include "topo_gaussian/geometry/lattice.h"

#include <cmath>
#include <cstdint>
#include <limits>

namespace topo_gaussian::geometry {

static std::array<int, 3> cellsPerAxis(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, double h, int pad) {
  std::array<int, 3> n{};
  for (int a = 0; a < 3; ++a) n[a] = std::max(1, int(std::ceil((hi[a] - lo[a]) / h))) + 2 * pad;
  return n;
}

double Lattice::cellCount(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, double h, int pad) {
  double c = 1.0;
  for (int a = 0; a < 3; ++a) c *= std::max(1.0, std::ceil((hi[a] - lo[a]) / h)) + 2.0 * pad;
  return c;
}

Lattice Lattice::covering(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, double h, int pad) {
  Lattice l;
  l.h = h;
  l.n = cellsPerAxis(lo, hi, h, pad);
  const Eigen::Vector3d mid = 0.5 * (lo + hi);
  for (int a = 0; a < 3; ++a) l.origin[a] = mid[a] - 0.5 * h * l.n[a];
  return l;
}

bool Lattice::cellOf(const Eigen::Vector3d& p, std::array<int, 3>* ijk) const {
  for (int a = 0; a < 3; ++a) {
    const double f = std::floor((p[a] - origin[a]) / h);
    if (!(f >= 0.0 && f < n[a])) return false;
    (*ijk)[a] = int(f);
  }
  return true;
}

std::vector<std::int32_t> distanceTransform6(const Lattice& L, const std::vector<std::uint8_t>& seeds,
                                             const std::vector<std::uint8_t>& passable, std::int32_t max_distance) {
  const std::int32_t inf = std::numeric_limits<std::int32_t>::max();
  std::vector<std::int32_t> d(L.cells(), inf);
  std::vector<std::size_t> frontier, next;
  for (std::size_t c = 0; c < d.size(); ++c)
    if (seeds[c]) {
      d[c] = 0;
      frontier.push_back(c);
    }
  const std::size_t sx = 1, sy = std::size_t(L.n[0]), sz = std::size_t(L.n[0]) * L.n[1];
  for (std::int32_t dist = 1; !frontier.empty() && dist <= max_distance; ++dist) {
    next.clear();
    for (std::size_t c : frontier) {
      const int i = int(c % sy), j = int((c / sy) % L.n[1]), k = int(c / sz);
      auto visit = [&](std::size_t o) {
        if (d[o] == inf && passable[o]) {
          d[o] = dist;
          next.push_back(o);
        }
      };
      if (i > 0) visit(c - sx);
      if (i + 1 < L.n[0]) visit(c + sx);
      if (j > 0) visit(c - sy);
      if (j + 1 < L.n[1]) visit(c + sy);
      if (k > 0) visit(c - sz);
      if (k + 1 < L.n[2]) visit(c + sz);
    }
    frontier.swap(next);
  }
  return d;
}

std::vector<std::uint8_t> dilate6(const Lattice& L, const std::vector<std::uint8_t>& set, int radius) {
  if (radius <= 0) return set;
  const std::vector<std::uint8_t> all(L.cells(), 1);
  const auto d = distanceTransform6(L, set, all, radius);
  std::vector<std::uint8_t> out(L.cells());
  for (std::size_t c = 0; c < out.size(); ++c) out[c] = d[c] <= radius ? 1 : 0;
  return out;
}

}  // namespace topo_gaussian::geometry
