// Small helpers for the JSON texts we write (report.json, export.json, `--json` output): numbers
// (non-finite → null), quoted strings. Header-only, standard library only. Reading JSON goes through
// io/json_reader.h (nlohmann::json), never through hand-written parsers.
#pragma once

#include <cmath>
#include <iomanip>
#include <sstream>
#include <string>

namespace topo_gaussian::json {

/// A number with 10 significant digits; NaN and ±Inf become null.
inline std::string num(double v) {
  if (!std::isfinite(v)) return "null";
  std::ostringstream os;
  os << std::setprecision(10) << v;
  return os.str();
}

/// A JSON string literal: quotes and backslashes escaped, newlines as \n, other control characters as spaces.
inline std::string quote(const std::string& s) {
  std::string o = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\')
      o += '\\', o += c;
    else if (c == '\n')
      o += "\\n";
    else if (static_cast<unsigned char>(c) < 0x20)
      o += ' ';
    else
      o += c;
  }
  return o + "\"";
}

}  // namespace topo_gaussian::json
