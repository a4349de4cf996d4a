#include "topo_gaussian/io/interior_ply.h"

#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>

#include "own_ply.h"
#include "topo_gaussian/common/error.h"

namespace topo_gaussian::io {

namespace {
constexpr std::size_t kRecord = 4 * 4 + 1 + 4;          // x y z r (float32), solid (uint8), density (float32)
constexpr std::size_t kRecordConfidence = kRecord + 4;  // ... confidence (float32)
const char* const kFix = "give an interior.ply written by topo infer (or the interior_inference node) for this volume";
const OwnPlyLayout kLayout{"interior",
                           "property float x\nproperty float y\nproperty float z\nproperty float r\nproperty uchar "
                           "solid\nproperty float density\n",
                           kRecord, kFix};
const OwnPlyLayout kLayoutConfidence{"interior",
                                     "property float x\nproperty float y\nproperty float z\nproperty float r\nproperty "
                                     "uchar solid\nproperty float density\nproperty float confidence\n",
                                     kRecordConfidence, kFix};

/// True when the header of the file at `path` names the confidence property (read up to end_header).
bool hasConfidenceColumn(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::string line;
  while (in && std::getline(in, line) && line != "end_header")
    if (line == "property float confidence") return true;
  return false;
}
}  // namespace

void writeInteriorPly(const std::string& path, const VolumeCloud& cloud, const std::vector<double>& r,
                      const std::vector<double>& density, bool continuous, const std::vector<double>& confidence) {
  if (r.size() != cloud.size() || density.size() != cloud.size() ||
      (!confidence.empty() && confidence.size() != cloud.size()))
    throw TopoError(path,
                    "interior has " + std::to_string(r.size()) + " r, " + std::to_string(density.size()) +
                        " density and " + std::to_string(confidence.size()) + " confidence values for " +
                        std::to_string(cloud.size()) + " particles",
                    "write the interior computed on this volume");
  const bool with_confidence = !confidence.empty();
  const OwnPlyLayout& layout = with_confidence ? kLayoutConfidence : kLayout;
  std::string body(cloud.size() * layout.record_bytes, '\0');
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const float v[4] = {float(cloud.X[i].x()), float(cloud.X[i].y()), float(cloud.X[i].z()), float(r[i])};
    const float d = float(density[i]);
    char* rec = &body[i * layout.record_bytes];
    std::memcpy(rec, v, sizeof v);  // little-endian hosts only (x86, arm64)
    rec[16] = r[i] >= 0.5 ? 1 : 0;
    std::memcpy(rec + 17, &d, sizeof d);
    if (with_confidence) {
      const float c = float(confidence[i]);
      std::memcpy(rec + 21, &c, sizeof c);
    }
  }
  std::vector<std::string> comments{std::string("topo_gaussian interior: solid = r >= 0.5") +
                                    (continuous ? " (continuous material: r is the density fraction)" : "")};
  if (with_confidence)
    comments.push_back("confidence = fraction of the designs that fit as well whose solid/hollow label is this one's");
  writeOwnPly(path, layout, comments, cloud.size(), body);
}

InteriorPly readInteriorPlyData(const std::string& path, std::size_t expected) {
  std::size_t count = 0, body = 0;
  std::vector<std::string> comments;
  const OwnPlyLayout& layout = hasConfidenceColumn(path) ? kLayoutConfidence : kLayout;
  const std::string bytes = readOwnPly(path, layout, &count, &body, &comments);
  const bool with_confidence = &layout == &kLayoutConfidence;
  InteriorPly out;
  for (const auto& c : comments) out.continuous = out.continuous || c.find("continuous material") != std::string::npos;
  if (count != expected)
    throw TopoError(path, "has " + std::to_string(count) + " particles, the volume has " + std::to_string(expected),
                    "use the interior computed on this volume");
  out.X.resize(count);
  out.r.resize(count);
  out.density.resize(count);
  if (with_confidence) out.confidence.resize(count);
  for (std::size_t i = 0; i < count; ++i) {
    const char* rec = &bytes[body + i * layout.record_bytes];
    float v[4], d;
    std::memcpy(v, rec, sizeof v);
    std::memcpy(&d, rec + 17, sizeof d);
    if (!(v[3] >= 0.0f && v[3] <= 1.0f))
      throw TopoError(path, "particle " + std::to_string(i) + " has r = " + std::to_string(v[3]) + ", outside [0, 1]",
                      kFix);
    if (!std::isfinite(v[0]) || !std::isfinite(v[1]) || !std::isfinite(v[2]) || !std::isfinite(d))
      throw TopoError(path, "particle " + std::to_string(i) + " has a non-finite position or density", kFix);
    out.X[i] = Eigen::Vector3d(v[0], v[1], v[2]);
    out.r[i] = v[3];
    out.density[i] = d;
    if (with_confidence) {
      float c;
      std::memcpy(&c, rec + 21, sizeof c);
      if (!(c >= 0.0f && c <= 1.0f))
        throw TopoError(path,
                        "particle " + std::to_string(i) + " has confidence = " + std::to_string(c) + ", outside [0, 1]",
                        kFix);
      out.confidence[i] = c;
    }
  }
  return out;
}

std::vector<double> readInteriorPly(const std::string& path, std::size_t expected) {
  return readInteriorPlyData(path, expected).r;
}

}  // namespace topo_gaussian::io
