// interior.ply: an inferred interior, one vertex per particle of its volume in the volume's order:
// x y z (float32, m), r (float32, the indicator in [0, 1]), solid (uint8, r >= 0.5), density
// (float32, kg/m³), and, when the run explored the designs that fit equally well
// (inference/design_spread.h), confidence (float32, agreement of those designs with this design's
// solid/hollow label, 1 = all agree); binary little endian. Files without confidence (older runs,
// restarts = 0, exports of a given interior) still read. A comment marks a continuous-material run
// (r is a density fraction). Written by `topo infer` and the interior_inference node into a run folder
// (io/run_folder.h), read by `topo simulate`, `topo export` and the node's restore.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "topo_gaussian/physics/volume_cloud.h"

namespace topo_gaussian::io {

/// Writes the interior of `cloud` atomically (with the confidence column when `confidence` is not
/// empty). Throws TopoError naming the path when the sizes of r, density or a non-empty confidence
/// differ from the cloud's, or the file cannot be written.
void writeInteriorPly(const std::string& path, const VolumeCloud& cloud, const std::vector<double>& r,
                      const std::vector<double>& density, bool continuous, const std::vector<double>& confidence = {});

/// Everything an interior .ply holds (positions as stored, float32; r; density; the continuous flag).
struct InteriorPly {
  std::vector<Eigen::Vector3d> X;
  std::vector<double> r, density;
  std::vector<double> confidence;  ///< empty when the file has no confidence column
  bool continuous = false;
};

/// Reads an interior .ply; throws TopoError naming the file when it is not one, is truncated, holds
/// an r (or confidence) outside [0, 1] or NaN, or its count differs from `expected_count` (the volume's particles).
InteriorPly readInteriorPlyData(const std::string& path, std::size_t expected_count);

/// Only r per particle (readInteriorPlyData(...).r).
std::vector<double> readInteriorPly(const std::string& path, std::size_t expected_count);

}  // namespace topo_gaussian::io
