#include "topo_gaussian/ros/body_pose_msg.h"

namespace topo_gaussian::topo_ros {

geometry_msgs::TransformStamped toTransformStamped(const inference::BodyPose& pose, const std::string& parent_frame,
                                                   const std::string& child_frame, const ::ros::Time& stamp) {
  geometry_msgs::TransformStamped tf;
  tf.header.stamp = stamp;
  tf.header.frame_id = parent_frame;
  tf.child_frame_id = child_frame;
  tf.transform.translation.x = pose.translation.x();
  tf.transform.translation.y = pose.translation.y();
  tf.transform.translation.z = pose.translation.z();
  tf.transform.rotation.x = pose.rotation.x();
  tf.transform.rotation.y = pose.rotation.y();
  tf.transform.rotation.z = pose.rotation.z();
  tf.transform.rotation.w = pose.rotation.w();
  return tf;
}

}  // namespace topo_gaussian::topo_ros
