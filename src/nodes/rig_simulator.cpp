// rig_simulator: a digital twin of a lab rig (an object with a known interior, simulated and rendered)
// publishing `image` + `camera_info` like a camera driver, tf world -> object_true, latched
// `surface_cloud` and ~ground_truth. Thin main: the node class (topo_gaussian/ros/rig_simulator_node.h)
// and the library (workflow::RigTwin, vision::renderSplats) do the work.
#include <ros/ros.h>

#include <exception>

#include "topo_gaussian/ros/ascii_text.h"
#include "topo_gaussian/ros/rig_simulator_node.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "rig_simulator");
  ros::NodeHandle nh, pnh("~");
  try {
    topo_gaussian::topo_ros::RigSimulatorNode node(nh, pnh);
    ros::spin();
  } catch (const std::exception& e) {  // invalid parameters or a failed twin simulation
    ROS_FATAL("rig_simulator: %s", topo_gaussian::topo_ros::asciiText(e.what()).c_str());
    return 1;
  }
  return 0;
}
