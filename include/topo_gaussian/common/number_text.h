// Numbers in messages for people (errors, log lines): a few significant digits, and lists of them.
// Header-only, standard library only, so every module uses it instead of a formatter of its own.
#pragma once

#include <cstdio>
#include <string>
#include <vector>

namespace topo_gaussian {

/// v with `digits` significant digits (printf "%.*g"); −0 is written as 0.
inline std::string numberText(double v, int digits = 4) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*g", digits, v + 0.0);
  return buf;
}

/// v with `decimals` digits after the point (printf "%.*f"), for labels with a fixed layout.
inline std::string fixedText(double v, int decimals = 3) {
  char buf[352];
  std::snprintf(buf, sizeof(buf), "%.*f", decimals, v + 0.0);
  return buf;
}

/// "[a, b, c]" with numberText.
inline std::string listText(const std::vector<double>& v, int digits = 6) {
  std::string s = "[";
  for (std::size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + numberText(v[i], digits);
  return s + "]";
}

/// "[a, b, c]" of names (experiments, keys, assignments).
inline std::string listText(const std::vector<std::string>& v) {
  std::string s = "[";
  for (std::size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + v[i];
  return s + "]";
}

}  // namespace topo_gaussian
