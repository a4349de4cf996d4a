// The rviz markers of an inferred interior (interior_inference publishes them latched on
// `interior_markers`): one MarkerArray that first deletes every earlier marker of its namespace, then
//   com            sphere at the centre of mass                      (object frame)
//   point          sphere at the hanging / support / pivot point     (object frame, when the task has one)
//   gravity        arrow from the centre of mass along gravity       (world frame, at the replay's first pose)
//   principal_axes three arrows along the principal axes of inertia, length ∝ the object size
//   solid          cube list of the solid particles (r ≥ 0.5), one spacing wide, in the solid colour,
//                  translucent
//   hollow         cube list of the hollow particles (r < 0.5), highlighted in cyan, opaque: the cavity
//   solid_surface  triangle list of the solid region's surface (the export's marching-tetrahedra mesh,
//                  geometry::solidRegionMesh), translucent solid colour; left out for a cloud that is
//                  not a lattice
//   features       text above the object: the achieved features and their targets
// Cut-away (cut_away, default on): particles and triangles on the viewer's side of the plane through
// the cloud's centre with normal cut_normal (x·n > c·n + h/2) are left out, so the section through
// the object shows its hollow and its solid. colour_by "confidence" (with per-particle confidence,
// inference/design_spread.h) fades each cube towards grey by (1 − confidence).
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
  bool cut_away = true;
  /// object frame; default: towards the camera of rviz/topo_gaussian.rviz (Orbit yaw 0.3 rad)
  Eigen::Vector3d cut_normal = Eigen::Vector3d(0.955, 0.296, 0.0);
  std::string colour_by = "indicator";              ///< indicator | confidence
  const std::vector<double>* confidence = nullptr;  ///< per particle, 0..1 (colour_by confidence)
  /// Experiments the design was inferred from (0: not said); the text's first line counts them and,
  /// with `confidence`, gives the share of the volume whose label is uncertain (confidence < 0.95).
  int experiments = 0;
};

/// First line of the features marker: "from N experiments; X % of the volume uncertain" (empty when
/// experiments is 0).
std::string experimentsText(int experiments, const VolumeCloud& cloud, const std::vector<double>* confidence);

/// Text of the features marker: one line per feature, "name = value unit (target T)".
std::string featuresText(const std::vector<inference::Feature>& features);

/// The MarkerArray described above (namespace "interior"). Throws TopoError when r and the cloud differ in size.
visualization_msgs::MarkerArray makeInteriorMarkers(const InteriorMarkerInput& in, const ::ros::Time& stamp);

}  // namespace topo_gaussian::topo_ros
