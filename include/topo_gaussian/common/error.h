// Error type shared by every module: a readable message that names the input,
// what is wrong with it and how to fix it. Header-only, no dependencies.
#pragma once

#include <stdexcept>
#include <string>

namespace topo_gaussian {

/// Thrown for bad input (files, clouds, parameters) and for failed computations.
/// what() is meant for a person: "<input>: <problem>. Fix: <what to do>".
class TopoError : public std::runtime_error {
 public:
  explicit TopoError(const std::string& message) : std::runtime_error(message) {}
  TopoError(const std::string& input, const std::string& problem, const std::string& fix)
      : std::runtime_error(input + ": " + problem + (fix.empty() ? std::string() : ". Fix: " + fix)) {}
};

}  // namespace topo_gaussian
