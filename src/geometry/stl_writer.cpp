#include "topo_gaussian/geometry/stl_writer.h"

#include <Eigen/Geometry>
#include <cstdint>
#include <cstring>
#include <vector>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/io/text_file.h"

namespace topo_gaussian::geometry {

namespace {

void putFloat(unsigned char* p, double v) {
  const float f = float(v);
  std::uint32_t b;
  std::memcpy(&b, &f, 4);
  for (int k = 0; k < 4; ++k) p[k] = static_cast<unsigned char>(b >> (8 * k));  // little-endian on any host
}

}  // namespace

void writeStlBinary(const SurfaceData& mesh, const std::string& path, double scale, const std::string& header) {
  const std::size_t nv = mesh.points.size();
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k)
      if (mesh.triangles[t][k] < 0 || std::size_t(mesh.triangles[t][k]) >= nv)
        throw TopoError(path,
                        "triangle " + std::to_string(t) + " names vertex " + std::to_string(mesh.triangles[t][k]) +
                            " of " + std::to_string(nv),
                        "build the mesh with valid vertex indices");
  if (mesh.triangles.size() > 0xFFFFFFFFull)
    throw TopoError(path, "has more triangles than binary STL can count (2^32 - 1)", "use a coarser volume");
  std::string out;  // the whole file, written atomically at the end (io/text_file.h)
  out.reserve(84 + 50 * mesh.triangles.size());
  std::string text = header;
  if (text.rfind("solid", 0) == 0) text = "binary STL: " + text;
  unsigned char head[84] = {};
  std::memcpy(head, text.data(), std::min<std::size_t>(text.size(), 80));
  const std::uint32_t count = std::uint32_t(mesh.triangles.size());
  for (int k = 0; k < 4; ++k) head[80 + k] = static_cast<unsigned char>(count >> (8 * k));
  out.append(reinterpret_cast<const char*>(head), 84);
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    const auto& tri = mesh.triangles[t];
    const Eigen::Vector3d a = mesh.points[tri[0]] * scale, b = mesh.points[tri[1]] * scale,
                          c = mesh.points[tri[2]] * scale;
    Eigen::Vector3d n = (b - a).cross(c - a);
    const double len = n.norm();
    n = len > 0.0 ? Eigen::Vector3d(n / len) : Eigen::Vector3d::Zero();
    unsigned char rec[50] = {};
    const Eigen::Vector3d* v[4] = {&n, &a, &b, &c};
    for (int q = 0; q < 4; ++q)
      for (int k = 0; k < 3; ++k) putFloat(rec + 12 * q + 4 * k, (*v[q])[k]);
    out.append(reinterpret_cast<const char*>(rec), 50);
  }
  io::writeTextFile(path, out);
}

}  // namespace topo_gaussian::geometry
