// The volume .ply (our own format, what `topo fill` and cloud_ingest write and every inference reads):
// one vertex per particle with x y z volume surface (binary little endian), the spacing in a comment.
#pragma once

#include <string>

#include "topo_gaussian/physics/volume_cloud.h"

namespace topo_gaussian::io {

/// Writes x y z (float) volume (float, m^3) surface (uchar) and a comment with the spacing.
/// Written atomically (io/text_file.h). Throws TopoError when the file cannot be written.
void writeVolumePly(const VolumeCloud& cloud, const std::string& path);

/// Reads a file written by writeVolumePly (or any PLY with x y z volume [surface]). A file without the
/// spacing comment (an older version's) gets the one fallback, deriveMissingSpacing
/// (physics/volume_cloud.h), and a warning: into `*warning` when given ("" when the file carried the
/// spacing), else on std::cerr.
VolumeCloud readVolumePly(const std::string& path, std::string* warning = nullptr);

}  // namespace topo_gaussian::io
