// The task registry (one explicit list of the task files' register functions) and TaskParameters,
// the declaration side of TaskConfig.
#include "topo_gaussian/inference/task_registry.h"

#include <set>

#include "task_factories.h"
#include "topo_gaussian/common/error.h"

namespace topo_gaussian::inference {

TaskParameters::Declared& TaskParameters::Declared::paper(const std::string& value) {
  owner_->setPaper(index_, value);
  return *this;
}

void TaskParameters::setPaper(std::size_t index, const std::string& value) { c_.specs_[index].paper_value = value; }

TaskParameters::Declared TaskParameters::add(ParamSpec spec, ParamValue value) {
  if (c_.spec(spec.name))
    throw TopoError("parameter " + spec.name + " of task '" + c_.task() + "'", "is declared twice",
                    "declare each parameter once (common ones in task_config.cpp, the rest in the task's file)");
  c_.declare(spec, value);
  return Declared(this, c_.specs_.size() - 1);
}

TaskParameters::Declared TaskParameters::number(const std::string& name, double def, const std::string& unit,
                                                const std::string& doc, double lo, double hi, bool lo_exclusive) {
  ParamSpec s{name, ParamType::Number, doc, lo, hi, lo_exclusive, {}, false, unit, ""};
  ParamValue v;
  v.number = def;
  v.set = true;
  return add(s, v);
}

TaskParameters::Declared TaskParameters::integer(const std::string& name, int def, const std::string& unit,
                                                 const std::string& doc, double lo, double hi) {
  ParamSpec s{name, ParamType::Integer, doc, lo, hi, false, {}, false, unit, ""};
  ParamValue v;
  v.number = def;
  v.set = true;
  return add(s, v);
}

TaskParameters::Declared TaskParameters::flag(const std::string& name, bool def, const std::string& doc) {
  ParamSpec s{name, ParamType::Boolean, doc, 0, 1, false, {}, false, "", ""};
  ParamValue v;
  v.number = def ? 1.0 : 0.0;
  v.set = true;
  return add(s, v);
}

TaskParameters::Declared TaskParameters::text(const std::string& name, const std::string& def, const std::string& doc,
                                              std::vector<std::string> choices) {
  ParamSpec s{name, ParamType::Text, doc, -1e300, 1e300, false, std::move(choices), false, "", ""};
  ParamValue v;
  v.text = def;
  v.set = !def.empty();
  return add(s, v);
}

TaskParameters::Declared TaskParameters::vector3(const std::string& name, const Eigen::Vector3d* def,
                                                 const std::string& unit, const std::string& doc, double lo,
                                                 double hi) {
  ParamSpec s{name, ParamType::Vector3, doc, lo, hi, false, {}, false, unit, ""};
  ParamValue v;
  if (def) {
    v.vec = *def;
    v.set = true;
  }
  return add(s, v);
}

TaskParameters::Declared TaskParameters::list(const std::string& name, std::vector<double> def, const std::string& unit,
                                              const std::string& doc, double lo, double hi) {
  ParamSpec s{name, ParamType::List, doc, lo, hi, false, {}, false, unit, ""};
  ParamValue v;
  v.list = std::move(def);
  v.set = !v.list.empty();
  return add(s, v);
}

TaskParameters::Declared TaskParameters::target(const std::string& name, ParamType type, const std::string& unit,
                                                const std::string& doc, double lo, double hi, bool lo_exclusive) {
  ParamSpec s{name, type, doc, lo, hi, lo_exclusive, {}, true, unit, ""};
  return add(s, ParamValue());
}

ParamValue& TaskParameters::declared(const std::string& name) {
  if (!c_.spec(name))
    throw TopoError("default of parameter " + name + " of task '" + c_.task() + "'",
                    "changes a parameter not declared before",
                    "declare the parameter first (common ones are declared before the task's own)");
  return c_.values_[name];
}

void TaskParameters::setDefault(const std::string& name, double value) { declared(name).number = value; }

void TaskParameters::setDefault(const std::string& name, const Eigen::Vector3d& value) {
  ParamValue& v = declared(name);
  v.vec = value;
  v.set = true;
}

void TaskParameters::shorthand(const std::string& key, std::vector<std::string> parameters) {
  for (const auto& p : parameters) declared(p);
  c_.shorthands_[key] = std::move(parameters);
}

void TaskParameters::alias(const std::string& old_name, const std::string& parameter, const std::string& note) {
  const std::string who = "alias " + old_name + " of task '" + c_.task() + "'";
  if (!c_.spec(parameter))
    throw TopoError(who, "names " + parameter + ", a parameter not declared before",
                    "declare the parameter first (common ones are declared before the task's own)");
  if (c_.canonicalName(parameter) != parameter)
    throw TopoError(who, "names the alias " + parameter, "name the parameter itself: " + c_.canonicalName(parameter));
  if (c_.spec(old_name) || c_.shorthands_.count(old_name))
    throw TopoError(who, "is already a parameter, alias or shorthand", "give the alias a name no parameter has");
  c_.aliases_.push_back({old_name, parameter, note});
}

namespace {

TaskList buildRegistry() {
  // One line per task file; a new task adds its file and one line here.
  TaskList tasks;
  registerStaticTasks(&tasks);  // hanging, balance, stand
  registerTumblerTask(&tasks);
  registerQiqiTask(&tasks);
  registerBallTask(&tasks);
  registerFingerTask(&tasks);
  registerPearTask(&tasks);
  registerCantileverTask(&tasks);
  std::set<std::string> names;
  for (const auto& t : tasks) {
    if (t.name.empty() || !names.insert(t.name).second)
      throw TopoError("task registry", "task name '" + t.name + "' is empty or registered twice",
                      "give each task file its own name");
    if (!t.make || !t.declare_parameters)
      throw TopoError("task registry: task '" + t.name + "'", "has no factory or no parameter declaration",
                      "set TaskDefinition::make and declare_parameters in the task's file");
  }
  return tasks;
}

}  // namespace

const TaskList& taskDefinitions() {
  static const TaskList tasks = buildRegistry();
  return tasks;
}

const TaskDefinition* findTaskDefinition(const std::string& name) {
  for (const auto& t : taskDefinitions())
    if (t.name == name) return &t;
  return nullptr;
}

std::string registeredTaskList() {
  std::string s;
  for (const auto& t : taskDefinitions()) s += (s.empty() ? "" : ", ") + t.name;
  return s;
}

const TaskDefinition& taskDefinition(const std::string& name) {
  if (const TaskDefinition* t = findTaskDefinition(name)) return *t;
  throw TopoError("task '" + name + "'", "unknown task",
                  "use one of: " + registeredTaskList() + " (or a YAML file with `task: NAME`)");
}

}  // namespace topo_gaussian::inference
