// Small helpers shared by the JSON writers of the inference library (report.json, export.json):
// numbers (non-finite → null), quoted strings, and a wall-clock stopwatch.
#pragma once

#include <chrono>
#include <cmath>
#include <iomanip>
#include <sstream>
#include <string>

namespace topo_gaussian {
namespace inference {
namespace json_text {

using Clock = std::chrono::steady_clock;
inline double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

inline std::string num(double v) {
  if (!std::isfinite(v)) return "null";
  std::ostringstream os;
  os << std::setprecision(10) << v;
  return os.str();
}

inline std::string quote(const std::string& s) {
  std::string o = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') o += '\\', o += c;
    else if (c == '\n') o += "\\n";
    else if (static_cast<unsigned char>(c) < 0x20) o += ' ';
    else o += c;
  }
  return o + "\"";
}

}  // namespace json_text
}  // namespace inference
}  // namespace topo_gaussian
