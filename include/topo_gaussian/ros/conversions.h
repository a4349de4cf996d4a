// Conversions between the library's types and ROS messages.
//  - VolumeCloud  -> sensor_msgs/PointCloud2 "volume layout": x y z volume (FLOAT32, m and m^3),
//    surface (UINT8, 1 within one spacing of the boundary) and spacing (FLOAT64 at offset 24, m: the
//    lattice spacing the volume was filled at, the same in every point, as a PointCloud2 has no slot
//    for one number; a field survives rosbag, PCL and rviz), a 32-byte point.
//  - PointCloud2  -> geometry::SurfaceData (kind Points) for filling: x y z required, FLOAT32 or
//    FLOAT64; normal_x/y/z used when all three are present. NaN points are kept here, cleaning drops them.
//  - PointCloud2 (volume layout) -> VolumeCloud, for interior_inference (`volume`, a goal's volume) and tests.
//  - ContactSamples <-> PointCloud2 "contact layout": x y z normal_x normal_y normal_z area (FLOAT32;
//    m, unit, m^2) and spacing (FLOAT64 at offset 32, m, the same in every point), published by cloud_ingest on `contact_samples` beside `volume` with the same stamp.
//  - an inferred interior <-> PointCloud2 "interior layout": x y z solid density stiffness confidence
//    rgb, all FLOAT32 (m, r in [0, 1], kg/m^3, Pa or 0 for rigid tasks, the agreement in [0, 1] of
//    the designs that fit as well with this particle's solid/hollow label (inference/design_spread.h;
//    1 when not explored or for a known interior), and rgb packed as PCL and rviz read it: solid red,
//    hollow blue, blended by r).
// Errors are TopoError with a message that names the topic (or other source) and the field.
#pragma once

#include <ros/time.h>
#include <sensor_msgs/PointCloud2.h>

#include <cstdint>
#include <string>
#include <vector>

#include "topo_gaussian/geometry/surface_data.h"
#include "topo_gaussian/physics/volume_cloud.h"

namespace topo_gaussian::topo_ros {

/// Volume cloud as an unorganised PointCloud2 (height 1) in `frame_id` at `stamp`.
sensor_msgs::PointCloud2 toPointCloud2(const VolumeCloud& cloud, const std::string& frame_id, const ::ros::Time& stamp);

/// Coordinates beyond this (in metres, either sign) are refused by toSurfaceData: no surface the lab
/// scans is 1000 km across, and values near FLT_MAX overflow the fill's arithmetic.
constexpr double kMaxCoordinateM = 1e6;

/// Surface points from any PointCloud2 with x y z fields of type FLOAT32 or FLOAT64 (metres).
/// `source` (the topic, or "service request") is named in every error and becomes
/// SurfaceData::source. Throws TopoError for a missing x/y/z field, an x/y/z field of another type
/// (an integer field is not metres: the error names the field, its type and the fix), a field that
/// lies outside the point, a data array shorter than width*height points, a big-endian cloud, or a
/// coordinate beyond ±kMaxCoordinateM (NaN points are kept: cleaning drops them).
geometry::SurfaceData toSurfaceData(const sensor_msgs::PointCloud2& msg, const std::string& source);

/// Reads a cloud in the volume layout (x y z volume required, x y z FLOAT32/FLOAT64; surface optional = 0;
/// spacing FLOAT64/FLOAT32). A cloud without the spacing field (recorded by an older version) gets the one
/// fallback, deriveMissingSpacing (physics/volume_cloud.h), and a warning: into `*warning` when given ("" when
/// the spacing was carried), else on std::cerr. Throws TopoError naming `source` for missing fields, malformed
/// data or a spacing field that is not one positive length (not for other bad values: call
/// VolumeCloud::validate for that).
VolumeCloud fromPointCloud2(const sensor_msgs::PointCloud2& msg, const std::string& source,
                            std::string* warning = nullptr);

/// Contact samples on the true surface as a PointCloud2 in the contact layout.
sensor_msgs::PointCloud2 toContactCloud(const ContactSamples& samples, const std::string& frame_id,
                                        const ::ros::Time& stamp);

/// Reads the contact layout (x y z normal_x normal_y normal_z area required; spacing as in fromPointCloud2,
/// without it the fallback deriveMissingSpacing and a warning likewise). Throws TopoError naming `source`
/// for missing fields or malformed data.
ContactSamples fromContactCloud(const sensor_msgs::PointCloud2& msg, const std::string& source,
                                std::string* warning = nullptr);

/// Colours of the interior layout (0xRRGGBB).
constexpr std::uint32_t kSolidRgb = 0xDC2828, kHollowRgb = 0x2864DC;
/// The colour of a particle with indicator r: kHollowRgb at 0, kSolidRgb at 1, linear between.
std::uint32_t interiorRgb(double r);

/// An interior (r, density per particle; stiffness per particle or empty = 0; confidence per
/// particle or empty = 1) as a PointCloud2 in the interior layout. Throws TopoError when the sizes
/// differ from the cloud's.
sensor_msgs::PointCloud2 toInteriorCloud(const VolumeCloud& cloud, const std::vector<double>& r,
                                         const std::vector<double>& density, const std::vector<double>& stiffness,
                                         const std::string& frame_id, const ::ros::Time& stamp,
                                         const std::vector<double>& confidence = {});

/// Positions and r (the `solid` field) of a cloud in the interior layout (x y z solid required, the
/// rest ignored). Throws TopoError naming `source` for missing fields, malformed data, or r outside
/// [0, 1] / NaN (with the point index).
struct InteriorPoints {
  std::vector<Eigen::Vector3d> X;
  std::vector<double> r;
};
InteriorPoints fromInteriorCloud(const sensor_msgs::PointCloud2& msg, const std::string& source);

/// True when the message has a field of this name.
bool hasField(const sensor_msgs::PointCloud2& msg, const std::string& name);

}  // namespace topo_gaussian::topo_ros
