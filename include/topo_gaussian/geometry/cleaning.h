// Cleaning an input surface before filling: non-finite values, transparent Gaussians,
// statistical outliers (PCL), unit conversion, recentring and a crop box.
#pragma once

#include <Eigen/Core>
#include <string>

#include "topo_gaussian/geometry/surface_data.h"

namespace topo_gaussian::geometry {

struct CleanOptions {
  double opacity_threshold = 0.02;  ///< Gaussians with sigmoid(opacity) below are dropped
  int outlier_neighbours = 16;      ///< k of PCL StatisticalOutlierRemoval; 0 disables (meshes: never)
  double outlier_std_ratio = 3.0;   ///< points farther than mean + ratio·stddev of k-NN distance go
  double scale = 1.0;               ///< multiply coordinates (and Gaussian sizes), e.g. 0.001 for mm → m
  bool recenter = false;            ///< move the bounding-box centre to the origin
  Eigen::Vector3d crop_min = Eigen::Vector3d::Constant(-1e300);  ///< crop box after scaling [m]
  Eigen::Vector3d crop_max = Eigen::Vector3d::Constant(1e300);
};

struct CleanReport {
  std::size_t points_in = 0;
  std::size_t non_finite = 0;
  std::size_t duplicates = 0;  ///< point clouds: points at exactly the position of an earlier one, merged
  std::size_t transparent = 0;
  std::size_t outliers = 0;
  std::size_t cropped = 0;
  Eigen::Vector3d shift = Eigen::Vector3d::Zero();  ///< added to every point by recentring
};

/// Cleans in place. Exact duplicate points of a point cloud are merged (the first kept) and counted.
/// Throws TopoError (naming surface.source) when nothing is left, when every point was non-finite,
/// or when the options are invalid.
CleanReport cleanSurface(SurfaceData& surface, const CleanOptions& options);

}  // namespace topo_gaussian::geometry
