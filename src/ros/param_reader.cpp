// ParamReader and its value checks (ros/param_reader.h).
#include "topo_gaussian/ros/param_reader.h"

#include <fcntl.h>
#include <unistd.h>

#include <cctype>
#include <cmath>
#include <cstdlib>
#include <mutex>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/number_text.h"

namespace topo_gaussian::topo_ros {

namespace {

using XmlRpc::XmlRpcValue;

std::string withUnit(const std::string& value, const std::string& unit) {
  return unit.empty() ? value : value + " " + unit;
}

std::string shortName(const std::string& name) {  // "~window_s (/x/window_s)" → "window_s"
  std::string s = name.substr(0, name.find(' '));
  return !s.empty() && s[0] == '~' ? s.substr(1) : s;
}

[[noreturn]] void wrongType(const XmlRpcValue& v, const std::string& name, const std::string& expected,
                            const std::string& example) {
  std::string found = param_check::typeName(v);
  if (v.getType() == XmlRpcValue::TypeString)
    found += " (\"" + static_cast<std::string>(const_cast<XmlRpcValue&>(v)) + "\")";
  throw TopoError(name, "is " + found + ", not " + expected,
                  "set it to " + expected + (example.empty() ? "" : ", e.g. _" + shortName(name) + ":=" + example));
}

double asDouble(const XmlRpcValue& v) {
  XmlRpcValue& m = const_cast<XmlRpcValue&>(v);  // XmlRpcValue's conversions are not const
  return v.getType() == XmlRpcValue::TypeInt ? static_cast<double>(static_cast<int>(m)) : static_cast<double>(m);
}

void checkRange(double x, const std::string& name, const std::string& unit, const Range& range,
                const std::string& example) {
  if (!std::isfinite(x)) throw TopoError(name, "is " + numberText(x, 6), "give a finite number, e.g. " + example);
  if (!range.contains(x))
    throw TopoError(name, "is " + withUnit(numberText(x, 6), unit) + ", outside " + range.text(unit),
                    "give a value in " + range.text(unit) + (example.empty() ? "" : ", e.g. " + example));
}

/// Numbers in one string: "[1, 2.5, 3]" or "1 2.5 3"; false when a token is not a number.
bool parseNumberList(std::string text, std::vector<double>& out) {
  for (char& ch : text)
    if (ch == '[' || ch == ']' || ch == ',') ch = ' ';
  std::istringstream in(text);
  out.clear();
  for (std::string tok; in >> tok;) {
    char* end = nullptr;
    out.push_back(std::strtod(tok.c_str(), &end));
    if (end == tok.c_str() || *end != '\0') return false;
  }
  return true;
}

}  // namespace

bool Range::contains(double v) const {
  const bool lo_ok = low_exclusive ? v > low : v >= low;
  const bool hi_ok = high_exclusive ? v < high : v <= high;
  return lo_ok && hi_ok;
}

std::string Range::text(const std::string& unit) const {
  auto end = [](double x) { return std::isinf(x) ? std::string(x < 0 ? "-inf" : "inf") : numberText(x, 6); };
  const std::string r = std::string(low_exclusive || std::isinf(low) ? "(" : "[") + end(low) + ", " + end(high) +
                        (high_exclusive || std::isinf(high) ? ")" : "]");
  return withUnit(r, unit);
}

namespace param_check {

std::string typeName(const XmlRpcValue& v) {
  switch (v.getType()) {
    case XmlRpcValue::TypeBoolean:
      return "a boolean";
    case XmlRpcValue::TypeInt:
      return "an integer";
    case XmlRpcValue::TypeDouble:
      return "a number with a fraction";
    case XmlRpcValue::TypeString:
      return "a string";
    case XmlRpcValue::TypeArray:
      return "a list";
    case XmlRpcValue::TypeStruct:
      return "a dictionary";
    default:
      return "of another type";
  }
}

double number(const XmlRpcValue& v, const std::string& name, const std::string& unit, const Range& range,
              const std::string& example) {
  if (v.getType() != XmlRpcValue::TypeInt && v.getType() != XmlRpcValue::TypeDouble)
    wrongType(v, name, withUnit("a number", unit.empty() ? "" : "[" + unit + "]"), example);
  const double x = asDouble(v);
  checkRange(x, name, unit, range, example);
  return x;
}

long integer(const XmlRpcValue& v, const std::string& name, const std::string& unit, const Range& range,
             const std::string& example) {
  long n = 0;
  if (v.getType() == XmlRpcValue::TypeInt) {
    n = static_cast<int>(const_cast<XmlRpcValue&>(v));
  } else if (v.getType() == XmlRpcValue::TypeDouble) {  // YAML writes 5e4 as a double: accept whole numbers
    const double d = asDouble(v);
    if (!(std::isfinite(d) && d == std::floor(d) && std::abs(d) < 2e9))
      throw TopoError(name, "is " + numberText(d, 6) + ", not a whole number",
                      "give a whole number" + (example.empty() ? "" : ", e.g. _" + shortName(name) + ":=" + example));
    n = static_cast<long>(d);
  } else {
    wrongType(v, name, "a whole number", example);
  }
  checkRange(static_cast<double>(n), name, unit, range, example);
  return n;
}

bool flag(const XmlRpcValue& v, const std::string& name) {
  if (v.getType() != XmlRpcValue::TypeBoolean) wrongType(v, name, "true or false", "true");
  return static_cast<bool>(const_cast<XmlRpcValue&>(v));
}

std::string text(const XmlRpcValue& v, const std::string& name, const std::vector<std::string>& choices,
                 const std::string& example) {
  if (v.getType() != XmlRpcValue::TypeString) wrongType(v, name, "a string", example.empty() ? "NAME" : example);
  const std::string s = static_cast<std::string>(const_cast<XmlRpcValue&>(v));
  if (choices.empty()) return s;
  std::string list;
  for (const auto& c : choices) {
    if (c == s) return s;
    list += (list.empty() ? "" : " | ") + c;
  }
  throw TopoError(name, "is \"" + s + "\", not one of " + list, "use one of " + list);
}

std::vector<double> numbers(const XmlRpcValue& v, const std::string& name, std::size_t size, const std::string& unit,
                            const std::string& example) {
  const std::string expected = "a list of " + (size > 0 ? std::to_string(size) + " " : std::string()) + "numbers" +
                               (unit.empty() ? "" : " [" + unit + "]");
  std::vector<double> out;
  if (v.getType() == XmlRpcValue::TypeArray) {
    for (int i = 0; i < v.size(); ++i) {
      const XmlRpcValue& x = const_cast<XmlRpcValue&>(v)[i];
      if (x.getType() != XmlRpcValue::TypeInt && x.getType() != XmlRpcValue::TypeDouble)
        throw TopoError(name, "entry " + std::to_string(i) + " is " + typeName(x) + ", not a number",
                        "set it to " + expected + (example.empty() ? "" : ", e.g. " + example));
      out.push_back(asDouble(x));
    }
  } else if (v.getType() != XmlRpcValue::TypeString ||
             !parseNumberList(static_cast<std::string>(const_cast<XmlRpcValue&>(v)), out)) {
    wrongType(v, name, expected, example);
  }
  if (size > 0 && out.size() != size)
    throw TopoError(name, "has " + std::to_string(out.size()) + " entries, not " + std::to_string(size),
                    "set it to " + expected + (example.empty() ? "" : ", e.g. " + example));
  for (double x : out)
    if (!std::isfinite(x))
      throw TopoError(name, "holds a non-finite number",
                      "set it to " + expected + (example.empty() ? "" : ", e.g. " + example));
  return out;
}

std::vector<std::string> texts(const XmlRpcValue& v, const std::string& name, const std::string& example,
                               const std::string& separators) {
  std::vector<std::string> out;
  if (v.getType() == XmlRpcValue::TypeArray) {
    for (int i = 0; i < v.size(); ++i) {
      const XmlRpcValue& x = const_cast<XmlRpcValue&>(v)[i];
      if (x.getType() != XmlRpcValue::TypeString)
        throw TopoError(name, "entry " + std::to_string(i) + " is " + typeName(x) + ", not a string",
                        "quote every entry" + (example.empty() ? "" : ", e.g. " + example));
      out.push_back(static_cast<std::string>(const_cast<XmlRpcValue&>(x)));
    }
    return out;
  }
  if (v.getType() != XmlRpcValue::TypeString) wrongType(v, name, "a list of strings", example);
  // One string (`_name:=...` on a command line): items separated by any of `separators`; list
  // brackets and quotes ignored, a trailing comma dropped.
  std::string item;
  auto flush = [&] {
    while (!item.empty() && (item.back() == ',' || std::isspace(static_cast<unsigned char>(item.back()))))
      item.pop_back();
    std::size_t b = 0;
    while (b < item.size() && std::isspace(static_cast<unsigned char>(item[b]))) ++b;
    if (b < item.size()) out.push_back(item.substr(b));
    item.clear();
  };
  for (char ch : static_cast<std::string>(const_cast<XmlRpcValue&>(v))) {
    if (separators.find(ch) != std::string::npos)
      flush();
    else if (ch != '[' && ch != ']' && ch != '\'' && ch != '"')
      item += ch;
  }
  flush();
  return out;
}

}  // namespace param_check

namespace param_doc {

std::string jsonLine(const Entry& e) {
  nlohmann::ordered_json j;
  j["node"] = e.node;
  j["ns"] = e.ns;
  j["name"] = e.name;
  j["type"] = e.type;
  j["default"] = e.default_value;
  j["unit"] = e.unit;
  j["range"] = e.range;
  j["choices"] = e.choices;
  j["size"] = e.size;
  j["example"] = e.example;
  return j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

void append(const std::string& path, const Entry& e) {
  static std::mutex mutex;
  static std::set<std::string> written;  // per process: a parameter read again is described once
  const std::string line = jsonLine(e) + "\n";
  std::lock_guard<std::mutex> lock(mutex);
  if (!written.insert(path + '\0' + line).second) return;
  const int fd = ::open(path.c_str(), O_WRONLY | O_APPEND | O_CREAT | O_CLOEXEC, 0644);
  if (fd < 0) return;
  const ssize_t n = ::write(fd, line.data(), line.size());  // one write: lines of several nodes never interleave
  (void)n;
  ::close(fd);
}

const std::string& targetFile() {
  static const std::string path = [] {
    const char* v = std::getenv("TOPO_DESCRIBE_PARAMS");
    return std::string(v ? v : "");
  }();
  return path;
}

std::string numberDefault(double v) { return numberText(v, 12); }

std::string numbersDefault(const std::vector<double>& v) { return listText(v, 12); }

std::string textDefault(const std::string& v) { return v.empty() ? "\"\"" : v; }

std::string textsDefault(const std::vector<std::string>& v) {
  std::string s = "[";
  for (std::size_t i = 0; i < v.size(); ++i) s += (i ? ", '" : "'") + v[i] + "'";
  return s + "]";
}

std::string rangeText(const Range& range) {
  return std::isinf(range.low) && std::isinf(range.high) ? std::string() : range.text("");
}

}  // namespace param_doc

ParamReader::ParamReader(const ::ros::NodeHandle& pnh, std::string node) : pnh_(pnh), node_(std::move(node)) {}

bool ParamReader::has(const std::string& name) const { return pnh_.hasParam(name); }

std::string ParamReader::displayName(const std::string& name) const {
  return "~" + name + " (" + pnh_.resolveName(name) + ")";
}

bool ParamReader::get(const std::string& name, XmlRpc::XmlRpcValue& v) const {
  return pnh_.hasParam(name) && pnh_.getParam(name, v);
}

void ParamReader::describe(const std::string& name, const char* type, const std::string& default_value,
                           const std::string& unit, const Range* range, const std::vector<std::string>& choices,
                           std::size_t size, const std::string& example) const {
  const std::string& path = param_doc::targetFile();
  if (path.empty()) return;
  param_doc::Entry e;
  e.node = node_;
  e.ns = pnh_.getNamespace();
  e.name = name;
  e.type = type;
  e.default_value = default_value;
  e.unit = unit;
  if (range) e.range = param_doc::rangeText(*range);
  e.choices = choices;
  e.size = size;
  e.example = example;
  param_doc::append(path, e);
}

double ParamReader::number(const std::string& name, double fallback, const std::string& unit,
                           const Range& range) const {
  describe(name, "number", param_doc::numberDefault(fallback), unit, &range);
  XmlRpc::XmlRpcValue v;
  return get(name, v) ? param_check::number(v, displayName(name), unit, range, numberText(fallback, 6)) : fallback;
}

long ParamReader::integer(const std::string& name, long fallback, const std::string& unit, const Range& range) const {
  describe(name, "integer", std::to_string(fallback), unit, &range);
  XmlRpc::XmlRpcValue v;
  return get(name, v) ? param_check::integer(v, displayName(name), unit, range, std::to_string(fallback)) : fallback;
}

bool ParamReader::flag(const std::string& name, bool fallback) const {
  describe(name, "flag", fallback ? "true" : "false");
  XmlRpc::XmlRpcValue v;
  return get(name, v) ? param_check::flag(v, displayName(name)) : fallback;
}

std::string ParamReader::text(const std::string& name, const std::string& fallback,
                              const std::vector<std::string>& choices) const {
  describe(name, "text", param_doc::textDefault(fallback), "", nullptr, choices);
  XmlRpc::XmlRpcValue v;
  return get(name, v) ? param_check::text(v, displayName(name), choices, fallback) : fallback;
}

std::vector<double> ParamReader::numbers(const std::string& name, const std::vector<double>& fallback, std::size_t size,
                                         const std::string& unit, const std::string& example) const {
  describe(name, "numbers", param_doc::numbersDefault(fallback), unit, nullptr, {}, size, example);
  XmlRpc::XmlRpcValue v;
  return get(name, v) ? param_check::numbers(v, displayName(name), size, unit, example) : fallback;
}

std::vector<std::string> ParamReader::texts(const std::string& name, const std::vector<std::string>& fallback,
                                            const std::string& example, const std::string& separators) const {
  describe(name, "texts", param_doc::textsDefault(fallback), "", nullptr, {}, 0, example);
  XmlRpc::XmlRpcValue v;
  return get(name, v) ? param_check::texts(v, displayName(name), example, separators) : fallback;
}

}  // namespace topo_gaussian::topo_ros
