#include "topo_gaussian/geometry/ingest.h"

#include <Eigen/Geometry>
#include <chrono>
#include <sstream>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/geometry/surface_reader.h"

namespace topo_gaussian::geometry {

namespace {

std::string jsonString(const std::string& s) {
  std::string o = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') o += '\\';
    if (static_cast<unsigned char>(c) < 0x20) {
      o += ' ';
      continue;
    }
    o += c;
  }
  return o + "\"";
}

}  // namespace

void applyUpAxis(SurfaceData& s, const std::string& up) {
  // Rows of the rotation R (new = R old) that takes the named axis to +z.
  Eigen::Matrix3d R;
  if (up == "z" || up == "+z")
    return;
  else if (up == "-z")
    R << 1, 0, 0, 0, -1, 0, 0, 0, -1;  // 180° about x
  else if (up == "y" || up == "+y")
    R << 1, 0, 0, 0, 0, -1, 0, 1, 0;  // +90° about x: y → z, z → −y
  else if (up == "-y")
    R << 1, 0, 0, 0, 0, 1, 0, -1, 0;  // −90° about x
  else if (up == "x" || up == "+x")
    R << 0, 0, -1, 0, 1, 0, 1, 0, 0;  // −90° about y: x → z, z → −x
  else if (up == "-x")
    R << 0, 0, 1, 0, 1, 0, -1, 0, 0;  // +90° about y
  else
    throw TopoError(s.source, "up axis '" + up + "' is not one of x y z -x -y -z",
                    "name the input's up axis, e.g. y for Y-up meshes (--up-axis y)");
  for (auto& p : s.points) p = R * p;
  for (auto& n : s.normals) n = R * n;
  for (auto& C : s.covariances) C = R * C * R.transpose();
  const Eigen::Quaterniond qr(R);
  for (auto& q : s.rotations) {
    const Eigen::Quaterniond r = qr * Eigen::Quaterniond(q[0], q[1], q[2], q[3]);
    q = Eigen::Vector4d(r.w(), r.x(), r.y(), r.z());
  }
}

IngestResult ingestSurface(SurfaceData surface, const IngestOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  IngestResult r;
  r.input = surface.source;
  r.kind = surface.kind;
  r.up_axis = options.up_axis;
  applyUpAxis(surface, options.up_axis);
  const std::size_t triangles_before = surface.triangles.size();
  r.clean = cleanSurface(surface, options.clean);
  if (r.clean.non_finite)
    r.warnings.push_back(
        "dropped " + std::to_string(r.clean.non_finite) + " point(s) with NaN/infinite values" +
        (surface.kind == SurfaceKind::Mesh
             ? " and the " + std::to_string(triangles_before - surface.triangles.size()) + " face(s) using them"
             : std::string()));
  if (r.clean.duplicates)
    r.warnings.push_back("merged " + std::to_string(r.clean.duplicates) + " exact duplicate point(s) of the " +
                         std::to_string(r.clean.points_in) +
                         " (the same coordinates written more than once): each position is used once");
  r.cloud = fillInterior(surface, options.fill, &r.fill);
  r.fill.points_in = r.clean.points_in;
  r.fill.triangles_in = triangles_before;
  r.warnings.insert(r.warnings.end(), r.fill.warnings.begin(), r.fill.warnings.end());
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

IngestResult ingestFile(const std::string& path, const IngestOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  IngestResult r = ingestSurface(readSurface(path), options);
  r.input = path;
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

std::string toJson(const IngestResult& r) {
  std::ostringstream j;
  j.precision(9);
  const auto& f = r.fill;
  auto vec = [&](const Eigen::Vector3d& v) {
    std::ostringstream s;
    s.precision(9);
    s << '[' << v.x() << ',' << v.y() << ',' << v.z() << ']';
    return s.str();
  };
  const double open =
      r.kind == SurfaceKind::Mesh ? std::max(f.topology.openFraction(), f.open_fraction) : f.open_fraction;
  j << "{\"input\":" << jsonString(r.input) << ",\"input_kind\":\"" << toString(r.kind) << "\",\"method\":\""
    << f.method << "\",\"points_in\":" << r.clean.points_in << ",\"points_after_cleaning\":"
    << (r.clean.points_in - r.clean.non_finite - r.clean.duplicates - r.clean.transparent - r.clean.outliers -
        r.clean.cropped)
    << ",\"triangles_in\":" << f.triangles_in << ",\"particles_out\":" << f.particles_out
    << ",\"surface_particles\":" << f.surface_particles << ",\"contact_samples\":" << f.contact_samples
    << ",\"contact_spacing_m\":" << f.contact_spacing_m << ",\"contact_area_m2\":" << f.contact_area_m2
    << ",\"mesh_volume_m3\":" << f.mesh_volume_m3 << ",\"exact_boundary\":" << (f.exact_boundary ? "true" : "false")
    << ",\"spacing_m\":" << f.spacing_m << ",\"total_volume_m3\":" << f.total_volume_m3
    << ",\"bbox_min\":" << vec(f.bbox_min) << ",\"bbox_max\":" << vec(f.bbox_max) << ",\"open_fraction\":" << open
    << ",\"boundary_edges\":" << f.topology.boundary_edges << ",\"seconds\":" << r.seconds
    << ",\"up_axis\":" << jsonString(r.up_axis) << ",\"faces_dropped\":" << f.repair.faces_dropped()
    << ",\"holes_closed\":" << f.repair.holes_closed << ",\"faces_ignored\":" << f.repair.ignored_faces
    << ",\"fallback\":" << jsonString(f.fallback) << ",\"warnings\":[";
  for (std::size_t i = 0; i < r.warnings.size(); ++i) j << (i ? "," : "") << jsonString(r.warnings[i]);
  j << "]}";
  return j.str();
}

}  // namespace topo_gaussian::geometry
