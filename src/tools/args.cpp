#include "args.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <system_error>

namespace topo_gaussian::tools {

Args::Args(const std::vector<std::string>& argv, const std::set<std::string>& flags,
           const std::set<std::string>& valued, const std::set<std::string>& repeated) {
  for (std::size_t i = 0; i < argv.size(); ++i) {
    const std::string& a = argv[i];
    if (a.rfind("--", 0) != 0) throw UsageError("unexpected argument '" + a + "' (options start with --)");
    std::string name = a.substr(2), value;
    const auto eq = name.find('=');
    if (eq != std::string::npos) {
      value = name.substr(eq + 1);
      name = name.substr(0, eq);
    }
    if (flags.count(name)) {
      values_[name] = "1";
    } else if (valued.count(name) || repeated.count(name)) {
      if (eq == std::string::npos) {
        if (i + 1 >= argv.size()) throw UsageError("option --" + name + " needs a value");
        value = argv[++i];
      }
      values_[name] = value;
      if (repeated.count(name)) repeated_[name].push_back(value);
    } else {
      throw UsageError("unknown option --" + name);
    }
  }
}

std::vector<std::string> Args::all(const std::string& name) const {
  auto it = repeated_.find(name);
  return it == repeated_.end() ? std::vector<std::string>() : it->second;
}

bool Args::has(const std::string& name) const { return values_.count(name) > 0; }

std::string Args::str(const std::string& name, const std::string& fallback) const {
  auto it = values_.find(name);
  return it == values_.end() ? fallback : it->second;
}

double Args::num(const std::string& name, double fallback) const {
  if (!has(name)) return fallback;
  const std::string s = str(name);
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(s.c_str(), &end);
  if (s.empty() || *end != '\0' || errno != 0 || !std::isfinite(v))
    throw UsageError("--" + name + " expects a number, got '" + s + "'");
  return v;
}

long Args::integer(const std::string& name, long fallback) const {
  if (!has(name)) return fallback;
  const std::string s = str(name);
  char* end = nullptr;
  errno = 0;
  const long v = std::strtol(s.c_str(), &end, 10);
  if (s.empty() || *end != '\0' || errno != 0) throw UsageError("--" + name + " expects an integer, got '" + s + "'");
  return v;
}

bool sameFile(const std::string& input, const std::string& output) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::exists(output, ec) && fs::equivalent(input, output, ec)) return true;
  const fs::path a = fs::weakly_canonical(input, ec);
  if (ec) return false;
  const fs::path b = fs::weakly_canonical(output, ec);
  return !ec && a == b;
}

}  // namespace topo_gaussian::tools
