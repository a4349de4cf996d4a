// Identified mass properties (m, c, I about c, physics/mass_properties.h) as the messages a robot
// consumes: geometry_msgs/InertiaStamped (m, com, ixx … izz: the inertia tensor's elements, as URDF
// and gazebo take them) and this package's IdentifiedInertia, the same with the ten moments'
// standard deviations and verdicts from the identifiability analysis (inference/identifiability.h).
#pragma once

#include <geometry_msgs/InertiaStamped.h>
#include <ros/time.h>

#include <string>

#include "topo_gaussian/IdentifiedInertia.h"
#include "topo_gaussian/inference/identifiability.h"
#include "topo_gaussian/io/inertial_files.h"
#include "topo_gaussian/physics/mass_properties.h"

namespace topo_gaussian::topo_ros {

geometry_msgs::InertiaStamped toInertiaStamped(const MassProperties& mass, const std::string& frame,
                                               const ::ros::Time& stamp);

/// The mass properties with the stds when has_std (analysed true), else NaN stds and analysed false.
topo_gaussian::IdentifiedInertia toIdentifiedInertia(const io::IdentifiedMass& identified, const std::string& frame,
                                                     const ::ros::Time& stamp);
/// The same from a result's mass properties and its analysis (its moments when it is available).
topo_gaussian::IdentifiedInertia toIdentifiedInertia(const MassProperties& mass,
                                                     const inference::IdentifiabilityAnalysis& analysis,
                                                     const std::string& frame, const ::ros::Time& stamp);

}  // namespace topo_gaussian::topo_ros
