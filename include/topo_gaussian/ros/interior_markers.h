// The rviz markers of an inferred interior (interior_inference publishes them latched on
// `interior_markers`): one MarkerArray that first deletes every earlier marker of its namespace, then
//   com            sphere at the centre of mass                      (object frame)
//   point          sphere at the hanging / support / pivot point     (object frame, when the task has one)
//   gravity        arrow from the centre of mass along gravity       (world frame, at the replay's first pose)
//   principal_axes three arrows along the principal axes of inertia, length ∝ the object size
//   solid          cube list of the solid particles (r ≥ 0.5), one spacing wide, in the solid colour
//   features       text above the object: the achieved features and their targets
// Markers in the object frame are frame_locked, so rviz moves them with the tf replay.
#pragma once

#include <visualization_msgs/MarkerArray.h>

#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "topo_gaussian/inference/task.h"
#include "topo_gaussian/physics/volume_cloud.h"

namespace topo_gaussian::topo_ros {

struct InteriorMarkerInput {
  const VolumeCloud* cloud = nullptr;        ///< particles (object frame)
  const std::vector<double>* r = nullptr;    ///< indicator per particle
  MassProperties mass;                       ///< of the design
  inference::TaskGeometry geometry;          ///< point and gravity of the task
  std::vector<inference::Feature> features;  ///< achieved (and target) values
  /// Where the object frame sits in the world for the gravity arrow (the replay's first pose).
  Eigen::Isometry3d object_in_world = Eigen::Isometry3d::Identity();
  std::string object_frame = "object_simulated", world_frame = "world";
};

/// Text of the features marker: one line per feature, "name = value unit (target T)".
std::string featuresText(const std::vector<inference::Feature>& features);

/// The MarkerArray described above (namespace "interior"). Throws TopoError when r and the cloud differ in size.
visualization_msgs::MarkerArray makeInteriorMarkers(const InteriorMarkerInput& in, const ::ros::Time& stamp);

}  // namespace topo_gaussian::topo_ros
