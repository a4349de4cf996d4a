#include "topo_gaussian/io/volume_ply.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <sstream>

#include "own_ply.h"
#include "topo_gaussian/common/error.h"

namespace topo_gaussian::io {

namespace {
constexpr std::size_t kRecord = 4 * 4 + 1;     // x y z volume (float32) surface (uint8)
constexpr std::size_t kContactRecord = 7 * 4;  // x y z nx ny nz area (float32)
const OwnPlyLayout kLayout{
    "volume", "property float x\nproperty float y\nproperty float z\nproperty float volume\nproperty uchar surface\n",
    kRecord, "write it with `topo fill --output FILE.ply`",
    OwnPlyElement{"contact",
                  "property float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\n"
                  "property float nz\nproperty float area\n",
                  kContactRecord}};
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
  std::vector<std::string> comments{"topo_gaussian volume cloud", "spacing " + spacing.str()};
  const ContactSamples& cs = c.contact;
  std::string contact(cs.size() * kContactRecord, '\0');
  if (!cs.empty()) {
    std::ostringstream cspacing;
    cspacing.precision(17);
    cspacing << cs.spacing;
    comments.push_back("contact_spacing " + cspacing.str());
    if (!cs.origin.empty()) comments.push_back("contact_origin " + cs.origin);
    for (std::size_t k = 0; k < cs.size(); ++k) {
      const float v[7] = {float(cs.X[k].x()),      float(cs.X[k].y()),      float(cs.X[k].z()), float(cs.normal[k].x()),
                          float(cs.normal[k].y()), float(cs.normal[k].z()), float(cs.area[k])};
      std::memcpy(&contact[k * kContactRecord], v, kContactRecord);
    }
  }
  writeOwnPly(path, kLayout, comments, c.size(), buf, cs.size(), contact);
}

VolumeCloud readVolumePly(const std::string& path, std::string* warning) {
  std::size_t n = 0, body = 0;
  std::vector<std::string> comments;
  std::size_t n_contact = 0, contact_body = 0;
  const std::string bytes = readOwnPly(path, kLayout, &n, &body, &comments, &n_contact, &contact_body);
  VolumeCloud c;
  for (const auto& cm : comments) {
    if (cm.rfind("spacing ", 0) == 0) c.spacing = std::strtod(cm.c_str() + 8, nullptr);
    if (cm.rfind("contact_spacing ", 0) == 0) c.contact.spacing = std::strtod(cm.c_str() + 16, nullptr);
    if (cm.rfind("contact_origin ", 0) == 0) c.contact.origin = cm.substr(15);
  }
  c.contact.X.resize(n_contact);
  c.contact.normal.resize(n_contact);
  c.contact.area.resize(n_contact);
  for (std::size_t k = 0; k < n_contact; ++k) {
    float v[7];
    std::memcpy(v, &bytes[contact_body + k * kContactRecord], kContactRecord);
    c.contact.X[k] = Eigen::Vector3d(v[0], v[1], v[2]);
    // Renormalised: float storage leaves |n| − 1 ~ 1e-7.
    const Eigen::Vector3d nk(v[3], v[4], v[5]);
    c.contact.normal[k] = nk.norm() > 0 ? Eigen::Vector3d(nk.normalized()) : nk;
    c.contact.area[k] = v[6];
  }
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
  // A file written before the spacing (or the contact samples' spacing) was carried: the one fallback.
  std::string note = deriveMissingSpacing(&c, path);
  const std::string contact_note = deriveMissingSpacing(&c.contact, path);
  if (!contact_note.empty()) note += (note.empty() ? "" : "; ") + contact_note;
  if (warning)
    *warning = note;
  else if (!note.empty())
    std::cerr << "[topo] warning: " << note << "\n";
  c.validate(path);
  return c;
}

}  // namespace topo_gaussian::io
