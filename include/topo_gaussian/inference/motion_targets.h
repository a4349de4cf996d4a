// Observed motion (motion::MotionFeatures, from the tracker or `topo track`) → the targets of an
// inference task. Each task declares its own rule beside its code (TaskDefinition::motion_targets,
// inference/task_registry.h); today:
//   tumbler                  period_s, max_tilt_deg: the tracker's values over its window; when the
//                            window starts at a release (the sampled signal's first sample is a turning
//                            point at least half its largest tilt), the task's own analysis
//                            (inference/oscillation.h, the first measured_cycles cycles) of the signal,
//                            so observed and simulated features are measured alike. A maximum tilt that
//                            does not exceed the release tilt (initial_tilt_deg) by 1 % becomes the
//                            release tilt: a doll released at rest always reaches it, never less.
//                            From a window that starts at the release also amplitude_deg (the mean half
//                            peak-to-peak swing): with the release tilt it fixes the rest tilt. The rest
//                            tilt itself (tracker equilibrium measured): equilibrium_from_release_deg, the
//                            analysis's equilibrium signed towards the release's side (a camera's mirror
//                            flips both), from a release window; otherwise equilibrium_tilt_deg, whose
//                            magnitude the task compares.
//   hanging, balance, stand  target_roll_deg ← equilibrium_deg                   (the camera looks along
//                            world x, so the image angle is the roll about x; equilibrium measured)
//   finger                   bend_angle_deg ← bending_angle_deg                  (bending measured)
//                            (the tracker's bend profile is not taken: see finger_task.cpp)
// Tasks without a rule (qiqi, ball, pear, cantilever) take their targets from files or goal targets.
// A feature is used only when the tracker measured it (confidence > 0 / oscillation found).
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "topo_gaussian/common/motion_features.h"
#include "topo_gaussian/inference/task_config.h"

namespace topo_gaussian::inference {

struct MotionTargets {
  std::vector<std::pair<std::string, double>> targets;  ///< task target name → value
  /// List targets (a finger's bend_profile_deg: one value per segment) → their values
  std::vector<std::pair<std::string, std::vector<double>>> list_targets;
  std::string note;  ///< why nothing (or not everything) was taken, empty when all was
};

/// The targets the task of `config` takes from `features` (its registered rule; see above).
MotionTargets targetsFromMotion(const TaskConfig& config, const motion::MotionFeatures& features);

/// "motion features (SOURCE, kind KIND)": how a rule names the features in its notes.
std::string motionFeaturesOrigin(const motion::MotionFeatures& features);

}  // namespace topo_gaussian::inference
