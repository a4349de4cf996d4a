#include "topo_gaussian/ros/interior_markers.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/geometry/solid_mesh.h"
#include "topo_gaussian/inference/region_uncertainty.h"
#include "topo_gaussian/ros/conversions.h"

namespace topo_gaussian::topo_ros {
namespace {

using visualization_msgs::Marker;

/// The cavity's highlight: cyan, a colour nothing else in the view has (the principal axes are red,
/// green and blue, the solid red, the grid grey), so a screenshot can find it.
constexpr std::uint32_t kHollowHighlightRgb = 0x20DCE6;

geometry_msgs::Point point(const Eigen::Vector3d& p) {
  geometry_msgs::Point q;
  q.x = p.x();
  q.y = p.y();
  q.z = p.z();
  return q;
}

std_msgs::ColorRGBA colour(std::uint32_t rgb, double alpha) {
  std_msgs::ColorRGBA c;
  c.r = float((rgb >> 16) & 0xFF) / 255.0f;
  c.g = float((rgb >> 8) & 0xFF) / 255.0f;
  c.b = float(rgb & 0xFF) / 255.0f;
  c.a = float(alpha);
  return c;
}

Marker base(const std::string& frame, const ::ros::Time& stamp, int id, int type) {
  Marker m;
  m.header.frame_id = frame;
  m.header.stamp = stamp;
  m.ns = "interior";
  m.id = id;
  m.type = type;
  m.action = Marker::ADD;
  m.pose.orientation.w = 1.0;
  m.frame_locked = true;  // follow the frame as the replay moves it
  return m;
}

Marker arrow(const std::string& frame, const ::ros::Time& stamp, int id, const Eigen::Vector3d& from,
             const Eigen::Vector3d& to, double shaft, std::uint32_t rgb) {
  Marker m = base(frame, stamp, id, Marker::ARROW);
  m.points = {point(from), point(to)};
  m.scale.x = shaft;        // shaft diameter
  m.scale.y = 2.0 * shaft;  // head diameter
  m.scale.z = 3.0 * shaft;  // head length
  m.color = colour(rgb, 1.0);
  return m;
}

}  // namespace

std::string featuresText(const std::vector<inference::Feature>& features) {
  std::ostringstream os;
  os << std::setprecision(4);
  for (const auto& f : features) {
    os << f.name << " = " << f.value << (f.unit.empty() ? "" : " " + f.unit);
    if (f.has_target) os << " (target " << f.target << ")";
    os << "\n";
  }
  std::string s = os.str();
  if (!s.empty()) s.pop_back();
  return s;
}

std::string experimentsText(int experiments, const VolumeCloud& cloud, const std::vector<double>* confidence) {
  if (experiments <= 0) return "";
  std::ostringstream os;
  os << "from " << experiments << (experiments == 1 ? " experiment" : " experiments");
  if (confidence && confidence->size() == cloud.size())
    os << std::setprecision(3) << "; " << 100.0 * inference::uncertainVolumeFraction(cloud.V, *confidence)
       << " % of the volume uncertain";
  return os.str();
}

visualization_msgs::MarkerArray makeInteriorMarkers(const InteriorMarkerInput& in, const ::ros::Time& stamp) {
  if (!in.cloud || !in.r || in.r->size() != in.cloud->size())
    throw TopoError("interior markers", "need one indicator value per particle of the volume cloud",
                    "pass the volume cloud and the r of the same design");
  const VolumeCloud& cloud = *in.cloud;
  const std::vector<double>& r = *in.r;
  visualization_msgs::MarkerArray out;
  Marker clear;
  clear.header.frame_id = in.object_frame;
  clear.header.stamp = stamp;
  clear.ns = "interior";
  clear.action = Marker::DELETEALL;
  out.markers.push_back(clear);

  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
  for (const auto& x : cloud.X) {
    lo = lo.cwiseMin(x);
    hi = hi.cwiseMax(x);
  }
  const double size = cloud.X.empty() ? 0.1 : std::max((hi - lo).norm(), 1e-6);
  const double dot = 0.06 * size, shaft = 0.015 * size;
  const Eigen::Vector3d c = in.mass.com;

  Marker com = base(in.object_frame, stamp, 1, Marker::SPHERE);
  com.pose.position = point(c);
  com.scale.x = com.scale.y = com.scale.z = dot;
  com.color = colour(0xFFD200, 1.0);
  out.markers.push_back(com);

  if (in.geometry.has_point) {
    Marker p = base(in.object_frame, stamp, 2, Marker::SPHERE);
    p.pose.position = point(in.geometry.point);
    p.scale.x = p.scale.y = p.scale.z = dot;
    p.color = colour(0x20C020, 1.0);
    out.markers.push_back(p);
  }

  const Eigen::Vector3d g = in.geometry.gravity;
  if (g.norm() > 0) {
    const Eigen::Vector3d from = in.object_in_world * c;
    out.markers.push_back(arrow(in.world_frame, stamp, 3, from, from + 0.5 * size * g.normalized(), shaft, 0xB040E0));
  }

  Eigen::Vector3d moments;
  Eigen::Matrix3d axes;
  if (in.mass.mass > 0 && in.mass.inertia.allFinite()) {
    in.mass.principal(&moments, &axes);
    const std::uint32_t rgb[3] = {0xFF3030, 0x30D030, 0x3060FF};
    for (int k = 0; k < 3; ++k)
      out.markers.push_back(
          arrow(in.object_frame, stamp, 4 + k, c, c + 0.35 * size * axes.col(k), 0.6 * shaft, rgb[k]));
  }

  if (in.colour_by != "indicator" && in.colour_by != "confidence")
    throw TopoError("~colour_by " + in.colour_by, "is not a marker colouring", "use indicator or confidence");
  const bool by_confidence = in.colour_by == "confidence" && in.confidence && in.confidence->size() == cloud.size();
  const double h = cloud.spacing > 0 ? cloud.spacing : 0.01 * size;
  // the cut: the viewer's half (beyond the plane through the centre) is left out
  const Eigen::Vector3d centre = 0.5 * (lo + hi);
  const Eigen::Vector3d n = in.cut_normal.norm() > 0 ? in.cut_normal.normalized() : Eigen::Vector3d::UnitX();
  auto kept = [&](const Eigen::Vector3d& x) { return !in.cut_away || (x - centre).dot(n) <= 0.5 * h * (1 + 1e-6); };
  auto cubeColour = [&](std::size_t i, std::uint32_t rgb, double alpha) {
    std_msgs::ColorRGBA c = colour(rgb, alpha);
    if (!by_confidence) return c;
    const float w = float(std::clamp((*in.confidence)[i], 0.0, 1.0)), grey = 0.6f;
    c.r = w * c.r + (1 - w) * grey;
    c.g = w * c.g + (1 - w) * grey;
    c.b = w * c.b + (1 - w) * grey;
    return c;
  };
  Marker solid = base(in.object_frame, stamp, 7, Marker::CUBE_LIST);
  solid.scale.x = solid.scale.y = solid.scale.z = h;
  solid.color = colour(kSolidRgb, 0.35);
  Marker hollow = base(in.object_frame, stamp, 9, Marker::CUBE_LIST);
  hollow.scale.x = hollow.scale.y = hollow.scale.z = h;
  hollow.color = colour(kHollowHighlightRgb, 1.0);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (!kept(cloud.X[i])) continue;
    Marker& m = r[i] >= 0.5 ? solid : hollow;
    m.points.push_back(point(cloud.X[i]));
    if (by_confidence) m.colors.push_back(cubeColour(i, r[i] >= 0.5 ? kSolidRgb : kHollowHighlightRgb, m.color.a));
  }
  if (!solid.points.empty()) out.markers.push_back(solid);
  if (!hollow.points.empty()) out.markers.push_back(hollow);

  // the solid region's surface, cut like the particles (a cloud that is not a lattice has none)
  try {
    const geometry::SurfaceData mesh = geometry::solidRegionMesh(cloud, r);
    Marker surf = base(in.object_frame, stamp, 10, Marker::TRIANGLE_LIST);
    surf.scale.x = surf.scale.y = surf.scale.z = 1.0;
    surf.color = colour(kSolidRgb, 0.4);
    for (const auto& t : mesh.triangles) {
      const Eigen::Vector3d a = mesh.points[t[0]], b = mesh.points[t[1]], c = mesh.points[t[2]];
      if (!kept((a + b + c) / 3.0)) continue;
      surf.points.push_back(point(a));
      surf.points.push_back(point(b));
      surf.points.push_back(point(c));
    }
    if (!surf.points.empty()) out.markers.push_back(surf);
  } catch (const TopoError&) {
    // not a lattice or nothing solid: the cubes show the interior
  }

  Marker text = base(in.object_frame, stamp, 8, Marker::TEXT_VIEW_FACING);
  text.pose.position = point(Eigen::Vector3d(0.5 * (lo.x() + hi.x()), 0.5 * (lo.y() + hi.y()), hi.z() + 0.3 * size));
  text.scale.z = 0.035 * size;
  text.color = colour(0xFFFFFF, 1.0);
  const std::string head = experimentsText(in.experiments, cloud, in.confidence), body = featuresText(in.features);
  text.text = head.empty() ? body : body.empty() ? head : head + "\n" + body;
  if (!text.text.empty()) out.markers.push_back(text);
  return out;
}

}  // namespace topo_gaussian::topo_ros
