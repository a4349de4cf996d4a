// Mesh readers: Wavefront OBJ, OFF and STL (binary and ASCII). All return kind Mesh with
// points = vertices and triangles (polygons fan-triangulated). STL vertices are merged exactly so that
// a closed STL surface is edge-manifold after reading.
//
// Robustness: text is read through bounded cursors, every index is range-checked before use, and
// declared counts only cap reservations (they never size an allocation beyond what the file can hold).
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "byte_cursor.h"
#include "reader_common.h"
#include "topo_gaussian/common/error.h"
#include "topo_gaussian/geometry/surface_reader.h"

namespace topo_gaussian::geometry {

namespace {

const char* const kObjFix =
    "re-export the mesh as OBJ from a mesh editor (v x y z lines, f i j k lines with 1-based indices)";
const char* const kOffFix =
    "re-export the mesh as OFF (first line OFF, then 'nv nf ne', nv vertex lines, nf face lines)";
const char* const kStlFix = "re-export the mesh as binary STL from a mesh editor or CAD tool";

std::string lineText(std::size_t line) { return "line " + std::to_string(line); }

/// Reads three coordinates from words[first..first+2].
bool parseXyz(const std::vector<std::string_view>& words, std::size_t first, Eigen::Vector3d& p) {
  if (words.size() < first + 3) return false;
  for (int k = 0; k < 3; ++k)
    if (!detail::parseDouble(words[first + static_cast<std::size_t>(k)], p[k])) return false;
  return true;
}

/// Rejects a mesh without vertices and sets the kind (triangle indices are checked by each reader).
void finishMesh(SurfaceData& out, const std::string& name, const char* format, const std::string& fix) {
  detail::requirePoints(out, name, std::string("the ") + format + " file has no vertices", fix);
  out.kind = SurfaceKind::Mesh;
}

// ------------------------------------------------------------------ OBJ

/// Vertex number of one OBJ face corner ("7", "7/2", "7/2/5", "7//5"): the part before the first '/'.
bool objCornerIndex(std::string_view corner, long long& idx) {
  const std::size_t slash = corner.find('/');
  return detail::parseInt64(corner.substr(0, slash), idx);
}

}  // namespace

SurfaceData readObj(const std::string& bytes, const std::string& name) {
  SurfaceData out;
  out.source = name;
  detail::TextCursor cur(bytes.data(), bytes.data() + bytes.size());
  std::vector<std::string_view> w;
  std::vector<int> polygon;
  // Face number (1-based, among 'f' lines) and line of each triangle whose indices may still be out of
  // range: positive indices may refer to vertices defined later, so they are checked at the end.
  std::vector<std::pair<std::size_t, std::size_t>> tri_origin;
  std::size_t face_count = 0;
  std::string_view line;
  while (cur.nextLine(line)) {
    const std::size_t ln = cur.lineNumber() - 1;
    // Strip comments, then split into words.
    const std::size_t hash = line.find('#');
    if (hash != std::string_view::npos) line = line.substr(0, hash);
    detail::splitWords(line, w);
    if (w.empty()) continue;
    if (w[0] == "v") {
      Eigen::Vector3d p;
      if (!parseXyz(w, 1, p)) {
        throw TopoError(
            name, lineText(ln) + ": a vertex needs three numbers 'v x y z', got " + detail::quoted(line, 60), kObjFix);
      }
      out.points.push_back(p);
      if (out.points.size() > kMaxSurfacePoints) detail::checkPointCount(out.points.size(), name, "vertices");
    } else if (w[0] == "f") {
      ++face_count;
      if (w.size() < 4) {
        throw TopoError(name, lineText(ln) + ": face " + std::to_string(face_count) + " has fewer than 3 vertices",
                        kObjFix);
      }
      polygon.clear();
      const long long defined = static_cast<long long>(out.points.size());
      for (std::size_t i = 1; i < w.size(); ++i) {
        long long idx;
        if (!objCornerIndex(w[i], idx) || idx == 0) {
          throw TopoError(name,
                          lineText(ln) + ": face " + std::to_string(face_count) + " has the invalid vertex reference " +
                              detail::quoted(w[i]) +
                              " (indices start at 1; negative ones count back from the last vertex)",
                          kObjFix);
        }
        // Negative indices are relative to the vertices defined so far; positive ones are 1-based.
        const long long zero_based = idx < 0 ? defined + idx : idx - 1;
        if (zero_based < 0 || zero_based > 2147483646LL) {
          throw TopoError(name,
                          lineText(ln) + ": face " + std::to_string(face_count) + " refers to vertex " +
                              std::to_string(idx) + ", which is out of range (" + std::to_string(defined) +
                              " vertices defined before it)",
                          kObjFix);
        }
        polygon.push_back(static_cast<int>(zero_based));
      }
      detail::fanTriangulate(polygon, out.triangles);
      tri_origin.resize(out.triangles.size(), {face_count, ln});
      if (out.triangles.size() > 2 * kMaxSurfacePoints)
        detail::checkPointCount(out.triangles.size() / 2, name,
                                "triangles (counted half: a closed mesh has two per vertex)");
    }
    // Everything else (vt, vn, vp, o, g, s, usemtl, mtllib, l, p, ...) carries no geometry we need.
  }
  const std::size_t nv = out.points.size();
  for (std::size_t t = 0; t < out.triangles.size(); ++t) {
    for (int k = 0; k < 3; ++k) {
      if (static_cast<std::size_t>(out.triangles[t][k]) >= nv) {
        throw TopoError(name,
                        lineText(tri_origin[t].second) + ": face " + std::to_string(tri_origin[t].first) +
                            " refers to vertex " + std::to_string(out.triangles[t][k] + 1) +
                            ", which is out of range (the file has " + std::to_string(nv) + " vertices)",
                        kObjFix);
      }
    }
  }
  finishMesh(out, name, "OBJ", "export a mesh with at least one 'v x y z' line");
  return out;
}

// ------------------------------------------------------------------ OFF

SurfaceData readOff(const std::string& bytes, const std::string& name) {
  SurfaceData out;
  out.source = name;
  detail::TextCursor cur(bytes.data(), bytes.data() + bytes.size());
  std::vector<std::string_view> w;
  std::string_view line;
  std::size_t ln = 0;
  // Next non-empty line without its comment, split into words; false at the end of the file.
  auto nextWords = [&]() {
    while (cur.nextLine(line)) {
      ln = cur.lineNumber() - 1;
      const std::size_t hash = line.find('#');
      if (hash != std::string_view::npos) line = line.substr(0, hash);
      detail::splitWords(line, w);
      if (!w.empty()) return true;
    }
    return false;
  };

  if (!nextWords()) throw TopoError(name, "the file is empty: no OFF header", kOffFix);
  // Header: [ST][C][N][4]OFF, optionally followed by the counts on the same line.
  std::size_t counts_at = 0;
  {
    std::string first = detail::lower(w[0]);
    const bool has_keyword = first.size() >= 3 && first.compare(first.size() - 3, 3, "off") == 0;
    if (has_keyword) {
      const std::string prefix = first.substr(0, first.size() - 3);
      // "4OFF" (homogeneous) and "nOFF" (n-dimensional) are not 3D vertex lists.
      if (prefix.find('4') != std::string::npos) {
        throw TopoError(name, "4OFF (4D homogeneous vertices) is not supported", kOffFix);
      }
      for (char c : prefix) {
        if (c != 's' && c != 't' && c != 'c' && c != 'n') {
          throw TopoError(name, "the first line " + detail::quoted(w[0]) + " is not an OFF header", kOffFix);
        }
      }
      if (w.size() >= 2 && detail::lower(w[1]) == "binary") {
        throw TopoError(name, "binary OFF is not supported", kOffFix);
      }
      if (w.size() == 1) {
        if (!nextWords())
          throw TopoError(name, "the file is truncated: the OFF header has no vertex/face counts", kOffFix);
        counts_at = 0;
      } else {
        counts_at = 1;
      }
    }
  }
  std::uint64_t nv = 0, nf = 0;
  if (w.size() < counts_at + 2 || !detail::parseUint64(w[counts_at], nv) ||
      !detail::parseUint64(w[counts_at + 1], nf)) {
    throw TopoError(
        name, lineText(ln) + ": expected the counts 'vertices faces edges', got " + detail::quoted(line, 60), kOffFix);
  }

  // Counts the text could hold (a vertex line takes >= 6 bytes, a face line >= 8) must be within the
  // limits; larger ones are reported as a truncated file when the data runs out.
  if (nv <= cur.remaining() / 6) detail::checkPointCount(nv, name, "vertices");
  if (nf <= cur.remaining() / 8)
    detail::checkPointCount(nf / 2, name, "faces (counted half: a closed mesh has two per vertex)");
  // A vertex line has at least 5 characters ("0 0 0") and a face line at least 7 ("3 0 1 2").
  out.points.reserve(detail::cappedReserve(nv, cur.remaining(), 6));
  for (std::uint64_t i = 0; i < nv; ++i) {
    if (!nextWords()) {
      throw TopoError(name,
                      "the file is truncated: it ends after " + std::to_string(i) + " of the " + std::to_string(nv) +
                          " vertices declared in the header",
                      kOffFix);
    }
    Eigen::Vector3d p;
    if (!parseXyz(w, 0, p)) {
      throw TopoError(
          name,
          lineText(ln) + ": vertex " + std::to_string(i) + " needs three numbers, got " + detail::quoted(line, 60),
          kOffFix);
    }
    out.points.push_back(p);
  }
  out.triangles.reserve(detail::cappedReserve(nf, cur.remaining(), 8));
  std::vector<int> polygon;
  for (std::uint64_t f = 0; f < nf; ++f) {
    if (!nextWords()) {
      throw TopoError(name,
                      "the file is truncated: it ends after " + std::to_string(f) + " of the " + std::to_string(nf) +
                          " faces declared in the header",
                      kOffFix);
    }
    std::uint64_t n = 0;
    if (!detail::parseUint64(w[0], n) || n > w.size() - 1) {
      throw TopoError(name,
                      lineText(ln) + ": face " + std::to_string(f) + " should be 'n i0 ... i(n-1)', got " +
                          detail::quoted(line, 60),
                      kOffFix);
    }
    polygon.clear();
    for (std::uint64_t k = 0; k < n; ++k) {
      long long idx;
      if (!detail::parseInt64(w[static_cast<std::size_t>(k) + 1], idx) || idx < 0 ||
          static_cast<std::uint64_t>(idx) >= out.points.size()) {
        throw TopoError(name,
                        lineText(ln) + ": face " + std::to_string(f) + " refers to vertex " +
                            detail::quoted(w[static_cast<std::size_t>(k) + 1]) +
                            ", which is out of range (the file has " + std::to_string(out.points.size()) +
                            " vertices, numbered from 0)",
                        kOffFix);
      }
      polygon.push_back(static_cast<int>(idx));
    }
    detail::fanTriangulate(polygon, out.triangles);  // any colour after the indices is ignored
  }
  finishMesh(out, name, "OFF", "export a mesh with at least one vertex");
  return out;
}

// ------------------------------------------------------------------ STL

namespace {

/// Exact vertex merging on the float bit patterns (with -0 folded onto +0).
class VertexMerger {
 public:
  explicit VertexMerger(SurfaceData& out, std::size_t expected) : out_(out) { map_.reserve(expected); }

  int add(float x, float y, float z) {
    const Key key{bits(x), bits(y), bits(z)};
    auto it = map_.find(key);
    if (it != map_.end()) return it->second;
    const int idx = static_cast<int>(out_.points.size());
    out_.points.emplace_back(x, y, z);
    map_.emplace(key, idx);
    return idx;
  }

 private:
  struct Key {
    std::uint32_t a, b, c;
    bool operator==(const Key& o) const { return a == o.a && b == o.b && c == o.c; }
  };
  struct KeyHash {
    std::size_t operator()(const Key& k) const {
      std::uint64_t h = k.a * 0x9E3779B97F4A7C15ull;
      h ^= (k.b + 0x7F4A7C15ull + (h << 6) + (h >> 2)) * 0xC2B2AE3D27D4EB4Full;
      h ^= (k.c + 0x165667B19E3779F9ull + (h << 6) + (h >> 2)) * 0x94D049BB133111EBull;
      return static_cast<std::size_t>(h ^ (h >> 31));
    }
  };
  static std::uint32_t bits(float f) {
    f += 0.0f;  // -0 → +0
    std::uint32_t b;
    std::memcpy(&b, &f, 4);
    return b;
  }
  SurfaceData& out_;
  std::unordered_map<Key, int, KeyHash> map_;
};

bool startsWithSolid(const std::string& bytes) {
  std::size_t i = 0;
  while (i < bytes.size() && detail::isSpace(bytes[i])) ++i;
  return bytes.size() - i >= 5 && detail::lower(std::string_view(bytes).substr(i, 5)) == "solid";
}

void readStlBinary(const std::string& bytes, std::uint32_t count, SurfaceData& out) {
  const unsigned char* p = reinterpret_cast<const unsigned char*>(bytes.data()) + 84;
  const bool swap = !detail::hostIsLittleEndian();
  VertexMerger merge(out, static_cast<std::size_t>(count) / 2 + 3);
  out.triangles.reserve(count);
  for (std::uint32_t t = 0; t < count; ++t, p += 50) {
    int idx[3];
    for (int v = 0; v < 3; ++v) {
      float c[3];
      for (int k = 0; k < 3; ++k) {
        const std::uint32_t b = static_cast<std::uint32_t>(detail::loadBits(p + 12 + 12 * v + 4 * k, 4, swap));
        std::memcpy(&c[k], &b, 4);
      }
      idx[v] = merge.add(c[0], c[1], c[2]);
    }
    out.triangles.emplace_back(idx[0], idx[1], idx[2]);
  }
}

/// Parses ASCII STL; returns an empty string on success, else what went wrong (with the line).
std::string readStlAscii(const std::string& bytes, SurfaceData& out) {
  detail::TextCursor cur(bytes.data(), bytes.data() + bytes.size());
  VertexMerger merge(out, detail::cappedReserve(bytes.size() / 64, bytes.size(), 1));
  std::vector<std::string_view> w;
  std::vector<int> loop;
  bool in_loop = false;
  std::string_view line;
  while (cur.nextLine(line)) {
    const std::size_t ln = cur.lineNumber() - 1;
    detail::splitWords(line, w);
    if (w.empty()) continue;
    const std::string key = detail::lower(w[0]);
    if (key == "solid" || key == "endsolid" || key == "facet" || key == "endfacet") {
      continue;  // names and facet normals are not needed (normals are recomputed from the vertices)
    } else if (key == "outer") {
      loop.clear();
      in_loop = true;
    } else if (key == "vertex") {
      Eigen::Vector3d p;
      if (!in_loop || !parseXyz(w, 1, p)) {
        return lineText(ln) + ": expected 'vertex x y z' inside 'outer loop', got " + detail::quoted(line, 60);
      }
      loop.push_back(merge.add(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())));
    } else if (key == "endloop") {
      if (!in_loop) return lineText(ln) + ": 'endloop' without 'outer loop'";
      detail::fanTriangulate(loop, out.triangles);
      in_loop = false;
    } else {
      return lineText(ln) + ": unexpected " + detail::quoted(w[0]) + " in ASCII STL";
    }
  }
  if (in_loop) return "the file ends inside a facet ('outer loop' without 'endloop')";
  return std::string();
}

}  // namespace

SurfaceData readStl(const std::string& bytes, const std::string& name) {
  SurfaceData out;
  out.source = name;
  std::uint32_t count = 0;
  const bool has_count = bytes.size() >= 84;
  if (has_count)
    count = static_cast<std::uint32_t>(
        detail::loadBits(reinterpret_cast<const unsigned char*>(bytes.data()) + 80, 4, !detail::hostIsLittleEndian()));
  const std::uint64_t binary_size = 84 + 50ull * count;
  // A binary STL is exactly 84 + 50 × count bytes, even when its header happens to start with "solid".
  if (has_count && bytes.size() == binary_size) {
    detail::checkPointCount(count / 2, name, "triangles (counted half: a closed mesh has two per vertex)");
    readStlBinary(bytes, count, out);
  } else if (startsWithSolid(bytes)) {
    const std::string problem = readStlAscii(bytes, out);
    if (!problem.empty()) {
      std::string msg = "not a valid ASCII STL (" + problem + ")";
      if (has_count) {
        msg += ", and its size " + std::to_string(bytes.size()) + " bytes does not match a binary STL of " +
               std::to_string(count) + " triangles (" + std::to_string(binary_size) + " bytes)";
      }
      throw TopoError(name, msg, kStlFix);
    }
    if (out.triangles.empty()) {
      throw TopoError(name, "the file is empty: the ASCII STL has no facets", "export a mesh with at least one facet");
    }
  } else if (!has_count) {
    throw TopoError(
        name,
        "the file is truncated: " + std::to_string(bytes.size()) +
            " bytes is shorter than the 84-byte header of a binary STL (and it does not start with 'solid')",
        kStlFix);
  } else {
    const std::uint64_t present = (bytes.size() - 84) / 50;
    throw TopoError(name,
                    "the binary STL header declares " + std::to_string(count) + " triangles (" +
                        std::to_string(binary_size) + " bytes) but the file size is " + std::to_string(bytes.size()) +
                        " bytes (room for " + std::to_string(present) + " triangles): the file is truncated or corrupt",
                    kStlFix);
  }
  finishMesh(out, name, "STL", "export a mesh with at least one triangle");
  return out;
}

}  // namespace topo_gaussian::geometry
