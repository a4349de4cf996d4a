// Internal: the task parameters shared by the dynamic rigid tasks (tumbler, ball): their
// declaration and the RigidSimOptions read from them.
#pragma once

#include "topo_gaussian/inference/task_config.h"
#include "topo_gaussian/inference/task_registry.h"
#include "topo_gaussian/physics/rigid_body.h"

namespace topo_gaussian::inference {

/// Declares what rigidOptionsFromConfig reads; the defaults that differ per task are arguments.
inline void declareRigidMotionParameters(TaskParameters& p, double duration_s, double contact_damping_ratio) {
  p.number("duration_s", duration_s, "s", "simulated time [s]", 0, 1e300, true);
  p.number("dt_s", 5e-3, "s", "sampling step of the simulated motion [s] (paper: 5e-3)", 0, 1e300, true).paper("5e-3");
  p.number("max_substep_s", 0.0, "s", "integration step limit [s]; 0 = automatic from the contact stiffness", 0);
  p.number("contact_stiffness_n_per_m", 0.0, "N/m", "penalty stiffness per contact particle [N/m]; 0 = automatic", 0);
  p.number("contact_offset_m", 0.0, "m", "penalty offset delta [m]", 0);
  p.number("contact_damping_ratio", contact_damping_ratio, "unitless",
           "normal contact damping, fraction of critical, unitless", 0, 10);
  p.number("friction_mu", 1.0, "unitless", "Coulomb friction coefficient, unitless", 0);
  p.number("linear_damping_per_s", 0.0, "1/s", "linear velocity damping [1/s]", 0);
  p.number("angular_damping_per_s", 0.0, "1/s", "angular velocity damping [1/s]", 0);
}

inline RigidSimOptions rigidOptionsFromConfig(const TaskConfig& c, const Eigen::Vector3d& gravity) {
  RigidSimOptions o;
  o.duration_s = c.number("duration_s");
  o.output_dt_s = c.number("dt_s");
  o.max_substep_s = c.number("max_substep_s");
  o.gravity = gravity;
  o.linear_damping_per_s = c.number("linear_damping_per_s");
  o.angular_damping_per_s = c.number("angular_damping_per_s");
  o.ground.stiffness_n_per_m = c.number("contact_stiffness_n_per_m");
  o.ground.offset_m = c.number("contact_offset_m");
  o.ground.damping_ratio = c.number("contact_damping_ratio");
  o.ground.friction_mu = c.number("friction_mu");
  return o;
}

/// A copy of o whose time loop polls stop (Task::shouldStop()).
inline RigidSimOptions withStop(RigidSimOptions o, const StopCheck& stop) {
  o.should_stop = stop;
  return o;
}

}  // namespace topo_gaussian::inference
