// Reading surfaces from files: 3DGS .ply, point clouds (.ply, .pcd), meshes (.obj, .off, .stl, .ply).
// Every reader throws TopoError naming the file, the problem and the fix; none crashes on bad bytes.
#pragma once

#include <cstdint>
#include <string>

#include "topo_gaussian/geometry/surface_data.h"

namespace topo_gaussian::geometry {

/// Limits every reader enforces before it allocates (so a huge or lying file is refused with a
/// message, never ends in std::bad_alloc): the file size, and the number of points (vertices) a
/// header may declare. A point in memory takes up to ~250 bytes (a 3D Gaussian with its covariance,
/// colour and normal), so the point limit keeps a read under ~5 GB.
constexpr std::uint64_t kMaxSurfaceFileBytes = 2ull << 30;  // 2 GiB
constexpr std::uint64_t kMaxSurfacePoints = 20000000;       // 2e7 points or vertices
constexpr std::uint64_t kBytesPerPointInMemory = 250;

/// Reads any supported file, choosing the reader by extension (case-insensitive).
/// A PLY with faces is a Mesh; with opacity, scale_* and rot_* it is Gaussians; otherwise Points.
SurfaceData readSurface(const std::string& path);

/// The individual readers parse a whole file held in memory; `name` is used in messages.
SurfaceData readPly(const std::string& bytes, const std::string& name);
SurfaceData readPcd(const std::string& bytes, const std::string& name);
SurfaceData readObj(const std::string& bytes, const std::string& name);
SurfaceData readOff(const std::string& bytes, const std::string& name);
SurfaceData readStl(const std::string& bytes, const std::string& name);

/// Whole file into memory; throws TopoError when it is not a regular file (a FIFO, /dev/zero, a
/// directory), is larger than kMaxSurfaceFileBytes, cannot be opened or is empty.
std::string readFileBytes(const std::string& path);

}  // namespace topo_gaussian::geometry
