#include "topo_gaussian/workflow/interior_export.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <limits>
#include <sstream>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/json.h"
#include "topo_gaussian/common/number_text.h"
#include "topo_gaussian/common/stopwatch.h"
#include "topo_gaussian/geometry/mesh_metrics.h"
#include "topo_gaussian/geometry/solid_mesh.h"
#include "topo_gaussian/geometry/stl_writer.h"
#include "topo_gaussian/inference/pipeline.h"
#include "topo_gaussian/io/inertial_files.h"
#include "topo_gaussian/io/interior_ply.h"
#include "topo_gaussian/io/text_file.h"
#include "topo_gaussian/vision/figure.h"
#include "topo_gaussian/vision/line_plot.h"
#include "topo_gaussian/vision/slice_picture.h"

namespace topo_gaussian::workflow {

namespace {

using json::num;
using json::quote;
using topo_gaussian::Clock;

const char* boolean(bool b) { return b ? "true" : "false"; }

const char* const kSmoothnessDefinition =
    "mean over mesh vertices of |U_i|, U_i = mean of the neighbours' unit normals - n_i (uniform Laplacian of the "
    "unit normal, dimensionless, ~ |Laplacian n| x edge^2 / 4); lower is smoother. smoothness / interface: over the "
    "vertices between solid and hollow particles (the designed interface); whole_mesh: every vertex of interior.stl, "
    "with the object's outer boundary (a lattice staircase)";

std::string smoothnessJson(const geometry::NormalSmoothness& m) {
  if (m.vertices == 0) return "null";
  return "{\"normal_laplacian_mean\": " + num(m.mean) + ", \"normal_laplacian_rms\": " + num(m.rms) +
         ", \"normal_laplacian_max\": " + num(m.max) + ", \"vertices\": " + std::to_string(m.vertices) +
         ", \"mean_edge_length_m\": " + num(m.mean_edge_length_m) + "}";
}

}  // namespace

InterfaceQuality measureInterface(const VolumeCloud& cloud, const std::vector<double>& r, double iso,
                                  geometry::SurfaceData* mesh_out) {
  const auto t0 = Clock::now();
  InterfaceQuality q;
  q.iso = iso;
  geometry::SolidMeshOptions mo;
  mo.iso = iso;
  std::vector<std::uint8_t> interface_vertex;
  geometry::SurfaceData mesh = geometry::solidRegionMesh(cloud, r, mo, &interface_vertex);
  q.particles = cloud.size();
  for (double v : r) q.solid_particles += v >= iso ? 1 : 0;
  q.check = geometry::checkManifold(mesh);
  q.mesh_volume_m3 = geometry::meshIntegrals(mesh).volume;
  q.solid_volume_m3 = geometry::solidParticleVolume(cloud, r, iso);
  // The mesh's outer boundary cuts each boundary cell where its inside fraction says (SolidMeshOptions::
  // boundary_fractions), so it is held to the particles' own volumes, exact at the object's boundary.
  q.volume_difference = (q.mesh_volume_m3 - q.solid_volume_m3) / q.solid_volume_m3;
  q.smoothness = geometry::normalSmoothness(mesh);
  q.interface_smoothness = geometry::normalSmoothness(mesh, &interface_vertex);
  q.mesh_s = secondsSince(t0);
  if (mesh_out) *mesh_out = std::move(mesh);
  return q;
}

std::string interfaceJson(const InterfaceQuality& q) {
  std::ostringstream s;
  s << "{\"smoothness\": " << (q.interface_smoothness.vertices ? num(q.interface_smoothness.mean) : "null")
    << ", \"smoothness_whole_mesh\": " << num(q.smoothness.mean)
    << ", \"smoothness_definition\": " << quote(kSmoothnessDefinition)
    << ", \"interface_vertices\": " << q.interface_smoothness.vertices
    << ", \"watertight\": " << boolean(q.check.watertight()) << ", \"triangles\": " << q.check.triangles
    << ", \"vertices\": " << q.check.vertices << ", \"solid_bodies\": " << q.check.bodies
    << ", \"enclosed_voids\": " << q.check.voids << ", \"mean_edge_length_m\": " << num(q.smoothness.mean_edge_length_m)
    << ", \"mesh_volume_m3\": " << num(q.mesh_volume_m3) << ", \"solid_volume_m3\": " << num(q.solid_volume_m3)
    << ", \"volume_relative_difference\": " << num(q.volume_difference) << ", \"iso\": " << num(q.iso) << "}";
  return s.str();
}

std::string withInterfaceSection(const std::string& report, const InterfaceQuality& q, const std::string& source) {
  std::size_t end = report.find_last_not_of(" \t\r\n");
  if (end == std::string::npos || report[end] != '}')
    throw TopoError(source, "does not end with '}', so it is not a JSON report",
                    "give the report.json written by topo infer");
  std::string body = report.substr(0, end);  // without the final '}'
  const auto trimEnd = [&] { body.erase(body.find_last_not_of(" \t\r\n") + 1); };
  trimEnd();
  const std::string key = ",\n  \"interface\": ";  // one added before: the last member, on one line
  const std::size_t old = body.rfind(key);
  if (old != std::string::npos && body.find('\n', old + key.size()) == std::string::npos) {
    body.erase(old);
    trimEnd();
  }
  const bool empty_object = !body.empty() && body.back() == '{';
  return body + (empty_object ? "\n  \"interface\": " : key) + interfaceJson(q) + "\n}\n";
}

ExportSummary exportInterior(const VolumeCloud& cloud, const std::vector<double>& r, const std::vector<double>& density,
                             const ExportOptions& o) {
  const auto t0 = Clock::now();
  if (density.size() != r.size())
    throw TopoError(
        "interior",
        "has " + std::to_string(r.size()) + " values of r but " + std::to_string(density.size()) + " densities",
        "give one density per particle");
  if (o.output_dir.empty()) throw TopoError("export", "has no output directory", "give one (topo export --output DIR)");
  if (!(o.stl_scale > 0.0) || !std::isfinite(o.stl_scale))
    throw TopoError("STL scale " + num(o.stl_scale), "is not positive", "use 1000 (millimetres) or 1 (metres)");
  // Everything that can fail on the input first, so that nothing is half-written.
  std::vector<io::LossPoint> history;
  if (!o.report_json.empty()) history = io::lossHistoryFromReport(o.report_json, o.report_source);
  geometry::SurfaceData mesh;
  ExportSummary s;
  s.interface = measureInterface(cloud, r, o.iso, &mesh);
  s.output_dir = o.output_dir;
  s.stl_scale = o.stl_scale;
  s.stl_unit = o.stl_unit;
  s.signal_rms_difference = std::numeric_limits<double>::quiet_NaN();

  std::error_code ec;
  std::filesystem::create_directories(o.output_dir, ec);
  if (!std::filesystem::is_directory(o.output_dir))
    throw TopoError(o.output_dir,
                    "is not a directory and cannot be created" + (ec ? " (" + ec.message() + ")" : std::string()),
                    "give a writable output directory");
  const std::string dir = o.output_dir + "/";
  if (s.interface.check.bodies > 1)
    s.notes.push_back("interior.stl has " + std::to_string(s.interface.check.bodies) +
                      " separate solid bodies: all but one print as loose parts (e.g. solid islands in a cavity)");
  if (s.interface.check.voids > 0)
    s.notes.push_back("interior.stl encloses " + std::to_string(s.interface.check.voids) +
                      (s.interface.check.voids == 1 ? " void" : " voids") +
                      " (the hollow parts): resin and powder printers need a drain hole to empty it");

  io::writeInteriorPly(dir + "interior.ply", cloud, r, density, o.continuous, o.confidence);
  s.files.push_back("interior.ply");
  writeStlBinary(mesh, dir + "interior.stl", o.stl_scale,
                 "topo_gaussian solid region (r >= " + num(o.iso) + "), unit " + o.stl_unit);
  s.files.push_back("interior.stl");

  const auto tp = Clock::now();
  vision::SliceOptions so;
  so.iso = o.iso;
  so.confidence = o.confidence;
  vision::writePng(vision::drawInteriorSlices(cloud.X, r, cloud.spacing, o.title, so), dir + "slices.png");
  s.files.push_back("slices.png");

  s.loss_points = history.size();
  if (!o.report_json.empty()) {
    if (history.empty()) {
      s.notes.push_back("loss.png not written: the report's loss_history is empty");
    } else {
      vision::LinePlot p;
      p.title = "loss history";
      const std::string task = io::jsonStringField(o.report_json, "task");
      if (!task.empty()) p.title += " (task " + task + ")";
      p.x_label = "iteration";
      p.y_label = "loss";
      p.log_y = true;
      vision::PlotSeries line;
      line.label = "loss";
      line.markers = history.size() <= 80;
      double best = std::numeric_limits<double>::infinity();
      for (const auto& h : history) {
        line.x.push_back(h.iteration);
        line.y.push_back(h.loss);
        if (std::isfinite(h.loss)) best = std::min(best, h.loss);
      }
      p.series.push_back(line);
      p.notes.push_back(std::to_string(history.size()) + " iterations, first " + numberText(history.front().loss) +
                        ", best " + numberText(best));
      try {
        vision::writePng(vision::drawLinePlot(p), dir + "loss.png");
        s.files.push_back("loss.png");
      } catch (const TopoError& e) {
        if (std::string(e.what()).find("no finite positive") == std::string::npos) throw;
        s.notes.push_back("loss.png not written: no positive finite loss to plot on a log axis");
      }
    }
  }

  if (!o.signals.empty()) {
    vision::LinePlot p;
    p.title = o.signals.size() >= 2 ? "observed vs simulated signal" : "signal";
    p.x_label = "time [s]";
    p.y_label = o.signals.size() == 1 ? o.signals[0].label : "value";
    const cv::Scalar colours[] = {cv::Scalar(30, 30, 30), cv::Scalar(40, 40, 215), cv::Scalar(180, 110, 30),
                                  cv::Scalar(40, 150, 40)};
    for (std::size_t k = 0; k < o.signals.size(); ++k) {
      vision::PlotSeries line;
      line.label = o.signals[k].label;
      line.x = o.signals[k].t;
      line.y = o.signals[k].value;
      line.bgr = colours[k % 4];
      p.series.push_back(line);
      s.signal_labels.push_back(line.label);
    }
    if (o.signals.size() >= 2) {
      std::size_t n = 0;
      s.signal_rms_difference = io::rmsDifference(o.signals[0], o.signals[1], &n);
      if (std::isfinite(s.signal_rms_difference))
        p.notes.push_back("RMS of " + o.signals[1].label + " - " + o.signals[0].label + ": " +
                          numberText(s.signal_rms_difference) + " over " + std::to_string(n) + " samples of " +
                          o.signals[0].label);
    }
    vision::writePng(vision::drawLinePlot(p), dir + "signal.png");
    s.files.push_back("signal.png");
  }
  s.pictures_s = secondsSince(tp);

  if (!o.report_json.empty()) {
    // the robot's mass properties (io/inertial_files.h), before report.json: a folder with a report is whole
    try {
      const io::IdentifiedMass id = io::identifiedMassFromReport(o.report_json, o.report_source);
      const std::string urdf = io::urdfInertial(id, o.object_name, o.report_source);
      const std::string sdf = io::sdfInertial(id, o.object_name, o.report_source);
      io::writeTextFile(dir + "inertial.urdf", urdf);
      s.files.push_back("inertial.urdf");
      io::writeTextFile(dir + "inertial.sdf", sdf);
      s.files.push_back("inertial.sdf");
    } catch (const TopoError& e) {
      s.notes.push_back(std::string("inertial.urdf and inertial.sdf not written: ") + e.what());
    }
    io::writeTextFile(dir + "report.json", withInterfaceSection(o.report_json, s.interface, o.report_source));
    s.files.push_back("report.json");
  }
  s.files.push_back("export.json");
  s.total_s = secondsSince(t0);
  io::writeTextFile(dir + "export.json", exportJson(s));
  return s;
}

std::string exportJson(const ExportSummary& s) {
  const InterfaceQuality& q = s.interface;
  const geometry::ManifoldCheck& c = q.check;
  std::ostringstream j;
  j << "{\n  \"particles\": " << q.particles << ",\n  \"solid_particles\": " << q.solid_particles
    << ",\n  \"iso\": " << num(q.iso) << ",\n  \"mesh\": {\"file\": \"interior.stl\", \"unit\": " << quote(s.stl_unit)
    << ", \"scale_from_m\": " << num(s.stl_scale) << ", \"vertices\": " << c.vertices
    << ", \"triangles\": " << c.triangles << ", \"edges\": " << c.edges << ", \"components\": " << c.components
    << ", \"solid_bodies\": " << c.bodies << ", \"enclosed_voids\": " << c.voids
    << ", \"euler_characteristic\": " << c.euler_characteristic << "},\n  \"watertight\": " << boolean(c.watertight())
    << ",\n  \"manifold_check\": {\"boundary_edges\": " << c.boundary_edges
    << ", \"nonmanifold_edges\": " << c.nonmanifold_edges << ", \"misoriented_edges\": " << c.misoriented_edges
    << ", \"nonmanifold_vertices\": " << c.nonmanifold_vertices
    << ", \"degenerate_triangles\": " << c.degenerate_triangles
    << ", \"min_triangle_area_m2\": " << num(c.min_triangle_area) << ", \"summary\": " << quote(c.summary())
    << "},\n  \"volume\": {\"stl_m3\": " << num(q.mesh_volume_m3)
    << ", \"solid_particles_m3\": " << num(q.solid_volume_m3)
    << ", \"relative_difference\": " << num(q.volume_difference)
    << "},\n  \"smoothness\": {\"interface\": " << smoothnessJson(q.interface_smoothness)
    << ", \"whole_mesh\": " << smoothnessJson(q.smoothness) << ", \"definition\": " << quote(kSmoothnessDefinition)
    << "},\n  \"loss_history_points\": " << s.loss_points << ",\n  \"signals\": [";
  for (std::size_t k = 0; k < s.signal_labels.size(); ++k) j << (k ? ", " : "") << quote(s.signal_labels[k]);
  j << "],\n  \"signal_rms_difference\": " << num(s.signal_rms_difference) << ",\n  \"files\": [";
  for (std::size_t k = 0; k < s.files.size(); ++k) j << (k ? ", " : "") << quote(s.files[k]);
  j << "],\n  \"notes\": [";
  for (std::size_t k = 0; k < s.notes.size(); ++k) j << (k ? ", " : "") << quote(s.notes[k]);
  j << "],\n  \"timings_s\": {\"mesh\": " << num(q.mesh_s) << ", \"pictures\": " << num(s.pictures_s)
    << ", \"total\": " << num(s.total_s) << "}\n}\n";
  return j.str();
}

}  // namespace topo_gaussian::workflow
