#include "own_ply.h"

#include <cstring>
#include <sstream>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/io/text_file.h"

namespace topo_gaussian::io {

std::string readOwnPly(const std::string& path, const OwnPlyLayout& layout, std::size_t* count, std::size_t* body,
                       std::vector<std::string>* comments, std::size_t* extra_count, std::size_t* extra_body) {
  std::string bytes = readTextFile(path, std::size_t(1) << 33);
  const std::size_t end = bytes.find("end_header\n");
  if (bytes.compare(0, 4, "ply\n") != 0 || end == std::string::npos)
    throw TopoError(path, std::string("is not a PLY file with a complete header"), layout.fix);
  const std::string header = bytes.substr(0, end);
  if (header.find("format binary_little_endian 1.0\n") == std::string::npos ||
      header.find(layout.properties) == std::string::npos)
    throw TopoError(path,
                    std::string("is not a topo_gaussian ") + layout.what + " .ply (binary little endian, properties " +
                        layout.properties + ")",
                    layout.fix);
  *count = 0;
  std::size_t n_extra = 0;
  bool has_count = false, has_extra = false;
  const std::string extra_line = layout.extra.name ? std::string("element ") + layout.extra.name : std::string();
  std::istringstream lines(header);
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("comment ", 0) == 0) {
      if (comments) comments->push_back(line.substr(8));
    } else if (line.rfind("element vertex", 0) == 0) {
      std::istringstream ls(line.substr(14));
      if (!(ls >> *count)) throw TopoError(path, "has a malformed line '" + line.substr(0, 60) + "'", layout.fix);
      has_count = true;
    } else if (!extra_line.empty() && line.rfind(extra_line + " ", 0) == 0) {
      std::istringstream ls(line.substr(extra_line.size()));
      if (!(ls >> n_extra)) throw TopoError(path, "has a malformed line '" + line.substr(0, 60) + "'", layout.fix);
      has_extra = true;
    }
  }
  if (!has_count) throw TopoError(path, "has no `element vertex N` line", layout.fix);
  if (has_extra && header.find(layout.extra.properties) == std::string::npos)
    throw TopoError(
        path, std::string("has an element ") + layout.extra.name + " without the properties " + layout.extra.properties,
        layout.fix);
  *body = end + std::strlen("end_header\n");
  const std::size_t present = (bytes.size() - *body) / layout.record_bytes;
  if (present < *count)
    throw TopoError(path,
                    "is truncated: " + std::to_string(present) + " of " + std::to_string(*count) + " particles present",
                    "the file was cut off (a crash or a full disk while writing): write it again");
  const std::size_t after = *body + *count * layout.record_bytes;
  if (has_extra) {
    const std::size_t present_extra = (bytes.size() - after) / layout.extra.record_bytes;
    if (present_extra < n_extra)
      throw TopoError(path,
                      "is truncated: " + std::to_string(present_extra) + " of " + std::to_string(n_extra) + " " +
                          layout.extra.name + " records present",
                      "the file was cut off (a crash or a full disk while writing): write it again");
  }
  if (extra_count) *extra_count = n_extra;
  if (extra_body) *extra_body = after;
  return bytes;
}

void writeOwnPly(const std::string& path, const OwnPlyLayout& layout, const std::vector<std::string>& comments,
                 std::size_t count, const std::string& records, std::size_t extra_count,
                 const std::string& extra_records) {
  std::ostringstream header;
  header << "ply\nformat binary_little_endian 1.0\n";
  for (const auto& c : comments) header << "comment " << c << "\n";
  header << "element vertex " << count << "\n" << layout.properties;
  if (extra_count > 0 && layout.extra.name)
    header << "element " << layout.extra.name << " " << extra_count << "\n" << layout.extra.properties;
  header << "end_header\n";
  writeTextFile(path, header.str() + records + (extra_count > 0 ? extra_records : std::string()));
}

}  // namespace topo_gaussian::io
