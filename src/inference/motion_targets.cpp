// targetsFromMotion: dispatches to the task's registered rule (each rule lives in its task's file).
#include "topo_gaussian/inference/motion_targets.h"

#include "topo_gaussian/inference/task_registry.h"

namespace topo_gaussian::inference {

std::string motionFeaturesOrigin(const motion::MotionFeatures& f) {
  return "motion features (" + (f.source.empty() ? std::string("unknown source") : f.source) + ", kind " +
         (f.kind.empty() ? std::string("?") : f.kind) + ")";
}

MotionTargets targetsFromMotion(const TaskConfig& config, const motion::MotionFeatures& features) {
  const TaskDefinition& task = taskDefinition(config.task());
  if (task.motion_targets) return task.motion_targets(config, features);
  MotionTargets out;
  out.note =
      "task " + config.task() + " does not take its targets from motion features: give them in the goal's targets";
  return out;
}

}  // namespace topo_gaussian::inference
