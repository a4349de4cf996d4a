// `topo export`: the printable and viewable output of an inferred interior (a thin front end of
// workflow::exportInterior, which the inference node's ~export service calls as well).
#include <cmath>
#include <fstream>
#include <iostream>
#include <sstream>

#include "args.h"
#include "commands.h"
#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/number_text.h"
#include "topo_gaussian/io/interior_ply.h"
#include "topo_gaussian/io/volume_ply.h"
#include "topo_gaussian/vision/figure.h"
#include "topo_gaussian/workflow/interior_export.h"

namespace topo_gaussian::tools {
namespace {

const char* kExportHelp =
    "usage: topo export --volume VOLUME.ply --interior DIR/interior.ply --output OUTDIR\n"
    "                   [--report DIR/report.json] [--signal FILE.csv ...] [--stl-unit mm|m] [--iso R]\n"
    "                   [--title TEXT] [--json]\n"
    "\n"
    "Writes an inferred interior for printing and for people. Into OUTDIR:\n"
    "  interior.ply   the interior again (x y z r solid density)\n"
    "  interior.stl   binary STL of the solid region (r >= 0.5): marching cubes on the particle\n"
    "                 lattice, its outer boundary placed by the boundary particles' inside fractions (so\n"
    "                 it has the object's volume), watertight by construction and checked (every edge shared by "
    "exactly two\n"
    "                 consistently oriented triangles, one fan per vertex, no degenerate triangle);\n"
    "                 millimetres unless --stl-unit m\n"
    "  slices.png     cross-sections: solid red, hollow blue, outside white; three planes through the\n"
    "                 centroid and a row along the longest axis, with axes and scale bars\n"
    "  loss.png       the loss history on a log axis (with --report)\n"
    "  signal.png     observed vs simulated signal, with their RMS difference (with --signal)\n"
    "  inertial.urdf  the report's mass [kg], centre of mass [m] and inertia about it [kg m^2] as a\n"
    "  inertial.sdf   one-link URDF / SDF for a robot's description, in the object's frame, with the\n"
    "                 analysis's standard deviations in a comment (with --report; refused, with a note,\n"
    "                 for an inertia no body has)\n"
    "  report.json    the given report plus an \"interface\" section (with --report)\n"
    "  export.json    triangle/vertex counts, the manifold check, the STL volume against the solid\n"
    "                 particles' volume (sum of V_i over r >= 0.5), and the interface smoothness (the\n"
    "                 paper's quality metric: mean |uniform Laplacian of the unit normal|, lower is smoother)\n"
    "\n"
    "  --volume FILE      the volume .ply the interior was inferred on (topo fill, topo shape --volume)\n"
    "  --interior FILE    interior.ply written by topo infer for that volume\n"
    "  --output DIR       output directory (created)\n"
    "  --report FILE      report.json of the same run (loss history)\n"
    "  --signal FILE.csv  time in the first column, one series per further column, optional header, e.g.\n"
    "                     time_s,observed,simulated (blank cells allowed); repeatable, e.g. the observed\n"
    "                     signal and the simulated one of topo simulate --signal; the first series is\n"
    "                     plotted as observed, the second as simulated\n"
    "  --stl-unit U       mm (default; what slicers assume) or m\n"
    "  --iso R            solid threshold of r, 0 < R <= 1 (default 0.5, as the solid flag of interior.ply)\n"
    "  --title TEXT       heading of slices.png (default: the interior's file name)\n"
    "  --json             print export.json on stdout\n"
    "exit codes: 0 success, 1 bad input (missing or mismatched files) or a mesh that fails the check,\n"
    "            2 bad command line\n";

std::string readWhole(const std::string& path, const std::string& what) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw TopoError(path, "cannot open the " + what, "check the path");
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string stem(const std::string& path) {
  std::string name = path.substr(path.find_last_of('/') + 1);
  const std::size_t dot = name.find_last_of('.');
  return dot == std::string::npos || dot == 0 ? name : name.substr(0, dot);
}

}  // namespace

int exportCommand(const std::vector<std::string>& argv) {
  const Args a(argv, {"help", "json"}, {"volume", "interior", "output", "report", "stl-unit", "iso", "title"},
               {"signal"});
  if (a.has("help")) {
    std::cout << kExportHelp;
    return 0;
  }
  for (const char* required : {"volume", "interior", "output"})
    if (!a.has(required)) throw UsageError(std::string("--") + required + " is required");
  workflow::ExportOptions o;
  o.output_dir = a.str("output");
  const std::string unit = a.str("stl-unit", "mm");
  if (unit != "mm" && unit != "m") throw UsageError("--stl-unit must be mm or m, got '" + unit + "'");
  o.stl_unit = unit;
  o.stl_scale = unit == "mm" ? 1000.0 : 1.0;
  o.iso = a.num("iso", 0.5);
  if (!(o.iso > 0.0 && o.iso <= 1.0)) throw UsageError("--iso must be in (0, 1], got '" + a.str("iso") + "'");

  const std::string volume_path = a.str("volume"), interior_path = a.str("interior");
  const VolumeCloud cloud = io::readVolumePly(volume_path);
  const io::InteriorPly interior = io::readInteriorPlyData(interior_path, cloud.size());
  // Same count is not enough: the interior must have been computed on these particles.
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const double off = (interior.X[i] - cloud.X[i]).norm();
    if (!(off <= 0.01 * cloud.spacing)) {
      std::ostringstream msg;
      msg << "particle " << i << " is at (" << interior.X[i].transpose() << ") but particle " << i << " of "
          << volume_path << " is at (" << cloud.X[i].transpose() << "): the interior was computed on another volume";
      throw TopoError(interior_path, msg.str(), "give the volume that topo infer was run on (--volume of that run)");
    }
  }
  o.continuous = interior.continuous;
  o.confidence = interior.confidence;  // kept when the run explored the designs that fit as well
  o.title = a.str("title", "interior " + interior_path);
  if (a.has("report")) {
    o.report_source = a.str("report");
    o.report_json = readWhole(o.report_source, "report (report.json of topo infer)");
  }
  const auto signal_files = a.all("signal");
  for (const auto& f : signal_files) {
    for (auto& s : io::readSignalCsv(f)) {
      if (signal_files.size() > 1) s.label = stem(f) + ": " + s.label;
      o.signals.push_back(std::move(s));
    }
  }

  const workflow::ExportSummary s = workflow::exportInterior(cloud, interior.r, interior.density, o);
  const workflow::InterfaceQuality& q = s.interface;
  std::fprintf(
      stderr,
      "[topo export] %zu particles, %zu solid; mesh %zu triangles, %zu vertices: %s\n"
      "[topo export] STL volume %.6g m^3 vs solid particles %.6g m^3 (%+.2f %%); smoothness (mean |Laplacian "
      "of the unit normal|) %s on the solid/hollow interface, %.4f on the whole mesh; %.2f s\n",
      q.particles, q.solid_particles, q.check.triangles, q.check.vertices, q.check.summary().c_str(), q.mesh_volume_m3,
      q.solid_volume_m3, 100.0 * q.volume_difference,
      q.interface_smoothness.vertices ? numberText(q.interface_smoothness.mean).c_str() : "none (no hollow part)",
      q.smoothness.mean, s.total_s);
  for (const auto& n : s.notes) std::cerr << "[topo export] " << n << "\n";
  std::cerr << "[topo export] wrote";
  for (const auto& f : s.files) std::cerr << " " << o.output_dir << "/" << f;
  std::cerr << "\n";
  if (a.has("json")) std::cout << workflow::exportJson(s);
  if (!q.check.watertight())
    throw TopoError(o.output_dir + "/interior.stl", "failed the manifold check (" + q.check.summary() + ")",
                    "this should not happen: please report it with the volume and interior files");
  return 0;
}

}  // namespace topo_gaussian::tools
