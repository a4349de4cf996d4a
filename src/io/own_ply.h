// Internal to io: the one PLY code path of our own formats (volume.ply, interior.ply): a binary
// little-endian header with comments, one vertex element with a fixed property list, fixed-size
// records. Third-party PLY files (3DGS, scans, meshes) are geometry's readers, not this.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace topo_gaussian::io {

struct OwnPlyLayout {
  const char* what;        ///< "volume", "interior" (messages)
  const char* properties;  ///< the exact "property ..." lines
  std::size_t record_bytes;
  const char* fix;  ///< how to get a good file
};

/// The file's bytes checked against the layout: `*count` records start at `*body`; the comment lines
/// (without "comment ") in `*comments`. Throws TopoError naming the path when it is not such a file,
/// its header is malformed, or it is truncated (with how many records are present).
std::string readOwnPly(const std::string& path, const OwnPlyLayout& layout, std::size_t* count, std::size_t* body,
                       std::vector<std::string>* comments);

/// Header + records, written atomically.
void writeOwnPly(const std::string& path, const OwnPlyLayout& layout, const std::vector<std::string>& comments,
                 std::size_t count, const std::string& records);

}  // namespace topo_gaussian::io
