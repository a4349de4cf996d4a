// motion_tracker: video (~video_file, ~extract_motion) or `image` stream -> latched `motion_features`
// and ~debug_image. Thin main: the node class (topo_gaussian/ros/motion_tracker_node.h) and the
// vision library do the work.
#include <ros/ros.h>

#include <exception>

#include "topo_gaussian/ros/ascii_text.h"
#include "topo_gaussian/ros/motion_tracker_node.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "motion_tracker");
  ros::NodeHandle nh, pnh("~");
  try {
    topo_gaussian::topo_ros::MotionTrackerNode node(nh, pnh);
    ros::spin();
  } catch (const std::exception& e) {  // invalid parameters
    ROS_FATAL("motion_tracker: %s", topo_gaussian::topo_ros::asciiText(e.what()).c_str());
    return 1;
  }
  return 0;
}
