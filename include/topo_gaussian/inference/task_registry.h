// Task registry: every inference task is declared in its own file (src/inference/*_task.cpp) by a
// TaskDefinition: its name, a one-line summary, its parameters (name, type, unit, range, default,
// documentation, the paper's value), its factory, the default shape it brings, the rule that turns
// observed motion features into its targets, and what the rig twin needs to replay its motion.
// Each task file has one register function; taskDefinitions() calls them from one explicit list
// (task_registry.cpp), so there is no static-initialisation order to get wrong and nothing for the
// linker to drop. Nothing outside a task's file branches on its name: TaskConfig::defaults, makeTask,
// defaultShapeForTask, targetsFromMotion, RigTwin, the identifiability analysis and the rig simulator
// ask the registry.
#pragma once

#include <Eigen/Core>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "topo_gaussian/common/motion_features.h"
#include "topo_gaussian/inference/motion_targets.h"
#include "topo_gaussian/inference/task.h"
#include "topo_gaussian/inference/task_config.h"
#include "topo_gaussian/physics/volume_cloud.h"

namespace topo_gaussian::inference {

/// Declares parameters into a TaskConfig: the common ones (task_config.cpp) and each task's own.
/// Units: an SI unit ("m", "kg/m^3", "deg") or "unitless"; the documentation says it too ("[m]" or
/// "unitless"). Text and Boolean parameters have no unit.
class TaskParameters {
 public:
  explicit TaskParameters(TaskConfig& config) : c_(config) {}

  /// A parameter just declared; adds what the paper gives for it: `.paper("5e-3")`.
  class Declared {
   public:
    Declared& paper(const std::string& value);

   private:
    friend class TaskParameters;
    Declared(TaskParameters* owner, std::size_t index) : owner_(owner), index_(index) {}
    TaskParameters* owner_;
    std::size_t index_;
  };

  Declared number(const std::string& name, double def, const std::string& unit, const std::string& doc,
                  double lo = -1e300, double hi = 1e300, bool lo_exclusive = false);
  Declared integer(const std::string& name, int def, const std::string& unit, const std::string& doc, double lo,
                   double hi);
  Declared flag(const std::string& name, bool def, const std::string& doc);
  /// def "" = no value.
  Declared text(const std::string& name, const std::string& def, const std::string& doc,
                std::vector<std::string> choices = {});
  /// def nullptr = no value (an optional point); each component within [lo, hi].
  Declared vector3(const std::string& name, const Eigen::Vector3d* def, const std::string& unit,
                   const std::string& doc, double lo = -1e300, double hi = 1e300);
  /// Empty def = no value.
  Declared list(const std::string& name, std::vector<double> def, const std::string& unit, const std::string& doc,
                double lo = -1e300, double hi = 1e300);
  /// An observed feature (set with --target), without a default.
  Declared target(const std::string& name, ParamType type, const std::string& unit, const std::string& doc,
                  double lo = -1e300, double hi = 1e300, bool lo_exclusive = false);

  /// Changes the default of a parameter declared before (a common one, e.g. loss_tolerance).
  void setDefault(const std::string& name, double value);
  void setDefault(const std::string& name, const Eigen::Vector3d& value);
  /// A shorthand key: setting it sets each listed parameter to the same value (the key itself may be
  /// one of them, then it is set last).
  void shorthand(const std::string& key, std::vector<std::string> parameters);
  /// Another name of a declared parameter (an old name kept working): setting or reading `old_name` sets or
  /// reads `parameter`; `note` says why it changed (`--list-params` shows "OLD: alias of NEW (NOTE)").
  void alias(const std::string& old_name, const std::string& parameter, const std::string& note);

 private:
  Declared add(ParamSpec spec, ParamValue value);
  ParamValue& declared(const std::string& name);
  void setPaper(std::size_t index, const std::string& value);
  TaskConfig& c_;
};

/// Observed motion features → a task's targets (see inference/motion_targets.h).
using MotionTargetRule = std::function<MotionTargets(const TaskConfig&, const motion::MotionFeatures&)>;
using TaskFactory = std::function<std::unique_ptr<Task>(const TaskConfig&, const VolumeCloud&)>;

/// What the rig twin (workflow/rig_twin.h) needs to replay a task's motion.
struct RigTwinMotion {
  std::string duration_parameter;  ///< how long the motion is simulated [s] ("duration_s")
  std::string period_feature;      ///< the feature holding its period [s] ("period_s")
  /// Used when duration_parameter is ≤ 0 (a motion that is off by default) [s]; 0: none.
  double fallback_duration_s = 0.0;
  /// The default true interior: a spherical cavity |u − centre| < radius in the normalised
  /// coordinates of the quadric representation.
  Eigen::Vector3d cavity_centre = Eigen::Vector3d::Zero();
  double cavity_radius = 0.0;
  /// Default shapes whose twin runs this task when none is named; "*": every shape no task names.
  std::vector<std::string> default_for_shapes;
  /// A hanging object (the task has target_roll_deg / target_pitch_deg and a point in geometry()): the
  /// twin releases it about the pose its true interior rests in (hangingRestPose), as a rig leaves it
  /// to settle before the swing, and holds it with its lowest point 5 mm above the table (z = 0) that
  /// the rig's camera watches.
  bool hangs = false;
};

struct TaskDefinition {
  std::string name;
  std::string summary;  ///< one line
  /// The task's own parameters (declared after the common ones; may change their defaults).
  std::function<void(TaskParameters&)> declare_parameters;
  TaskFactory make;
  /// The default shape (physics/default_shapes.h) used when no volume is given; "" = needs a volume.
  std::string default_shape;
  /// Observed motion → targets; empty: the targets come from files or goal targets only.
  MotionTargetRule motion_targets;
  /// Set when the rig twin can replay the task's motion.
  std::optional<RigTwinMotion> twin;
  /// Set when the task's experiment rocks the object on a rounded base about a horizontal body axis:
  /// the name of its Vector3 parameter holding that axis. The identifiability analysis then proposes
  /// rocking the object about other axes with this task (inference/identifiability.h).
  std::string rocking_axis_parameter;
  /// Set when the pressure-actuated soft twin (workflow/finger_twin.h) replays the task on its default
  /// shape: the rig simulator runs that twin for the shape with this task, or with none named.
  bool pressure_twin = false;
};

using TaskList = std::vector<TaskDefinition>;

/// Every registered task, in registry order (hanging, balance, stand, tumbler, ...).
const TaskList& taskDefinitions();
/// nullptr for an unknown name.
const TaskDefinition* findTaskDefinition(const std::string& name);
/// Throws TopoError for an unknown name, listing the registered ones.
const TaskDefinition& taskDefinition(const std::string& name);
/// "hanging, balance, ..." (for messages).
std::string registeredTaskList();

}  // namespace topo_gaussian::inference
