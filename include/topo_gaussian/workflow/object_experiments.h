// The experiments made on one object, kept across inference goals (paper §7 "multiple videos", one
// experiment at a time): a lab hangs the object, infers, then rocks it, infers again from both, and so
// on, each goal naming the object. The object's record is the joint config of its experiments as they
// were run (targets set); a new goal's config is joined after them:
//   object E1..Ek + goal G  →  joint {E1, ..., Ek, G}   (G's shared parameters are the object's)
// An experiment of the goal with the name of an earlier one replaces it (the experiment repeated). A shared
// value (material, representation) that a goal's experiment brings from its task file (hanging.yaml's
// density 1000) yields to the object's; one the goal's overrides name must agree with it.
// The record changes only when a run finishes (remember), never for a goal that is refused or cancelled.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "topo_gaussian/inference/task_config.h"

namespace topo_gaussian::workflow {

class ObjectExperiments {
 public:
  /// The goal's config joined after the object's earlier experiments (the goal alone for an unknown
  /// or empty id). A single-experiment goal becomes the experiment named after its task, numbered
  /// when that name is taken ("tumbler", "tumbler_2", ...). Throws TopoError (naming the object and the
  /// experiment) when an experiment of the goal disagrees with the object's shared parameters.
  /// `overrides`: the goal's "KEY=VALUE" as the user gave them; of a goal with several experiments, only the
  /// shared values they name are the goal's own (the others, from its task files, yield to the object's).
  inference::TaskConfig withEarlier(const std::string& object_id, const inference::TaskConfig& goal,
                                    const std::vector<std::string>& overrides = {}) const;
  /// Keeps the experiments of `as_run` (the joint config withEarlier gave, with its targets) as the
  /// object's record. Nothing for an empty id.
  void remember(const std::string& object_id, const inference::TaskConfig& as_run);
  /// The object's experiments by name, in order (empty for an unknown id).
  std::vector<std::string> experimentNames(const std::string& object_id) const;
  /// Forgets the object (its next goal starts a new record).
  void forget(const std::string& object_id);

 private:
  std::map<std::string, inference::TaskConfig> objects_;
};

}  // namespace topo_gaussian::workflow
