// readSurface: loads a regular file (size-checked) into memory and picks the reader by extension.
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
  std::error_code lec;
  if (!path.empty() && !fs::exists(st) && fs::is_symlink(fs::symlink_status(path, lec))) {
    // A link is there: say what is wrong with it, not that the file does not exist.
    std::error_code rec;
    const fs::path target = fs::read_symlink(path, rec);
    if (ec == std::errc::too_many_symbolic_link_levels)
      throw TopoError(path,
                      "is a symbolic link that leads back to itself through links (a link loop: " + ec.message() +
                          ")",
                      "point the link at the surface file (ln -sf FILE " + path + "), or give the file's own path");
    throw TopoError(path, "is a symbolic link to " + target.string() + ", which does not exist (a dangling link)",
                    "point the link at the surface file, or give the file's own path");
  }
  if (path.empty() || !fs::exists(st)) {
    throw TopoError(path.empty() ? std::string("(empty path)") : path, "the file does not exist",
                    "check the path (a relative path is taken from the current working directory)");
  }
  if (fs::is_directory(st)) {
    throw TopoError(path, "is a directory, not a file",
                    std::string("give the path of a surface file (") + detail::supportedExtensions() + ")");
  }
  if (!fs::is_regular_file(st)) {
    // A FIFO would block until a writer appears, /dev/zero or /dev/urandom would be read forever.
    throw TopoError(path, "is not a regular file (a pipe, device or socket): it cannot be read as a surface",
                    "save the surface to a regular file first (e.g. cat the stream into a .ply) and give that path");
  }
  const std::uintmax_t size = fs::file_size(path, ec);
  if (ec) throw TopoError(path, "its size cannot be read (" + ec.message() + ")", "check the path and its permissions");
  if (size > kMaxSurfaceFileBytes) {
    throw TopoError(path,
                    "is " + std::to_string(size) + " bytes, more than the " + std::to_string(kMaxSurfaceFileBytes) +
                        " bytes (2 GiB) topo reads: it would need about " +
                        std::to_string((size * 3 / 1000000000) + 1) + " GB of memory to parse",
                    "downsample the surface first (e.g. CloudCompare: Subsample, or MeshLab: Quadric Edge Collapse "
                    "Decimation) or crop it to the object; the fill needs far fewer points");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    throw TopoError(path, "the file cannot be opened (no read permission?)", "check the file's permissions");
  }
  std::string bytes;
  bytes.reserve(static_cast<std::size_t>(size));
  // Read in chunks, never more than the size checked above (the file may grow while we read).
  char buf[1 << 16];
  while (bytes.size() <= kMaxSurfaceFileBytes && (in.read(buf, sizeof(buf)) || in.gcount() > 0)) {
    bytes.append(buf, static_cast<std::size_t>(in.gcount()));
    if (in.eof()) break;
  }
  if (bytes.size() > kMaxSurfaceFileBytes)
    throw TopoError(path, "grew beyond " + std::to_string(kMaxSurfaceFileBytes) + " bytes while it was read",
                    "wait until the file is written completely, then read it again");
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
