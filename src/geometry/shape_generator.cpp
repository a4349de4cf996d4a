#include "topo_gaussian/geometry/shape_generator.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/io/text_file.h"
#include "topo_gaussian/physics/default_shapes.h"

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

// Surface of revolution about z of a meridian profile (r, z) that starts and ends on the axis
// (r = 0: the two poles) and runs from the bottom pole to the top pole with the solid on its left
// (towards the axis); every point in between has r > 0 and becomes a ring of `seg` vertices.
SurfaceData revolve(const std::vector<Eigen::Vector2d>& profile, int seg, const std::string& name) {
  SurfaceData m = emptyMesh(name);
  const int rings = int(profile.size()) - 2;
  m.points.emplace_back(0, 0, profile.front().y());
  for (int i = 1; i <= rings; ++i)
    for (int j = 0; j < seg; ++j) {
      const double ph = 2 * M_PI * j / seg;
      m.points.emplace_back(profile[i].x() * std::cos(ph), profile[i].x() * std::sin(ph), profile[i].y());
    }
  const int top = int(m.points.size());
  m.points.emplace_back(0, 0, profile.back().y());
  auto ring = [&](int i, int j) { return 1 + (i - 1) * seg + (j % seg); };
  for (int j = 0; j < seg; ++j) m.triangles.emplace_back(0, ring(1, j + 1), ring(1, j));
  for (int i = 1; i < rings; ++i)
    for (int j = 0; j < seg; ++j) quad(m, ring(i, j), ring(i, j + 1), ring(i + 1, j + 1), ring(i + 1, j));
  for (int j = 0; j < seg; ++j) m.triangles.emplace_back(top, ring(rings, j), ring(rings, j + 1));
  return m;
}

// Extrusion along y ∈ [−w, w] of a convex polygon in the (x, z) plane given counter-clockwise
// (x to the right, z up). Side walls are quads, the two caps fans from the first vertex.
SurfaceData extrudeY(const std::vector<Eigen::Vector2d>& poly, double w, const std::string& name) {
  SurfaceData m = emptyMesh(name);
  const int n = int(poly.size());
  for (double y : {-w, w})
    for (const auto& p : poly) m.points.emplace_back(p.x(), y, p.y());
  for (int k = 0; k < n; ++k) quad(m, k, n + k, n + (k + 1) % n, (k + 1) % n);
  for (int k = 1; k + 1 < n; ++k) {
    m.triangles.emplace_back(0, k, k + 1);          // y = −w, normal −y
    m.triangles.emplace_back(n, n + k + 1, n + k);  // y = +w, normal +y
  }
  return m;
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
  for (int c = 0; c < 8; ++c)
    m.points.emplace_back((c & 1 ? 1 : -1) * h.x(), (c & 2 ? 1 : -1) * h.y(), (c & 4 ? 1 : -1) * h.z());
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
    throw TopoError("shape " + name, "size " + std::to_string(size) + " m is not positive",
                    "give a size in metres, e.g. 0.1");
  if (name == "sphere") return makeSphere(size);
  if (name == "torus") return makeTorus(size * 2.0 / 3.0, size / 3.0);
  if (name == "box") return makeBox(Eigen::Vector3d::Constant(size));
  throw TopoError("shape " + name, "is not a known shape", "use one of: sphere, torus, box");
}

SurfaceData makeDefaultShapeMesh(const std::string& name, int resolution) {
  const DefaultShape shape = defaultShape(name);  // throws for an unknown name, listing the valid ones
  if (resolution < 8 || resolution > 4096)
    throw TopoError("mesh resolution " + std::to_string(resolution), "is out of range",
                    "give 8 to 4096 segments around a full circle (default 64)");
  const std::string source = "default " + name + " shape";
  const ShapeOutline outline = shape.outline(resolution);
  switch (outline.kind) {
    case ShapeOutline::Kind::ExtrudedAlongY:
      return extrudeY(outline.curve, outline.half_width, source);
    case ShapeOutline::Kind::RevolvedAboutZ:
      return revolve(outline.curve, resolution, source);
    case ShapeOutline::Kind::Box:
      break;
  }
  SurfaceData m = makeBox(shape.hi - shape.lo);
  const Eigen::Vector3d mid = 0.5 * (shape.lo + shape.hi);
  for (auto& p : m.points) p += mid;
  m.source = source;
  return m;
}

void writeObj(const SurfaceData& mesh, const std::string& path) {
  std::ostringstream f;  // written atomically at the end (io/text_file.h)
  f.precision(9);
  f << "# " << mesh.source << " (topo_gaussian)\n";
  for (const auto& p : mesh.points) f << "v " << p.x() << ' ' << p.y() << ' ' << p.z() << '\n';
  for (const auto& t : mesh.triangles) f << "f " << t[0] + 1 << ' ' << t[1] + 1 << ' ' << t[2] + 1 << '\n';
  io::writeTextFile(path, f.str());
}

}  // namespace topo_gaussian::geometry
