// Observed motion (MotionFeatures from motion_tracker) → the targets of an inference task:
//   tumbler                  period_s ← period_s, max_tilt_deg ← max_tilt_deg  (oscillation found)
//   hanging, balance, stand  target_roll_deg ← equilibrium_deg                   (the camera looks along
//                            world x, so the image angle is the roll about x; equilibrium measured)
//   finger                   bend_angle_deg ← bending_angle_deg                  (bending measured)
// Other tasks (qiqi, ball, pear, cantilever) take their targets from files or goal targets only.
// A feature is used only when the tracker measured it (confidence > 0 / oscillation found).
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "topo_gaussian/MotionFeatures.h"

namespace topo_gaussian::topo_ros {

struct MotionTargets {
  std::vector<std::pair<std::string, double>> targets;  ///< task target name → value
  std::string note;  ///< why nothing (or not everything) was taken, empty when all was
};

/// The targets `task` can take from `features` (see the table above).
MotionTargets targetsFromMotion(const std::string& task, const topo_gaussian::MotionFeatures& features);

}  // namespace topo_gaussian::topo_ros
