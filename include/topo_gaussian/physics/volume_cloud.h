// VolumeCloud: the particle discretisation of a solid object (paper §4),
// {(X_i, V_i)} plus a surface flag and the lattice spacing it was sampled on.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

namespace topo_gaussian {

struct VolumeCloud {
  std::vector<Eigen::Vector3d> X;     ///< rest positions [m]
  std::vector<double> V;              ///< particle volumes [m^3]; their sum is the enclosed volume
  std::vector<std::uint8_t> surface;  ///< 1 for particles within one spacing of the boundary
  double spacing = 0.0;               ///< lattice spacing h [m]

  std::size_t size() const { return X.size(); }
  bool empty() const { return X.empty(); }
  double totalVolume() const;
  /// Volume-weighted centroid Σ V_i X_i / Σ V_i.
  Eigen::Vector3d centroid() const;
  /// Axis-aligned bounds of the particle positions.
  void bounds(Eigen::Vector3d* lo, Eigen::Vector3d* hi) const;
  std::size_t surfaceCount() const;
  /// Throws TopoError (naming `what`) when sizes disagree, a value is not finite,
  /// a volume is not positive or the cloud is empty.
  void validate(const std::string& what = "volume cloud") const;
};

}  // namespace topo_gaussian
