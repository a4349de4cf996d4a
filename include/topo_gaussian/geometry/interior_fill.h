// fillInterior: any surface in, a filled VolumeCloud out (paper §4).
//  - closed meshes: exact ray-parity inside test at every lattice point, and each boundary particle
//    carries the exact inside part of its cell (V_i = f_i h³ at its centroid, cell_clip.h);
//  - 3D Gaussians: the PhysGaussian density method (density_fill.h);
//  - point clouds and open meshes: the same density method on isotropic splats of the points
//    (or of samples on the triangles), with the leak check that refuses open surfaces.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "topo_gaussian/geometry/contact_samples.h"
#include "topo_gaussian/geometry/density_fill.h"
#include "topo_gaussian/geometry/mesh_fill.h"
#include "topo_gaussian/geometry/mesh_repair.h"
#include "topo_gaussian/geometry/surface_data.h"
#include "topo_gaussian/physics/volume_cloud.h"

namespace topo_gaussian::geometry {

/// Default of FillOptions::max_open_fraction (also quoted in messages and `topo fill --help`).
constexpr double kDefaultMaxOpenFraction = 0.05;

struct FillOptions {
  double spacing_m = 0.0;            ///< lattice spacing [m]; 0 → chosen from target_count
  std::size_t target_count = 50000;  ///< particles wanted when spacing_m is 0 (met within ~15 %)
  double jitter = 0.0;               ///< random offset of each particle, fraction of the spacing (0..0.5)
  unsigned seed = 1;                 ///< for the jitter
  int grid_resolution = 0;           ///< density grid cells along the longest side; 0 = lattice spacing
  DensityFillOptions density;        ///< PhysGaussian parameters (Gaussians, points, open meshes)
  /// Largest fraction of the ray-filled interior allowed to leak to the outside through gaps in
  /// the surface; above it the fill is refused with an error that says how open the surface is.
  double max_open_fraction = kDefaultMaxOpenFraction;
  double max_cells = 2.5e8;  ///< refuse lattices (and density grids) with more cells than this
  /// Refuse a fill whose grids would need more memory than this [bytes]; 0 = half the physical memory.
  double max_memory_bytes = 0.0;
  /// Warn (suggesting scale 0.001) when the surface's bounding box is larger than this [m].
  double warn_extent_m = 20.0;
  /// Point clouds: keep only the inner half of the splat shell (density.split_shell), so the solid
  /// ends at the sampled surface rather than one splat radius outside it (+12..27 % volume on random
  /// samplings of a sphere without it, +1.5..6.4 % with it). Gaussians follow density.split_shell.
  bool split_point_shell = true;
  /// Points and Gaussians: the solid ends at the zero level of the points' signed distance (their
  /// normals, given or estimated, oriented by the density fill) and boundary particles carry the
  /// inside fraction of their cell, V_i = f_i h³ (surface_field.h); within ~1 % of the exact volume
  /// on clean samplings instead of the density shell's +2..27 %. false: whole cells of the shell.
  bool boundary_fraction = true;
  MeshRepairOptions mesh_repair;  ///< meshes: which holes are closed and which open pieces are left out
  /// Contact samples on the true surface, stored in VolumeCloud::contact (geometry/contact_samples.h).
  ContactSampleOptions contact;
};

struct FillReport {
  std::string method;  ///< mesh-parity | gaussian-density | point-density | mesh-sample-density
  std::size_t points_in = 0;
  std::size_t triangles_in = 0;
  std::size_t particles_out = 0;
  std::size_t surface_particles = 0;
  std::size_t contact_samples = 0;  ///< points on the true surface (VolumeCloud::contact)
  double contact_spacing_m = 0.0;
  double contact_area_m2 = 0.0;  ///< Σ of the samples' areas: the surface area
  double spacing_m = 0.0;
  double total_volume_m3 = 0.0;  ///< the filled volume, Σ V_i
  /// Closed meshes: the exact enclosed volume by the divergence theorem (after any flip of inverted
  /// normals); 0 for other inputs.
  double mesh_volume_m3 = 0.0;
  /// Closed meshes: cut cells at least half inside, each a particle with the exact inside part of its
  /// cell (cell_clip.h); cut cells less than half inside, merged into the nearest particle of a
  /// neighbour, or (no such neighbour) given a particle of their own.
  std::size_t clipped_cells = 0, merged_cells = 0, own_particle_cells = 0;
  bool exact_boundary = false;  ///< closed meshes: volume, centroid and inertia are exact (no staircase)
  Eigen::Vector3d bbox_min = Eigen::Vector3d::Zero(), bbox_max = Eigen::Vector3d::Zero();  ///< of the input
  double open_fraction = 0.0;  ///< leaked / ray-filled cells (density methods), 0 for closed meshes
  MeshTopology topology;       ///< meshes only
  std::size_t dense_cells = 0, ray_filled_cells = 0, leaked_cells = 0;
  int closing_cells = 0;  ///< closing radius used (density methods)
  double seconds = 0.0;
  MeshRepairReport repair;  ///< meshes only: faces dropped, holes closed, open pieces left out
  /// Why a mesh was not filled by the exact inside test ("" when it was, or for other inputs).
  std::string fallback;
  /// One line each: every repair, fallback and suspicion (a suspiciously large object, ...). Never
  /// silent: the CLI prints them and --json lists them.
  std::vector<std::string> warnings;
};

/// Throws TopoError naming surface.source for: no points, fewer than 4 points, zero extent,
/// coordinates beyond kMaxCoordinateM, an object thinner than the given spacing, a spacing that would
/// exceed max_cells or max_memory_bytes, an open surface beyond max_open_fraction, or a surface that
/// encloses no volume at this spacing. Meshes are repaired first (repairMesh), with warnings.
VolumeCloud fillInterior(const SurfaceData& surface, const FillOptions& options, FillReport* report = nullptr);

/// Checks the options alone (ranges, direction codes); throws TopoError naming `what`.
void validateFillOptions(const FillOptions& options, const std::string& what);

}  // namespace topo_gaussian::geometry
