// TaskConfig: the parameters of one inference task (config/tasks/*.yaml), typed, with units and
// documentation, validated on every change. Each task declares its own parameters beside its code
// (inference/task_registry.h); the parameters every task shares are declared in task_config.cpp. A YAML file gives a
// task and its parameters; `--set KEY=VALUE` and `--target NAME=VALUE` override single values. Unknown keys and
// impossible values (negative density, dt ≤ 0, ε ≤ 0, ...) are refused with a message naming the key and the fix.
#pragma once

#include <Eigen/Core>
#include <map>
#include <string>
#include <vector>

namespace topo_gaussian::inference {

enum class ParamType { Number, Integer, Boolean, Text, Vector3, List };

struct ParamSpec {
  std::string name;
  ParamType type = ParamType::Number;
  std::string doc;      ///< one line, with the unit in brackets ("[m]") or the word "unitless"
  double min = -1e300;  ///< inclusive lower bound (Number/Integer/List entries)
  double max = 1e300;   ///< inclusive upper bound
  bool min_exclusive = false;
  std::vector<std::string> choices;  ///< allowed Text values (empty = any)
  bool is_target = false;            ///< an observed feature (set with --target)
  std::string unit;                  ///< SI unit ("m", "kg/m^3", "deg"), "unitless", or "" for Text/Boolean
  std::string paper_value;           ///< the value the TopoGaussian paper uses, "" where it gives none
};

struct ParamValue {
  double number = 0.0;
  std::string text;
  Eigen::Vector3d vec = Eigen::Vector3d::Zero();
  std::vector<double> list;
  bool set = false;  ///< false: no value (optional parameters, unset targets)
};

class TaskConfig {
 public:
  /// The defaults of a registered task (TaskConfig::taskNames(), inference/task_registry.h): the
  /// common parameters, then the task's own declarations. Throws TopoError for an unknown task
  /// name, listing the registered ones.
  static TaskConfig defaults(const std::string& task);
  /// The parameters every task has (representation, materials, regularisers, optimiser, gravity)
  /// with their common defaults; task() is empty. A task may change some of these defaults.
  static TaskConfig common();
  /// Reads a YAML file: `task: NAME` plus parameters (and an optional `targets:` map).
  static TaskConfig fromYamlFile(const std::string& path);
  /// A task name ("tumbler") or a YAML path; names resolve to config/tasks/NAME.yaml under
  /// `task_dir` when that file exists, otherwise to the built-in defaults.
  static TaskConfig load(const std::string& name_or_path, const std::string& task_dir = "");
  /// The registered tasks, in registry order.
  static std::vector<std::string> taskNames();

  const std::string& task() const { return task_; }
  const std::string& source() const { return source_; }

  /// Sets one parameter from text ("1200", "true", "0,0,0.1", "[0.1, 0.2]"). Throws TopoError for
  /// unknown keys (with the nearest known key) and invalid values (with the allowed range).
  void set(const std::string& key, const std::string& value, const std::string& origin = "--set");
  void setNumber(const std::string& key, double value);
  void setVector(const std::string& key, const Eigen::Vector3d& value);
  void setList(const std::string& key, const std::vector<double>& value);
  /// "KEY=VALUE" form (CLI).
  void setAssignment(const std::string& assignment, const std::string& origin = "--set");

  bool has(const std::string& key) const;  ///< known and given a value
  double number(const std::string& key) const;
  int integer(const std::string& key) const { return static_cast<int>(number(key)); }
  bool boolean(const std::string& key) const { return number(key) != 0.0; }
  const std::string& text(const std::string& key) const;
  Eigen::Vector3d vector3(const std::string& key) const;
  const std::vector<double>& list(const std::string& key) const;

  const std::vector<ParamSpec>& specs() const { return specs_; }
  const ParamSpec* spec(const std::string& key) const;
  /// "key = value" text of one parameter (for reports).
  std::string valueText(const std::string& key) const;
  /// Help text: every parameter with its default, unit, documentation and paper value.
  std::string help() const;

 private:
  std::string task_;
  std::string source_ = "defaults";
  std::vector<ParamSpec> specs_;
  std::map<std::string, ParamValue> values_;
  /// Shorthand keys (a task's declaration): setting the key sets each listed parameter to the same
  /// value; the key itself may be one of them.
  std::map<std::string, std::vector<std::string>> shorthands_;
  void declare(const ParamSpec& spec, const ParamValue& value);
  void check(const ParamSpec& spec, const ParamValue& value, const std::string& origin) const;
  friend class TaskParameters;
};

}  // namespace topo_gaussian::inference
