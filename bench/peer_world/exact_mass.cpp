// V = Σ_t a'·(b' × c')/6, ∫x = Σ_t V_t s/4, ∫xxᵀ = Σ_t V_t (a'a'ᵀ + b'b'ᵀ + c'c'ᵀ + s sᵀ)/20 over signed
// tetrahedra from a reference point: exact mass moments of closed triangle meshes (whole or clipped by a
// plane), closed forms of simple solids, and their sum by the parallel-axis theorem.
#include "peer_world/exact_mass.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <utility>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/number_text.h"

namespace topo_gaussian::peer {

namespace {

constexpr double kPi = 3.14159265358979323846;

/// Volume integrals about a reference point o: V = ∫dV, F = ∫(x − o) dV, S = ∫(x − o)(x − o)ᵀ dV.
struct VolumeIntegrals {
  double volume_m3 = 0.0;
  Eigen::Vector3d first_m4 = Eigen::Vector3d::Zero();
  Eigen::Matrix3d second_m5 = Eigen::Matrix3d::Zero();

  /// The tetrahedron (o, a, b, c), vertices relative to o: V = a·(b × c)/6, the canonical formula.
  void addTetrahedron(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
    const double v = a.dot(b.cross(c)) / 6.0;
    const Eigen::Vector3d s = a + b + c;
    volume_m3 += v;
    first_m4 += v / 4.0 * s;
    second_m5 += v / 20.0 * (a * a.transpose() + b * b.transpose() + c * c.transpose() + s * s.transpose());
  }
  void negate() {
    volume_m3 = -volume_m3;
    first_m4 = -first_m4;
    second_m5 = -second_m5;
  }
};

/// m = ρV, c = o + F/V, C = S − V (c − o)(c − o)ᵀ, I = ρ (tr(C) 1 − C).
MassMoments momentsFromIntegrals(const VolumeIntegrals& in, const Eigen::Vector3d& origin_m, double density_kg_m3) {
  const Eigen::Vector3d c_rel = in.first_m4 / in.volume_m3;
  Eigen::Matrix3d C = in.second_m5 - in.volume_m3 * c_rel * c_rel.transpose();
  C = 0.5 * (C + C.transpose()).eval();
  MassMoments m;
  m.mass_kg = density_kg_m3 * in.volume_m3;
  m.com_m = origin_m + c_rel;
  m.inertia_com_kg_m2 = density_kg_m3 * (C.trace() * Eigen::Matrix3d::Identity() - C);
  return m;
}

std::string vectorText(const Eigen::Vector3d& v) {
  return "(" + numberText(v.x()) + ", " + numberText(v.y()) + ", " + numberText(v.z()) + ")";
}

void checkFinite(const std::string& input, double value) {
  if (!std::isfinite(value))
    throw TopoError(input, "is not finite (" + numberText(value) + ")", "pass a finite number");
}
void checkFinite(const std::string& input, const Eigen::Vector3d& v) {
  if (!v.allFinite()) throw TopoError(input, "is not finite " + vectorText(v), "pass finite coordinates");
}

/// Indices in range, no repeated vertex in a triangle, finite vertices in use.
void checkIndices(const std::vector<Eigen::Vector3d>& vertices, const std::vector<Eigen::Vector3i>& triangles,
                  const std::string& name) {
  if (triangles.empty())
    throw TopoError(name, "has no triangles", "pass a closed triangle mesh (vertices and triangles)");
  const int n = static_cast<int>(vertices.size());
  for (std::size_t t = 0; t < triangles.size(); ++t) {
    const Eigen::Vector3i& f = triangles[t];
    for (int k = 0; k < 3; ++k)
      if (f[k] < 0 || f[k] >= n)
        throw TopoError(
            name, "triangle " + std::to_string(t) + " uses vertex " + std::to_string(f[k]) + " of " + std::to_string(n),
            "pass triangles whose indices are in [0, number of vertices)");
    if (f[0] == f[1] || f[1] == f[2] || f[0] == f[2])
      throw TopoError(name, "triangle " + std::to_string(t) + " repeats a vertex (a degenerate triangle)",
                      "remove degenerate triangles before measuring the mesh");
    for (int k = 0; k < 3; ++k)
      if (!vertices[f[k]].allFinite())
        throw TopoError(name, "vertex " + std::to_string(f[k]) + " is not finite", "pass finite vertex coordinates");
  }
}

/// Closed and consistently oriented: every directed edge (i, j) occurs once and its reverse (j, i) once.
void checkClosed(const std::vector<Eigen::Vector3d>& vertices, const std::vector<Eigen::Vector3i>& triangles,
                 const std::string& name) {
  checkIndices(vertices, triangles, name);
  std::vector<std::pair<int, int>> edges;
  edges.reserve(3 * triangles.size());
  for (const Eigen::Vector3i& f : triangles)
    for (int k = 0; k < 3; ++k) edges.emplace_back(f[k], f[(k + 1) % 3]);
  std::sort(edges.begin(), edges.end());
  const auto edgeText = [](const std::pair<int, int>& e) {
    return "(" + std::to_string(e.first) + ", " + std::to_string(e.second) + ")";
  };
  for (std::size_t k = 1; k < edges.size(); ++k)
    if (edges[k] == edges[k - 1])
      throw TopoError(name,
                      "the edge " + edgeText(edges[k]) +
                          " is used twice in the same direction: its triangles are not consistently oriented, or "
                          "more than two triangles share it",
                      "orient every triangle the same way (outward) and pass a manifold mesh");
  std::size_t open = 0;
  std::pair<int, int> first_open{-1, -1};
  for (const auto& e : edges)
    if (!std::binary_search(edges.begin(), edges.end(), std::make_pair(e.second, e.first))) {
      if (open++ == 0) first_open = e;
    }
  if (open > 0)
    throw TopoError(name,
                    "is not closed: " + std::to_string(open) + " edge(s) belong to one triangle only (e.g. " +
                        edgeText(first_open) + ")",
                    "close the holes (every edge must be shared by exactly two triangles) before measuring it");
}

/// Volume integrals of the whole mesh about `origin`, sign as given (negative for an inward mesh).
VolumeIntegrals wholeMesh(const std::vector<Eigen::Vector3d>& vertices, const std::vector<Eigen::Vector3i>& triangles,
                          const Eigen::Vector3d& origin) {
  VolumeIntegrals in;
  for (const Eigen::Vector3i& f : triangles)
    in.addTetrahedron(vertices[f[0]] - origin, vertices[f[1]] - origin, vertices[f[2]] - origin);
  return in;
}

/// Bounding-box centre and diagonal of the vertices the triangles use.
std::pair<Eigen::Vector3d, double> boundingBox(const std::vector<Eigen::Vector3d>& vertices,
                                               const std::vector<Eigen::Vector3i>& triangles) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
  for (const Eigen::Vector3i& f : triangles)
    for (int k = 0; k < 3; ++k) {
      lo = lo.cwiseMin(vertices[f[k]]);
      hi = hi.cwiseMax(vertices[f[k]]);
    }
  return {0.5 * (lo + hi), (hi - lo).norm()};
}

/// +1 for an outward mesh, −1 for an inward one (flipped); throws when it encloses no volume.
double orientationSign(const VolumeIntegrals& whole, double diagonal_m, const std::string& name) {
  const double scale = diagonal_m * diagonal_m * diagonal_m;
  if (!(std::abs(whole.volume_m3) > 1e-12 * scale))
    throw TopoError(name, "encloses no volume (" + numberText(whole.volume_m3) + " m³)",
                    "pass a closed solid, not a flat or degenerate surface");
  return whole.volume_m3 > 0 ? 1.0 : -1.0;
}

/// m = k_V e_x e_y e_z ρ, I = m/k_I diag(e_y² + e_z², e_x² + e_z², e_x² + e_y²): the solids whose extents e
/// are along the axes (ellipsoid: k_V = 4/3 π, k_I = 5 with semi-axes; box: k_V = 8, k_I = 3 with half edges).
MassMoments axisAlignedSolid(const std::string& what, const Eigen::Vector3d& centre_m, const Eigen::Vector3d& extents_m,
                             double density_kg_m3, double volume_factor, double inertia_divisor) {
  checkFinite(what + " centre_m", centre_m);
  checkFinite(what + " density_kg_m3", density_kg_m3);
  if (!extents_m.allFinite() || !(extents_m.minCoeff() > 0))
    throw TopoError(what, "has extents " + vectorText(extents_m) + " m, not three positive lengths",
                    "give positive lengths");
  const Eigen::Vector3d e2 = extents_m.cwiseProduct(extents_m);
  MassMoments m;
  m.mass_kg = volume_factor * extents_m.prod() * density_kg_m3;
  m.com_m = centre_m;
  const Eigen::Vector3d diagonal(e2.y() + e2.z(), e2.x() + e2.z(), e2.x() + e2.y());
  m.inertia_com_kg_m2 = (m.mass_kg / inertia_divisor * diagonal).asDiagonal();
  return m;
}

}  // namespace

MassMoments meshMoments(const std::vector<Eigen::Vector3d>& vertices, const std::vector<Eigen::Vector3i>& triangles,
                        double density_kg_m3, const std::string& mesh_name) {
  checkFinite(mesh_name + " density_kg_m3", density_kg_m3);
  checkClosed(vertices, triangles, mesh_name);
  const auto [origin, diagonal] = boundingBox(vertices, triangles);
  VolumeIntegrals in = wholeMesh(vertices, triangles, origin);
  if (orientationSign(in, diagonal, mesh_name) < 0) in.negate();
  return momentsFromIntegrals(in, origin, density_kg_m3);
}

MassMoments clippedMeshMoments(const std::vector<Eigen::Vector3d>& vertices,
                               const std::vector<Eigen::Vector3i>& triangles, const Eigen::Vector3d& plane_point,
                               const Eigen::Vector3d& plane_normal, double density_kg_m3,
                               const std::string& mesh_name) {
  checkFinite(mesh_name + " density_kg_m3", density_kg_m3);
  checkFinite(mesh_name + " clipping plane_point", plane_point);
  checkFinite(mesh_name + " clipping plane_normal", plane_normal);
  if (!(plane_normal.norm() > 0))
    throw TopoError(mesh_name + " clipping plane_normal", "is zero", "give the plane's normal (any length)");
  checkClosed(vertices, triangles, mesh_name);
  const Eigen::Vector3d n = plane_normal.normalized();
  const auto [centre, diagonal] = boundingBox(vertices, triangles);
  const double sign = orientationSign(wholeMesh(vertices, triangles, centre), diagonal, mesh_name);
  // o on the plane, near the mesh: the cap's tetrahedra (o and three points of the plane) are flat.
  const Eigen::Vector3d origin = centre - n.dot(centre - plane_point) * n;
  VolumeIntegrals in;
  for (const Eigen::Vector3i& f : triangles) {
    Eigen::Vector3d p[3];
    double d[3];
    for (int k = 0; k < 3; ++k) {
      p[k] = vertices[f[k]] - origin;
      d[k] = n.dot(vertices[f[k]] - plane_point);
    }
    if (d[0] > 0 && d[1] > 0 && d[2] > 0) {
      in.addTetrahedron(p[0], p[1], p[2]);
      continue;
    }
    // Sutherland–Hodgman against d > 0: at most four vertices, fanned from the first.
    Eigen::Vector3d poly[4];
    int count = 0;
    for (int k = 0; k < 3; ++k) {
      const int j = (k + 1) % 3;
      if (d[k] > 0) poly[count++] = p[k];
      if ((d[k] > 0) != (d[j] > 0)) poly[count++] = p[k] + (p[j] - p[k]) * (d[k] / (d[k] - d[j]));
    }
    for (int k = 1; k + 1 < count; ++k) in.addTetrahedron(poly[0], poly[k], poly[k + 1]);
  }
  if (sign < 0) in.negate();
  if (!(in.volume_m3 > 1e-12 * diagonal * diagonal * diagonal))
    throw TopoError(mesh_name + " clipped at the plane through " + vectorText(plane_point) + " with normal " +
                        vectorText(plane_normal),
                    "no volume of the solid lies on the plane's positive side n·(x − point) > 0",
                    "check the plane's point and the normal's direction (it points into the kept part)");
  return momentsFromIntegrals(in, origin, density_kg_m3);
}

MassMoments sphereMoments(const Eigen::Vector3d& centre_m, double radius_m, double density_kg_m3) {
  if (!(radius_m > 0) || !std::isfinite(radius_m))
    throw TopoError("sphere radius_m", "is " + numberText(radius_m) + ", not a positive length", "give r > 0");
  return axisAlignedSolid("sphere", centre_m, Eigen::Vector3d::Constant(radius_m), density_kg_m3, 4.0 / 3.0 * kPi, 5.0);
}

MassMoments ellipsoidMoments(const Eigen::Vector3d& centre_m, const Eigen::Vector3d& semi_axes_m,
                             double density_kg_m3) {
  return axisAlignedSolid("ellipsoid (semi_axes_m)", centre_m, semi_axes_m, density_kg_m3, 4.0 / 3.0 * kPi, 5.0);
}

MassMoments boxMoments(const Eigen::Vector3d& centre_m, const Eigen::Vector3d& half_edges_m, double density_kg_m3) {
  return axisAlignedSolid("box (half_edges_m)", centre_m, half_edges_m, density_kg_m3, 8.0, 3.0);
}

MassMoments combine(const std::vector<MassMoments>& parts) {
  double total = 0.0;
  Eigen::Vector3d first = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < parts.size(); ++i) {
    const MassMoments& p = parts[i];
    if (!std::isfinite(p.mass_kg) || !p.com_m.allFinite() || !p.inertia_com_kg_m2.allFinite())
      throw TopoError("combine: part " + std::to_string(i), "has a non-finite mass, centre of mass or inertia",
                      "pass finite moments");
    total += p.mass_kg;
    first += p.mass_kg * p.com_m;
  }
  if (!(total > 0))
    throw TopoError("combine: " + std::to_string(parts.size()) + " parts",
                    "have a total mass of " + numberText(total) + " kg (zero or negative)",
                    "check the densities: a cavity's part is (ρ_cavity − ρ_body) times a region inside the body, "
                    "and the body's own part must be included");
  MassMoments out;
  out.mass_kg = total;
  out.com_m = first / total;
  for (const MassMoments& p : parts) {
    const Eigen::Vector3d d = p.com_m - out.com_m;
    out.inertia_com_kg_m2 +=
        p.inertia_com_kg_m2 + p.mass_kg * (d.squaredNorm() * Eigen::Matrix3d::Identity() - d * d.transpose());
  }
  out.inertia_com_kg_m2 = 0.5 * (out.inertia_com_kg_m2 + out.inertia_com_kg_m2.transpose()).eval();
  return out;
}

bool insideMesh(const std::vector<Eigen::Vector3d>& vertices, const std::vector<Eigen::Vector3i>& triangles,
                const Eigen::Vector3d& point, const std::string& mesh_name) {
  checkFinite(mesh_name + " query point", point);
  checkIndices(vertices, triangles, mesh_name);
  double solid_angle = 0.0;
  for (const Eigen::Vector3i& f : triangles) {
    const Eigen::Vector3d a = vertices[f[0]] - point, b = vertices[f[1]] - point, c = vertices[f[2]] - point;
    const double la = a.norm(), lb = b.norm(), lc = c.norm();
    const double num = a.dot(b.cross(c));
    const double den = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
    const double scale = la * lb * lc;
    // In the triangle's plane and on it (den ≤ 0: the angles at the point sum to 2π, or it is on an edge).
    if (scale == 0.0 || (std::abs(num) <= 1e-12 * scale && den <= 1e-12 * scale)) return true;
    solid_angle += 2.0 * std::atan2(num, den);
  }
  const double w = solid_angle / (4.0 * kPi);
  if (std::abs(w - std::round(w)) > 1e-6)
    throw TopoError(mesh_name,
                    "gives the point " + vectorText(point) + " a winding number of " + numberText(w, 6) +
                        ", not an integer: the mesh is open or overlaps itself",
                    "pass a closed, manifold triangle mesh");
  return std::abs(w) > 0.5;
}

}  // namespace topo_gaussian::peer
