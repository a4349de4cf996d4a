// Fixed-radius neighbour search by uniform grid hashing (cell edge = radius, so every neighbour of
// a point lies in its own or one of the 26 adjacent cells): O(N) for clouds of bounded density.
// Used for rest neighbourhoods (SPH), boundary shells and any "which particles are within r" query.
// Neighbours are the points with distance strictly less than the radius.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace topo_gaussian {

/// Neighbourhoods in compressed-row form: the neighbours of point i are
/// indices[offsets[i]] … indices[offsets[i+1] − 1], sorted ascending.
struct NeighborList {
  std::vector<int> offsets;  ///< N + 1 entries, offsets[0] = 0
  std::vector<int> indices;  ///< all neighbour indices, row after row

  std::size_t size() const { return offsets.empty() ? 0 : offsets.size() - 1; }  ///< N
  int count(std::size_t i) const { return offsets[i + 1] - offsets[i]; }
  const int* begin(std::size_t i) const { return indices.data() + offsets[i]; }
  const int* end(std::size_t i) const { return indices.data() + offsets[i + 1]; }
};

/// Points bucketed into cubic cells of edge `cell_m`; query() visits the candidates of the 27 cells
/// around a position (a superset of the points within cell_m). Dense cell table when the bounding
/// grid is small, sorted cell keys with binary search otherwise.
class SpatialGrid {
 public:
  /// Throws TopoError for cell_m ≤ 0 / non-finite, a non-finite point, or a grid too fine to index.
  SpatialGrid(const std::vector<Eigen::Vector3d>& X, double cell_m);

  /// Calls visit(j, x_j) for every point j in the 27 cells around p (p need not be one of the
  /// points). x_j comes from a copy stored in cell order, so candidate reads are contiguous.
  template <class Visit>
  void query(const Eigen::Vector3d& p, Visit&& visit) const;

  std::size_t size() const { return order_.size(); }
  /// Point indices grouped by cell: iterating queries in this order keeps the cache warm.
  const std::vector<int>& order() const { return order_; }

 private:
  struct Range {
    int begin = 0, end = 0;
  };
  Eigen::Array3i cellOf(const Eigen::Vector3d& p, bool* inside) const;
  Range cellRange(const Eigen::Array3i& c) const;

  Eigen::Vector3d origin_ = Eigen::Vector3d::Zero();
  double inv_cell_ = 1.0;
  Eigen::Array3i dims_ = Eigen::Array3i::Ones();
  bool dense_ = true;
  std::vector<int> order_;               ///< point indices grouped by cell (ascending within a cell)
  std::vector<Eigen::Vector3d> sorted_;  ///< positions in order_ order
  std::vector<int> cell_start_;          ///< dense: ncells + 1 offsets into order_
  std::vector<std::int64_t> cell_keys_;  ///< sparse: sorted distinct cell keys
  std::vector<int> key_start_;           ///< sparse: cell_keys_.size() + 1 offsets into order_
};

/// Neighbours within `radius_m` (strictly closer) of every point; include_self adds i to its own
/// row. Throws TopoError for radius ≤ 0 / non-finite or a non-finite point.
NeighborList buildNeighborList(const std::vector<Eigen::Vector3d>& X, double radius_m, bool include_self = false);

// ---------------------------------------------------------------- inline

template <class Visit>
void SpatialGrid::query(const Eigen::Vector3d& p, Visit&& visit) const {
  bool inside = true;
  const Eigen::Array3i c = cellOf(p, &inside);
  if (!inside) return;  // more than one cell outside the grid: no candidates
  const int x0 = c[0] > 0 ? c[0] - 1 : 0, x1 = c[0] + 1 < dims_[0] ? c[0] + 1 : dims_[0] - 1;
  if (x0 > x1) return;
  for (int dz = -1; dz <= 1; ++dz) {
    const int z = c[2] + dz;
    if (z < 0 || z >= dims_[2]) continue;
    for (int dy = -1; dy <= 1; ++dy) {
      const int y = c[1] + dy;
      if (y < 0 || y >= dims_[1]) continue;
      if (dense_) {
        // Cells x0..x1 of one row are consecutive in the table: one contiguous range.
        const std::int64_t row = static_cast<std::int64_t>(dims_[0]) * (y + static_cast<std::int64_t>(dims_[1]) * z);
        const int end = cell_start_[row + x1 + 1];
        for (int k = cell_start_[row + x0]; k < end; ++k) visit(order_[k], sorted_[k]);
      } else {
        for (int x = x0; x <= x1; ++x) {
          const Range r = cellRange(Eigen::Array3i(x, y, z));
          for (int k = r.begin; k < r.end; ++k) visit(order_[k], sorted_[k]);
        }
      }
    }
  }
}

}  // namespace topo_gaussian
