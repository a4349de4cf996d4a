// Internal: RigidSimOptions from the task parameters shared by the dynamic rigid tasks.
#pragma once

#include "topo_gaussian/inference/task_config.h"
#include "topo_gaussian/physics/rigid_body.h"

namespace topo_gaussian::inference {

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

}  // namespace topo_gaussian::inference
