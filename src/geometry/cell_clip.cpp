#include "topo_gaussian/geometry/cell_clip.h"

#include <algorithm>
#include <array>
#include <cmath>

namespace topo_gaussian::geometry {

namespace {

// A convex polygon: a triangle clipped by at most 6 planes has at most 9 vertices.
struct Polygon {
  std::array<Eigen::Vector3d, 12> v;
  int n = 0;
};

// Keeps the part of P where s·(p[axis] − c) ≥ 0 (Sutherland–Hodgman; vertex order, hence the
// orientation of the projection, is kept). New vertices lie exactly on the plane.
Polygon clip(const Polygon& P, int axis, double c, double s) {
  Polygon out;
  for (int a = 0; a < P.n; ++a) {
    const Eigen::Vector3d& p = P.v[a];
    const Eigen::Vector3d& q = P.v[(a + 1) % P.n];
    const double dp = s * (p[axis] - c), dq = s * (q[axis] - c);
    if (dp >= 0.0) out.v[out.n++] = p;
    if ((dp >= 0.0) != (dq >= 0.0)) {
      Eigen::Vector3d x = p + (dp / (dp - dq)) * (q - p);
      x[axis] = c;
      out.v[out.n++] = x;
    }
  }
  return out;
}

// Integrals over the xy-projection of a polygon, with the sign of its orientation
// (counter-clockwise seen from +z positive): w is the vertex z minus `w0`.
struct Integrals {
  double a = 0, x = 0, y = 0;            // ∫1, ∫x, ∫y
  double w = 0, xw = 0, yw = 0, w2 = 0;  // ∫w, ∫x w, ∫y w, ∫w²
};

// Fan triangulation from vertex 0; each triangle integrates degree-2 polynomials exactly by the
// edge-midpoint rule ∫_T g = |T|/3 Σ g(midpoints).
Integrals integrate(const Polygon& P, double w0, bool with_w) {
  Integrals I;
  if (P.n < 3) return I;
  const Eigen::Vector3d& o = P.v[0];
  for (int k = 1; k + 1 < P.n; ++k) {
    const Eigen::Vector3d& b = P.v[k];
    const Eigen::Vector3d& c = P.v[k + 1];
    const double area = 0.5 * ((b.x() - o.x()) * (c.y() - o.y()) - (b.y() - o.y()) * (c.x() - o.x()));  // signed
    if (area == 0.0) continue;
    const Eigen::Vector3d m[3] = {0.5 * (o + b), 0.5 * (b + c), 0.5 * (c + o)};
    const double f = area / 3.0;
    I.a += area;
    for (const auto& p : m) {
      I.x += f * p.x();
      I.y += f * p.y();
      if (with_w) {
        const double w = p.z() - w0;
        I.w += f * w;
        I.xw += f * p.x() * w;
        I.yw += f * p.y() * w;
        I.w2 += f * w * w;
      }
    }
  }
  return I;
}

struct Piece {
  Polygon poly;  // column-local x, y; absolute z
  double area = 0, sx = 0, sy = 0;
  int kmin = 0, kmax = 0;
};

struct CellSum {
  double v = 0;                                 // ∫χ dV
  Eigen::Vector3d m = Eigen::Vector3d::Zero();  // ∫χ (x − cell corner) dV
};

}  // namespace

double meshSignedVolume(const SurfaceData& mesh) {
  if (mesh.points.empty()) return 0.0;
  Eigen::Vector3d ref = Eigen::Vector3d::Zero();
  for (const auto& p : mesh.points) ref += p;
  ref /= double(mesh.points.size());
  double v6 = 0.0;
  for (const auto& t : mesh.triangles)
    v6 += (mesh.points[t[0]] - ref).dot((mesh.points[t[1]] - ref).cross(mesh.points[t[2]] - ref));
  return v6 / 6.0;
}

CellClipResult clipCells(const SurfaceData& mesh, const Lattice& L) {
  const int nx = L.n[0], ny = L.n[1], nz = L.n[2];
  const double h = L.h;
  CellClipResult result;
  if (nx <= 0 || ny <= 0 || nz <= 0) return result;
  // Triangles by the columns their bounding box overlaps.
  std::vector<std::vector<int>> columns(std::size_t(nx) * ny);
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    const auto& tri = mesh.triangles[t];
    const Eigen::Vector3d &A = mesh.points[tri[0]], &B = mesh.points[tri[1]], &C = mesh.points[tri[2]];
    const double x0 = std::min({A.x(), B.x(), C.x()}), x1 = std::max({A.x(), B.x(), C.x()});
    const double y0 = std::min({A.y(), B.y(), C.y()}), y1 = std::max({A.y(), B.y(), C.y()});
    const int i0 = std::max(0, int(std::floor((x0 - L.origin.x()) / h)));
    const int i1 = std::min(nx - 1, int(std::floor((x1 - L.origin.x()) / h)));
    const int j0 = std::max(0, int(std::floor((y0 - L.origin.y()) / h)));
    const int j1 = std::min(ny - 1, int(std::floor((y1 - L.origin.y()) / h)));
    for (int j = j0; j <= j1; ++j)
      for (int i = i0; i <= i1; ++i) columns[std::size_t(j) * nx + i].push_back(int(t));
  }
  result.inside.assign(L.cells(), 0);
  const double h3 = h * h * h;
  double volume = 0.0;
  std::size_t anomalies = 0, full = 0;
#pragma omp parallel reduction(+ : volume, anomalies, full)
  {
    std::vector<CellPart> parts;
    std::vector<Piece> pieces;
    std::vector<CellSum> sums;
    std::vector<Eigen::Vector3d> above;  // (area, ∫x, ∫y) of the pieces whose lowest cell is k
#pragma omp for schedule(dynamic, 16)
    for (long col = 0; col < long(columns.size()); ++col) {
      const auto& tris = columns[col];
      if (tris.empty()) continue;
      const int i = int(col % nx), j = int(col / nx);
      const double cx = L.origin.x() + i * h, cy = L.origin.y() + j * h;  // column corner
      pieces.clear();
      int kmin = nz, kmax = -1;
      for (int t : tris) {
        Polygon P;
        P.n = 3;
        for (int a = 0; a < 3; ++a) {
          const Eigen::Vector3d& p = mesh.points[mesh.triangles[t][a]];
          P.v[a] = Eigen::Vector3d(p.x() - cx, p.y() - cy, p.z());
        }
        P = clip(P, 0, 0.0, 1.0);
        if (P.n >= 3) P = clip(P, 0, h, -1.0);
        if (P.n >= 3) P = clip(P, 1, 0.0, 1.0);
        if (P.n >= 3) P = clip(P, 1, h, -1.0);
        if (P.n < 3) continue;
        const Integrals I = integrate(P, 0.0, false);
        if (I.a == 0.0) continue;  // vertical, or touching the column only along an edge
        Piece pc;
        pc.poly = P;
        pc.area = I.a;
        pc.sx = I.x;
        pc.sy = I.y;
        double zlo = P.v[0].z(), zhi = zlo;
        for (int a = 1; a < P.n; ++a) zlo = std::min(zlo, P.v[a].z()), zhi = std::max(zhi, P.v[a].z());
        pc.kmin = std::clamp(int(std::floor((zlo - L.origin.z()) / h)), 0, nz - 1);
        pc.kmax = std::clamp(int(std::floor((zhi - L.origin.z()) / h)), 0, nz - 1);
        kmin = std::min(kmin, pc.kmin);
        kmax = std::max(kmax, pc.kmax);
        pieces.push_back(pc);
      }
      if (pieces.empty()) continue;
      const int nk = kmax - kmin + 1;
      sums.assign(nk, CellSum{});
      above.assign(nk, Eigen::Vector3d::Zero());
      for (const Piece& pc : pieces) {
        above[pc.kmin - kmin] += Eigen::Vector3d(pc.area, pc.sx, pc.sy);
        for (int k = pc.kmin; k <= pc.kmax; ++k) {
          const double z0 = L.origin.z() + k * h, z1 = z0 + h;
          // Top piece (z_t ≥ z1): integrand z1 − z0 = h; middle piece: w = z_t − z0.
          const Polygon U = clip(pc.poly, 2, z1, 1.0);
          Polygon M = clip(pc.poly, 2, z1, -1.0);
          if (M.n >= 3) M = clip(M, 2, z0, 1.0);
          const Integrals iu = integrate(U, 0.0, false), im = integrate(M, z0, true);
          CellSum& s = sums[k - kmin];
          s.v += h * iu.a + im.w;
          s.m += Eigen::Vector3d(h * iu.x + im.xw, h * iu.y + im.yw, 0.5 * h * h * iu.a + 0.5 * im.w2);
        }
      }
      // Sweep down: pieces wholly above cell k (lowest cell > k) add h·(area, ∫x, ∫y).
      Eigen::Vector3d r = Eigen::Vector3d::Zero();
      for (int k = kmax; k >= kmin; --k) {
        CellSum& s = sums[k - kmin];
        s.v += h * r[0];
        s.m += Eigen::Vector3d(h * r[1], h * r[2], 0.5 * h * h * r[0]);
        r += above[k - kmin];
        volume += s.v;
        if (s.v < -1e-6 * h3 || s.v > (1.0 + 1e-6) * h3) ++anomalies;
        // Non-zero winding: where shells overlap (2, 3, ...) the cell is wholly inside, and a part with
        // winding −1 is inside as one with +1.
        const double f = std::abs(s.v) / h3;
        if (f >= 1.0 - kPartialTolerance) {
          ++full;
          result.inside[L.index(i, j, k)] = 1;  // distinct cells: no race
        }
        if (f <= kPartialTolerance || f >= 1.0 - kPartialTolerance) continue;
        CellPart part;
        part.cell = L.index(i, j, k);
        part.volume_m3 = std::abs(s.v);
        part.centroid = Eigen::Vector3d(cx, cy, L.origin.z() + k * h) + s.m / s.v;
        parts.push_back(part);
      }
    }
#pragma omp critical
    result.partial.insert(result.partial.end(), parts.begin(), parts.end());
  }
  std::sort(result.partial.begin(), result.partial.end(),
            [](const CellPart& a, const CellPart& b) { return a.cell < b.cell; });
  result.volume_m3 = volume;
  result.winding_anomalies = anomalies;
  result.wholly_inside = full;
  return result;
}

}  // namespace topo_gaussian::geometry
