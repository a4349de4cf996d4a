// ingest: the whole first stage in one call — read, clean, fill — as used by the `topo fill`
// command, the cloud_ingest node and the benchmark.
#pragma once

#include <string>

#include "topo_gaussian/geometry/cleaning.h"
#include "topo_gaussian/geometry/interior_fill.h"
#include "topo_gaussian/geometry/surface_data.h"
#include "topo_gaussian/physics/volume_cloud.h"

namespace topo_gaussian::geometry {

struct IngestOptions {
  CleanOptions clean;
  FillOptions fill;
};

struct IngestResult {
  std::string input;  ///< file name or topic
  SurfaceKind kind = SurfaceKind::Points;
  VolumeCloud cloud;
  CleanReport clean;
  FillReport fill;
  double seconds = 0.0;  ///< read + clean + fill
};

/// Cleans and fills a surface already in memory.
IngestResult ingestSurface(SurfaceData surface, const IngestOptions& options);
/// Reads `path` (any supported format), then cleans and fills it.
IngestResult ingestFile(const std::string& path, const IngestOptions& options);

/// One-line JSON object: input, input_kind, method, points_in, points_after_cleaning,
/// triangles_in, particles_out, surface_particles, spacing_m, total_volume_m3, bbox_min, bbox_max,
/// open_fraction, boundary_edges, seconds.
std::string toJson(const IngestResult& result);

}  // namespace topo_gaussian::geometry
