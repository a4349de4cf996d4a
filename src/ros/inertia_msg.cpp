// toInertiaStamped, toIdentifiedInertia (ros/inertia_msg.h).
#include "topo_gaussian/ros/inertia_msg.h"

#include <cmath>

namespace topo_gaussian::topo_ros {

geometry_msgs::InertiaStamped toInertiaStamped(const MassProperties& mass, const std::string& frame,
                                               const ::ros::Time& stamp) {
  geometry_msgs::InertiaStamped m;
  m.header.frame_id = frame;
  m.header.stamp = stamp;
  geometry_msgs::Inertia& in = m.inertia;
  in.m = mass.mass;
  in.com.x = mass.com.x();
  in.com.y = mass.com.y();
  in.com.z = mass.com.z();
  const Eigen::Matrix3d& I = mass.inertia;
  in.ixx = I(0, 0);
  in.ixy = I(0, 1);
  in.ixz = I(0, 2);
  in.iyy = I(1, 1);
  in.iyz = I(1, 2);
  in.izz = I(2, 2);
  return m;
}

topo_gaussian::IdentifiedInertia toIdentifiedInertia(const io::IdentifiedMass& id, const std::string& frame,
                                                     const ::ros::Time& stamp) {
  topo_gaussian::IdentifiedInertia m;
  const geometry_msgs::InertiaStamped plain = toInertiaStamped(id.mass, frame, stamp);
  m.header = plain.header;
  m.inertia = plain.inertia;
  m.summary = id.summary;
  m.analysed = id.has_std;
  static const char* names[10] = {"m", "cx", "cy", "cz", "Ixx", "Iyy", "Izz", "Ixy", "Ixz", "Iyz"};
  for (int k = 0; k < 10; ++k) {
    m.moment_names.push_back(names[k]);
    m.moment_std.push_back(id.has_std ? id.std[k] : NAN);
    m.determined.push_back(id.has_std && id.determined[k]);
  }
  return m;
}

topo_gaussian::IdentifiedInertia toIdentifiedInertia(const MassProperties& mass,
                                                     const inference::IdentifiabilityAnalysis& analysis,
                                                     const std::string& frame, const ::ros::Time& stamp) {
  io::IdentifiedMass id;
  id.mass = mass;
  id.has_std = analysis.available && analysis.moments.size() == 10;
  for (std::size_t k = 0; id.has_std && k < 10; ++k) {
    id.std[k] = analysis.moments[k].std;
    id.determined[k] = analysis.moments[k].determined;
  }
  id.summary = analysis.summary;
  return toIdentifiedInertia(id, frame, stamp);
}

}  // namespace topo_gaussian::topo_ros
