// A tiny command-line parser for the `topo` subcommands: --name value and --flag options,
// with typed getters that report bad values by name.
#pragma once

#include <map>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

namespace topo_gaussian::tools {

class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class Args {
 public:
  /// `flags` are options without a value; every other --name takes the next argument.
  /// `repeated` options may be given several times (all() returns every value in order).
  Args(const std::vector<std::string>& argv, const std::set<std::string>& flags, const std::set<std::string>& valued,
       const std::set<std::string>& repeated = {});

  bool has(const std::string& name) const;
  std::string str(const std::string& name, const std::string& fallback = "") const;
  double num(const std::string& name, double fallback) const;
  long integer(const std::string& name, long fallback) const;
  std::vector<std::string> all(const std::string& name) const;

 private:
  std::map<std::string, std::string> values_;
  std::map<std::string, std::vector<std::string>> repeated_;
};

/// True when `output` names the same file as `input` (also through a symlink, "./", ".."): an output
/// that would overwrite an input is refused before any work (topo fill, topo track).
bool sameFile(const std::string& input, const std::string& output);

}  // namespace topo_gaussian::tools
