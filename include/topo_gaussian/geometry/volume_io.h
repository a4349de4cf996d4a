// The volume .ply: one vertex per particle with x y z volume surface (binary little endian).
#pragma once

#include <string>

#include "topo_gaussian/physics/volume_cloud.h"

namespace topo_gaussian::geometry {

/// Writes x y z (float) volume (float, m^3) surface (uchar) and a comment with the spacing.
/// Throws TopoError when the file cannot be written.
void writeVolumePly(const VolumeCloud& cloud, const std::string& path);

/// Reads a file written by writeVolumePly (or any PLY with x y z volume [surface]).
VolumeCloud readVolumePly(const std::string& path);

}  // namespace topo_gaussian::geometry
