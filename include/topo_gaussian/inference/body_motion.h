// BodyPose: where a rigid object's body (cloud) frame is in the world at one time, the motion a
// rigid task reports (TaskEvaluation::motion), and its interpolation in time. The rig twin renders
// it; the inference node replays it as tf `object_simulated`.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

#include "topo_gaussian/physics/rigid_body.h"

namespace topo_gaussian::inference {

/// Pose of the object's body (cloud) frame in the world at one time: world = rotation · X + translation,
/// X a particle position as stored in the volume cloud. What the rig twin renders and the inference
/// node replays as tf `object_simulated`.
struct BodyPose {
  double t = 0.0;                                         ///< [s]
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();  ///< [m]
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
};

/// The body pose of a rigid state whose position is the centre of mass `com` (body frame).
template <typename State>
BodyPose bodyPoseOf(double t, const State& s, const Eigen::Vector3d& com) {
  BodyPose p;
  p.t = t;
  p.rotation = Eigen::Quaterniond(valueOf(s.orientation.w()), valueOf(s.orientation.x()), valueOf(s.orientation.y()),
                                  valueOf(s.orientation.z()))
                   .normalized();
  const Eigen::Vector3d pos(valueOf(s.position[0]), valueOf(s.position[1]), valueOf(s.position[2]));
  p.translation = pos - p.rotation * com;
  return p;
}

/// The pose at time t: linear in the translation, slerp in the rotation between the two samples
/// around t; clamped to the first/last sample outside the sampled range. `motion` must be sorted by
/// time; throws TopoError when it is empty.
BodyPose poseAt(const std::vector<BodyPose>& motion, double t);

}  // namespace topo_gaussian::inference
