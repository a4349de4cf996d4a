#include "topo_gaussian/io/volume_ply.h"

#include <cstring>
#include <sstream>

#include "topo_gaussian/io/text_file.h"
#include "topo_gaussian/common/error.h"

namespace topo_gaussian::io {

namespace {
constexpr std::size_t kRecord = 4 * 4 + 1;  // x y z volume (float32) surface (uint8)
}

void writeVolumePly(const VolumeCloud& c, const std::string& path) {
  c.validate(path);
  std::ostringstream spacing;
  spacing.precision(17);
  spacing << c.spacing;
  std::ostringstream header;
  header << "ply\nformat binary_little_endian 1.0\ncomment topo_gaussian volume cloud\n"
         << "comment spacing " << spacing.str() << "\n"
         << "element vertex " << c.size() << "\n"
         << "property float x\nproperty float y\nproperty float z\nproperty float volume\nproperty uchar surface\n"
         << "end_header\n";
  std::string buf(c.size() * kRecord, '\0');
  for (std::size_t i = 0; i < c.size(); ++i) {
    const float v[4] = {float(c.X[i].x()), float(c.X[i].y()), float(c.X[i].z()), float(c.V[i])};
    std::memcpy(&buf[i * kRecord], v, 16);  // little-endian hosts only (x86, arm64)
    buf[i * kRecord + 16] = char(c.surface[i]);
  }
  writeTextFile(path, header.str() + buf);
}

VolumeCloud readVolumePly(const std::string& path) {
  const std::string bytes = readTextFile(path, std::size_t(1) << 32);  // 250M particles at most
  const std::size_t end = bytes.find("end_header\n");
  const std::string expected =
      "property float x\nproperty float y\nproperty float z\nproperty float volume\nproperty uchar surface\n";
  if (bytes.compare(0, 4, "ply\n") != 0 || end == std::string::npos ||
      bytes.find("format binary_little_endian 1.0\n") == std::string::npos || bytes.find(expected) == std::string::npos)
    throw TopoError(path, "is not a topo_gaussian volume .ply (binary_little_endian with x y z volume surface)",
                    "write it with `topo fill --output FILE.ply`");
  std::istringstream header(bytes.substr(0, end));
  std::string line;
  VolumeCloud c;
  std::size_t n = 0;
  while (std::getline(header, line)) {
    std::istringstream ls(line);
    std::string a, b;
    ls >> a >> b;
    if (a == "comment" && b == "spacing") ls >> c.spacing;
    if (a == "element" && b == "vertex") ls >> n;
  }
  const std::size_t body = end + std::strlen("end_header\n");
  if (bytes.size() - body < n * kRecord)
    throw TopoError(path, "is truncated: " + std::to_string((bytes.size() - body) / kRecord) + " of " +
                              std::to_string(n) + " particles present", "write the volume again");
  c.X.resize(n);
  c.V.resize(n);
  c.surface.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    float v[4];
    std::memcpy(v, &bytes[body + i * kRecord], 16);
    c.X[i] = Eigen::Vector3d(v[0], v[1], v[2]);
    c.V[i] = v[3];
    c.surface[i] = std::uint8_t(bytes[body + i * kRecord + 16]);
  }
  c.validate(path);
  return c;
}

}  // namespace topo_gaussian::io
