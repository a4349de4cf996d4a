// Conversions between the library's types and ROS messages.
//  - VolumeCloud  -> sensor_msgs/PointCloud2 "volume layout": x y z volume (FLOAT32, m and m^3) and
//    surface (UINT8, 1 within one spacing of the boundary), padded to a 20-byte point.
//  - PointCloud2  -> geometry::SurfaceData (kind Points) for filling: x y z required, of any numeric
//    type; normal_x/y/z used when all three are present. NaN points are kept here, cleaning drops them.
//  - PointCloud2 (volume layout) -> VolumeCloud, for tests and later nodes.
// Errors are TopoError with a message that names the topic (or other source) and the field.
#pragma once

#include <ros/time.h>
#include <sensor_msgs/PointCloud2.h>

#include <string>

#include "topo_gaussian/geometry/surface_data.h"
#include "topo_gaussian/physics/volume_cloud.h"

namespace topo_gaussian::topo_ros {

/// Volume cloud as an unorganised PointCloud2 (height 1) in `frame_id` at `stamp`.
sensor_msgs::PointCloud2 toPointCloud2(const VolumeCloud& cloud, const std::string& frame_id,
                                       const ::ros::Time& stamp);

/// Surface points from any PointCloud2 with x y z fields (FLOAT32/FLOAT64 or integer types).
/// `source` (the topic, or "service request") is named in every error and becomes
/// SurfaceData::source. Throws TopoError for a missing x/y/z field, a field that lies outside the
/// point, a data array shorter than width*height points, or a big-endian cloud.
geometry::SurfaceData toSurfaceData(const sensor_msgs::PointCloud2& msg, const std::string& source);

/// Reads a cloud in the volume layout (x y z volume required, surface optional = 0). The spacing is
/// not carried by the message: it is recovered as the cube root of the median particle volume.
/// Throws TopoError naming `source` for missing fields or malformed data (not for bad values:
/// call VolumeCloud::validate for that).
VolumeCloud fromPointCloud2(const sensor_msgs::PointCloud2& msg, const std::string& source);

/// True when the message has a field of this name.
bool hasField(const sensor_msgs::PointCloud2& msg, const std::string& name);

}  // namespace topo_gaussian::topo_ros
