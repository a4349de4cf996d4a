// PCD reader (Point Cloud Library format, v0.5 to v0.7): DATA ascii, binary and binary_compressed
// (LZF, field-major). Reads x y z (required), normal_x normal_y normal_z and packed rgb/rgba.
//
// Robustness: every read is bounds-checked; POINTS × point size is checked against the bytes present
// (binary) and the decompressed size must match exactly (binary_compressed), so a lying header gives a
// TopoError, never an out-of-bounds read or a huge allocation.
#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>
#include <vector>

#include "byte_cursor.h"
#include "reader_common.h"
#include "topo_gaussian/common/error.h"
#include "topo_gaussian/geometry/surface_reader.h"

namespace topo_gaussian::geometry {

namespace {

using detail::ScalarType;

const char* const kResave = "save the cloud again with PCL (pcl::io::savePCDFileBinary) with fields x y z";
const char* const kTruncatedFix = "copy or save the file again completely; POINTS must match the data";

enum class PcdData { Ascii, Binary, BinaryCompressed };

struct PcdField {
  std::string name;
  std::size_t size = 4;
  char type = 'F';
  std::uint64_t count = 1;
  ScalarType scalar = ScalarType::Float32;
  std::size_t offset = 0;  ///< byte offset inside one point (AoS); × POINTS for the SoA layout
};

struct PcdHeader {
  std::vector<PcdField> fields;
  std::uint64_t points = 0;
  std::size_t point_step = 0;  ///< bytes of one point (sum of size × count)
  PcdData data = PcdData::Ascii;
  std::size_t data_offset = 0;
};

/// Maps PCD TYPE/SIZE to a scalar type; false for combinations PCD does not define.
bool scalarTypeOf(char type, std::size_t size, ScalarType& t) {
  if (type == 'F') {
    if (size == 4)
      t = ScalarType::Float32;
    else if (size == 8)
      t = ScalarType::Float64;
    else
      return false;
    return true;
  }
  const bool is_signed = type == 'I';
  if (type != 'I' && type != 'U') return false;
  switch (size) {
    case 1:
      t = is_signed ? ScalarType::Int8 : ScalarType::UInt8;
      return true;
    case 2:
      t = is_signed ? ScalarType::Int16 : ScalarType::UInt16;
      return true;
    case 4:
      t = is_signed ? ScalarType::Int32 : ScalarType::UInt32;
      return true;
    case 8:
      t = is_signed ? ScalarType::Int64 : ScalarType::UInt64;
      return true;
    default:
      return false;
  }
}

PcdHeader parseHeader(const std::string& bytes, const std::string& name) {
  detail::TextCursor cur(bytes.data(), bytes.data() + bytes.size());
  PcdHeader h;
  std::vector<std::string_view> w;
  std::vector<std::string_view> sizes, types, counts;
  bool have_fields = false, have_size = false, have_type = false, have_count = false;
  bool have_width = false, have_height = false, have_points = false, have_data = false;
  std::uint64_t width = 0, height = 1, points = 0;
  std::string_view line;
  std::size_t lines = 0;
  while (!have_data && cur.nextLine(line)) {
    ++lines;
    const std::string where = "PCD header line " + std::to_string(lines) + " ";
    detail::splitWords(line, w);
    if (w.empty() || w[0][0] == '#') continue;
    const std::string key = detail::lower(w[0]);
    auto number = [&](std::uint64_t& v) {
      if (w.size() != 2 || !detail::parseUint64(w[1], v)) {
        throw TopoError(
            name, where + "should be '" + std::string(w[0]) + " <non-negative integer>': " + detail::quoted(line, 60),
            kResave);
      }
    };
    if (key == "version" || key == "viewpoint") {
      continue;  // not needed for reading the points
    } else if (key == "fields" || key == "columns") {
      h.fields.clear();
      for (std::size_t i = 1; i < w.size(); ++i) {
        PcdField f;
        f.name = std::string(w[i]);
        h.fields.push_back(f);
      }
      have_fields = true;
    } else if (key == "size") {
      sizes.assign(w.begin() + 1, w.end());
      have_size = true;
    } else if (key == "type") {
      types.assign(w.begin() + 1, w.end());
      have_type = true;
    } else if (key == "count") {
      counts.assign(w.begin() + 1, w.end());
      have_count = true;
    } else if (key == "width") {
      number(width);
      have_width = true;
    } else if (key == "height") {
      number(height);
      have_height = true;
    } else if (key == "points") {
      number(points);
      have_points = true;
    } else if (key == "data") {
      if (w.size() != 2) throw TopoError(name, where + "should be 'DATA ascii|binary|binary_compressed'", kResave);
      const std::string kind = detail::lower(w[1]);
      if (kind == "ascii")
        h.data = PcdData::Ascii;
      else if (kind == "binary")
        h.data = PcdData::Binary;
      else if (kind == "binary_compressed")
        h.data = PcdData::BinaryCompressed;
      else
        throw TopoError(name, where + "has the unknown DATA kind " + detail::quoted(w[1]), kResave);
      have_data = true;
    } else {
      throw TopoError(name, where + "has the unknown keyword " + detail::quoted(w[0]) + " (not a PCD file?)", kResave);
    }
  }
  if (!have_data) {
    throw TopoError(name, "the PCD header has no DATA line (the file is truncated or not a PCD file)", kResave);
  }
  if (!have_fields || h.fields.empty()) throw TopoError(name, "the PCD header has no FIELDS", kResave);
  const std::size_t nf = h.fields.size();
  auto checkCount = [&](bool have, const std::vector<std::string_view>& list, const char* key) {
    if (!have) throw TopoError(name, std::string("the PCD header has no ") + key + " line", kResave);
    if (list.size() != nf) {
      throw TopoError(name,
                      std::string("the PCD header's ") + key + " line has " + std::to_string(list.size()) +
                          " entries but FIELDS has " + std::to_string(nf),
                      std::string("give one ") + key + " entry per field, or " + kResave);
    }
  };
  checkCount(have_size, sizes, "SIZE");
  checkCount(have_type, types, "TYPE");
  if (have_count) checkCount(true, counts, "COUNT");

  std::uint64_t step = 0;
  for (std::size_t i = 0; i < nf; ++i) {
    PcdField& f = h.fields[i];
    std::uint64_t size = 0;
    if (!detail::parseUint64(sizes[i], size) || size > 8) size = 0;
    f.size = static_cast<std::size_t>(size);
    f.type = types[i].size() == 1 ? static_cast<char>(types[i][0] & ~0x20) : '?';  // upper case
    if (!scalarTypeOf(f.type, f.size, f.scalar)) {
      throw TopoError(name,
                      "field " + f.name + " has TYPE " + detail::quoted(types[i]) + " with SIZE " +
                          detail::quoted(sizes[i]) + ", which PCD does not define",
                      "use TYPE F with SIZE 4 or 8, or TYPE I/U with SIZE 1, 2, 4 or 8");
    }
    f.count = 1;
    if (have_count && (!detail::parseUint64(counts[i], f.count) || f.count == 0 || f.count > (1u << 20))) {
      throw TopoError(name, "field " + f.name + " has the invalid COUNT " + detail::quoted(counts[i]),
                      "COUNT must be a positive integer (1 for x y z)");
    }
    f.offset = static_cast<std::size_t>(step);
    step += f.size * f.count;  // ≤ 2^20 fields' worth of ≤ 8 MiB each: no overflow
  }
  h.point_step = static_cast<std::size_t>(step);

  if (!have_width && !have_points) {
    throw TopoError(name, "the PCD header has neither WIDTH nor POINTS", kResave);
  }
  if (have_width) {
    if (height != 0 && width > UINT64_MAX / height) {
      throw TopoError(name, "the PCD header's WIDTH × HEIGHT overflows", kResave);
    }
    const std::uint64_t wh = width * (have_height ? height : 1);
    if (have_points && points != wh) {
      throw TopoError(
          name, "the PCD header says POINTS " + std::to_string(points) + " but WIDTH × HEIGHT = " + std::to_string(wh),
          "make POINTS equal WIDTH × HEIGHT, or " + std::string(kResave));
    }
    points = wh;
  }
  h.points = points;
  h.data_offset = cur.offset();
  return h;
}

/// LZF decompression (the liblzf format PCL uses). Returns the number of bytes written, or -1 when
/// the stream is corrupt: a reference before the start, or a run that would overflow either buffer.
long long lzfDecompress(const unsigned char* in, std::size_t in_len, unsigned char* out, std::size_t out_len) {
  const unsigned char* ip = in;
  const unsigned char* const in_end = in + in_len;
  unsigned char* op = out;
  unsigned char* const out_end = out + out_len;
  while (ip < in_end) {
    const unsigned int ctrl = *ip++;
    if (ctrl < 32) {  // literal run of ctrl + 1 bytes
      const std::size_t len = ctrl + 1;
      if (len > static_cast<std::size_t>(out_end - op) || len > static_cast<std::size_t>(in_end - ip)) return -1;
      std::memcpy(op, ip, len);
      op += len;
      ip += len;
    } else {  // back reference: length (ctrl >> 5) + 2, offset ((ctrl & 31) << 8) + next byte + 1
      std::size_t len = ctrl >> 5;
      if (len == 7) {
        if (ip >= in_end) return -1;
        len += *ip++;
      }
      if (ip >= in_end) return -1;
      const std::size_t back = ((static_cast<std::size_t>(ctrl & 0x1f)) << 8) + *ip++ + 1;
      len += 2;
      if (back > static_cast<std::size_t>(op - out)) return -1;
      if (len > static_cast<std::size_t>(out_end - op)) return -1;
      const unsigned char* ref = op - back;
      for (std::size_t i = 0; i < len; ++i) op[i] = ref[i];  // may overlap: byte by byte
      op += len;
    }
  }
  return static_cast<long long>(op - out);
}

struct FieldRoles {
  const PcdField* xyz[3] = {nullptr, nullptr, nullptr};
  const PcdField* normal[3] = {nullptr, nullptr, nullptr};
  const PcdField* rgb = nullptr;
};

FieldRoles findRoles(const PcdHeader& h, const std::string& name) {
  FieldRoles r;
  auto find = [&](const char* n) -> const PcdField* {
    for (const PcdField& f : h.fields)
      if (f.name == n) return &f;
    return nullptr;
  };
  const char* axes[3] = {"x", "y", "z"};
  std::string missing;
  for (int k = 0; k < 3; ++k) {
    r.xyz[k] = find(axes[k]);
    if (!r.xyz[k]) missing += (missing.empty() ? "" : " ") + std::string(axes[k]);
  }
  if (!missing.empty()) {
    throw TopoError(name, "the PCD has no field " + missing + " (positions need x y z)", kResave);
  }
  r.normal[0] = find("normal_x"), r.normal[1] = find("normal_y"), r.normal[2] = find("normal_z");
  if (!r.normal[0] || !r.normal[1] || !r.normal[2]) r.normal[0] = r.normal[1] = r.normal[2] = nullptr;
  r.rgb = find("rgb");
  if (!r.rgb) r.rgb = find("rgba");
  if (r.rgb && r.rgb->size != 4) r.rgb = nullptr;  // packed colour is always 4 bytes
  return r;
}

/// Packed 0x(AA)RRGGBB → RGB in [0, 1].
Eigen::Vector3d unpackRgb(std::uint32_t v) {
  return Eigen::Vector3d(((v >> 16) & 0xff) / 255.0, ((v >> 8) & 0xff) / 255.0, (v & 0xff) / 255.0);
}

/// Reads points from binary data. Element k of field f of point i lies at
/// base + f.offset × field_scale + (i × f.count + k) × f.size × point_scale + ... ; both layouts are
/// expressed by `at(field, point)` returning the first byte of that field's value for that point.
template <typename At>
void readBinaryPoints(const PcdHeader& h, const FieldRoles& roles, At at, SurfaceData& out) {
  const bool swap = !detail::hostIsLittleEndian();  // PCD binary data is little-endian in practice
  const std::size_t n = static_cast<std::size_t>(h.points);
  out.points.resize(n);
  if (roles.normal[0]) out.normals.resize(n);
  if (roles.rgb) out.colors.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) out.points[i][k] = detail::loadScalar(at(*roles.xyz[k], i), roles.xyz[k]->scalar, swap);
    if (roles.normal[0])
      for (int k = 0; k < 3; ++k)
        out.normals[i][k] = detail::loadScalar(at(*roles.normal[k], i), roles.normal[k]->scalar, swap);
    if (roles.rgb) out.colors[i] = unpackRgb(static_cast<std::uint32_t>(detail::loadBits(at(*roles.rgb, i), 4, swap)));
  }
}

void readAsciiPoints(const std::string& bytes, const PcdHeader& h, const FieldRoles& roles, SurfaceData& out,
                     const std::string& name) {
  detail::TextCursor cur(bytes.data() + h.data_offset, bytes.data() + bytes.size());
  const std::size_t nf = h.fields.size();
  std::uint64_t values_per_point = 0;
  for (const PcdField& f : h.fields) values_per_point += f.count;
  // Each value takes at least one character and a separator: reserve no more than the text can hold.
  const std::size_t reserve = detail::cappedReserve(h.points, cur.remaining(), 2 * values_per_point);
  if (reserve >= h.points) detail::checkPointCount(h.points, name);  // the text could hold them all
  out.points.reserve(reserve);
  if (roles.normal[0]) out.normals.reserve(reserve);
  if (roles.rgb) out.colors.reserve(reserve);
  std::vector<double> first(nf, 0.0);  // first element of each field of the current point
  std::string_view tok;
  for (std::uint64_t i = 0; i < h.points; ++i) {
    for (std::size_t f = 0; f < nf; ++f) {
      for (std::uint64_t k = 0; k < h.fields[f].count; ++k) {
        if (!cur.nextToken(tok)) {
          throw TopoError(name,
                          "the file is truncated: the ASCII data ends in point " + std::to_string(i) + " (only " +
                              std::to_string(i) + " of the " + std::to_string(h.points) +
                              " points declared by POINTS are present)",
                          kTruncatedFix);
        }
        double v;
        if (!detail::parseDouble(tok, v)) {
          throw TopoError(name,
                          "line " + std::to_string(cur.lineNumber()) + " of the ASCII data has " + detail::quoted(tok) +
                              " where a number for field " + h.fields[f].name + " was expected",
                          kResave);
        }
        if (k == 0) first[f] = v;
      }
    }
    auto value = [&](const PcdField* f) { return first[static_cast<std::size_t>(f - h.fields.data())]; };
    out.points.emplace_back(value(roles.xyz[0]), value(roles.xyz[1]), value(roles.xyz[2]));
    if (roles.normal[0])
      out.normals.emplace_back(value(roles.normal[0]), value(roles.normal[1]), value(roles.normal[2]));
    if (roles.rgb) {
      // ASCII rgb is the packed integer, written as a float's value (TYPE F) or as an integer (I/U).
      const double v = value(roles.rgb);
      std::uint32_t bits = 0;
      if (roles.rgb->type == 'F') {
        const float fv = static_cast<float>(v);
        std::memcpy(&bits, &fv, 4);
      } else if (v >= -2147483648.0 && v <= 4294967295.0) {
        bits = v < 0 ? static_cast<std::uint32_t>(static_cast<std::int32_t>(v)) : static_cast<std::uint32_t>(v);
      }
      out.colors.push_back(unpackRgb(bits));
    }
  }
}

}  // namespace

SurfaceData readPcd(const std::string& bytes, const std::string& name) {
  const PcdHeader h = parseHeader(bytes, name);
  const FieldRoles roles = findRoles(h, name);
  SurfaceData out;
  out.source = name;
  out.kind = SurfaceKind::Points;
  const unsigned char* data = reinterpret_cast<const unsigned char*>(bytes.data()) + h.data_offset;
  const std::size_t avail = bytes.size() - h.data_offset;

  if (h.data == PcdData::Ascii) {
    readAsciiPoints(bytes, h, roles, out, name);
  } else if (h.data == PcdData::Binary) {
    const std::size_t step = h.point_step;
    if (step == 0 || h.points > avail / step) {
      throw TopoError(name,
                      "the file is truncated: POINTS " + std::to_string(h.points) + " × " + std::to_string(step) +
                          " bytes per point need more than the " + std::to_string(avail) +
                          " bytes of binary data present (room for " + std::to_string(step ? avail / step : 0) +
                          " of the " + std::to_string(h.points) + " points)",
                      kTruncatedFix);
    }
    detail::checkPointCount(h.points, name);
    readBinaryPoints(
        h, roles, [&](const PcdField& f, std::size_t i) { return data + i * step + f.offset; }, out);
  } else {
    if (avail < 8) {
      throw TopoError(name,
                      "the file is truncated: binary_compressed data needs an 8-byte size header, " +
                          std::to_string(avail) + " bytes present",
                      kTruncatedFix);
    }
    const std::uint32_t packed = static_cast<std::uint32_t>(detail::loadBits(data, 4, !detail::hostIsLittleEndian()));
    const std::uint32_t unpacked =
        static_cast<std::uint32_t>(detail::loadBits(data + 4, 4, !detail::hostIsLittleEndian()));
    const std::size_t step = h.point_step;
    if (step == 0 || h.points > UINT32_MAX / step || unpacked != h.points * step) {
      throw TopoError(name,
                      "the binary_compressed data unpacks to " + std::to_string(unpacked) + " bytes, but POINTS " +
                          std::to_string(h.points) + " × " + std::to_string(step) + " bytes per point need " +
                          std::to_string(h.points * step),
                      kTruncatedFix);
    }
    if (packed > avail - 8) {
      throw TopoError(name,
                      "the file is truncated: the binary_compressed block is " + std::to_string(packed) +
                          " bytes, but only " + std::to_string(avail - 8) + " bytes follow its size header",
                      kTruncatedFix);
    }
    // LZF expands at most 264 bytes per 3 input bytes: a larger claim is a lie, refuse before allocating.
    if (static_cast<std::uint64_t>(unpacked) > (static_cast<std::uint64_t>(packed) / 3 + 1) * 264) {
      throw TopoError(name,
                      "the binary_compressed block claims " + std::to_string(unpacked) + " bytes from only " +
                          std::to_string(packed) + " compressed bytes, more than LZF can produce (corrupt file)",
                      kTruncatedFix);
    }
    detail::checkPointCount(h.points, name);
    std::vector<unsigned char> raw(unpacked);
    const long long got = lzfDecompress(data + 8, packed, raw.data(), raw.size());
    if (got != static_cast<long long>(unpacked)) {
      throw TopoError(name,
                      got < 0 ? std::string("the binary_compressed data is corrupt (invalid LZF stream)")
                              : "the binary_compressed data unpacks to " + std::to_string(got) +
                                    " bytes instead of the " + std::to_string(unpacked) + " declared",
                      kTruncatedFix);
    }
    // Field-major layout: all points' values of field 0, then of field 1, ...
    const std::size_t npts = static_cast<std::size_t>(h.points);
    const unsigned char* base = raw.data();
    readBinaryPoints(
        h, roles,
        [&](const PcdField& f, std::size_t i) {
          return base + f.offset * npts + i * f.size * static_cast<std::size_t>(f.count);
        },
        out);
  }
  detail::requirePoints(out, name, "the PCD declares 0 points", "save a cloud with at least one point");
  return out;
}

}  // namespace topo_gaussian::geometry
