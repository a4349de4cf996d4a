#include "topo_gaussian/geometry/ingest.h"

#include <chrono>
#include <sstream>

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

IngestResult ingestSurface(SurfaceData surface, const IngestOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  IngestResult r;
  r.input = surface.source;
  r.kind = surface.kind;
  r.clean = cleanSurface(surface, options.clean);
  r.cloud = fillInterior(surface, options.fill, &r.fill);
  r.fill.points_in = r.clean.points_in;
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
    << (r.clean.points_in - r.clean.non_finite - r.clean.transparent - r.clean.outliers - r.clean.cropped)
    << ",\"triangles_in\":" << f.triangles_in << ",\"particles_out\":" << f.particles_out
    << ",\"surface_particles\":" << f.surface_particles << ",\"spacing_m\":" << f.spacing_m
    << ",\"total_volume_m3\":" << f.total_volume_m3 << ",\"bbox_min\":" << vec(f.bbox_min)
    << ",\"bbox_max\":" << vec(f.bbox_max) << ",\"open_fraction\":" << open
    << ",\"boundary_edges\":" << f.topology.boundary_edges << ",\"seconds\":" << r.seconds << "}";
  return j.str();
}

}  // namespace topo_gaussian::geometry
