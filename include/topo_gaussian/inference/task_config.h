// TaskConfig: the parameters of one inference task (config/tasks/*.yaml), typed, with units and
// documentation, validated on every change. Each task declares its own parameters beside its code
// (inference/task_registry.h); the parameters every task shares are declared in task_config.cpp. A YAML file gives a
// task and its parameters; `--set KEY=VALUE` and `--target NAME=VALUE` override single values. Unknown keys and
// impossible values (negative density, dt ≤ 0, ε ≤ 0, ...) are refused with a message naming the key and the fix.
#pragma once

#include <Eigen/Core>
#include <map>
#include <set>
#include <string>
#include <utility>
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

/// Another name of a parameter (an old name kept for the files and calls that use it): setting or
/// reading `name` sets or reads `parameter`; `--list-params` and `topo tasks --markdown` show the note.
struct ParamAlias {
  std::string name;
  std::string parameter;
  std::string note;  ///< why the name changed, e.g. "it always counted evaluations"
};

struct ParamValue {
  double number = 0.0;
  std::string text;
  Eigen::Vector3d vec = Eigen::Vector3d::Zero();
  std::vector<double> list;
  bool set = false;  ///< false: no value (optional parameters, unset targets)
};

struct Experiment;

/// Separator of an experiment's name and a key in a multi-experiment config ("rock_y.period_s").
constexpr char kExperimentKeySeparator = '.';

class TaskConfig {
 public:
  /// The defaults of a registered task (TaskConfig::taskNames(), inference/task_registry.h): the
  /// common parameters, then the task's own declarations. Throws TopoError for an unknown task
  /// name, listing the registered ones.
  static TaskConfig defaults(const std::string& task);
  /// The parameters every task has (representation, materials, regularisers, optimiser, gravity)
  /// with their common defaults; task() is empty. A task may change some of these defaults.
  static TaskConfig common();
  /// Reads a YAML file: `task: NAME` plus parameters (and an optional `targets:` map), or several
  /// experiments of one object: shared parameters (representation, materials, regularisers, optimiser)
  /// at the top and an `experiments:` list whose items are `{name, weight, task, ..., targets}` maps or
  /// `{name, weight, file: other.yaml}` (relative to this file).
  static TaskConfig fromYamlFile(const std::string& path);
  /// A task name ("tumbler") or a YAML path; names resolve to config/tasks/NAME.yaml under
  /// `task_dir` when that file exists, otherwise to the built-in defaults.
  static TaskConfig load(const std::string& name_or_path, const std::string& task_dir = "");
  /// `task` (a name or YAML path, may be empty), then every "[NAME=]FILE" of `experiments` as one more
  /// experiment of the same object (NAME defaults to the file's stem, or the task name): what
  /// `topo infer --task T --experiment F ...` and the InferInterior goal's `experiments` load.
  /// `assignments` ("KEY=VALUE", the user's --set or goal overrides): those of a shared parameter
  /// (isShared, no "NAME." prefix) are set in every loaded file before they are joined, so task files
  /// whose own values differ (tumbler.yaml's density_solid 5000, hanging.yaml's 1000) make one object
  /// when the user names the value; without it they are refused. The caller still applies them all.
  static TaskConfig loadWithExperiments(const std::string& task, const std::vector<std::string>& experiments,
                                        const std::string& task_dir = "",
                                        const std::vector<std::string>& assignments = {});
  /// "NAME=VALUE" → {NAME, VALUE}; a text without '=' (or whose '=' comes after a '/', a path) →
  /// {"", text}: how `--experiment [NAME=]FILE` and `--features [NAME=]FILE` are read.
  static std::pair<std::string, std::string> splitNamedValue(const std::string& text);
  /// The registered tasks, in registry order.
  static std::vector<std::string> taskNames();

  /// The task; for several experiments, the first experiment's task.
  const std::string& task() const { return task_; }
  const std::string& source() const { return source_; }

  /// Several experiments of one object (paper §7 ablation "multiple videos"): one interior, one joint
  /// loss Σ_e w_e L_e. A single-experiment config has none (experimentList() is then itself).
  bool hasExperiments() const { return !experiments_.empty(); }
  const std::vector<Experiment>& experiments() const { return experiments_; }
  /// The experiments to simulate: experiments(), or {task(), 1, *this} for a single-experiment config.
  std::vector<Experiment> experimentList() const;
  /// Adds an experiment. The first one also gives this config its task (and the task's defaults,
  /// keeping the shared parameters already set here). The shared parameters (TaskConfig::common():
  /// representation, materials, regularisers, optimiser, gravity) of one object are this config's: an
  /// experiment that set one of them to another value is refused (naming it and the key). Throws
  /// TopoError for an empty or duplicate name, a weight ≤ 0, or an experiment that has experiments.
  void addExperiment(const std::string& name, double weight, const TaskConfig& experiment);
  /// Removes experiment `name` (e.g. one whose observations are missing); the object's config then
  /// takes the new first experiment's task. Throws TopoError for an unknown name or the last one.
  void removeExperiment(const std::string& name);
  /// True for the parameters of TaskConfig::common() (one value per object).
  static bool isShared(const std::string& key);
  /// Keys given a value explicitly (a file, --set, --target), not by the defaults.
  const std::set<std::string>& explicitKeys() const { return explicit_; }

  /// Sets one parameter from text ("1200", "true", "0,0,0.1", "[0.1, 0.2]"). Throws TopoError for
  /// unknown keys (with the nearest known key) and invalid values (with the allowed range). An alias
  /// (aliases()) sets its parameter; one origin (a file, the --set list, a goal's overrides) giving
  /// both names different values is refused, naming both.
  /// With experiments: "NAME.KEY" sets KEY of experiment NAME; a shared KEY is set for all; another
  /// KEY is set in every experiment whose task has it, except a target, which must name its
  /// experiment when more than one has it.
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
  /// The spec of a parameter, or of the parameter an alias names; nullptr for an unknown key.
  const ParamSpec* spec(const std::string& key) const;
  /// Old names still accepted, in declaration order (TaskParameters::alias).
  const std::vector<ParamAlias>& aliases() const { return aliases_; }
  /// The parameter `key` names: itself, or the parameter of the alias `key`.
  const std::string& canonicalName(const std::string& key) const;
  /// "NAME: alias of PARAMETER (NOTE)" for the alias `name`, "" for any other key.
  std::string aliasText(const std::string& name) const;
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
  std::vector<ParamAlias> aliases_;
  /// Of a parameter with an alias: the origin, the name used and the value text of its last change
  /// (to refuse one origin giving both names different values).
  struct NamedChange {
    std::string origin, name, value;
  };
  std::map<std::string, NamedChange> alias_changes_;
  std::vector<Experiment> experiments_;
  std::set<std::string> explicit_;
  void declare(const ParamSpec& spec, const ParamValue& value);
  /// set() of this config's own value (no experiments involved).
  void setOwn(const std::string& key, const std::string& value, const std::string& origin);
  void check(const ParamSpec& spec, const ParamValue& value, const std::string& origin) const;
  friend class TaskParameters;
};

/// One experiment of an object: a task with its own parameters and targets, and the weight of its
/// loss in the joint loss.
struct Experiment {
  std::string name;
  double weight = 1.0;
  TaskConfig config;
};

}  // namespace topo_gaussian::inference
