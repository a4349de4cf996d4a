#include "topo_gaussian/io/interior_ply.h"

#include <cmath>
#include <cstring>
#include <sstream>

#include "own_ply.h"
#include "topo_gaussian/common/error.h"

namespace topo_gaussian::io {

namespace {
constexpr std::size_t kRecord = 4 * 4 + 1 + 4;  // x y z r (float32), solid (uint8), density (float32)
const OwnPlyLayout kLayout{
    "interior",
    "property float x\nproperty float y\nproperty float z\nproperty float r\nproperty uchar solid\n"
    "property float density\n",
    kRecord, "give an interior.ply written by topo infer (or the interior_inference node) for this volume"};
}  // namespace

void writeInteriorPly(const std::string& path, const VolumeCloud& cloud, const std::vector<double>& r,
                      const std::vector<double>& density, bool continuous) {
  if (r.size() != cloud.size() || density.size() != cloud.size())
    throw TopoError(path,
                    "interior has " + std::to_string(r.size()) + " r and " + std::to_string(density.size()) +
                        " density values for " + std::to_string(cloud.size()) + " particles",
                    "write the interior computed on this volume");
  std::string body(cloud.size() * kRecord, '\0');
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const float v[4] = {float(cloud.X[i].x()), float(cloud.X[i].y()), float(cloud.X[i].z()), float(r[i])};
    const float d = float(density[i]);
    char* rec = &body[i * kRecord];
    std::memcpy(rec, v, sizeof v);  // little-endian hosts only (x86, arm64)
    rec[16] = r[i] >= 0.5 ? 1 : 0;
    std::memcpy(rec + 17, &d, sizeof d);
  }
  writeOwnPly(path, kLayout,
              {std::string("topo_gaussian interior: solid = r >= 0.5") +
               (continuous ? " (continuous material: r is the density fraction)" : "")},
              cloud.size(), body);
}

InteriorPly readInteriorPlyData(const std::string& path, std::size_t expected) {
  std::size_t count = 0, body = 0;
  std::vector<std::string> comments;
  const std::string bytes = readOwnPly(path, kLayout, &count, &body, &comments);
  InteriorPly out;
  for (const auto& c : comments) out.continuous = out.continuous || c.find("continuous material") != std::string::npos;
  if (count != expected)
    throw TopoError(path, "has " + std::to_string(count) + " particles, the volume has " + std::to_string(expected),
                    "use the interior computed on this volume");
  out.X.resize(count);
  out.r.resize(count);
  out.density.resize(count);
  for (std::size_t i = 0; i < count; ++i) {
    const char* rec = &bytes[body + i * kRecord];
    float v[4], d;
    std::memcpy(v, rec, sizeof v);
    std::memcpy(&d, rec + 17, sizeof d);
    if (!(v[3] >= 0.0f && v[3] <= 1.0f))
      throw TopoError(path, "particle " + std::to_string(i) + " has r = " + std::to_string(v[3]) + ", outside [0, 1]",
                      kLayout.fix);
    if (!std::isfinite(v[0]) || !std::isfinite(v[1]) || !std::isfinite(v[2]) || !std::isfinite(d))
      throw TopoError(path, "particle " + std::to_string(i) + " has a non-finite position or density", kLayout.fix);
    out.X[i] = Eigen::Vector3d(v[0], v[1], v[2]);
    out.r[i] = v[3];
    out.density[i] = d;
  }
  return out;
}

std::vector<double> readInteriorPly(const std::string& path, std::size_t expected) {
  return readInteriorPlyData(path, expected).r;
}

}  // namespace topo_gaussian::io
