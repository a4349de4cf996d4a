#include "topo_gaussian/ros/ascii_text.h"

#include <cstdint>
#include <cstdio>

namespace topo_gaussian::topo_ros {

namespace {

/// ASCII spellings of the code points our messages use.
struct Spelling {
  std::uint32_t code;
  const char* ascii;
};
constexpr Spelling kSpellings[] = {
    {0x00D7, "x"},      {0x00B7, "*"},     {0x22C5, "*"},     {0x2265, ">="},    {0x2264, "<="},    {0x2260, "!="},
    {0x2248, "~"},      {0x00B1, "+/-"},   {0x00B0, " deg"},  {0x2212, "-"},     {0x2013, "-"},     {0x2014, "--"},
    {0x2192, "->"},     {0x2190, "<-"},    {0x2194, "<->"},   {0x21D2, "=>"},    {0x2026, "..."},   {0x2018, "'"},
    {0x2019, "'"},      {0x201C, "\""},    {0x201D, "\""},    {0x00B2, "^2"},    {0x00B3, "^3"},    {0x00B9, "^1"},
    {0x207B, "^-"},     {0x00BD, "1/2"},   {0x00B5, "u"},     {0x03BC, "u"},     {0x03B8, "theta"}, {0x03B5, "eps"},
    {0x03C3, "sigma"},  {0x03C1, "rho"},   {0x03C0, "pi"},    {0x03C9, "omega"}, {0x03C6, "phi"},   {0x03C4, "tau"},
    {0x03BB, "lambda"}, {0x03B4, "delta"}, {0x0394, "Delta"}, {0x03A3, "Sum"},   {0x2211, "Sum"},   {0x2202, "d"},
    {0x2207, "grad"},   {0x2208, " in "},  {0x221E, "inf"},   {0x221A, "sqrt"},  {0x2016, "||"},    {0x00A7, "S"},
    {0x00A0, " "},
};

const char* spelling(std::uint32_t c) {
  for (const auto& s : kSpellings)
    if (s.code == c) return s.ascii;
  return nullptr;
}

}  // namespace

std::string asciiText(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  const auto* s = reinterpret_cast<const unsigned char*>(text.data());
  const std::size_t n = text.size();
  for (std::size_t i = 0; i < n;) {
    const unsigned char b = s[i];
    if (b < 0x80) {
      out += char(b);
      ++i;
      continue;
    }
    std::size_t len = b >= 0xF0 && b < 0xF8 ? 4 : b >= 0xE0 ? 3 : b >= 0xC0 ? 2 : 0;
    std::uint32_t c = len == 4 ? b & 0x07u : len == 3 ? b & 0x0Fu : b & 0x1Fu;
    bool valid = len > 0 && i + len <= n;
    for (std::size_t k = 1; valid && k < len; ++k) {
      if ((s[i + k] & 0xC0) != 0x80) valid = false;
      c = (c << 6) | (s[i + k] & 0x3Fu);
    }
    if (!valid) {
      out += '?';
      ++i;
      continue;
    }
    i += len;
    if (c >= 0x0300 && c <= 0x036F) continue;  // combining marks (the tilde of x̃): dropped
    if (const char* a = spelling(c)) {
      out += a;
    } else {
      char buf[16];
      std::snprintf(buf, sizeof buf, "U+%04X", unsigned(c));
      out += buf;
    }
  }
  return out;
}

}  // namespace topo_gaussian::topo_ros
