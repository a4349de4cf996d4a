#include "topo_gaussian/geometry/solid_mesh.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <climits>
#include <cmath>
#include <cstdint>
#include <map>
#include <sstream>
#include <unordered_map>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/number_text.h"

namespace topo_gaussian::geometry {

namespace {

/// A vertex is kept at least this fraction of an edge away from the edge's nodes, so that no
/// triangle collapses when a node's value equals the iso-value (or nearly).
constexpr double kMinT = 1e-3;

/// logit(r) is clamped to ±kLogitMax = ±ln(1e6), i.e. r within 1e-6 of 0 or 1 (the outside, a pinned
/// shell) counts as exactly 0 or 1. The clamp is applied to the result so that it is exactly
/// symmetric: a 0/1 face then has saddle value exactly 0 (joined, as 0.5 is for r), where clamping r
/// to [1e-6, 1 - 1e-6] first would round 1 - 1e-6 and break the tie the wrong way.
constexpr double kRClamp = 1e-6;
constexpr double kLogitMax = 13.815510557964274;  // ln(1e6)

double logit(double r) {
  if (!(r > 0.0)) return -kLogitMax;
  if (!(r < 1.0)) return kLogitMax;
  return std::clamp(std::log(r / (1.0 - r)), -kLogitMax, kLogitMax);
}

std::string point(const Eigen::Vector3d& p) {
  return "(" + numberText(p.x(), 6) + ", " + numberText(p.y(), 6) + ", " + numberText(p.z(), 6) + ")";
}

/// Cube corners are numbered x + 2y + 4z. The 12 cube edges as corner pairs.
constexpr int kEdges[12][2] = {{0, 1}, {2, 3}, {4, 5}, {6, 7}, {0, 2}, {1, 3},
                               {4, 6}, {5, 7}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};

int edgeIndex(int a, int b) {
  for (int e = 0; e < 12; ++e)
    if ((kEdges[e][0] == a && kEdges[e][1] == b) || (kEdges[e][0] == b && kEdges[e][1] == a)) return e;
  return -1;
}

Eigen::Vector3d cornerPosition(int c) { return Eigen::Vector3d(c & 1, (c >> 1) & 1, (c >> 2) & 1); }

/// The 6 faces of the unit cube, each as 4 corners in counter-clockwise order seen from outside the
/// cube (right-handed about the outward normal), with the cube edge between corner k and k+1.
struct Face {
  int corner[4];
  int edge[4];
};

std::array<Face, 6> cubeFaces() {
  std::array<Face, 6> faces{};
  int f = 0;
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side) {
      const int u = (axis + 1) % 3, v = (axis + 2) % 3;
      const int base = side << axis;
      int c[4] = {base, base | (1 << u), base | (1 << u) | (1 << v), base | (1 << v)};
      Eigen::Vector3d normal = Eigen::Vector3d::Zero();
      normal[axis] = side ? 1.0 : -1.0;
      const Eigen::Vector3d turn =
          (cornerPosition(c[1]) - cornerPosition(c[0])).cross(cornerPosition(c[2]) - cornerPosition(c[1]));
      if (turn.dot(normal) < 0) std::swap(c[1], c[3]);
      for (int k = 0; k < 4; ++k) {
        faces[f].corner[k] = c[k];
        faces[f].edge[k] = edgeIndex(c[k], c[(k + 1) % 4]);
      }
      ++f;
    }
  return faces;
}

/// Marching cubes in which every cube face is resolved on its own (so both cubes that share a face
/// agree) and the surface inside a cube is built from the closed loops those face segments form:
///  - on a face, an iso-segment runs from the crossing where a counter-clockwise walk enters the
///    inside (f ≥ iso) to the crossing where it leaves, so every loop is oriented with its normal
///    pointing to the outside, and the neighbouring cube walks the same segment backwards;
///  - a face with two diagonal inside corners and two diagonal outside ones is resolved by the
///    asymptotic decider (the bilinear interpolant's value at its saddle point): at ≥ iso the inside
///    corners are joined across the face. A 0/1 field has saddle value 0.5, so solid particles that
///    touch along a cell edge are joined and a one-particle shell stays closed;
///  - a loop of 3 crossings is a triangle, of 4 two triangles (split along the shorter diagonal), of
///    more a fan around the loop's centroid.
/// Each crossing is one vertex, shared through the lattice edge it lies on.
class CubeMarcher {
 public:
  CubeMarcher(const std::vector<double>& field, const std::vector<std::int32_t>& owner,
              const std::vector<double>& fraction, const std::array<int, 3>& n, const Eigen::Vector3d& origin, double h,
              double iso, SurfaceData& out, std::vector<std::uint8_t>& interface)
      : f_(field),
        owner_(owner),
        fraction_(fraction),
        n_(n),
        origin_(origin),
        h_(h),
        iso_(iso),
        out_(out),
        interface_(interface),
        faces_(cubeFaces()) {
    edges_.reserve(1024);
  }

  Eigen::Vector3d nodePosition(std::size_t id) const {
    const std::size_t i = id % n_[0], j = (id / n_[0]) % n_[1], k = id / (std::size_t(n_[0]) * n_[1]);
    return origin_ + h_ * Eigen::Vector3d(double(i), double(j), double(k));
  }

  /// The mesh vertex on the lattice edge (a, b), created once (the same for (b, a)).
  int edgeVertex(std::size_t a, std::size_t b) {
    if (a > b) std::swap(a, b);
    const std::uint64_t key = std::uint64_t(a) * std::uint64_t(f_.size()) + std::uint64_t(b);
    auto it = edges_.find(key);
    if (it != edges_.end()) return it->second;
    const double fa = f_[a], fb = f_[b];
    double t = std::clamp((iso_ - fa) / (fb - fa), kMinT, 1.0 - kMinT);
    const bool a_solid = fa >= iso_;
    const std::size_t solid = a_solid ? a : b, other = a_solid ? b : a;
    if (!fraction_.empty() && owner_[other] < 0) {  // the outer boundary: where the surface cuts the cell
      const double d = std::clamp(fraction_[solid] - 0.5, kMinT, 1.0 - kMinT);
      t = a_solid ? d : 1.0 - d;
    }
    const Eigen::Vector3d pa = nodePosition(a), pb = nodePosition(b);
    const int idx = int(out_.points.size());
    out_.points.push_back(pa + t * (pb - pa));
    interface_.push_back(owner_[fa >= iso_ ? b : a] >= 0 ? 1 : 0);  // the non-solid end is a (hollow) particle
    edges_.emplace(key, idx);
    return idx;
  }

  /// One cube with corner nodes c (numbered x + 2y + 4z).
  void cube(const std::array<std::size_t, 8>& c) {
    double f[8];
    bool in[8];
    for (int q = 0; q < 8; ++q) in[q] = (f[q] = f_[c[q]]) >= iso_;
    int next[12];
    std::fill(next, next + 12, -1);
    for (const Face& face : faces_) {
      bool enters[4], leaves[4];  // walking corner k → k+1 along edge k
      int crossings = 0;
      for (int k = 0; k < 4; ++k) {
        const bool a = in[face.corner[k]], b = in[face.corner[(k + 1) % 4]];
        enters[k] = !a && b;
        leaves[k] = a && !b;
        crossings += a != b ? 1 : 0;
      }
      if (crossings == 2) {
        int from = -1, to = -1;
        for (int k = 0; k < 4; ++k) {
          if (enters[k]) from = face.edge[k];
          if (leaves[k]) to = face.edge[k];
        }
        next[from] = to;
      } else if (crossings == 4) {
        const double f0 = f[face.corner[0]], f1 = f[face.corner[1]], f2 = f[face.corner[2]], f3 = f[face.corner[3]];
        const double saddle = (f0 * f2 - f1 * f3) / (f0 + f2 - f1 - f3);
        const bool joined = saddle >= iso_;  // the inside corners are connected across the face
        for (int k = 0; k < 4; ++k)
          if (enters[k]) next[face.edge[k]] = face.edge[joined ? (k + 3) % 4 : (k + 1) % 4];
      }
    }
    bool used[12] = {};
    int loop[12];
    for (int start = 0; start < 12; ++start) {
      if (next[start] < 0 || used[start]) continue;
      int m = 0;
      for (int e = start; e >= 0 && !used[e] && m < 12; e = next[e]) {
        used[e] = true;
        loop[m++] = edgeVertex(c[kEdges[e][0]], c[kEdges[e][1]]);
      }
      emitLoop(loop, m);
    }
  }

 private:
  void emitLoop(const int* v, int m) {
    if (m == 3) {
      out_.triangles.emplace_back(v[0], v[1], v[2]);
    } else if (m == 4) {
      const auto& P = out_.points;
      if ((P[v[0]] - P[v[2]]).squaredNorm() <= (P[v[1]] - P[v[3]]).squaredNorm()) {
        out_.triangles.emplace_back(v[0], v[1], v[2]);
        out_.triangles.emplace_back(v[0], v[2], v[3]);
      } else {
        out_.triangles.emplace_back(v[1], v[2], v[3]);
        out_.triangles.emplace_back(v[1], v[3], v[0]);
      }
    } else if (m > 4) {
      Eigen::Vector3d centre = Eigen::Vector3d::Zero();
      int inner = 0;
      for (int k = 0; k < m; ++k) centre += out_.points[v[k]], inner += interface_[v[k]];
      const int ci = int(out_.points.size());
      out_.points.push_back(centre / double(m));
      interface_.push_back(2 * inner > m ? 1 : 0);
      for (int k = 0; k < m; ++k) out_.triangles.emplace_back(v[k], v[(k + 1) % m], ci);
    }
  }

  const std::vector<double>& f_;
  const std::vector<std::int32_t>& owner_;
  const std::vector<double>& fraction_;  ///< per node: the particle's V_i / h³ (empty: mid-points)
  std::array<int, 3> n_;
  Eigen::Vector3d origin_;
  double h_, iso_;
  SurfaceData& out_;
  std::vector<std::uint8_t>& interface_;
  std::array<Face, 6> faces_;
  std::unordered_map<std::uint64_t, int> edges_;
};

}  // namespace

double solidParticleVolume(const VolumeCloud& cloud, const std::vector<double>& r, double iso) {
  double v = 0.0;
  for (std::size_t i = 0; i < cloud.size() && i < r.size(); ++i)
    if (r[i] >= iso) v += cloud.V[i];
  return v;
}

SurfaceData solidRegionMesh(const VolumeCloud& cloud, const std::vector<double>& r, const SolidMeshOptions& o,
                            std::vector<std::uint8_t>* interface_vertex) {
  cloud.validate("volume cloud");
  if (r.size() != cloud.size())
    throw TopoError(
        "interior",
        "has " + std::to_string(r.size()) + " indicator values for " + std::to_string(cloud.size()) + " particles",
        "use the interior computed on this volume");
  if (!(o.iso > 0.0 && o.iso <= 1.0))
    throw TopoError("iso-value " + numberText(o.iso, 6), "is outside (0, 1]",
                    "use 0.5 (the solid threshold of interior.ply)");
  std::size_t solid = 0;
  for (std::size_t i = 0; i < r.size(); ++i) {
    if (!std::isfinite(r[i]))
      throw TopoError("interior", "particle " + std::to_string(i) + " has a non-finite indicator r",
                      "write the interior again (topo infer)");
    solid += r[i] >= o.iso ? 1 : 0;
  }
  if (solid == 0)
    throw TopoError("interior",
                    "has no solid particle (every r < " + numberText(o.iso, 6) + "), so there is nothing to print",
                    "check that the interior belongs to this volume, or lower the iso-value");

  // Lattice nodes: particle i sits on node round((X_i − φ) / h), one padding layer on each side. The
  // lattice's phase φ is the most common position modulo h (the interior particles sit exactly on
  // their cell centres; a boundary particle of topo fill sits at the centroid of its cell's inside
  // part, within its cell, so it is not the bounding box's corner that fixes the lattice).
  const double h = cloud.spacing;
  Eigen::Vector3d phase;
  for (int a = 0; a < 3; ++a) {
    std::map<long, std::size_t> votes;
    for (const auto& x : cloud.X) {
      const double f = x[a] / h - std::floor(x[a] / h);
      ++votes[std::lround(f * 1e4) % 10000];
    }
    long best = 0;
    std::size_t most = 0;
    for (const auto& v : votes)
      if (v.second > most) most = v.second, best = v.first;
    phase[a] = h * double(best) * 1e-4;
  }
  std::vector<Eigen::Vector3i> node(cloud.size());
  Eigen::Vector3i nlo = Eigen::Vector3i::Constant(INT_MAX), nhi = Eigen::Vector3i::Constant(INT_MIN);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3d a = (cloud.X[i] - phase) / h;
    const Eigen::Vector3d idx = a.array().round();
    const bool boundary = i < cloud.surface.size() && cloud.surface[i];
    if ((a - idx).cwiseAbs().maxCoeff() > (boundary ? 0.75 : o.lattice_tolerance) + 1e-6)
      throw TopoError("volume cloud",
                      "particle " + std::to_string(i) + " at " + point(cloud.X[i]) + " is " +
                          numberText((a - idx).cwiseAbs().maxCoeff(), 6) + " spacings off the lattice of spacing " +
                          numberText(h, 6) + " m",
                      "export needs a lattice volume as topo fill writes it (its spacing is in the file)");
    if ((idx.cwiseAbs().array() > 1e9).any())
      throw TopoError("volume cloud", "spacing " + numberText(h, 6) + " m is far smaller than its coordinates",
                      "write the volume with topo fill (its spacing is in the file)");
    node[i] = idx.cast<int>();
    nlo = nlo.cwiseMin(node[i]);
    nhi = nhi.cwiseMax(node[i]);
  }
  std::array<int, 3> n{};
  for (int a = 0; a < 3; ++a) {
    const double cells = double(nhi[a]) - double(nlo[a]) + 4.0;
    if (cells > 2e9)
      throw TopoError("volume cloud", "spacing " + numberText(h, 6) + " m is far smaller than its extent",
                      "write the volume with topo fill (its spacing is in the file)");
    n[a] = int(cells);
  }
  const double nodes = double(n[0]) * n[1] * n[2];
  if (nodes > o.max_nodes)
    throw TopoError("volume cloud",
                    "its lattice of spacing " + numberText(h, 6) + " m would need " + numberText(nodes, 6) +
                        " nodes (more than " + numberText(o.max_nodes, 6) + ")",
                    "check the spacing of the volume (topo fill writes it), or use a coarser volume");
  const Eigen::Vector3d origin = phase + h * (nlo.cast<double>() - Eigen::Vector3d::Ones());
  const std::size_t N = std::size_t(nodes);
  const bool use_logit = o.interpolate_logit && o.iso > kRClamp && o.iso < 1.0 - kRClamp;
  const auto value = [&](double r) { return use_logit ? logit(r) : r; };
  const double iso = value(o.iso);
  std::vector<double> field(N, value(0.0));
  std::vector<std::int32_t> owner(N, -1);
  std::vector<double> fraction;
  if (o.boundary_fractions) fraction.assign(N, 1.0);
  auto idOf = [&](const Eigen::Vector3i& q) {
    const Eigen::Vector3i c = q - nlo + Eigen::Vector3i::Ones();
    return (std::size_t(c.z()) * n[1] + std::size_t(c.y())) * n[0] + std::size_t(c.x());
  };
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    std::size_t id = idOf(node[i]);
    if (owner[id] >= 0) {
      // Two boundary particles in one node (a merged cell's centroid crossed into its neighbour): the
      // second takes the nearest free node around it (interior particles never collide).
      // Only a particle near its cell's border moved there (an exact duplicate is an error).
      const Eigen::Vector3d a = (cloud.X[i] - phase) / h;
      const bool boundary =
          i < cloud.surface.size() && cloud.surface[i] && (a - node[i].cast<double>()).cwiseAbs().maxCoeff() > 0.4;
      double best = 1e300;
      std::size_t free_id = N;
      for (int dz = -1; dz <= 1 && boundary; ++dz)
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            const Eigen::Vector3i q = node[i] + Eigen::Vector3i(dx, dy, dz);
            if (((q - nlo).array() < -1).any() || ((q - nlo).array() > Eigen::Array3i(n[0], n[1], n[2]) - 3).any())
              continue;
            const std::size_t qid = idOf(q);
            const double d = (phase + h * q.cast<double>() - cloud.X[i]).squaredNorm();
            if (owner[qid] < 0 && d < best) best = d, free_id = qid;
          }
      if (free_id == N)
        throw TopoError("volume cloud",
                        "particles " + std::to_string(owner[id]) + " and " + std::to_string(i) +
                            " fall on the same lattice node at spacing " + numberText(h, 6) + " m",
                        "export needs a lattice volume with one particle per cell, as topo fill writes it");
      id = free_id;
    }
    owner[id] = std::int32_t(i);
    field[id] = value(r[i]);
    if (!fraction.empty()) fraction[id] = cloud.V[i] / (h * h * h);
  }

  SurfaceData mesh;
  mesh.kind = SurfaceKind::Mesh;
  mesh.source = "solid region";
  std::vector<std::uint8_t> interface;
  CubeMarcher march(field, owner, fraction, n, origin, h, iso, mesh, interface);
  const std::size_t sx = 1, sy = std::size_t(n[0]), sz = std::size_t(n[0]) * n[1];
  for (int k = 0; k + 1 < n[2]; ++k)
    for (int j = 0; j + 1 < n[1]; ++j)
      for (int i = 0; i + 1 < n[0]; ++i) {
        const std::size_t base = std::size_t(k) * sz + std::size_t(j) * sy + std::size_t(i) * sx;
        std::array<std::size_t, 8> c;
        int inside = 0;
        for (int q = 0; q < 8; ++q) {
          c[q] = base + (q & 1 ? sx : 0) + (q & 2 ? sy : 0) + (q & 4 ? sz : 0);
          inside += field[c[q]] >= iso ? 1 : 0;
        }
        if (inside == 0 || inside == 8) continue;
        march.cube(c);
      }
  if (interface_vertex) *interface_vertex = std::move(interface);
  return mesh;
}

}  // namespace topo_gaussian::geometry
