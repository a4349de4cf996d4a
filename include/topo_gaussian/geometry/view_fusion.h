// fuseViews: depth clouds of one object from several viewpoints (a depth camera on an arm or beside a
// turntable), each with its sensor pose, fused into one surface point set with normals.
//
// Voxel averaging, not a TSDF: every point goes to the world frame (world <- sensor) and into a
// cubic voxel; each occupied voxel gives one point, its mean moved onto the plane fitted to the raw
// points of the voxel and its 26 neighbours (~30..80 points), which also gives the normal, turned
// towards the sensors that saw those points (the outside). The plane averages the noise across the
// surface (a voxel mean alone does not: a voxel cut by the noisy shell holds one tail of it) and
// the voxels even out the density where views overlap. Simplest that works: no volume grid (memory
// grows with the surface, not the box), nothing to tune but the voxel, and the solid is left to the
// existing fill (its signed distance from oriented points ends the solid at the surface). A TSDF would
// average the noise too but needs a band grid, a truncation distance and a mesh extraction before the
// same fill.
#pragma once

#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "topo_gaussian/geometry/surface_data.h"
#include "topo_gaussian/geometry/view_coverage.h"

namespace topo_gaussian::geometry {

/// One depth cloud and where its sensor was.
struct DepthView {
  std::vector<Eigen::Vector3d> points;  ///< in the sensor's frame [m]; NaN/infinite points are skipped
  Eigen::Isometry3d world_from_sensor = Eigen::Isometry3d::Identity();
  std::string name;  ///< e.g. "view 3 (frame camera_depth_optical_frame)", used in messages
};

struct ViewFusionOptions {
  /// Voxel edge [m]; 0: 1 % of the diagonal of the views' bounding box (its 0.5..99.5 % percentiles
  /// per axis, so stray points do not widen it).
  double voxel_m = 0.0;
  /// Voxels with fewer points are dropped as stray (flying pixels at depth edges); 1 keeps all.
  int min_points_per_voxel = 1;
  int coverage_bins = 400;  ///< directions of the coverage report (view_coverage.h)
};

struct FusedViews {
  SurfaceData surface;  ///< Points with normals, in the world frame; source names the views
  ViewCoverage coverage;
  std::size_t views = 0;
  std::size_t points_in = 0;    ///< finite points of all views
  std::size_t voxels = 0;       ///< fused points (occupied voxels kept)
  std::size_t stray_voxels = 0; ///< dropped by min_points_per_voxel
  double voxel_m = 0.0;         ///< the voxel edge used
  double mean_points_per_voxel = 0.0;
};

/// Throws TopoError naming `source` when there are no views, no finite point at all, a pose that is
/// not a rigid transform, or a voxel grid beyond 2^21 cells per axis.
FusedViews fuseViews(const std::vector<DepthView>& views, const ViewFusionOptions& options,
                     const std::string& source = "depth views");
/// The same over views held elsewhere (none null), so a caller that keeps many clouds does not copy them.
FusedViews fuseViews(const std::vector<const DepthView*>& views, const ViewFusionOptions& options,
                     const std::string& source = "depth views");

}  // namespace topo_gaussian::geometry
