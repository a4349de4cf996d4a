// Internal checks shared by the file readers. Not part of the public API.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "byte_cursor.h"
#include "topo_gaussian/common/error.h"
#include "topo_gaussian/geometry/surface_data.h"
#include "topo_gaussian/geometry/surface_reader.h"

namespace topo_gaussian::geometry::detail {

/// The list of extensions readSurface understands, for messages.
inline const char* supportedExtensions() { return ".ply .pcd .obj .off .stl"; }

/// How many items to reserve for a declared count when each item needs at least
/// `min_bytes_per_item` bytes of the `remaining` ones: a lying header cannot make us allocate more
/// than the file could possibly hold.
inline std::size_t cappedReserve(std::uint64_t declared, std::size_t remaining, std::size_t min_bytes_per_item) {
  const std::uint64_t cap = remaining / (min_bytes_per_item == 0 ? 1 : min_bytes_per_item) + 1;
  return static_cast<std::size_t>(declared < cap ? declared : cap);
}

/// Refuses a declared number of points (vertices) above kMaxSurfacePoints, before anything is
/// allocated for them, with the memory it would take and the fix. Readers call it once the data is
/// known to hold that many (a count beyond the data is reported as a truncated file instead).
inline void checkPointCount(std::uint64_t declared, const std::string& name, const char* what = "points") {
  if (declared <= kMaxSurfacePoints) return;
  const double gb = double(declared) * double(kBytesPerPointInMemory) / 1e9;
  throw TopoError(name,
                  "the file declares " + std::to_string(declared) + " " + what + ", more than the " +
                      std::to_string(kMaxSurfacePoints) + " topo reads (about " +
                      std::to_string(static_cast<unsigned long long>(gb + 0.5)) + " GB of memory at ~" +
                      std::to_string(kBytesPerPointInMemory) + " bytes per point)",
                  "downsample the surface first (e.g. CloudCompare: Subsample, or MeshLab: Poisson-disk sampling / "
                  "Quadric Edge Collapse Decimation) to at most " +
                      std::to_string(kMaxSurfacePoints) + " " + what + "; the fill needs far fewer");
}

/// Throws the "empty" error every reader gives when it found no points.
inline void requirePoints(const SurfaceData& s, const std::string& name, const std::string& what_is_missing,
                          const std::string& fix) {
  if (s.points.empty()) throw TopoError(name, "the file is empty: " + what_is_missing, fix);
}

/// Appends the fan triangulation (p0, p_i, p_i+1) of a polygon whose indices are already checked.
inline void fanTriangulate(const std::vector<int>& polygon, std::vector<Eigen::Vector3i>& triangles) {
  for (std::size_t i = 1; i + 1 < polygon.size(); ++i) triangles.emplace_back(polygon[0], polygon[i], polygon[i + 1]);
}

}  // namespace topo_gaussian::geometry::detail
