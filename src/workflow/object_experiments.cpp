#include "topo_gaussian/workflow/object_experiments.h"

#include <algorithm>
#include <set>

#include "topo_gaussian/common/error.h"

namespace topo_gaussian::workflow {

namespace {

bool hasName(const inference::TaskConfig& c, const std::string& name) {
  for (const auto& e : c.experiments())
    if (e.name == name) return true;
  return false;
}

/// `name`, or name_2, name_3, ... when an experiment of `c` already has it.
std::string freeName(const inference::TaskConfig& c, const std::string& name) {
  if (!hasName(c, name)) return name;
  for (int k = 2;; ++k) {
    const std::string n = name + "_" + std::to_string(k);
    if (!hasName(c, n)) return n;
  }
}

/// The common parameters with the values `c` set explicitly for its object (materials, representation).
inference::TaskConfig sharedOf(const inference::TaskConfig& c) {
  inference::TaskConfig out = inference::TaskConfig::common();
  for (const std::string& key : c.explicitKeys())
    if (inference::TaskConfig::isShared(key)) out.set(key, c.valueText(key), c.source());
  // a joint record's shared values are its experiments' (set by the first goal's overrides), explicit or not
  if (c.hasExperiments())
    for (const auto& spec : out.specs())
      if (c.has(spec.name) && c.valueText(spec.name) != out.valueText(spec.name))
        out.set(spec.name, c.valueText(spec.name), c.source());
  return out;
}

}  // namespace

inference::TaskConfig ObjectExperiments::withEarlier(const std::string& object_id, const inference::TaskConfig& goal,
                                                     const std::vector<std::string>& overrides) const {
  const auto it = objects_.find(object_id);
  if (object_id.empty() || it == objects_.end()) return goal;
  const inference::TaskConfig& earlier = it->second;
  // The goal's experiments (a single task: one, named after it), after the earlier ones they do not repeat.
  std::vector<inference::Experiment> added;
  if (goal.hasExperiments())
    added = goal.experiments();
  else
    added.push_back(inference::Experiment{freeName(earlier, goal.task()), 1.0, goal});
  inference::TaskConfig out = sharedOf(earlier);
  std::set<std::string> named;  // the shared keys the goal's overrides name
  for (const std::string& o : overrides) named.insert(o.substr(0, o.find('=')));
  // the goal's own shared values (a change is refused below): of a goal with several experiments, those
  // its overrides name (a task file's are the file's, not the user's)
  const auto own = [&](const std::string& key) { return !goal.hasExperiments() || named.count(key) > 0; };
  try {
    for (const std::string& key : goal.explicitKeys())
      if (inference::TaskConfig::isShared(key) && own(key)) out.set(key, goal.valueText(key), "the goal");
    for (const auto& e : earlier.experiments())
      if (std::none_of(added.begin(), added.end(), [&](const inference::Experiment& a) { return a.name == e.name; }))
        out.addExperiment(e.name, e.weight, e.config);
    for (const auto& a : added) {
      // An experiment of a goal with several: a shared value its task file brings (hanging.yaml's density
      // 1000) yields to the object's; one the goal names itself (its overrides) must agree (refused below).
      inference::TaskConfig config = a.config;
      if (goal.hasExperiments())
        for (const auto& spec : inference::TaskConfig::common().specs())
          if (!named.count(spec.name) && out.has(spec.name) && config.has(spec.name) &&
              config.valueText(spec.name) != out.valueText(spec.name))
            config.set(spec.name, out.valueText(spec.name), "the object '" + object_id + "'");
      out.addExperiment(a.name, a.weight, config);
    }
  } catch (const TopoError& e) {
    throw TopoError("object '" + object_id + "'", std::string("cannot take this goal's experiments: ") + e.what(),
                    "give the goal the object's shared parameters (materials, representation), or another object_id");
  }
  return out;
}

void ObjectExperiments::remember(const std::string& object_id, const inference::TaskConfig& as_run) {
  if (object_id.empty()) return;
  if (as_run.hasExperiments()) {
    objects_[object_id] = as_run;
    return;
  }
  inference::TaskConfig record = sharedOf(as_run);
  record.addExperiment(as_run.task(), 1.0, as_run);
  objects_[object_id] = record;
}

std::vector<std::string> ObjectExperiments::experimentNames(const std::string& object_id) const {
  std::vector<std::string> names;
  const auto it = objects_.find(object_id);
  if (it != objects_.end())
    for (const auto& e : it->second.experiments()) names.push_back(e.name);
  return names;
}

void ObjectExperiments::forget(const std::string& object_id) { objects_.erase(object_id); }

}  // namespace topo_gaussian::workflow
