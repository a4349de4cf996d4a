// Export of an interior (workflow: what `topo export` and the inference node's ~export service
// call): into one directory
//   interior.ply   the interior (x y z r solid density), as topo infer writes it
//   interior.stl   binary STL of the solid region (r ≥ iso), watertight by construction (marching
//                  tetrahedra on the particle lattice, geometry/solid_mesh.h), in millimetres by default
//   slices.png     cross-sections: solid red, hollow blue, outside white (vision/slice_picture.h)
//   loss.png       the loss history on a log axis        (when a report with a history is given)
//   signal.png     observed vs simulated signal          (when signals are given)
//   inertial.urdf  the report's mass, centre of mass and inertia as a one-link URDF, and
//   inertial.sdf   as an SDF model (io/inertial_files.h; when a report is given and they are physical)
//   report.json    the given report with an "interface" section added (when a report is given)
//   export.json    mesh counts, the manifold check, the STL volume against Σ V_i of the solid
//                  particles, and the interface smoothness (geometry/mesh_smoothness.h)
// and measureInterface for the numbers alone (topo infer adds them to its report.json).
#pragma once

#include <string>
#include <vector>

#include "topo_gaussian/geometry/mesh_check.h"
#include "topo_gaussian/geometry/mesh_smoothness.h"
#include "topo_gaussian/geometry/surface_data.h"
#include "topo_gaussian/io/run_files.h"
#include "topo_gaussian/physics/volume_cloud.h"

namespace topo_gaussian::workflow {

/// The solid region's mesh and its quality.
struct InterfaceQuality {
  double iso = 0.5;
  std::size_t particles = 0, solid_particles = 0;
  geometry::ManifoldCheck check;
  double mesh_volume_m3 = 0.0;     ///< enclosed by the mesh (divergence theorem)
  double solid_volume_m3 = 0.0;    ///< Σ V_i over r_i ≥ iso
  double volume_difference = 0.0;  ///< (mesh − Σ V_i) / Σ V_i over the solid particles (exact boundary volumes)
  /// The paper's quality metric over the designed solid/hollow interface (mesh vertices between a
  /// solid and a hollow particle; vertices = 0 when nothing is hollow) ...
  geometry::NormalSmoothness interface_smoothness;
  /// ... and over the whole printable mesh (with the object's outer boundary, a lattice staircase).
  geometry::NormalSmoothness smoothness;
  double mesh_s = 0.0;  ///< time to extract, check and measure
};

/// Meshes the solid region (r ≥ iso) of a lattice cloud and measures it; the mesh is returned in
/// `mesh` when given. Throws TopoError for a cloud that is not a lattice, sizes that differ, or no
/// solid particle (geometry::solidRegionMesh).
InterfaceQuality measureInterface(const VolumeCloud& cloud, const std::vector<double>& r, double iso = 0.5,
                                  geometry::SurfaceData* mesh = nullptr);

/// The "interface" object for report.json (one line of JSON).
std::string interfaceJson(const InterfaceQuality& q);
/// report_json with "interface": interfaceJson(q) as its last member (replacing one added before).
/// Throws TopoError (naming `source`) when the text does not end with a JSON object's '}'.
std::string withInterfaceSection(const std::string& report_json, const InterfaceQuality& q,
                                 const std::string& source = "report.json");

struct ExportOptions {
  std::string output_dir;                     ///< created when missing
  std::string report_json;                    ///< text of the run's report.json ("" = none)
  std::string report_source = "report.json";  ///< its name, for messages
  std::vector<io::SignalSeries> signals;      ///< series for signal.png (first: observed, second: simulated)
  double iso = 0.5;                           ///< solid is r ≥ iso
  double stl_scale = 1000.0;                  ///< STL coordinates = metres × scale (1000: millimetres)
  std::string stl_unit = "mm";                ///< written in the STL header and export.json
  bool continuous = false;                    ///< interior.ply comment: r is a density fraction
  std::string title = "interior";             ///< heading of the pictures
  std::string object_name = "object";         ///< robot / model and link name in inertial.urdf, inertial.sdf
  std::vector<double> confidence;  ///< per particle (inference/design_spread.h) or empty: interior.ply, slices.png
};

struct ExportSummary {
  InterfaceQuality interface;
  std::string output_dir;
  std::vector<std::string> files;  ///< written, in order (file names inside output_dir)
  std::vector<std::string> notes;  ///< what was not written and why
  std::size_t loss_points = 0;
  std::vector<std::string> signal_labels;
  double signal_rms_difference = 0.0;  ///< simulated − observed (first two series), NaN when not computed
  double stl_scale = 1000.0;
  std::string stl_unit = "mm";
  double pictures_s = 0.0, total_s = 0.0;
};

/// Writes the files listed at the top. r and density have one value per particle. Throws TopoError
/// naming the input and the fix for bad input (sizes, not a lattice, no solid particle, a report
/// without loss_history, an unwritable directory); a mesh that fails the manifold check is still
/// written and reported (check.watertight() false) so that the caller can refuse it.
ExportSummary exportInterior(const VolumeCloud& cloud, const std::vector<double>& r, const std::vector<double>& density,
                             const ExportOptions& options);

/// export.json.
std::string exportJson(const ExportSummary& s);

}  // namespace topo_gaussian::workflow
