// topo_gaussian/MotionFeatures (the ROS message) <-> motion::MotionFeatures (the library type,
// common/motion_features.h): field by field, nothing computed. The message is only a transport of
// the library type.
#pragma once

#include "topo_gaussian/MotionFeatures.h"
#include "topo_gaussian/common/motion_features.h"

namespace topo_gaussian::topo_ros {

topo_gaussian::MotionFeatures toMotionFeaturesMsg(const motion::MotionFeatures& features);
motion::MotionFeatures fromMotionFeaturesMsg(const topo_gaussian::MotionFeatures& msg);

}  // namespace topo_gaussian::topo_ros
