// A rigid body's pose (inference::BodyPose: world = rotation · X + translation) as a tf transform
// parent → child, for the frames that follow a simulated or true motion (object_true of the rig
// twin, object_simulated of the inference's replay).
#pragma once

#include <geometry_msgs/TransformStamped.h>
#include <ros/time.h>

#include <string>

#include "topo_gaussian/inference/body_motion.h"

namespace topo_gaussian::topo_ros {

geometry_msgs::TransformStamped toTransformStamped(const inference::BodyPose& pose, const std::string& parent_frame,
                                                   const std::string& child_frame, const ::ros::Time& stamp);

}  // namespace topo_gaussian::topo_ros
