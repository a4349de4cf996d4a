#include "topo_gaussian/physics/neighbor_list.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include "topo_gaussian/common/error.h"

namespace topo_gaussian {

namespace {

// Cells per axis beyond which keys could overflow 64 bits (2e6³ < 2⁶³).
constexpr double kMaxCellsPerAxis = 2.0e6;

}  // namespace

SpatialGrid::SpatialGrid(const std::vector<Eigen::Vector3d>& X, double cell_m) {
  if (!(cell_m > 0.0) || !std::isfinite(cell_m))
    throw TopoError("neighbour search radius", "is " + std::to_string(cell_m),
                    "use a positive finite radius in metres (e.g. 2 × the lattice spacing)");
  const std::size_t n = X.size();
  if (n > static_cast<std::size_t>(2147483647))
    throw TopoError("neighbour search", "has " + std::to_string(n) + " points, more than an int indexes",
                    "split the cloud");
  Eigen::Vector3d lo = Eigen::Vector3d::Zero(), hi = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < n; ++i) {
    if (!X[i].allFinite())
      throw TopoError("neighbour search", "point " + std::to_string(i) + " is not finite",
                      "remove NaN/Inf points first");
    if (i == 0) {
      lo = hi = X[0];
    } else {
      lo = lo.cwiseMin(X[i]);
      hi = hi.cwiseMax(X[i]);
    }
  }
  origin_ = lo;
  inv_cell_ = 1.0 / cell_m;
  for (int a = 0; a < 3; ++a) {
    const double cells = std::floor((hi[a] - lo[a]) * inv_cell_) + 1.0;
    if (!(cells <= kMaxCellsPerAxis))
      throw TopoError(
          "neighbour search radius",
          std::to_string(cell_m) + " m gives " + std::to_string(cells) + " cells along one axis of the cloud",
          "use a larger radius or a cloud of smaller extent");
    dims_[a] = static_cast<int>(cells);
  }
  const std::int64_t ncells = static_cast<std::int64_t>(dims_[0]) * dims_[1] * static_cast<std::int64_t>(dims_[2]);
  dense_ = ncells <= 16 * static_cast<std::int64_t>(n) + 4096;  // a surface in its box: still dense

  // Cell key of every point (row-major x fastest).
  std::vector<std::int64_t> key(n);
#pragma omp parallel for schedule(static) if (n > 8192)
  for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t>(n); ++i) {
    bool inside = true;
    const Eigen::Array3i c = cellOf(X[i], &inside);
    key[i] = c[0] + static_cast<std::int64_t>(dims_[0]) * (c[1] + static_cast<std::int64_t>(dims_[1]) * c[2]);
  }

  order_.resize(n);
  if (dense_) {
    // Counting sort: indices stay ascending inside each cell.
    cell_start_.assign(static_cast<std::size_t>(ncells) + 1, 0);
    for (std::size_t i = 0; i < n; ++i) ++cell_start_[key[i] + 1];
    for (std::int64_t c = 0; c < ncells; ++c) cell_start_[c + 1] += cell_start_[c];
    std::vector<int> fill(cell_start_.begin(), cell_start_.end() - 1);
    for (std::size_t i = 0; i < n; ++i) order_[fill[key[i]]++] = static_cast<int>(i);
  } else {
    std::vector<std::pair<std::int64_t, int>> kv(n);
    for (std::size_t i = 0; i < n; ++i) kv[i] = {key[i], static_cast<int>(i)};
    std::sort(kv.begin(), kv.end());
    for (std::size_t i = 0; i < n; ++i) {
      order_[i] = kv[i].second;
      if (i == 0 || kv[i].first != kv[i - 1].first) {
        cell_keys_.push_back(kv[i].first);
        key_start_.push_back(static_cast<int>(i));
      }
    }
    key_start_.push_back(static_cast<int>(n));
  }
  sorted_.resize(n);
  for (std::size_t k = 0; k < n; ++k) sorted_[k] = X[order_[k]];
}

Eigen::Array3i SpatialGrid::cellOf(const Eigen::Vector3d& p, bool* inside) const {
  Eigen::Array3i c;
  for (int a = 0; a < 3; ++a) {
    const double f = std::floor((p[a] - origin_[a]) * inv_cell_);
    // A point further than one cell outside the grid has no candidates (this also rejects NaN).
    if (!(f >= -1.0 && f <= static_cast<double>(dims_[a]))) {
      *inside = false;
      return Eigen::Array3i::Zero();
    }
    // Points of the cloud itself lie in [0, dims − 1] (same arithmetic as the dims).
    c[a] = static_cast<int>(f);
  }
  return c;
}

SpatialGrid::Range SpatialGrid::cellRange(const Eigen::Array3i& c) const {
  const std::int64_t k =
      c[0] + static_cast<std::int64_t>(dims_[0]) * (c[1] + static_cast<std::int64_t>(dims_[1]) * c[2]);
  Range r;
  if (dense_) {
    r.begin = cell_start_[k];
    r.end = cell_start_[k + 1];
  } else {
    const auto it = std::lower_bound(cell_keys_.begin(), cell_keys_.end(), k);
    if (it != cell_keys_.end() && *it == k) {
      const std::size_t j = static_cast<std::size_t>(it - cell_keys_.begin());
      r.begin = key_start_[j];
      r.end = key_start_[j + 1];
    }
  }
  return r;
}

NeighborList buildNeighborList(const std::vector<Eigen::Vector3d>& X, double radius_m, bool include_self) {
  const SpatialGrid grid(X, radius_m);  // validates radius and points
  const std::ptrdiff_t n = static_cast<std::ptrdiff_t>(X.size());
  const double r2 = radius_m * radius_m;
  NeighborList list;
  list.offsets.assign(static_cast<std::size_t>(n) + 1, 0);

  // Two passes (count, then fill) so rows are written in place without per-point vectors. Points
  // are visited in cell order: consecutive queries read the same cells.
  const std::vector<int>& order = grid.order();
#pragma omp parallel for schedule(dynamic, 256)
  for (std::ptrdiff_t k = 0; k < n; ++k) {
    const int i = order[k];
    int count = 0;
    const Eigen::Vector3d xi = X[i];
    grid.query(xi, [&](int j, const Eigen::Vector3d& xj) {
      if ((j != i || include_self) && (xj - xi).squaredNorm() < r2) ++count;
    });
    list.offsets[i + 1] = count;
  }
  for (std::ptrdiff_t i = 0; i < n; ++i) list.offsets[i + 1] += list.offsets[i];
  list.indices.resize(static_cast<std::size_t>(list.offsets[n]));

#pragma omp parallel
  {
    std::vector<int> buffer;  // one spare slot so candidates are written without a branch
#pragma omp for schedule(dynamic, 256)
    for (std::ptrdiff_t k = 0; k < n; ++k) {
      const int i = order[k];
      const int count = list.offsets[i + 1] - list.offsets[i];
      buffer.resize(static_cast<std::size_t>(count) + 1);
      int* buf = buffer.data();
      int m = 0;
      const Eigen::Vector3d xi = X[i];
      grid.query(xi, [&](int j, const Eigen::Vector3d& xj) {
        buf[m] = j;
        m += ((j != i || include_self) && (xj - xi).squaredNorm() < r2) ? 1 : 0;
      });
      std::sort(buf, buf + m);
      std::copy(buf, buf + m, list.indices.data() + list.offsets[i]);
    }
  }
  return list;
}

}  // namespace topo_gaussian
