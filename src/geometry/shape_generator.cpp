#include "topo_gaussian/geometry/shape_generator.h"

#include <cmath>
#include <fstream>

#include "topo_gaussian/physics/error.h"

namespace topo_gaussian::geometry {

namespace {

SurfaceData emptyMesh(const std::string& name) {
  SurfaceData m;
  m.kind = SurfaceKind::Mesh;
  m.source = name;
  return m;
}

// Quad (a b c d, counter-clockwise seen from outside) as two triangles, skipping degenerate ones.
void quad(SurfaceData& m, int a, int b, int c, int d) {
  if (a != b && b != c && a != c) m.triangles.emplace_back(a, b, c);
  if (a != c && c != d && a != d) m.triangles.emplace_back(a, c, d);
}

}  // namespace

SurfaceData makeSphere(double r, int seg, int rings) {
  SurfaceData m = emptyMesh("generated sphere");
  m.points.emplace_back(0, 0, -r);  // south pole: index 0
  for (int i = 1; i < rings; ++i) {
    const double th = M_PI * i / rings - M_PI / 2;
    for (int j = 0; j < seg; ++j) {
      const double ph = 2 * M_PI * j / seg;
      m.points.emplace_back(r * std::cos(th) * std::cos(ph), r * std::cos(th) * std::sin(ph), r * std::sin(th));
    }
  }
  const int north = int(m.points.size());
  m.points.emplace_back(0, 0, r);
  auto ring = [&](int i, int j) { return 1 + (i - 1) * seg + (j % seg); };
  for (int j = 0; j < seg; ++j) m.triangles.emplace_back(0, ring(1, j + 1), ring(1, j));
  for (int i = 1; i + 1 < rings; ++i)
    for (int j = 0; j < seg; ++j) quad(m, ring(i, j), ring(i, j + 1), ring(i + 1, j + 1), ring(i + 1, j));
  for (int j = 0; j < seg; ++j) m.triangles.emplace_back(north, ring(rings - 1, j), ring(rings - 1, j + 1));
  return m;
}

SurfaceData makeTorus(double R, double r, int seg, int tube) {
  SurfaceData m = emptyMesh("generated torus");
  for (int i = 0; i < seg; ++i) {
    const double u = 2 * M_PI * i / seg;
    for (int j = 0; j < tube; ++j) {
      const double v = 2 * M_PI * j / tube;
      m.points.emplace_back((R + r * std::cos(v)) * std::cos(u), (R + r * std::cos(v)) * std::sin(u), r * std::sin(v));
    }
  }
  auto id = [&](int i, int j) { return (i % seg) * tube + (j % tube); };
  for (int i = 0; i < seg; ++i)
    for (int j = 0; j < tube; ++j) quad(m, id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
  return m;
}

SurfaceData makeBox(const Eigen::Vector3d& size) {
  SurfaceData m = emptyMesh("generated box");
  const Eigen::Vector3d h = 0.5 * size;
  for (int c = 0; c < 8; ++c) m.points.emplace_back((c & 1 ? 1 : -1) * h.x(), (c & 2 ? 1 : -1) * h.y(), (c & 4 ? 1 : -1) * h.z());
  quad(m, 0, 2, 3, 1);  // -z
  quad(m, 4, 5, 7, 6);  // +z
  quad(m, 0, 1, 5, 4);  // -y
  quad(m, 2, 6, 7, 3);  // +y
  quad(m, 0, 4, 6, 2);  // -x
  quad(m, 1, 3, 7, 5);  // +x
  return m;
}

const std::vector<std::string>& shapeNames() {
  static const std::vector<std::string> names{"sphere", "torus", "box"};
  return names;
}

SurfaceData makeShape(const std::string& name, double size) {
  if (!(size > 0.0) || !std::isfinite(size))
    throw TopoError("shape " + name, "size " + std::to_string(size) + " m is not positive", "give a size in metres, e.g. 0.1");
  if (name == "sphere") return makeSphere(size);
  if (name == "torus") return makeTorus(size * 2.0 / 3.0, size / 3.0);
  if (name == "box") return makeBox(Eigen::Vector3d::Constant(size));
  throw TopoError("shape " + name, "is not a known shape", "use one of: sphere, torus, box");
}

void writeObj(const SurfaceData& mesh, const std::string& path) {
  std::ofstream f(path);
  if (!f) throw TopoError(path, "cannot be opened for writing", "check the directory exists and is writable");
  f.precision(9);
  f << "# " << mesh.source << " (topo_gaussian)\n";
  for (const auto& p : mesh.points) f << "v " << p.x() << ' ' << p.y() << ' ' << p.z() << '\n';
  for (const auto& t : mesh.triangles) f << "f " << t[0] + 1 << ' ' << t[1] + 1 << ' ' << t[2] + 1 << '\n';
  if (!f) throw TopoError(path, "could not be written completely", "check free disk space");
}

}  // namespace topo_gaussian::geometry
