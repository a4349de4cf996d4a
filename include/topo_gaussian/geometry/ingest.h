// ingest: the whole first stage in one call — read, clean, fill — as used by the `topo fill`
// command, the cloud_ingest node and the benchmark.
#pragma once

#include <string>
#include <vector>

#include "topo_gaussian/geometry/cleaning.h"
#include "topo_gaussian/geometry/interior_fill.h"
#include "topo_gaussian/geometry/surface_data.h"
#include "topo_gaussian/physics/volume_cloud.h"

namespace topo_gaussian::geometry {

struct IngestOptions {
  /// Which axis of the input points up: x, y, z, -x, -y or -z. The surface is rotated (a proper,
  /// right-handed rotation) so that this axis becomes +z before cleaning, so the crop box, the fill's
  /// excluded direction (−z) and every later stage see z up. Default z (no rotation); Y-up files
  /// (most mesh exporters, bunny.off) need "y".
  std::string up_axis = "z";
  CleanOptions clean;
  FillOptions fill;
};

/// Rotates the surface (points, normals, Gaussian rotations and covariances) so that `up_axis`
/// becomes +z; throws TopoError naming `surface.source` for any value but x y z -x -y -z.
void applyUpAxis(SurfaceData& surface, const std::string& up_axis);

struct IngestResult {
  std::string input;  ///< file name or topic
  SurfaceKind kind = SurfaceKind::Points;
  VolumeCloud cloud;
  CleanReport clean;
  FillReport fill;
  double seconds = 0.0;  ///< read + clean + fill
  std::string up_axis = "z";
  /// Every warning of the run, one line each (cleaning and fill: repairs, fallbacks, suspicions).
  std::vector<std::string> warnings;
};

/// Cleans and fills a surface already in memory.
IngestResult ingestSurface(SurfaceData surface, const IngestOptions& options);
/// Reads `path` (any supported format), then cleans and fills it.
IngestResult ingestFile(const std::string& path, const IngestOptions& options);

/// One-line JSON object: input, input_kind, method, points_in, points_after_cleaning,
/// triangles_in, particles_out, surface_particles, spacing_m, total_volume_m3, bbox_min, bbox_max,
/// open_fraction, boundary_edges, seconds, up_axis, faces_dropped, holes_closed, faces_ignored,
/// fallback ("" when none), warnings (array of strings).
std::string toJson(const IngestResult& result);

}  // namespace topo_gaussian::geometry
