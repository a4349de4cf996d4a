// libFuzzer entry point for the ROS message -> cloud conversions (src/ros/conversions.cpp):
// toSurfaceData, fromPointCloud2 and fromInteriorCloud on a sensor_msgs/PointCloud2 whose layout and
// bytes come from the input, as a publisher on `surface_cloud` or a service request could send them.
//
// Input layout (little-endian; missing bytes read as 0):
//   u32 width, u32 height, u32 point_step, u32 row_step, u8 flags (bit 0 is_bigendian, bit 1 is_dense),
//   u8 field count (modulo 9), then per field: u8 name (an index into kNames), u32 offset,
//   u8 datatype, u32 count; the rest is msg.data.
// A TopoError is the expected answer to a bad cloud; any other exception escaping, a sanitizer report,
// or a result that breaks the conversions' promises (one point per width*height, the volume round
// trip with its spacing) is a bug. Header-only ROS: the message types, and librostime for ros::Time.
#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/PointField.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/ros/conversions.h"

namespace {

using namespace topo_gaussian;

const char* const kNames[] = {"x",       "y",     "z",   "normal_x", "normal_y",  "normal_z",  "volume",
                              "surface", "solid", "rgb", "density",  "stiffness", "intensity", "",
                              "spacing"};  // appended: the corpus's earlier indices keep their names

class Bytes {
 public:
  Bytes(const std::uint8_t* data, std::size_t size) : p_(data), n_(size) {}
  template <typename T>
  T take() {
    T v{};
    const std::size_t k = std::min(sizeof(T), n_ - i_);
    std::memcpy(&v, p_ + i_, k);
    i_ += k;
    return v;
  }
  std::vector<std::uint8_t> rest() { return std::vector<std::uint8_t>(p_ + i_, p_ + n_); }

 private:
  const std::uint8_t* p_;
  std::size_t n_, i_ = 0;
};

sensor_msgs::PointCloud2 cloudFrom(const std::uint8_t* data, std::size_t size) {
  Bytes in(data, size);
  sensor_msgs::PointCloud2 msg;
  msg.width = in.take<std::uint32_t>();
  msg.height = in.take<std::uint32_t>();
  msg.point_step = in.take<std::uint32_t>();
  msg.row_step = in.take<std::uint32_t>();
  const auto flags = in.take<std::uint8_t>();
  msg.is_bigendian = flags & 1;
  msg.is_dense = (flags & 2) != 0;
  const int fields = in.take<std::uint8_t>() % 9;
  for (int k = 0; k < fields; ++k) {
    sensor_msgs::PointField f;
    f.name = kNames[in.take<std::uint8_t>() % (sizeof(kNames) / sizeof(kNames[0]))];
    f.offset = in.take<std::uint32_t>();
    f.datatype = in.take<std::uint8_t>();
    f.count = in.take<std::uint32_t>();
    msg.fields.push_back(f);
  }
  msg.data = in.rest();
  return msg;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const sensor_msgs::PointCloud2 msg = cloudFrom(data, size);
  const std::size_t points = std::size_t(msg.width) * msg.height;
  try {
    const geometry::SurfaceData s = topo_ros::toSurfaceData(msg, "/fuzz");
    if (s.points.size() != points) std::abort();
    if (!s.normals.empty() && s.normals.size() != points) std::abort();
    for (const auto& p : s.points)
      for (int k = 0; k < 3; ++k)
        if (std::abs(p[k]) > topo_ros::kMaxCoordinateM) std::abort();  // refused, never passed on
  } catch (const TopoError&) {
  }
  try {
    std::string warning;  // a cloud without the spacing field: derived, with a warning (not printed here)
    const VolumeCloud c = topo_ros::fromPointCloud2(msg, "/fuzz", &warning);
    if (c.X.size() != points || c.V.size() != points || c.surface.size() != points) std::abort();
    if (!std::isfinite(c.spacing) || c.spacing < 0) std::abort();
    // Round trip: what we publish reads back as the same particles with the same spacing, no warning.
    const sensor_msgs::PointCloud2 again = topo_ros::toPointCloud2(c, "object", ros::Time());
    const VolumeCloud back = topo_ros::fromPointCloud2(again, "/fuzz again", &warning);
    if (back.size() != points || (points > 0 && (back.spacing != c.spacing || !warning.empty()))) std::abort();
  } catch (const TopoError&) {
  }
  try {
    const topo_ros::InteriorPoints p = topo_ros::fromInteriorCloud(msg, "/fuzz");
    if (p.X.size() != points || p.r.size() != points) std::abort();
    for (double r : p.r)
      if (!(r >= 0.0 && r <= 1.0)) std::abort();
    // Round trip through the interior layout we publish.
    VolumeCloud c;
    c.X = p.X;
    c.V.assign(p.X.size(), 1e-6);
    const sensor_msgs::PointCloud2 out = topo_ros::toInteriorCloud(c, p.r, p.r, {}, "object", ros::Time());
    if (topo_ros::fromInteriorCloud(out, "/fuzz again").r.size() != points) std::abort();
  } catch (const TopoError&) {
  }
  return 0;
}
