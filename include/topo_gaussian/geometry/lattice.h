// Lattice: a regular grid of cubic cells, the common ground of every fill method.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>

namespace topo_gaussian::geometry {

struct Lattice {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();  ///< corner of cell (0,0,0) [m]
  double h = 1.0;                                    ///< cell size [m]
  std::array<int, 3> n{{0, 0, 0}};                   ///< cells per axis

  /// Lattice of cell size h whose cells cover [lo, hi] centred, with `pad` extra cells on each side.
  static Lattice covering(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, double h, int pad);
  /// Number of cells a covering() lattice would have (as double: never overflows).
  static double cellCount(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, double h, int pad);

  std::size_t cells() const { return std::size_t(n[0]) * n[1] * n[2]; }
  std::size_t index(int i, int j, int k) const { return (std::size_t(k) * n[1] + j) * n[0] + i; }
  Eigen::Vector3d center(int i, int j, int k) const { return origin + h * Eigen::Vector3d(i + 0.5, j + 0.5, k + 0.5); }
  /// Cell containing p, or false when p is outside the lattice.
  bool cellOf(const Eigen::Vector3d& p, std::array<int, 3>* ijk) const;
};

/// Breadth-first 6-neighbour distance (in cells) from every seed cell, moving only through cells
/// whose `passable` flag is set (seeds always count). Unreached cells get INT32_MAX.
/// Stops expanding at max_distance.
std::vector<std::int32_t> distanceTransform6(const Lattice& lattice, const std::vector<std::uint8_t>& seeds,
                                             const std::vector<std::uint8_t>& passable,
                                             std::int32_t max_distance = INT32_MAX);

/// Cells within `radius` 6-neighbour steps of a set cell.
std::vector<std::uint8_t> dilate6(const Lattice& lattice, const std::vector<std::uint8_t>& set, int radius);

}  // namespace topo_gaussian::geometry
