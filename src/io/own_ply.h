// Internal to io: the one PLY code path of our own formats (volume.ply, interior.ply): a binary
// little-endian header with comments, one vertex element with a fixed property list, fixed-size
// records, optionally followed by one more element of fixed-size records (volume.ply's contact
// samples), which older files may lack. Third-party PLY files (3DGS, scans, meshes) are geometry's readers, not this.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace topo_gaussian::io {

/// A second element after the vertices: name, exact "property ..." lines, bytes per record.
struct OwnPlyElement {
  const char* name = nullptr;  ///< nullptr: the layout has no second element
  const char* properties = nullptr;
  std::size_t record_bytes = 0;
};

struct OwnPlyLayout {
  const char* what;        ///< "volume", "interior" (messages)
  const char* properties;  ///< the exact "property ..." lines
  std::size_t record_bytes;
  const char* fix;  ///< how to get a good file
  OwnPlyElement extra{};
};

/// The file's bytes checked against the layout: `*count` records start at `*body`; the comment lines
/// (without "comment ") in `*comments`; the second element's `*extra_count` records (0 when the file
/// has none) at `*extra_body`. Throws TopoError naming the path when it is not such a file, its header
/// is malformed, or it is truncated (with how many records are present).
std::string readOwnPly(const std::string& path, const OwnPlyLayout& layout, std::size_t* count, std::size_t* body,
                       std::vector<std::string>* comments, std::size_t* extra_count = nullptr,
                       std::size_t* extra_body = nullptr);

/// Header + records (+ the second element's records when extra_count > 0), written atomically.
void writeOwnPly(const std::string& path, const OwnPlyLayout& layout, const std::vector<std::string>& comments,
                 std::size_t count, const std::string& records, std::size_t extra_count = 0,
                 const std::string& extra_records = std::string());

}  // namespace topo_gaussian::io
