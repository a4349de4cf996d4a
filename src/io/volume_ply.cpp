#include "topo_gaussian/io/volume_ply.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <sstream>

#include "own_ply.h"
#include "topo_gaussian/common/error.h"

namespace topo_gaussian::io {

namespace {
constexpr std::size_t kRecord = 4 * 4 + 1;  // x y z volume (float32) surface (uint8)
const OwnPlyLayout kLayout{
    "volume", "property float x\nproperty float y\nproperty float z\nproperty float volume\nproperty uchar surface\n",
    kRecord, "write it with `topo fill --output FILE.ply`"};
}  // namespace

void writeVolumePly(const VolumeCloud& c, const std::string& path) {
  c.validate(path);
  std::ostringstream spacing;
  spacing.precision(17);
  spacing << c.spacing;
  std::string buf(c.size() * kRecord, '\0');
  for (std::size_t i = 0; i < c.size(); ++i) {
    const float v[4] = {float(c.X[i].x()), float(c.X[i].y()), float(c.X[i].z()), float(c.V[i])};
    std::memcpy(&buf[i * kRecord], v, 16);  // little-endian hosts only (x86, arm64)
    buf[i * kRecord + 16] = char(c.surface[i]);
  }
  writeOwnPly(path, kLayout, {"topo_gaussian volume cloud", "spacing " + spacing.str()}, c.size(), buf);
}

VolumeCloud readVolumePly(const std::string& path) {
  std::size_t n = 0, body = 0;
  std::vector<std::string> comments;
  const std::string bytes = readOwnPly(path, kLayout, &n, &body, &comments);
  VolumeCloud c;
  for (const auto& cm : comments)
    if (cm.rfind("spacing ", 0) == 0) c.spacing = std::strtod(cm.c_str() + 8, nullptr);
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
  // Name the real problem before VolumeCloud::validate, which checks the spacing first.
  std::size_t bad = 0, first_bad = n;
  for (std::size_t i = 0; i < n; ++i)
    if (!(c.V[i] > 0.0) || !std::isfinite(c.V[i])) {
      ++bad;
      first_bad = std::min(first_bad, i);
    }
  if (bad)
    throw TopoError(path,
                    std::to_string(bad) + " of its " + std::to_string(n) +
                        " particles have a volume that is not a positive finite number (the first: particle " +
                        std::to_string(first_bad) + ", volume " + std::to_string(c.V[first_bad]) + " m^3)",
                    "every particle needs its volume in m^3 (> 0); write the file with `topo fill --output FILE.ply`");
  if (!(c.spacing > 0.0) || !std::isfinite(c.spacing)) {
    if (n == 0) {
      c.validate(path);
      return c;
    }
    // No (valid) "comment spacing h": a lattice particle's volume is h³.
    std::vector<double> v(c.V.begin(), c.V.end());
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    c.spacing = std::cbrt(v[v.size() / 2]);
  }
  c.validate(path);
  return c;
}

}  // namespace topo_gaussian::io
