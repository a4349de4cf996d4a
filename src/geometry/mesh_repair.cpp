// repairMesh: drop invalid and duplicated faces, close small holes, peel off open pieces (see the header).
#include "topo_gaussian/geometry/mesh_repair.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cstdint>
#include <unordered_map>
#include <utility>

namespace topo_gaussian::geometry {

namespace {

std::uint64_t edgeKey(int u, int v) {
  const auto lo = std::uint32_t(std::min(u, v)), hi = std::uint32_t(std::max(u, v));
  return (std::uint64_t(lo) << 32) | hi;
}

double faceArea(const std::vector<Eigen::Vector3d>& p, const Eigen::Vector3i& t) {
  return 0.5 * (p[t[1]] - p[t[0]]).cross(p[t[2]] - p[t[0]]).norm();
}

}  // namespace

SurfaceData repairMesh(const SurfaceData& mesh, MeshRepairReport* report, const MeshRepairOptions& o) {
  MeshRepairReport local;
  MeshRepairReport& r = report ? *report : local;
  r = MeshRepairReport{};
  r.faces_in = mesh.triangles.size();
  std::vector<Eigen::Vector3d> pts = mesh.points;
  const long nv = long(pts.size());

  // 0. Weld: a vertex at exactly the position of an earlier one is that vertex (a triangle soup, as OBJ,
  // PLY and OFF exporters may write it, shares no edge until welded; STL is welded by its reader).
  const std::vector<std::size_t> first = firstAtSamePosition(pts);
  for (std::size_t v = 0; v < first.size(); ++v) r.welded_vertices += first[v] != v;

  // 1. Faces that cannot be part of a surface, and second copies of a face.
  std::vector<Eigen::Vector3i> faces;
  std::vector<std::pair<std::array<int, 3>, std::size_t>> sorted;
  for (Eigen::Vector3i t : mesh.triangles) {
    if (t.minCoeff() < 0 || t.maxCoeff() >= nv) {
      ++r.degenerate_faces;
      continue;
    }
    for (int a = 0; a < 3; ++a) t[a] = int(first[std::size_t(t[a])]);
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) {
      ++r.degenerate_faces;
      continue;
    }
    if (!pts[t[0]].allFinite() || !pts[t[1]].allFinite() || !pts[t[2]].allFinite()) {
      ++r.nonfinite_faces;
      continue;
    }
    std::array<int, 3> k{t[0], t[1], t[2]};
    std::sort(k.begin(), k.end());
    sorted.emplace_back(k, faces.size());
    faces.push_back(t);
  }
  std::sort(sorted.begin(), sorted.end());
  std::vector<char> keep(faces.size(), 1);
  for (std::size_t i = 1; i < sorted.size(); ++i)
    if (sorted[i].first == sorted[i - 1].first) {
      keep[sorted[i].second] = 0;
      ++r.duplicate_faces;
    }
  {
    std::vector<Eigen::Vector3i> unique;
    unique.reserve(faces.size());
    for (std::size_t i = 0; i < faces.size(); ++i)
      if (keep[i]) unique.push_back(faces[i]);
    faces.swap(unique);
  }
  for (const auto& t : faces) r.total_area_m2 += faceArea(pts, t);

  std::unordered_map<std::uint64_t, int> uses;
  uses.reserve(faces.size() * 2);
  for (const auto& t : faces)
    for (int a = 0; a < 3; ++a) ++uses[edgeKey(t[a], t[(a + 1) % 3])];

  // 2. Small holes: loops of boundary edges (used once), walked against the faces' orientation.
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
  for (const auto& t : faces)
    for (int a = 0; a < 3; ++a) {
      lo = lo.cwiseMin(pts[t[a]]);
      hi = hi.cwiseMax(pts[t[a]]);
    }
  const double diagonal = faces.empty() ? 0.0 : (hi - lo).norm();
  std::unordered_map<int, int> next;  // hole edge b → a for a face edge a → b used once
  std::unordered_map<int, char> branching;
  for (const auto& t : faces)
    for (int a = 0; a < 3; ++a) {
      const int u = t[a], v = t[(a + 1) % 3];
      if (uses[edgeKey(u, v)] != 1) continue;
      if (!next.emplace(v, u).second) branching[v] = 1;
    }
  std::unordered_map<int, char> visited;
  const std::size_t faces_before_holes = faces.size();
  std::vector<int> hole_of;  // per fan face (index − faces_before_holes): which hole it closes
  for (const auto& kv : next) {
    const int start = kv.first;
    if (visited.count(start) || branching.count(start)) continue;
    std::vector<int> loop;
    int at = start;
    bool ok = false;
    while (int(loop.size()) <= o.max_hole_edges) {
      if (visited.count(at) || branching.count(at)) break;
      visited[at] = 1;
      loop.push_back(at);
      const auto it = next.find(at);
      if (it == next.end()) break;
      at = it->second;
      if (at == start) {
        ok = true;
        break;
      }
    }
    if (!ok || loop.size() < 3 || int(loop.size()) > o.max_hole_edges) continue;
    double perimeter = 0.0;
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    for (std::size_t i = 0; i < loop.size(); ++i) {
      perimeter += (pts[loop[i]] - pts[loop[(i + 1) % loop.size()]]).norm();
      centre += pts[loop[i]];
    }
    if (perimeter > o.max_hole_perimeter_frac * diagonal) continue;
    const int c = int(pts.size());
    pts.push_back(centre / double(loop.size()));
    for (std::size_t i = 0; i < loop.size(); ++i) {
      const int u = loop[i], v = loop[(i + 1) % loop.size()];
      faces.emplace_back(u, v, c);
      hole_of.push_back(int(r.holes_closed));
      ++uses[edgeKey(u, v)];
      ++uses[edgeKey(v, c)];
      ++uses[edgeKey(c, u)];
    }
    ++r.holes_closed;
  }
  const std::size_t holes_found = r.holes_closed;
  r.holes_closed = 0;

  // 3. Peel: a face with an edge no other face uses cannot bound a volume; removing it may expose
  // the next one (a sheet is peeled from its rim inwards).
  std::vector<std::pair<std::uint64_t, int>> edge_faces;
  edge_faces.reserve(faces.size() * 3);
  for (std::size_t f = 0; f < faces.size(); ++f)
    for (int a = 0; a < 3; ++a) edge_faces.emplace_back(edgeKey(faces[f][a], faces[f][(a + 1) % 3]), int(f));
  std::sort(edge_faces.begin(), edge_faces.end());
  std::vector<char> alive(faces.size(), 1);
  auto isOpen = [&](int f) {
    for (int a = 0; a < 3; ++a)
      if (uses[edgeKey(faces[f][a], faces[f][(a + 1) % 3])] == 1) return true;
    return false;
  };
  std::vector<int> stack;
  for (std::size_t f = 0; f < faces.size(); ++f)
    if (isOpen(int(f))) stack.push_back(int(f));
  while (!stack.empty()) {
    const int f = stack.back();
    stack.pop_back();
    if (!alive[f] || !isOpen(f)) continue;
    alive[f] = 0;
    ++r.ignored_faces;
    if (std::size_t(f) < faces_before_holes) r.ignored_area_m2 += faceArea(pts, faces[f]);
    for (int a = 0; a < 3; ++a) {
      const std::uint64_t k = edgeKey(faces[f][a], faces[f][(a + 1) % 3]);
      --uses[k];
      auto range = std::equal_range(edge_faces.begin(), edge_faces.end(), std::make_pair(k, -1),
                                    [](const auto& x, const auto& y) { return x.first < y.first; });
      for (auto it = range.first; it != range.second; ++it)
        if (alive[it->second] && uses[k] == 1) stack.push_back(it->second);
    }
  }
  // 4. Orientation: walk each connected piece across its manifold edges (two faces left on the edge)
  // and turn every face that runs an edge the same way as its neighbour; per piece the fewer faces are
  // turned (a tie: the piece encloses positive volume). A face with half its neighbours turned made
  // the piece's volume vanish (a box with every second triangle flipped), so this comes first.
  {
    // The face across each edge (3 per face) where exactly two faces are left on it, else -1: one pass
    // over the runs of the sorted edge list.
    std::vector<int> across(3 * faces.size(), -1);
    for (std::size_t i = 0; i < edge_faces.size();) {
      std::size_t j = i;
      int pair[2] = {-1, -1}, count = 0;
      for (; j < edge_faces.size() && edge_faces[j].first == edge_faces[i].first; ++j)
        if (alive[edge_faces[j].second] && count++ < 2) pair[count - 1] = edge_faces[j].second;
      if (count == 2)
        for (int side = 0; side < 2; ++side) {
          const auto& t = faces[pair[side]];
          for (int a = 0; a < 3; ++a)
            if (edgeKey(t[a], t[(a + 1) % 3]) == edge_faces[i].first) across[3 * pair[side] + a] = pair[1 - side];
        }
      i = j;
    }
    auto runs = [&](int f, int u, int v) {  // face f (as stored) runs the edge u → v
      for (int a = 0; a < 3; ++a)
        if (faces[f][a] == u && faces[f][(a + 1) % 3] == v) return true;
      return false;
    };
    std::vector<signed char> turn(faces.size(), -1);  // -1 not reached, 0 keep, 1 turn over
    std::vector<int> piece, queue;
    for (std::size_t seed = 0; seed < faces.size(); ++seed) {
      if (!alive[seed] || turn[seed] >= 0) continue;
      piece.clear();
      queue.assign(1, int(seed));
      turn[seed] = 0;
      while (!queue.empty()) {
        const int f = queue.back();
        queue.pop_back();
        piece.push_back(f);
        for (int a = 0; a < 3; ++a) {
          const int u = faces[f][a], v = faces[f][(a + 1) % 3];
          const int g = across[3 * f + a];
          if (g < 0 || turn[g] >= 0) continue;
          // f as it will be runs u → v unless turned; g must then run it v → u.
          turn[g] = static_cast<signed char>(runs(g, u, v) != bool(turn[f]));
          queue.push_back(g);
        }
      }
      std::size_t turned = 0;
      for (int f : piece) turned += std::size_t(turn[f]);
      bool invert = 2 * turned > piece.size();
      if (2 * turned == piece.size()) {
        double v6 = 0.0;
        for (int f : piece) {
          const auto& t = faces[f];
          const double o = pts[t[0]].dot(pts[t[1]].cross(pts[t[2]]));
          v6 += turn[f] ? -o : o;
        }
        invert = v6 < 0.0;
      }
      for (int f : piece) {
        if (invert) turn[f] = static_cast<signed char>(!turn[f]);
        if (!turn[f]) continue;
        std::swap(faces[f][1], faces[f][2]);
        ++r.reoriented_faces;
      }
    }
  }

  // Closed pieces that enclose no volume (a flat "pillow": a loose triangle whose rim was closed as
  // a hole) are left out too.
  std::vector<int> parent(pts.size());
  for (std::size_t v = 0; v < parent.size(); ++v) parent[v] = int(v);
  auto root = [&](int x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (std::size_t f = 0; f < faces.size(); ++f)
    if (alive[f])
      for (int a = 1; a < 3; ++a) parent[root(faces[f][a])] = root(faces[f][0]);
  std::unordered_map<int, double> volume;
  double largest = 0.0;
  for (std::size_t f = 0; f < faces.size(); ++f)
    if (alive[f]) {
      const auto& t = faces[f];
      volume[root(t[0])] += pts[t[0]].dot(pts[t[1]].cross(pts[t[2]])) / 6.0;
    }
  for (const auto& kv : volume) largest = std::max(largest, std::abs(kv.second));
  for (std::size_t f = 0; f < faces.size(); ++f)
    if (alive[f] && std::abs(volume[root(faces[f][0])]) <= 1e-9 * largest) {
      alive[f] = 0;
      ++r.ignored_faces;
      if (f < faces_before_holes) r.ignored_area_m2 += faceArea(pts, faces[f]);
    }
  const std::size_t left = std::size_t(std::count(alive.begin(), alive.end(), char(1)));
  // Accept the closed rest when the pieces left out are few (a stray triangle to a far point has a
  // large area but is one face) or small.
  r.closed = left > 0 && (r.ignored_faces <= o.max_ignored_face_frac * double(faces.size()) ||
                          r.ignored_area_m2 <= o.max_ignored_area_frac * r.total_area_m2);
  if (!r.closed) {  // keep everything for the density method; nothing is ignored then
    std::fill(alive.begin(), alive.end(), 1);
    r.ignored_faces = 0;
    r.ignored_area_m2 = 0.0;
  }

  {  // holes whose fan is still part of the surface
    std::vector<char> counted(holes_found, 0);
    for (std::size_t f = faces_before_holes; f < faces.size(); ++f) {
      const int h = hole_of[f - faces_before_holes];
      if (alive[f] && !counted[h]) {
        counted[h] = 1;
        ++r.holes_closed;
      }
      if (alive[f]) ++r.hole_edges;
    }
  }

  // 5. Keep the chosen faces and only the vertices they use.
  SurfaceData out;
  out.kind = SurfaceKind::Mesh;
  out.source = mesh.source;
  std::vector<int> remap(pts.size(), -1);
  const bool normals = mesh.hasNormals(), colors = mesh.hasColors();
  for (std::size_t f = 0; f < faces.size(); ++f) {
    if (!alive[f]) continue;
    Eigen::Vector3i t;
    for (int a = 0; a < 3; ++a) {
      const int v = faces[f][a];
      if (remap[v] < 0) {
        remap[v] = int(out.points.size());
        out.points.push_back(pts[v]);
        const bool original = v < nv;
        if (normals) out.normals.push_back(original ? mesh.normals[v] : Eigen::Vector3d::Zero());
        if (colors) out.colors.push_back(original ? mesh.colors[v] : Eigen::Vector3d::Constant(0.5));
      }
      t[a] = remap[v];
    }
    out.triangles.push_back(t);
  }
  return out;
}

}  // namespace topo_gaussian::geometry
