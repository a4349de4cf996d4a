// Internal helpers shared by the file readers (PLY, PCD, OBJ, OFF, STL): bounded text and byte
// cursors, number parsing that never throws, and binary scalar decoding. Not part of the public
// API; include only from src/geometry/*_reader(s).cpp.
//
// Everything here works on a [begin, end) range of an in-memory file and never reads outside it.
#pragma once

#include <algorithm>
#include <charconv>
#include <clocale>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

namespace topo_gaussian::geometry::detail {

inline bool isSpace(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f'; }

/// Lower-case ASCII copy.
inline std::string lower(std::string_view s) {
  std::string out(s);
  for (char& c : out)
    if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
  return out;
}

inline std::string_view trim(std::string_view s) {
  while (!s.empty() && isSpace(s.front())) s.remove_prefix(1);
  while (!s.empty() && isSpace(s.back())) s.remove_suffix(1);
  return s;
}

/// Shortens a token for an error message (binary garbage must not flood the message).
inline std::string quoted(std::string_view s, std::size_t max_len = 40) {
  std::string out = "'";
  for (std::size_t i = 0; i < s.size() && i < max_len; ++i) {
    const unsigned char c = static_cast<unsigned char>(s[i]);
    out += (c >= 32 && c < 127) ? static_cast<char>(c) : '?';
  }
  if (s.size() > max_len) out += "...";
  return out + "'";
}

/// Parses a whole token as a floating-point number (decimal, exponent, inf, nan; a leading '+' is
/// allowed). Returns false for anything else. Never throws and is independent of the C locale.
inline bool parseDouble(std::string_view tok, double& out) {
  if (tok.empty()) return false;
  const char* first = tok.data();
  const char* last = tok.data() + tok.size();
  if (*first == '+') {
    ++first;
    if (first == last || *first == '-' || *first == '+') return false;
  }
#if defined(__cpp_lib_to_chars) && __cpp_lib_to_chars >= 201611L
  auto res = std::from_chars(first, last, out);
  if (res.ec == std::errc() && res.ptr == last) return true;
  if (res.ec != std::errc::result_out_of_range) return false;
    // Out of range (e.g. 1e999 or 1e-999): fall through to strtod, which saturates to inf / 0.
#endif
  // strtod needs a NUL-terminated string and uses the locale's decimal point: copy the token into a
  // small buffer and swap '.' for the locale's separator. Numbers longer than the buffer are rejected.
  char buf[128];
  const std::size_t n = static_cast<std::size_t>(last - first);
  if (n == 0 || n >= sizeof(buf)) return false;
  const char point = std::localeconv()->decimal_point[0];
  for (std::size_t i = 0; i < n; ++i) {
    const char c = first[i];
    // Reject hex floats and characters strtod would accept but a file format does not.
    if (c == 'x' || c == 'X' || c == 'p' || c == 'P' || c == ',') return false;
    buf[i] = (c == '.') ? point : c;
  }
  buf[n] = '\0';
  char* end = nullptr;
  out = std::strtod(buf, &end);
  return end == buf + n;
}

/// Parses a whole token as a signed 64-bit integer.
inline bool parseInt64(std::string_view tok, long long& out) {
  if (tok.empty()) return false;
  const char* first = tok.data();
  const char* last = tok.data() + tok.size();
  if (*first == '+') ++first;
  auto res = std::from_chars(first, last, out);
  return res.ec == std::errc() && res.ptr == last;
}

/// Parses a whole token as an unsigned 64-bit integer (no sign allowed).
inline bool parseUint64(std::string_view tok, std::uint64_t& out) {
  if (tok.empty()) return false;
  const char* first = tok.data();
  const char* last = tok.data() + tok.size();
  if (*first == '+') ++first;
  if (first != last && *first == '-') return false;
  auto res = std::from_chars(first, last, out);
  return res.ec == std::errc() && res.ptr == last;
}

/// Splits a line into whitespace-separated words.
inline void splitWords(std::string_view line, std::vector<std::string_view>& words) {
  words.clear();
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && isSpace(line[i])) ++i;
    const std::size_t start = i;
    while (i < line.size() && !isSpace(line[i])) ++i;
    if (i > start) words.push_back(line.substr(start, i - start));
  }
}

/// Walks a text buffer line by line or token by token. Tracks the 1-based line number.
class TextCursor {
 public:
  TextCursor(const char* begin, const char* end) : p_(begin), begin_(begin), end_(end) {}
  explicit TextCursor(std::string_view s) : TextCursor(s.data(), s.data() + s.size()) {}

  bool atEnd() const { return p_ >= end_; }
  std::size_t offset() const { return static_cast<std::size_t>(p_ - begin_); }
  std::size_t remaining() const { return static_cast<std::size_t>(end_ - p_); }
  const char* position() const { return p_; }
  /// Line number of the next character to be read (1-based).
  std::size_t lineNumber() const { return line_; }

  /// Next line without its terminator ('\n' or "\r\n"). False at the end of the buffer.
  bool nextLine(std::string_view& line) {
    if (p_ >= end_) return false;
    const char* start = p_;
    const void* nl = std::memchr(p_, '\n', static_cast<std::size_t>(end_ - p_));
    const char* stop = nl ? static_cast<const char*>(nl) : end_;
    p_ = nl ? stop + 1 : end_;
    if (stop > start && stop[-1] == '\r') --stop;
    line = std::string_view(start, static_cast<std::size_t>(stop - start));
    ++line_;
    return true;
  }

  /// Next whitespace-separated token (line breaks count as whitespace). False at the end.
  bool nextToken(std::string_view& tok) {
    while (p_ < end_ && isSpace(*p_)) {
      if (*p_ == '\n') ++line_;
      ++p_;
    }
    if (p_ >= end_) return false;
    const char* start = p_;
    while (p_ < end_ && !isSpace(*p_)) ++p_;
    tok = std::string_view(start, static_cast<std::size_t>(p_ - start));
    return true;
  }

 private:
  const char* p_;
  const char* begin_;
  const char* end_;
  std::size_t line_ = 1;
};

/// Scalar types of binary records (PLY property types, PCD TYPE/SIZE pairs).
enum class ScalarType : std::uint8_t { Int8, UInt8, Int16, UInt16, Int32, UInt32, Int64, UInt64, Float32, Float64 };

inline std::size_t scalarSize(ScalarType t) {
  switch (t) {
    case ScalarType::Int8:
    case ScalarType::UInt8:
      return 1;
    case ScalarType::Int16:
    case ScalarType::UInt16:
      return 2;
    case ScalarType::Int32:
    case ScalarType::UInt32:
    case ScalarType::Float32:
      return 4;
    case ScalarType::Int64:
    case ScalarType::UInt64:
    case ScalarType::Float64:
      return 8;
  }
  return 1;
}

inline bool isIntegerType(ScalarType t) { return t != ScalarType::Float32 && t != ScalarType::Float64; }

/// True when this machine stores numbers little-endian.
inline bool hostIsLittleEndian() {
  const std::uint16_t one = 1;
  unsigned char b;
  std::memcpy(&b, &one, 1);
  return b == 1;
}

/// Raw bits of a scalar of `size` bytes at `p`, converted to host byte order.
inline std::uint64_t loadBits(const unsigned char* p, std::size_t size, bool swap) {
  unsigned char tmp[8] = {0, 0, 0, 0, 0, 0, 0, 0};
  if (swap) {
    for (std::size_t i = 0; i < size; ++i) tmp[i] = p[size - 1 - i];
  } else {
    std::memcpy(tmp, p, size);
  }
  switch (size) {
    case 1: {
      std::uint8_t v;
      std::memcpy(&v, tmp, 1);
      return v;
    }
    case 2: {
      std::uint16_t v;
      std::memcpy(&v, tmp, 2);
      return v;
    }
    case 4: {
      std::uint32_t v;
      std::memcpy(&v, tmp, 4);
      return v;
    }
    default: {
      std::uint64_t v;
      std::memcpy(&v, tmp, 8);
      return v;
    }
  }
}

/// Decodes one binary scalar at `p` (which must hold scalarSize(t) bytes) as a double.
inline double loadScalar(const unsigned char* p, ScalarType t, bool swap) {
  const std::uint64_t bits = loadBits(p, scalarSize(t), swap);
  switch (t) {
    case ScalarType::Int8:
      return static_cast<std::int8_t>(static_cast<std::uint8_t>(bits));
    case ScalarType::UInt8:
      return static_cast<double>(bits);
    case ScalarType::Int16:
      return static_cast<std::int16_t>(static_cast<std::uint16_t>(bits));
    case ScalarType::UInt16:
      return static_cast<double>(bits);
    case ScalarType::Int32:
      return static_cast<std::int32_t>(static_cast<std::uint32_t>(bits));
    case ScalarType::UInt32:
      return static_cast<double>(bits);
    case ScalarType::Int64:
      return static_cast<double>(static_cast<std::int64_t>(bits));
    case ScalarType::UInt64:
      return static_cast<double>(bits);
    case ScalarType::Float32: {
      const std::uint32_t b32 = static_cast<std::uint32_t>(bits);
      float f;
      std::memcpy(&f, &b32, 4);
      return f;
    }
    case ScalarType::Float64: {
      double d;
      std::memcpy(&d, &bits, 8);
      return d;
    }
  }
  return 0.0;
}

/// Bounded reader of binary data. take() refuses (returns nullptr) rather than read past the end.
class ByteCursor {
 public:
  ByteCursor(const unsigned char* begin, const unsigned char* end) : p_(begin), begin_(begin), end_(end) {}

  std::size_t remaining() const { return static_cast<std::size_t>(end_ - p_); }
  std::size_t offset() const { return static_cast<std::size_t>(p_ - begin_); }

  /// Pointer to the next n bytes and advances past them, or nullptr when fewer than n remain.
  const unsigned char* take(std::size_t n) {
    if (n > remaining()) return nullptr;
    const unsigned char* out = p_;
    p_ += n;
    return out;
  }

 private:
  const unsigned char* p_;
  const unsigned char* begin_;
  const unsigned char* end_;
};

/// A double that is a whole number in [lo, hi] (for counts and indices read as floating point).
inline bool asIndex(double v, double lo, double hi, long long& out) {
  if (!(v >= lo && v <= hi)) return false;  // also rejects NaN
  const long long i = static_cast<long long>(v);
  if (static_cast<double>(i) != v) return false;
  out = i;
  return true;
}

}  // namespace topo_gaussian::geometry::detail
