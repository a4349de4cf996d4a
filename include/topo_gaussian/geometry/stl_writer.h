// Binary STL output (what slicers and CAD tools read): an 80-byte header, the triangle count and
// 50 bytes per triangle (facet normal, three corners, all float32 little-endian, attribute 0).
// STL has no unit field; slicers assume millimetres, so the solid-region export writes millimetres
// (scale 1000 from metres) and says so in the header text.
#pragma once

#include <string>

#include "topo_gaussian/geometry/surface_data.h"

namespace topo_gaussian::geometry {

/// Writes mesh.points × scale. `header` (at most 80 characters are kept) must not start with
/// "solid" (readers would take the file for ASCII STL); it is prefixed when it does.
/// Throws TopoError when the file cannot be written or a triangle index is out of range.
void writeStlBinary(const SurfaceData& mesh, const std::string& path, double scale = 1.0,
                    const std::string& header = "topo_gaussian mesh");

}  // namespace topo_gaussian::geometry
