#include "topo_gaussian/ros/motion_targets.h"

namespace topo_gaussian::topo_ros {

MotionTargets targetsFromMotion(const std::string& task, const topo_gaussian::MotionFeatures& f) {
  MotionTargets out;
  const std::string from = "motion features (" + (f.source.empty() ? std::string("unknown source") : f.source) + ", kind " +
                           (f.kind.empty() ? std::string("?") : f.kind) + ")";
  if (task == "tumbler") {
    if (!f.oscillation_found || !(f.period_s > 0)) {
      out.note = from + " hold no oscillation" + (f.message.empty() ? "" : ": " + f.message);
      return out;
    }
    out.targets.emplace_back("period_s", f.period_s);
    if (f.max_tilt_deg > 0 && f.amplitude_confidence > 0) out.targets.emplace_back("max_tilt_deg", f.max_tilt_deg);
    else out.note = from + ": the tilt was not measured, only the period is used";
  } else if (task == "hanging" || task == "balance" || task == "stand") {
    if (f.equilibrium_confidence > 0) out.targets.emplace_back("target_roll_deg", f.equilibrium_deg);
    else out.note = from + " hold no measured equilibrium angle";
  } else if (task == "finger") {
    if (f.bending_confidence > 0) out.targets.emplace_back("bend_angle_deg", f.bending_angle_deg);
    else out.note = from + " hold no measured bending angle";
  } else {
    out.note = "task " + task + " does not take its targets from motion features: give them in the goal's targets";
  }
  return out;
}

}  // namespace topo_gaussian::topo_ros
