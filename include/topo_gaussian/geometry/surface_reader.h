// Reading surfaces from files: 3DGS .ply, point clouds (.ply, .pcd), meshes (.obj, .off, .stl, .ply).
// Every reader throws TopoError naming the file, the problem and the fix; none crashes on bad bytes.
#pragma once

#include <string>

#include "topo_gaussian/geometry/surface_data.h"

namespace topo_gaussian::geometry {

/// Reads any supported file, choosing the reader by extension (case-insensitive).
/// A PLY with faces is a Mesh; with opacity, scale_* and rot_* it is Gaussians; otherwise Points.
SurfaceData readSurface(const std::string& path);

/// The individual readers parse a whole file held in memory; `name` is used in messages.
SurfaceData readPly(const std::string& bytes, const std::string& name);
SurfaceData readPcd(const std::string& bytes, const std::string& name);
SurfaceData readObj(const std::string& bytes, const std::string& name);
SurfaceData readOff(const std::string& bytes, const std::string& name);
SurfaceData readStl(const std::string& bytes, const std::string& name);

/// Whole file into memory; throws TopoError when it cannot be opened or is empty.
std::string readFileBytes(const std::string& path);

}  // namespace topo_gaussian::geometry
