// readSurface: loads a file into memory and picks the reader by extension.
#include "topo_gaussian/geometry/surface_reader.h"

#include <filesystem>
#include <fstream>
#include <system_error>

#include "byte_cursor.h"
#include "reader_common.h"
#include "topo_gaussian/common/error.h"

namespace topo_gaussian::geometry {

std::string readFileBytes(const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  if (path.empty() || !fs::exists(st)) {
    throw TopoError(path.empty() ? std::string("(empty path)") : path, "the file does not exist",
                    "check the path (a relative path is taken from the current working directory)");
  }
  if (fs::is_directory(st)) {
    throw TopoError(path, "is a directory, not a file",
                    std::string("give the path of a surface file (") + detail::supportedExtensions() + ")");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    throw TopoError(path, "the file cannot be opened (no read permission?)", "check the file's permissions");
  }
  std::string bytes;
  // Read in chunks: works for regular files and for pipes, whose size is not known up front.
  char buf[1 << 16];
  while (in.read(buf, sizeof(buf)) || in.gcount() > 0) {
    bytes.append(buf, static_cast<std::size_t>(in.gcount()));
    if (in.eof()) break;
  }
  if (in.bad()) throw TopoError(path, "reading the file failed (I/O error)", "check the disk and copy the file again");
  if (bytes.empty()) {
    throw TopoError(path, "the file is empty (0 bytes)", "copy or export the file again; it has no content");
  }
  return bytes;
}

SurfaceData readSurface(const std::string& path) {
  const std::string ext = detail::lower(std::filesystem::path(path).extension().string());
  SurfaceData (*reader)(const std::string&, const std::string&) = nullptr;
  if (ext == ".ply")
    reader = &readPly;
  else if (ext == ".pcd")
    reader = &readPcd;
  else if (ext == ".obj")
    reader = &readObj;
  else if (ext == ".off")
    reader = &readOff;
  else if (ext == ".stl")
    reader = &readStl;
  if (!reader) {
    throw TopoError(
        path, "unsupported file extension " + (ext.empty() ? std::string("(none)") : "'" + ext + "'"),
        std::string("convert the surface to one of the supported formats: ") + detail::supportedExtensions());
  }
  const std::string bytes = readFileBytes(path);
  SurfaceData data = reader(bytes, path);
  data.source = path;
  return data;
}

}  // namespace topo_gaussian::geometry
