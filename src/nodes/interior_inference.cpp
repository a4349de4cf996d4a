// interior_inference: action `infer_interior`, services ~infer ~simulate ~export, latched `interior`
// and `interior_markers`, tf replay of the result. Thin main: the node class
// (topo_gaussian/ros/interior_inference_node.h) and topo_inference do the work.
#include <ros/ros.h>

#include <exception>

#include "topo_gaussian/ros/ascii_text.h"
#include "topo_gaussian/ros/interior_inference_node.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "interior_inference");
  ros::NodeHandle nh, pnh("~");
  try {
    topo_gaussian::topo_ros::InteriorInferenceNode node(nh, pnh);
    ros::AsyncSpinner spinner(3);  // services, topics and the tf replay stay live while a goal runs
    spinner.start();
    ros::waitForShutdown();
  } catch (const std::exception& e) {  // invalid parameters
    ROS_FATAL("interior_inference: %s", topo_gaussian::topo_ros::asciiText(e.what()).c_str());
    return 1;
  }
  return 0;
}
