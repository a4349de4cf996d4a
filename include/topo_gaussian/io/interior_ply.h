// interior.ply: an inferred interior, one vertex per particle of its volume in the volume's order:
// x y z (float32, m), r (float32, the indicator in [0, 1]), solid (uint8, r >= 0.5), density
// (float32, kg/m³); binary little endian. A comment marks a continuous-material run (r is a
// density fraction). Written by `topo infer` and the interior_inference node into a run folder
// (io/run_folder.h), read by `topo simulate`, `topo export` and the node's restore.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "topo_gaussian/physics/volume_cloud.h"

namespace topo_gaussian::io {

/// Writes the interior of `cloud` atomically. Throws TopoError naming the path when the sizes of r
/// and density differ from the cloud's or the file cannot be written.
void writeInteriorPly(const std::string& path, const VolumeCloud& cloud, const std::vector<double>& r,
                      const std::vector<double>& density, bool continuous);

/// Everything an interior .ply holds (positions as stored, float32; r; density; the continuous flag).
struct InteriorPly {
  std::vector<Eigen::Vector3d> X;
  std::vector<double> r, density;
  bool continuous = false;
};

/// Reads an interior .ply; throws TopoError naming the file when it is not one, is truncated, holds
/// an r outside [0, 1] or NaN, or its count differs from `expected_count` (the volume's particles).
InteriorPly readInteriorPlyData(const std::string& path, std::size_t expected_count);

/// Only r per particle (readInteriorPlyData(...).r).
std::vector<double> readInteriorPly(const std::string& path, std::size_t expected_count);

}  // namespace topo_gaussian::io
