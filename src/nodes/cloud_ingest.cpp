// cloud_ingest: surface (~surface_file, `surface_cloud`, ~fill_interior) -> latched `volume`.
// Thin main: the node class (topo_gaussian/ros/cloud_ingest_node.h) and the geometry library do the work.
#include <ros/ros.h>

#include <exception>

#include "topo_gaussian/ros/ascii_text.h"
#include "topo_gaussian/ros/cloud_ingest_node.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "cloud_ingest");
  // Handles outlive the node object: destroying the last one shuts ROS (and its logging) down,
  // which would swallow the ROS_FATAL below.
  ros::NodeHandle nh, pnh("~");
  try {
    topo_gaussian::topo_ros::CloudIngestNode node(nh, pnh);
    ros::spin();
  } catch (const std::exception& e) {  // invalid parameters
    ROS_FATAL("cloud_ingest: %s", topo_gaussian::topo_ros::asciiText(e.what()).c_str());
    return 1;
  }
  return 0;
}
