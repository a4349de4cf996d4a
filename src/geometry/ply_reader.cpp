// PLY reader: ascii, binary_little_endian and binary_big_endian; any elements and properties
// (scalars and lists). Interprets the "vertex" element (positions, normals, colours and 3D Gaussian
// Splatting attributes) and the "face" element (triangles; polygons are fan-triangulated); other
// elements are read past and ignored.
//
// Robustness: every read is bounds-checked, and every declared count is checked against the bytes
// that are left before anything is allocated for it, so a lying header gives a TopoError, never an
// out-of-bounds read or a huge allocation.
#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "byte_cursor.h"
#include "reader_common.h"
#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/number_text.h"
#include "topo_gaussian/geometry/surface_reader.h"

namespace topo_gaussian::geometry {

namespace {

using detail::ScalarType;

constexpr double kShC0 = 0.28209479177387814;  // zeroth spherical-harmonics basis constant
const char* const kReexport = "re-export the file as binary_little_endian PLY with x y z float properties";

enum class PlyFormat { Ascii, BinaryLittleEndian, BinaryBigEndian };

struct PlyProperty {
  std::string name;
  bool is_list = false;
  ScalarType type = ScalarType::Float32;      // scalar type, or the item type of a list
  ScalarType count_type = ScalarType::UInt8;  // lists only: type of the item count
};

struct PlyElement {
  std::string name;
  std::uint64_t count = 0;
  std::vector<PlyProperty> properties;

  /// Index of the property called `prop`, or -1.
  int find(std::string_view prop) const {
    for (std::size_t i = 0; i < properties.size(); ++i)
      if (properties[i].name == prop) return static_cast<int>(i);
    return -1;
  }
  /// Smallest number of bytes one binary record can take (scalars plus list counts).
  std::size_t minRecordBytes() const {
    std::size_t n = 0;
    for (const PlyProperty& p : properties) n += detail::scalarSize(p.is_list ? p.count_type : p.type);
    return n;
  }
  bool hasLists() const {
    for (const PlyProperty& p : properties)
      if (p.is_list) return true;
    return false;
  }
};

struct PlyHeader {
  PlyFormat format = PlyFormat::Ascii;
  std::vector<PlyElement> elements;
  std::size_t data_offset = 0;  ///< first byte after the end_header line
};

bool scalarTypeFromName(std::string_view s, ScalarType& t) {
  struct Entry {
    const char* name;
    ScalarType type;
  };
  static const Entry kTypes[] = {
      {"char", ScalarType::Int8},      {"int8", ScalarType::Int8},       {"uchar", ScalarType::UInt8},
      {"uint8", ScalarType::UInt8},    {"short", ScalarType::Int16},     {"int16", ScalarType::Int16},
      {"ushort", ScalarType::UInt16},  {"uint16", ScalarType::UInt16},   {"int", ScalarType::Int32},
      {"int32", ScalarType::Int32},    {"uint", ScalarType::UInt32},     {"uint32", ScalarType::UInt32},
      {"float", ScalarType::Float32},  {"float32", ScalarType::Float32}, {"double", ScalarType::Float64},
      {"float64", ScalarType::Float64}};
  for (const Entry& e : kTypes)
    if (s == e.name) {
      t = e.type;
      return true;
    }
  return false;
}

PlyHeader parseHeader(const std::string& bytes, const std::string& name) {
  detail::TextCursor cur(bytes.data(), bytes.data() + bytes.size());
  std::string_view line;
  if (!cur.nextLine(line) || detail::trim(line) != "ply") {
    throw TopoError(name, "not a PLY file (the first line is not 'ply')",
                    "check that the file really is a PLY file, or " + std::string(kReexport));
  }
  PlyHeader header;
  bool have_format = false;
  bool have_end = false;
  std::vector<std::string_view> w;
  while (cur.nextLine(line)) {
    const std::size_t ln = cur.lineNumber() - 1;
    const std::string where = "PLY header line " + std::to_string(ln) + " ";
    detail::splitWords(line, w);
    if (w.empty()) continue;
    const std::string_view key = w[0];
    if (key == "end_header") {
      have_end = true;
      break;
    }
    if (key == "comment" || key == "obj_info") continue;
    if (key == "format") {
      if (w.size() < 2) throw TopoError(name, where + "'format' names no format", kReexport);
      if (w[1] == "ascii")
        header.format = PlyFormat::Ascii;
      else if (w[1] == "binary_little_endian")
        header.format = PlyFormat::BinaryLittleEndian;
      else if (w[1] == "binary_big_endian")
        header.format = PlyFormat::BinaryBigEndian;
      else
        throw TopoError(name, where + "has the unknown format " + detail::quoted(w[1]), kReexport);
      have_format = true;
    } else if (key == "element") {
      PlyElement el;
      if (w.size() != 3 || !detail::parseUint64(w[2], el.count)) {
        throw TopoError(name, where + "is not 'element <name> <count>': " + detail::quoted(line, 60), kReexport);
      }
      el.name = std::string(w[1]);
      header.elements.push_back(std::move(el));
    } else if (key == "property") {
      if (header.elements.empty()) {
        throw TopoError(name, where + "declares a property before any element", kReexport);
      }
      PlyProperty p;
      if (w.size() == 5 && w[1] == "list") {
        p.is_list = true;
        if (!scalarTypeFromName(w[2], p.count_type) || !scalarTypeFromName(w[3], p.type)) {
          throw TopoError(name, where + "has an unknown list type: " + detail::quoted(line, 60), kReexport);
        }
        if (!detail::isIntegerType(p.count_type)) {
          throw TopoError(name, where + "declares a list whose count type is not an integer", kReexport);
        }
        p.name = std::string(w[4]);
      } else if (w.size() == 3) {
        if (!scalarTypeFromName(w[1], p.type)) {
          throw TopoError(name, where + "has the unknown property type " + detail::quoted(w[1]),
                          "use one of char uchar short ushort int uint float double (or int8..float64), or " +
                              std::string(kReexport));
        }
        p.name = std::string(w[2]);
      } else {
        throw TopoError(name, where + "is not 'property <type> <name>' or 'property list <count type> <type> <name>'",
                        kReexport);
      }
      header.elements.back().properties.push_back(std::move(p));
    } else {
      throw TopoError(name, where + "has the unknown keyword " + detail::quoted(key) + " (corrupt header?)", kReexport);
    }
  }
  if (!have_end) {
    throw TopoError(name, "the PLY header has no end_header line (the file is truncated or not PLY)", kReexport);
  }
  if (!have_format) throw TopoError(name, "the PLY header has no 'format' line", kReexport);
  header.data_offset = cur.offset();
  return header;
}

// ------------------------------------------------------------------ value sources
// Both sources read one value of a given type; they return false when the data ends.

class BinarySource {
 public:
  BinarySource(const unsigned char* begin, const unsigned char* end, bool swap) : cur_(begin, end), swap_(swap) {}
  bool read(ScalarType t, double& v) {
    const unsigned char* p = cur_.take(detail::scalarSize(t));
    if (!p) return false;
    v = detail::loadScalar(p, t, swap_);
    return true;
  }
  /// Skips n values of type t.
  bool skip(ScalarType t, std::uint64_t n) {
    const std::size_t size = detail::scalarSize(t);
    if (n > cur_.remaining() / size) return false;
    return cur_.take(static_cast<std::size_t>(n) * size) != nullptr;
  }
  std::size_t remaining() const { return cur_.remaining(); }
  /// Largest list length that could still be read with items of type t.
  std::uint64_t maxItems(ScalarType t) const { return cur_.remaining() / detail::scalarSize(t); }

 private:
  detail::ByteCursor cur_;
  bool swap_;
};

class AsciiSource {
 public:
  AsciiSource(const char* begin, const char* end, const std::string& name) : cur_(begin, end), name_(name) {}
  bool read(ScalarType, double& v) {
    std::string_view tok;
    if (!cur_.nextToken(tok)) return false;
    if (!detail::parseDouble(tok, v)) {
      throw TopoError(name_,
                      "line " + std::to_string(cur_.lineNumber()) + " of the ASCII PLY data has " +
                          detail::quoted(tok) + " where a number was expected",
                      kReexport);
    }
    return true;
  }
  bool skip(ScalarType t, std::uint64_t n) {
    double v;
    for (std::uint64_t i = 0; i < n; ++i)
      if (!read(t, v)) return false;
    return true;
  }
  std::size_t remaining() const { return cur_.remaining(); }
  /// Each value takes at least one character and one separator.
  std::uint64_t maxItems(ScalarType) const { return cur_.remaining() / 2 + 1; }

 private:
  detail::TextCursor cur_;
  const std::string& name_;
};

// ------------------------------------------------------------------ element reading

/// Property indices of the vertex element that the reader understands (-1 when absent).
struct VertexLayout {
  int x = -1, y = -1, z = -1;
  int n[3] = {-1, -1, -1};
  int rgb[3] = {-1, -1, -1};
  int dc[3] = {-1, -1, -1};
  int opacity = -1;
  int scale[3] = {-1, -1, -1};
  int rot[4] = {-1, -1, -1, -1};
  int sh_rest = 0;  // number of f_rest_* properties
  bool gaussians = false;
  bool normals = false;
  bool colors = false;
};

VertexLayout vertexLayout(const PlyElement& el, const std::string& name) {
  VertexLayout L;
  L.x = el.find("x");
  L.y = el.find("y");
  L.z = el.find("z");
  const char* axes[3] = {"x", "y", "z"};
  const int* pos[3] = {&L.x, &L.y, &L.z};
  std::string missing;
  for (int k = 0; k < 3; ++k)
    if (*pos[k] < 0) missing += (missing.empty() ? "" : " ") + std::string(axes[k]);
  if (!missing.empty()) {
    throw TopoError(name, "the vertex element has no property " + missing + " (positions need x y z)", kReexport);
  }
  for (int k = 0; k < 3; ++k) {
    const PlyProperty& p = el.properties[static_cast<std::size_t>(*pos[k])];
    if (p.is_list) {
      throw TopoError(name, "vertex property " + p.name + " is a list, but a position must be a single number",
                      kReexport);
    }
  }
  // Optional per-vertex data; a list where a scalar is expected is ignored.
  auto scalar = [&](const char* prop) {
    const int i = el.find(prop);
    return (i >= 0 && !el.properties[static_cast<std::size_t>(i)].is_list) ? i : -1;
  };
  L.n[0] = scalar("nx"), L.n[1] = scalar("ny"), L.n[2] = scalar("nz");
  L.normals = L.n[0] >= 0 && L.n[1] >= 0 && L.n[2] >= 0;
  L.dc[0] = scalar("f_dc_0"), L.dc[1] = scalar("f_dc_1"), L.dc[2] = scalar("f_dc_2");
  const char* rgb_names[2][3] = {{"red", "green", "blue"}, {"diffuse_red", "diffuse_green", "diffuse_blue"}};
  for (auto& names : rgb_names) {
    if (L.rgb[0] >= 0) break;
    for (int k = 0; k < 3; ++k) L.rgb[k] = scalar(names[k]);
    if (L.rgb[0] < 0 || L.rgb[1] < 0 || L.rgb[2] < 0) L.rgb[0] = L.rgb[1] = L.rgb[2] = -1;
  }
  const bool have_dc = L.dc[0] >= 0 && L.dc[1] >= 0 && L.dc[2] >= 0;
  if (!have_dc) L.dc[0] = L.dc[1] = L.dc[2] = -1;
  L.colors = have_dc || L.rgb[0] >= 0;

  // 3D Gaussian Splatting attributes: all of opacity, scale_0..2, rot_0..3, or none of scale/rot.
  const char* gauss_names[8] = {"opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"};
  int* gauss_idx[8] = {&L.opacity, &L.scale[0], &L.scale[1], &L.scale[2], &L.rot[0], &L.rot[1], &L.rot[2], &L.rot[3]};
  int found = 0;
  bool any_shape = false;
  std::string absent;
  for (int k = 0; k < 8; ++k) {
    *gauss_idx[k] = scalar(gauss_names[k]);
    if (*gauss_idx[k] >= 0) {
      ++found;
      if (k > 0) any_shape = true;
    } else {
      absent += (absent.empty() ? "" : " ") + std::string(gauss_names[k]);
    }
  }
  if (found == 8) {
    L.gaussians = true;
  } else if (any_shape) {
    throw TopoError(name, "the vertex element has some 3D Gaussian properties but lacks " + absent,
                    "export the Gaussians with all of opacity scale_0..2 rot_0..3 (standard 3DGS layout), "
                    "or remove the scale_*/rot_* properties to read the file as plain points");
  }
  for (const PlyProperty& p : el.properties)
    if (p.name.rfind("f_rest_", 0) == 0) ++L.sh_rest;
  return L;
}

int shDegreeFromRestCount(int count, const std::string& name) {
  switch (count) {
    case 0:
      return 0;
    case 9:
      return 1;
    case 24:
      return 2;
    case 45:
      return 3;
    default:
      throw TopoError(name,
                      "the file has " + std::to_string(count) +
                          " f_rest_* properties, which matches no spherical-harmonics degree (0, 9, 24 or 45 expected)",
                      "export the Gaussians with the standard 3DGS layout (f_rest_0..f_rest_{3((d+1)^2-1)-1})");
  }
}

double sigmoid(double x) { return 1.0 / (1.0 + std::exp(-x)); }

/// Checks before reading an element that the remaining data could hold `count` records.
template <typename Source>
void checkElementFits(const Source& src, const PlyElement& el, bool binary, const std::string& name) {
  if (el.count == 0 || el.properties.empty()) return;
  const std::size_t rem = src.remaining();
  if (binary) {
    const std::size_t rec = el.minRecordBytes();
    if (el.count > rem / rec) {
      const std::string exact = el.hasLists() ? "at least " : "";
      throw TopoError(name,
                      "the file is truncated: the header declares " + std::to_string(el.count) + " " + el.name +
                          " records of " + exact + std::to_string(rec) + " bytes, but only " + std::to_string(rem) +
                          " bytes of data are present (room for " + std::to_string(rem / rec) + " of the " +
                          std::to_string(el.count) + " " + el.name + " records)",
                      "copy or export the file again completely; the header count must match the data");
    }
  } else {
    // Every ASCII value takes at least one character plus one separator.
    const std::uint64_t tokens_per_record = el.properties.size();
    if (el.count > (rem / 2 + 1) / tokens_per_record) {
      throw TopoError(name,
                      "the file is truncated: the header declares " + std::to_string(el.count) + " " + el.name +
                          " records, but only " + std::to_string(rem) + " bytes of ASCII data follow the header",
                      "copy or export the file again completely; the header count must match the data");
    }
  }
}

[[noreturn]] void throwEndedEarly(const PlyElement& el, std::uint64_t record, const std::string& name) {
  throw TopoError(name,
                  "the file is truncated or corrupt: the data ends (or a list length is impossible) in " + el.name +
                      " record " + std::to_string(record) + " (only " + std::to_string(record) + " of the " +
                      std::to_string(el.count) + " " + el.name + " records declared by the header are present)",
                  "copy or export the file again completely; the header count must match the data");
}

/// Reads one record's list property; returns its length (after checking it could fit).
template <typename Source>
bool readListCount(Source& src, const PlyProperty& p, std::uint64_t& n) {
  double v;
  if (!src.read(p.count_type, v)) return false;
  long long len;
  if (!detail::asIndex(v, 0.0, 4294967295.0, len)) return false;
  n = static_cast<std::uint64_t>(len);
  return n <= src.maxItems(p.type);
}

/// Reads past one element's records without interpreting them.
template <typename Source>
void skipElement(Source& src, const PlyElement& el, const std::string& name) {
  if (el.properties.empty()) return;  // nothing stored per record
  for (std::uint64_t r = 0; r < el.count; ++r) {
    for (const PlyProperty& p : el.properties) {
      if (p.is_list) {
        std::uint64_t n;
        if (!readListCount(src, p, n) || !src.skip(p.type, n)) throwEndedEarly(el, r, name);
      } else if (!src.skip(p.type, 1)) {
        throwEndedEarly(el, r, name);
      }
    }
  }
}

template <typename Source>
void readVertices(Source& src, const PlyElement& el, const VertexLayout& L, bool faces, SurfaceData& out,
                  const std::string& name) {
  const std::size_t n = static_cast<std::size_t>(el.count);  // already checked against the data size
  const bool gaussians = L.gaussians && !faces;
  out.points.reserve(n);
  if (L.normals) out.normals.reserve(n);
  if (L.colors) out.colors.reserve(n);
  if (gaussians) {
    out.opacity.reserve(n);
    out.scales.reserve(n);
    out.rotations.reserve(n);
    out.covariances.reserve(n);
  }
  // Colour scale of integer red/green/blue: 8-bit → /255, 16-bit → /65535; floats as they are.
  double rgb_scale[3] = {1.0, 1.0, 1.0};
  for (int k = 0; k < 3; ++k) {
    if (L.rgb[k] < 0) continue;
    const ScalarType t = el.properties[static_cast<std::size_t>(L.rgb[k])].type;
    if (detail::scalarSize(t) == 1 && detail::isIntegerType(t))
      rgb_scale[k] = 1.0 / 255.0;
    else if (detail::scalarSize(t) == 2 && detail::isIntegerType(t))
      rgb_scale[k] = 1.0 / 65535.0;
  }

  std::vector<double> v(el.properties.size(), 0.0);
  for (std::size_t r = 0; r < n; ++r) {
    for (std::size_t i = 0; i < el.properties.size(); ++i) {
      const PlyProperty& p = el.properties[i];
      if (p.is_list) {
        std::uint64_t len;
        if (!readListCount(src, p, len) || !src.skip(p.type, len)) throwEndedEarly(el, r, name);
      } else if (!src.read(p.type, v[i])) {
        throwEndedEarly(el, r, name);
      }
    }
    auto at = [&](int i) { return v[static_cast<std::size_t>(i)]; };
    out.points.emplace_back(at(L.x), at(L.y), at(L.z));
    if (L.normals) out.normals.emplace_back(at(L.n[0]), at(L.n[1]), at(L.n[2]));
    if (L.colors) {
      Eigen::Vector3d c;
      for (int k = 0; k < 3; ++k) {
        c[k] = L.dc[0] >= 0 ? 0.5 + kShC0 * at(L.dc[k]) : at(L.rgb[k]) * rgb_scale[k];
        if (c[k] < 0.0) c[k] = 0.0;  // NaN stays NaN (cleaning is done elsewhere)
        if (c[k] > 1.0) c[k] = 1.0;
      }
      out.colors.push_back(c);
    }
    if (gaussians) {
      out.opacity.push_back(sigmoid(at(L.opacity)));
      const Eigen::Vector3d s(std::exp(at(L.scale[0])), std::exp(at(L.scale[1])), std::exp(at(L.scale[2])));
      Eigen::Vector4d q(at(L.rot[0]), at(L.rot[1]), at(L.rot[2]), at(L.rot[3]));
      const double qn = q.norm();
      if (qn == 0.0) {
        throw TopoError(
            name, "Gaussian " + std::to_string(r) + " has the zero quaternion rot_0..3 = 0 0 0 0, which is no rotation",
            "fix or remove that Gaussian in the exporter; rotations must be non-zero quaternions (w x y z)");
      }
      q /= qn;  // NaN/inf stay visible for cleaning
      out.scales.push_back(s);
      out.rotations.push_back(q);
      out.covariances.push_back(gaussianCovariance(s, q));
    }
  }
}

template <typename Source>
void readFaces(Source& src, const PlyElement& el, std::uint64_t vertex_count, SurfaceData& out,
               const std::string& name) {
  int list = el.find("vertex_indices");
  if (list < 0) list = el.find("vertex_index");
  if (list < 0 || !el.properties[static_cast<std::size_t>(list)].is_list) {
    throw TopoError(name, "the face element has no list property vertex_indices (or vertex_index)",
                    "export faces as 'property list uchar int vertex_indices'");
  }
  out.triangles.reserve(static_cast<std::size_t>(el.count));  // already checked against the data size
  std::vector<int> polygon;
  for (std::uint64_t r = 0; r < el.count; ++r) {
    for (std::size_t i = 0; i < el.properties.size(); ++i) {
      const PlyProperty& p = el.properties[i];
      if (!p.is_list) {
        if (!src.skip(p.type, 1)) throwEndedEarly(el, r, name);
        continue;
      }
      std::uint64_t len;
      if (!readListCount(src, p, len)) throwEndedEarly(el, r, name);
      if (static_cast<int>(i) != list) {
        if (!src.skip(p.type, len)) throwEndedEarly(el, r, name);
        continue;
      }
      polygon.clear();
      for (std::uint64_t k = 0; k < len; ++k) {
        double d;
        if (!src.read(p.type, d)) throwEndedEarly(el, r, name);
        long long idx;
        if (!detail::asIndex(d, 0.0, static_cast<double>(vertex_count) - 1.0, idx) || idx > 2147483647LL) {
          throw TopoError(name,
                          "face " + std::to_string(r) + " refers to vertex " + numberText(d, 15) +
                              ", which is out of range (the file has " + std::to_string(vertex_count) + " vertices)",
                          "repair the mesh (e.g. re-export it from a mesh editor); face indices must be 0.." +
                              std::to_string(vertex_count == 0 ? 0 : vertex_count - 1));
        }
        polygon.push_back(static_cast<int>(idx));
      }
      detail::fanTriangulate(polygon, out.triangles);  // faces of fewer than 3 vertices add nothing
    }
  }
}

template <typename Source>
void readBody(Source& src, const PlyHeader& h, bool binary, SurfaceData& out, const std::string& name) {
  const PlyElement* vertex = nullptr;
  for (const PlyElement& el : h.elements)
    if (el.name == "vertex") {
      vertex = &el;
      break;
    }
  if (!vertex) {
    throw TopoError(name, "the PLY header declares no 'vertex' element", kReexport);
  }
  const VertexLayout layout = vertexLayout(*vertex, name);
  bool faces = false;
  for (const PlyElement& el : h.elements)
    if (el.name == "face" && el.count > 0) faces = true;
  // Header-level checks come before reading any data.
  const int sh_degree = (layout.gaussians && !faces) ? shDegreeFromRestCount(layout.sh_rest, name) : -1;

  bool face_done = false;
  for (const PlyElement& el : h.elements) {
    checkElementFits(src, el, binary, name);
    if (&el == vertex) detail::checkPointCount(vertex->count, name, "vertices");
    if (&el == vertex) {
      readVertices(src, el, layout, faces, out, name);
    } else if (el.name == "face" && !face_done && el.count > 0) {
      detail::checkPointCount(el.count / 2, name, "faces (counted half: a closed mesh has two per vertex)");
      readFaces(src, el, vertex->count, out, name);
      face_done = true;
    } else {
      skipElement(src, el, name);
    }
  }
  if (faces) {
    out.kind = SurfaceKind::Mesh;
  } else if (layout.gaussians) {
    out.kind = SurfaceKind::Gaussians;
    out.sh_degree = sh_degree;
  } else {
    out.kind = SurfaceKind::Points;
  }
}

}  // namespace

SurfaceData readPly(const std::string& bytes, const std::string& name) {
  const PlyHeader header = parseHeader(bytes, name);
  SurfaceData out;
  out.source = name;
  const char* data = bytes.data() + header.data_offset;
  const char* end = bytes.data() + bytes.size();
  if (header.format == PlyFormat::Ascii) {
    AsciiSource src(data, end, name);
    readBody(src, header, false, out, name);
  } else {
    const bool big = header.format == PlyFormat::BinaryBigEndian;
    const bool swap = big == detail::hostIsLittleEndian();
    BinarySource src(reinterpret_cast<const unsigned char*>(data), reinterpret_cast<const unsigned char*>(end), swap);
    readBody(src, header, true, out, name);
    // Data left over means the header's types or counts do not describe the data (e.g. 'uchar'
    // declared where the exporter wrote float): what was read is garbage. A few trailing bytes (a
    // newline some exporters add) are tolerated.
    const std::size_t total = static_cast<std::size_t>(end - data), used = total - src.remaining();
    if (src.remaining() > 16 && src.remaining() > used / 64) {
      throw TopoError(name,
                      "the header describes " + std::to_string(used) + " bytes of binary data, but " +
                          std::to_string(total) + " bytes follow it (" + std::to_string(src.remaining()) +
                          " left over): the declared property types or element counts do not match the data",
                      "re-export the file; or correct the header so that every property's type (float, uchar, ...) "
                      "and every element count matches what the exporter wrote");
    }
  }
  detail::requirePoints(out, name, "the PLY vertex element has 0 vertices",
                        "export a PLY with at least one vertex (element vertex N, N > 0)");
  return out;
}

}  // namespace topo_gaussian::geometry
