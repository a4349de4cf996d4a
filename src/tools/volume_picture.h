// A PNG of a VolumeCloud for people: a cut-away 3D view (the half facing the camera removed)
// and the horizontal slice through the centroid, with counts and volume in the title.
#pragma once

#include <string>

#include "topo_gaussian/physics/volume_cloud.h"

namespace topo_gaussian::tools {

/// Throws TopoError when the image cannot be written.
void writeVolumePicture(const VolumeCloud& cloud, const std::string& title, const std::string& png_path);

}  // namespace topo_gaussian::tools
