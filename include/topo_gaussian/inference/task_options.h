// A task's own parameters as a typed struct, declared and read from one list (the pattern of
// src/inference/rigid_options.h, with each parameter's name written once). A task lists its fields
// once, as a generic function of a visitor f:
//
//   struct TumblerOptions { double initial_tilt_deg = 0; std::optional<double> period_s; ... };
//   constexpr auto kTumblerFields = [](auto& f) {
//     f.number("initial_tilt_deg", &TumblerOptions::initial_tilt_deg, 10.0, "deg", "release tilt [deg]", -89, 89);
//     f.target("period_s", &TumblerOptions::period_s, "s", "observed rocking period [s]", 0, 1e300, true);
//   };
//
// Its declaration calls declareOptions<TumblerOptions>(p, kTumblerFields) (each field declared as
// TaskParameters declares it: name, default, unit, documentation, range; `.paper("...")` chains as there),
// its factory readOptions<TumblerOptions>(config, kTumblerFields) (each field read back from the config:
// no key typed twice, no field read with the wrong type). Fields: number, integer, flag, text, vector3 (with
// a default, or as std::optional<Eigen::Vector3d> without one, set only when given), list, and targets (no
// default) as std::optional<double>, std::optional<std::string> or std::optional<std::vector<double>>, set
// only when given. A field list whose defaults differ per task (the soft tasks' SoftSimOptions,
// src/inference/soft_task.h) is a function of those defaults that returns the list.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "topo_gaussian/inference/task_config.h"
#include "topo_gaussian/inference/task_registry.h"

namespace topo_gaussian::inference {

/// The declaring visitor: every field is a TaskParameters declaration (the member pointer is unused).
template <class Options>
class DeclareFields {
 public:
  explicit DeclareFields(TaskParameters& p) : p_(p) {}

  template <class... Rest>
  TaskParameters::Declared number(const std::string& name, double Options::*, double def, Rest&&... rest) {
    return p_.number(name, def, std::forward<Rest>(rest)...);
  }
  template <class... Rest>
  TaskParameters::Declared integer(const std::string& name, int Options::*, int def, Rest&&... rest) {
    return p_.integer(name, def, std::forward<Rest>(rest)...);
  }
  TaskParameters::Declared flag(const std::string& name, bool Options::*, bool def, const std::string& doc) {
    return p_.flag(name, def, doc);
  }
  TaskParameters::Declared text(const std::string& name, std::string Options::*, const std::string& def,
                                const std::string& doc, std::vector<std::string> choices = {}) {
    return p_.text(name, def, doc, std::move(choices));
  }
  TaskParameters::Declared vector3(const std::string& name, Eigen::Vector3d Options::*, const Eigen::Vector3d& def,
                                   const std::string& unit, const std::string& doc) {
    return p_.vector3(name, &def, unit, doc);
  }
  /// An optional point or direction (no default): the field holds it when it is given.
  TaskParameters::Declared vector3(const std::string& name, std::optional<Eigen::Vector3d> Options::*,
                                   const std::string& unit, const std::string& doc) {
    return p_.vector3(name, nullptr, unit, doc);
  }
  template <class... Rest>
  TaskParameters::Declared list(const std::string& name, std::vector<double> Options::*, std::vector<double> def,
                                Rest&&... rest) {
    return p_.list(name, std::move(def), std::forward<Rest>(rest)...);
  }
  /// An observed number (a target, without a default): the field holds it when it is given.
  template <class... Rest>
  TaskParameters::Declared target(const std::string& name, std::optional<double> Options::*, Rest&&... rest) {
    return p_.target(name, ParamType::Number, std::forward<Rest>(rest)...);
  }
  /// An observed text (a target file): the field holds it when it is given.
  TaskParameters::Declared target(const std::string& name, std::optional<std::string> Options::*,
                                  const std::string& unit, const std::string& doc) {
    return p_.target(name, ParamType::Text, unit, doc);
  }
  /// An observed list (one value per pose, ...): the field holds it when it is given.
  template <class... Rest>
  TaskParameters::Declared target(const std::string& name, std::optional<std::vector<double>> Options::*,
                                  Rest&&... rest) {
    return p_.target(name, ParamType::List, std::forward<Rest>(rest)...);
  }

 private:
  TaskParameters& p_;
};

/// The reading visitor: every field is read back from the config into the options.
template <class Options>
class ReadFields {
 public:
  /// What `.paper("...")` chains on while reading: nothing.
  struct Read {
    Read& paper(const std::string&) { return *this; }
  };

  ReadFields(const TaskConfig& config, Options* options) : c_(config), o_(*options) {}

  template <class... Rest>
  Read number(const std::string& name, double Options::*field, Rest&&...) {
    o_.*field = c_.number(name);
    return {};
  }
  template <class... Rest>
  Read integer(const std::string& name, int Options::*field, Rest&&...) {
    o_.*field = c_.integer(name);
    return {};
  }
  template <class... Rest>
  Read flag(const std::string& name, bool Options::*field, Rest&&...) {
    o_.*field = c_.boolean(name);
    return {};
  }
  Read text(const std::string& name, std::string Options::*field, const std::string&, const std::string&,
            const std::vector<std::string>& = {}) {
    o_.*field = c_.text(name);
    return {};
  }
  template <class... Rest>
  Read vector3(const std::string& name, Eigen::Vector3d Options::*field, Rest&&...) {
    o_.*field = c_.vector3(name);
    return {};
  }
  template <class... Rest>
  Read vector3(const std::string& name, std::optional<Eigen::Vector3d> Options::*field, Rest&&...) {
    if (c_.has(name)) o_.*field = c_.vector3(name);
    return {};
  }
  template <class... Rest>
  Read list(const std::string& name, std::vector<double> Options::*field, const std::vector<double>&, Rest&&...) {
    o_.*field = c_.list(name);
    return {};
  }
  template <class... Rest>
  Read target(const std::string& name, std::optional<double> Options::*field, Rest&&...) {
    if (c_.has(name)) o_.*field = c_.number(name);
    return {};
  }
  template <class... Rest>
  Read target(const std::string& name, std::optional<std::string> Options::*field, Rest&&...) {
    if (c_.has(name)) o_.*field = c_.text(name);
    return {};
  }
  template <class... Rest>
  Read target(const std::string& name, std::optional<std::vector<double>> Options::*field, Rest&&...) {
    if (c_.has(name)) o_.*field = c_.list(name);
    return {};
  }

 private:
  const TaskConfig& c_;
  Options& o_;
};

/// Declares the fields that `fields(f)` lists, in that order.
template <class Options, class Fields>
void declareOptions(TaskParameters& p, const Fields& fields) {
  DeclareFields<Options> f(p);
  fields(f);
}

/// The options that `fields(f)` lists, read from the config.
template <class Options, class Fields>
Options readOptions(const TaskConfig& config, const Fields& fields) {
  Options o;
  ReadFields<Options> f(config, &o);
  fields(f);
  return o;
}

}  // namespace topo_gaussian::inference
