#include "topo_gaussian/ros/conversions.h"

#include <sensor_msgs/PointField.h>
#include <sensor_msgs/point_cloud2_iterator.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <iostream>
#include <sstream>
#include <vector>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/number_text.h"

namespace topo_gaussian::topo_ros {

namespace {

using sensor_msgs::PointField;

std::size_t datatypeSize(std::uint8_t datatype) {
  switch (datatype) {
    case PointField::INT8:
    case PointField::UINT8:
      return 1;
    case PointField::INT16:
    case PointField::UINT16:
      return 2;
    case PointField::INT32:
    case PointField::UINT32:
    case PointField::FLOAT32:
      return 4;
    case PointField::FLOAT64:
      return 8;
    default:
      return 0;
  }
}

template <typename T>
double load(const std::uint8_t* p) {
  T v;
  std::memcpy(&v, p, sizeof(T));  // fields need not be aligned
  return static_cast<double>(v);
}

double loadAs(std::uint8_t datatype, const std::uint8_t* p) {
  switch (datatype) {
    case PointField::INT8:
      return load<std::int8_t>(p);
    case PointField::UINT8:
      return load<std::uint8_t>(p);
    case PointField::INT16:
      return load<std::int16_t>(p);
    case PointField::UINT16:
      return load<std::uint16_t>(p);
    case PointField::INT32:
      return load<std::int32_t>(p);
    case PointField::UINT32:
      return load<std::uint32_t>(p);
    case PointField::FLOAT32:
      return load<float>(p);
    case PointField::FLOAT64:
      return load<double>(p);
    default:
      return std::nan("");
  }
}

std::string datatypeName(std::uint8_t datatype) {
  switch (datatype) {
    case PointField::INT8:
      return "INT8";
    case PointField::UINT8:
      return "UINT8";
    case PointField::INT16:
      return "INT16";
    case PointField::UINT16:
      return "UINT16";
    case PointField::INT32:
      return "INT32";
    case PointField::UINT32:
      return "UINT32";
    case PointField::FLOAT32:
      return "FLOAT32";
    case PointField::FLOAT64:
      return "FLOAT64";
    default:
      return "unknown (" + std::to_string(int(datatype)) + ")";
  }
}

std::string fieldList(const sensor_msgs::PointCloud2& msg) {
  if (msg.fields.empty()) return "none";
  std::string s;
  for (const auto& f : msg.fields) s += (s.empty() ? "" : " ") + f.name;
  return s;
}

/// Checked access to the points of a cloud: layout validated once, then read by (point, field).
class CloudReader {
 public:
  CloudReader(const sensor_msgs::PointCloud2& msg, const std::string& source) : msg_(msg), source_(source) {
    if (msg.is_bigendian)
      throw TopoError(source, "the PointCloud2 is big-endian, which this node does not read",
                      "publish a little-endian cloud (is_bigendian = false)");
    count_ = std::size_t(msg.width) * std::size_t(msg.height);
    if (count_ == 0 && !msg.data.empty())
      throw TopoError(source,
                      "the PointCloud2 declares no points (width × height = " + std::to_string(msg.width) + " × " +
                          std::to_string(msg.height) + ") but its data holds " + std::to_string(msg.data.size()) +
                          " bytes",
                      "set width and height to the points in the data (width = data bytes / point_step, height = 1)");
    if (count_ == 0) return;
    if (msg.point_step == 0)
      throw TopoError(source, "the PointCloud2 has point_step 0 for " + std::to_string(count_) + " points",
                      "set point_step to the size of one point in bytes");
    const std::size_t row = std::size_t(msg.row_step);
    if (row < std::size_t(msg.width) * msg.point_step)
      throw TopoError(source,
                      "the PointCloud2 row_step " + std::to_string(row) + " is smaller than width × point_step (" +
                          std::to_string(std::size_t(msg.width) * msg.point_step) + ")",
                      "set row_step = width * point_step");
    const std::size_t needed = row * (msg.height - 1) + std::size_t(msg.width) * msg.point_step;
    if (msg.data.size() < needed)
      throw TopoError(source,
                      "the PointCloud2 data holds " + std::to_string(msg.data.size()) + " bytes but " +
                          std::to_string(msg.width) + " × " + std::to_string(msg.height) + " points need " +
                          std::to_string(needed),
                      "make width, height, row_step and point_step agree with the data");
    // More data than the layout declares: the points beyond width × height would be dropped unread.
    const std::size_t declared = row * msg.height;
    if (msg.data.size() > declared)
      throw TopoError(
          source,
          "the PointCloud2 data holds " + std::to_string(msg.data.size()) + " bytes, more than row_step × height = " +
              std::to_string(row) + " × " + std::to_string(msg.height) + " = " + std::to_string(declared) +
              " bytes for its width × height = " + std::to_string(msg.width) + " × " + std::to_string(msg.height) +
              " points (at point_step " + std::to_string(msg.point_step) + " the data is " +
              std::to_string(msg.data.size() / msg.point_step) + " points): the rest would be dropped unread",
          "set width × height (and row_step = width × point_step) to the points in the data, or publish "
          "only the points the header declares");
  }

  std::size_t size() const { return count_; }

  /// Index of field `name` in msg.fields, or -1. A field that does not fit in the point is an error.
  int find(const std::string& name) const {
    for (std::size_t i = 0; i < msg_.fields.size(); ++i) {
      const auto& f = msg_.fields[i];
      if (f.name != name) continue;
      const std::size_t size = datatypeSize(f.datatype);
      if (size == 0)
        throw TopoError(source_, "field '" + name + "' has unknown datatype " + std::to_string(int(f.datatype)),
                        "use one of the sensor_msgs/PointField types (FLOAT32 for coordinates)");
      if (f.count < 1) throw TopoError(source_, "field '" + name + "' has count 0", "set count = 1");
      if (std::size_t(f.offset) + size > msg_.point_step)
        throw TopoError(source_,
                        "field '" + name + "' (offset " + std::to_string(f.offset) + ", " + std::to_string(size) +
                            " bytes) lies outside the " + std::to_string(msg_.point_step) + "-byte point",
                        "fix the field offsets or point_step");
      return int(i);
    }
    return -1;
  }

  int require(const std::string& name, const std::string& needed_for) const {
    const int i = find(name);
    if (i < 0)
      throw TopoError(source_, "the PointCloud2 has no field '" + name + "' (fields: " + fieldList(msg_) + ")",
                      "publish a cloud with " + needed_for);
    return i;
  }

  /// require() for a coordinate: FLOAT32 or FLOAT64 only. An integer field (a uint8 'x') holds no
  /// position in metres: reading it as metres would fill a box of 0..255 m.
  int requirePosition(const std::string& name, const std::string& needed_for) const {
    const int i = require(name, needed_for);
    const auto t = msg_.fields[std::size_t(i)].datatype;
    if (t != PointField::FLOAT32 && t != PointField::FLOAT64)
      throw TopoError(source_,
                      "position field '" + name + "' has type " + datatypeName(t) +
                          ", not a coordinate in metres (FLOAT32 or FLOAT64)",
                      "publish x y z as FLOAT32 (or FLOAT64) metres; convert scaled integer coordinates before "
                      "publishing");
    return i;
  }

  double get(std::size_t point, int field) const {
    const auto& f = msg_.fields[std::size_t(field)];
    const std::size_t r = point / msg_.width, c = point % msg_.width;
    const std::uint8_t* p = msg_.data.data() + r * msg_.row_step + c * msg_.point_step + f.offset;
    return loadAs(f.datatype, p);
  }

  /// The spacing carried in field `spacing` (the same value in every point: a PointCloud2 has no
  /// slot for one number), or 0 when the cloud has no such field or no points. Throws when the field
  /// is not FLOAT32/FLOAT64, its value is not a positive finite length, or two points disagree.
  double carriedSpacing() const {
    const int f = find("spacing");
    if (f < 0 || count_ == 0) return 0.0;
    const auto t = msg_.fields[std::size_t(f)].datatype;
    if (t != PointField::FLOAT32 && t != PointField::FLOAT64)
      throw TopoError(source_, "field 'spacing' has type " + datatypeName(t) + ", not a length in metres",
                      "publish the spacing as FLOAT64 (or FLOAT32) metres");
    const double h = get(0, f);
    if (!(h > 0.0) || !std::isfinite(h))
      throw TopoError(source_, "field 'spacing' is " + numberText(h, 6) + ", not a positive length in metres",
                      "publish the spacing the volume was filled at (m) in every point");
    for (std::size_t i = 1; i < count_; ++i)
      if (get(i, f) != h)
        throw TopoError(source_,
                        "point " + std::to_string(i) + " has spacing " + numberText(get(i, f), 6) +
                            " m but point 0 has " + numberText(h, 6) + " m",
                        "publish one volume per message, with its one spacing in every point");
    return h;
  }

 private:
  const sensor_msgs::PointCloud2& msg_;
  std::string source_;
  std::size_t count_ = 0;
};

}  // namespace

bool hasField(const sensor_msgs::PointCloud2& msg, const std::string& name) {
  return std::any_of(msg.fields.begin(), msg.fields.end(), [&](const PointField& f) { return f.name == name; });
}

sensor_msgs::PointCloud2 toPointCloud2(const VolumeCloud& cloud, const std::string& frame_id,
                                       const ::ros::Time& stamp) {
  const std::size_t n = cloud.size();
  if (cloud.V.size() != n || (!cloud.surface.empty() && cloud.surface.size() != n))
    throw TopoError("volume cloud",
                    "has " + std::to_string(n) + " positions but " + std::to_string(cloud.V.size()) + " volumes and " +
                        std::to_string(cloud.surface.size()) + " surface flags",
                    "give one volume (and one surface flag) per particle");
  if (n > 0 && !(cloud.spacing > 0.0 && std::isfinite(cloud.spacing)))
    throw TopoError("volume cloud", "has spacing " + numberText(cloud.spacing, 6) + ", which the message carries",
                    "set the spacing the volume was made at (m) where it is made");
  sensor_msgs::PointCloud2 msg;
  msg.header.frame_id = frame_id;
  msg.header.stamp = stamp;
  msg.height = 1;
  sensor_msgs::PointCloud2Modifier modifier(msg);
  modifier.setPointCloud2Fields(6, "x", 1, PointField::FLOAT32, "y", 1, PointField::FLOAT32, "z", 1,
                                PointField::FLOAT32, "volume", 1, PointField::FLOAT32, "surface", 1, PointField::UINT8,
                                "spacing", 1, PointField::FLOAT64);
  // 17 bytes of fields, padded so that the spacing (and every point's floats) stay aligned.
  msg.fields[5].offset = 24;
  msg.point_step = 32;
  modifier.resize(n);
  msg.is_dense = true;
  msg.is_bigendian = false;
  if (n == 0) return msg;  // the iterators dereference data.front(): not on an empty cloud

  sensor_msgs::PointCloud2Iterator<float> x(msg, "x"), y(msg, "y"), z(msg, "z"), v(msg, "volume");
  sensor_msgs::PointCloud2Iterator<std::uint8_t> s(msg, "surface");
  sensor_msgs::PointCloud2Iterator<double> h(msg, "spacing");
  for (std::size_t i = 0; i < n; ++i, ++x, ++y, ++z, ++v, ++s, ++h) {
    *x = float(cloud.X[i].x());
    *y = float(cloud.X[i].y());
    *z = float(cloud.X[i].z());
    *v = float(cloud.V[i]);
    *s = cloud.surface.empty() ? 0 : cloud.surface[i];
    *h = cloud.spacing;
    if (!(std::isfinite(*x) && std::isfinite(*y) && std::isfinite(*z) && std::isfinite(*v))) msg.is_dense = false;
  }
  return msg;
}

geometry::SurfaceData toSurfaceData(const sensor_msgs::PointCloud2& msg, const std::string& source) {
  const CloudReader in(msg, source);
  const std::string xyz = "x y z fields (FLOAT32 coordinates in metres)";
  const int fx = in.requirePosition("x", xyz), fy = in.requirePosition("y", xyz), fz = in.requirePosition("z", xyz);
  const int nx = in.find("normal_x"), ny = in.find("normal_y"), nz = in.find("normal_z");
  const bool normals = nx >= 0 && ny >= 0 && nz >= 0;

  geometry::SurfaceData s;
  s.kind = geometry::SurfaceKind::Points;
  s.source = source;
  s.points.reserve(in.size());
  if (normals) s.normals.reserve(in.size());
  for (std::size_t i = 0; i < in.size(); ++i) {
    s.points.emplace_back(in.get(i, fx), in.get(i, fy), in.get(i, fz));
    const Eigen::Vector3d& p = s.points.back();
    for (int k = 0; k < 3; ++k)
      if (std::abs(p[k]) > kMaxCoordinateM)  // false for NaN: NaN points are kept, cleaning drops them
        throw TopoError(source,
                        "point " + std::to_string(i) + " has " + "xyz"[k] + " = " + numberText(p[k], 6) +
                            " m, beyond the " + numberText(kMaxCoordinateM, 6) + " m a surface can reach",
                        "publish coordinates in metres (a scan's far or invalid points as NaN), or crop the cloud");
    if (normals) s.normals.emplace_back(in.get(i, nx), in.get(i, ny), in.get(i, nz));
  }
  return s;
}

namespace {

/// A reader's warning (a spacing derived for an older message): into `*warning` when given, else std::cerr.
void passOn(const std::string& note, std::string* warning) {
  if (warning)
    *warning = note;
  else if (!note.empty())
    std::cerr << "[topo] warning: " << note << "\n";
}

}  // namespace

VolumeCloud fromPointCloud2(const sensor_msgs::PointCloud2& msg, const std::string& source, std::string* warning) {
  const CloudReader in(msg, source);
  const std::string layout = "the volume layout: x y z volume (FLOAT32) and surface (UINT8)";
  const int fx = in.requirePosition("x", layout), fy = in.requirePosition("y", layout),
            fz = in.requirePosition("z", layout);
  const int fv = in.require("volume", layout);
  const int fs = in.find("surface");

  VolumeCloud c;
  c.X.reserve(in.size());
  c.V.reserve(in.size());
  c.surface.reserve(in.size());
  for (std::size_t i = 0; i < in.size(); ++i) {
    c.X.emplace_back(in.get(i, fx), in.get(i, fy), in.get(i, fz));
    c.V.push_back(in.get(i, fv));
    c.surface.push_back(fs >= 0 && in.get(i, fs) != 0.0 ? 1 : 0);
  }
  c.spacing = in.carriedSpacing();
  passOn(deriveMissingSpacing(&c, source), warning);  // a message from before the field: the one fallback
  return c;
}

sensor_msgs::PointCloud2 toContactCloud(const ContactSamples& c, const std::string& frame_id,
                                        const ::ros::Time& stamp) {
  const std::size_t n = c.size();
  if (c.normal.size() != n || c.area.size() != n)
    throw TopoError("contact samples",
                    "has " + std::to_string(n) + " positions but " + std::to_string(c.normal.size()) + " normals and " +
                        std::to_string(c.area.size()) + " areas",
                    "give one normal and one area per sample");
  if (n > 0 && !(c.spacing > 0.0 && std::isfinite(c.spacing)))
    throw TopoError("contact samples", "have spacing " + numberText(c.spacing, 6) + ", which the message carries",
                    "set the samples' spacing (m) where they are made");
  sensor_msgs::PointCloud2 msg;
  msg.header.frame_id = frame_id;
  msg.header.stamp = stamp;
  msg.height = 1;
  sensor_msgs::PointCloud2Modifier modifier(msg);
  modifier.setPointCloud2Fields(8, "x", 1, PointField::FLOAT32, "y", 1, PointField::FLOAT32, "z", 1,
                                PointField::FLOAT32, "normal_x", 1, PointField::FLOAT32, "normal_y", 1,
                                PointField::FLOAT32, "normal_z", 1, PointField::FLOAT32, "area", 1,
                                PointField::FLOAT32, "spacing", 1, PointField::FLOAT64);
  msg.fields[7].offset = 32;  // 28 bytes of floats, padded so that the spacing stays aligned
  msg.point_step = 40;
  modifier.resize(n);
  msg.is_dense = true;
  msg.is_bigendian = false;
  if (n == 0) return msg;
  sensor_msgs::PointCloud2Iterator<float> x(msg, "x"), nx(msg, "normal_x"), a(msg, "area");
  sensor_msgs::PointCloud2Iterator<double> h(msg, "spacing");
  for (std::size_t k = 0; k < n; ++k, ++x, ++nx, ++a, ++h) {
    *h = c.spacing;
    for (int d = 0; d < 3; ++d) {
      x[d] = float(c.X[k][d]);
      nx[d] = float(c.normal[k][d]);
    }
    *a = float(c.area[k]);
  }
  return msg;
}

ContactSamples fromContactCloud(const sensor_msgs::PointCloud2& msg, const std::string& source,
                                std::string* warning) {
  const CloudReader in(msg, source);
  const std::string layout = "the contact layout: x y z normal_x normal_y normal_z area (FLOAT32)";
  const int fx = in.requirePosition("x", layout), fy = in.requirePosition("y", layout),
            fz = in.requirePosition("z", layout);
  const int nx = in.require("normal_x", layout), ny = in.require("normal_y", layout),
            nz = in.require("normal_z", layout), fa = in.require("area", layout);
  ContactSamples c;
  c.origin = source;
  for (std::size_t i = 0; i < in.size(); ++i) {
    c.X.emplace_back(in.get(i, fx), in.get(i, fy), in.get(i, fz));
    Eigen::Vector3d n(in.get(i, nx), in.get(i, ny), in.get(i, nz));
    c.normal.push_back(n.norm() > 0 ? Eigen::Vector3d(n.normalized()) : n);
    c.area.push_back(in.get(i, fa));
  }
  c.spacing = in.carriedSpacing();
  passOn(deriveMissingSpacing(&c, source), warning);
  return c;
}

std::uint32_t interiorRgb(double r) {
  const double w = std::isfinite(r) ? std::clamp(r, 0.0, 1.0) : 0.0;
  std::uint32_t out = 0;
  for (int shift : {16, 8, 0}) {
    const double a = double((kHollowRgb >> shift) & 0xFF), b = double((kSolidRgb >> shift) & 0xFF);
    out |= std::uint32_t(std::lround(a + w * (b - a))) << shift;
  }
  return out;
}

sensor_msgs::PointCloud2 toInteriorCloud(const VolumeCloud& cloud, const std::vector<double>& r,
                                         const std::vector<double>& density, const std::vector<double>& stiffness,
                                         const std::string& frame_id, const ::ros::Time& stamp,
                                         const std::vector<double>& confidence) {
  const std::size_t n = cloud.size();
  if (r.size() != n || density.size() != n || (!stiffness.empty() && stiffness.size() != n) ||
      (!confidence.empty() && confidence.size() != n))
    throw TopoError("interior",
                    "has " + std::to_string(r.size()) + " indicator, " + std::to_string(density.size()) + " density, " +
                        std::to_string(stiffness.size()) + " stiffness and " + std::to_string(confidence.size()) +
                        " confidence values for " + std::to_string(n) + " particles",
                    "give one value per particle of the volume cloud");
  sensor_msgs::PointCloud2 msg;
  msg.header.frame_id = frame_id;
  msg.header.stamp = stamp;
  msg.height = 1;
  sensor_msgs::PointCloud2Modifier modifier(msg);
  modifier.setPointCloud2Fields(8, "x", 1, PointField::FLOAT32, "y", 1, PointField::FLOAT32, "z", 1,
                                PointField::FLOAT32, "solid", 1, PointField::FLOAT32, "density", 1, PointField::FLOAT32,
                                "stiffness", 1, PointField::FLOAT32, "confidence", 1, PointField::FLOAT32, "rgb", 1,
                                PointField::FLOAT32);
  modifier.resize(n);
  msg.is_dense = true;
  msg.is_bigendian = false;
  if (n == 0) return msg;  // the iterators dereference data.front(): not on an empty cloud
  sensor_msgs::PointCloud2Iterator<float> x(msg, "x"), y(msg, "y"), z(msg, "z"), s(msg, "solid"), d(msg, "density"),
      e(msg, "stiffness"), k(msg, "confidence"), c(msg, "rgb");
  for (std::size_t i = 0; i < n; ++i, ++x, ++y, ++z, ++s, ++d, ++e, ++k, ++c) {
    *x = float(cloud.X[i].x());
    *y = float(cloud.X[i].y());
    *z = float(cloud.X[i].z());
    *s = float(r[i]);
    *d = float(density[i]);
    *e = stiffness.empty() ? 0.0f : float(stiffness[i]);
    *k = confidence.empty() ? 1.0f : float(confidence[i]);
    const std::uint32_t rgb = interiorRgb(r[i]);
    std::memcpy(&*c, &rgb, sizeof(rgb));  // packed as PCL does: the float's bits are 0x00RRGGBB
    if (!(std::isfinite(*x) && std::isfinite(*y) && std::isfinite(*z) && std::isfinite(*s))) msg.is_dense = false;
  }
  return msg;
}

InteriorPoints fromInteriorCloud(const sensor_msgs::PointCloud2& msg, const std::string& source) {
  const CloudReader in(msg, source);
  const std::string layout = "the interior layout: x y z solid (FLOAT32; solid = r in [0, 1])";
  const int fx = in.requirePosition("x", layout), fy = in.requirePosition("y", layout),
            fz = in.requirePosition("z", layout);
  const int fr = in.require("solid", layout);
  InteriorPoints out;
  out.X.reserve(in.size());
  out.r.reserve(in.size());
  for (std::size_t i = 0; i < in.size(); ++i) {
    out.X.emplace_back(in.get(i, fx), in.get(i, fy), in.get(i, fz));
    const double r = in.get(i, fr);
    if (!(r >= 0.0 && r <= 1.0))
      throw TopoError(source, "point " + std::to_string(i) + " has solid = " + std::to_string(r) + ", outside [0, 1]",
                      "publish the indicator r in [0, 1] (1 solid, 0 hollow)");
    out.r.push_back(r);
  }
  return out;
}

}  // namespace topo_gaussian::topo_ros
