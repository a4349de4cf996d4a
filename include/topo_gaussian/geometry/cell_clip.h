// Exact inside volume and first moment of every lattice cell cut by a closed triangle mesh
// (paper §4: the particles X_i, V_i of a solid; DESIGN "Boundary particles carry the inside
// fraction of their cell so m, c and I are exact").
//
// For a closed, outward-oriented mesh the inside indicator is the upward-ray winding number
//   χ(p) = Σ_t s_t [p_z < z_t(p_x, p_y)],   s_t = sign(n_t · e_z),
// summed over the triangles t whose xy-projection contains (p_x, p_y). Integrating over the cell
// [x0,x1]×[y0,y1]×[z0,z1] (column square Q) in z first gives, with signed projected area dA,
//   V    = Σ_t ∫_{proj(t)∩Q} (clamp(z_t, z0, z1) − z0) dA,
//   ∫x χ = Σ_t ∫ x (clamp(z_t) − z0) dA,   ∫z χ = Σ_t ∫ ½(clamp(z_t)² − z0²) dA.
// Each triangle is clipped to the column (Sutherland–Hodgman, orientation kept) and split by the
// planes z = z0 and z = z1: on the middle piece the integrand is linear in z_t, on the top piece
// constant; the integrands are polynomials of degree ≤ 2 on polygons, exact with the edge-midpoint
// rule on a fan triangulation. Pieces wholly above a cell add (z1 − z0)·(area, ∫x, ∫y) by a sweep
// down the column, so every cell of the column is exact, including those a vertical face cuts.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "topo_gaussian/geometry/lattice.h"
#include "topo_gaussian/geometry/surface_data.h"

namespace topo_gaussian::geometry {

/// The inside part of one lattice cell that the surface cuts.
struct CellPart {
  std::size_t cell = 0;                                ///< Lattice::index(i, j, k)
  double volume_m3 = 0.0;                              ///< ∫_cell χ dV, in (0, h³)
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();  ///< ∫_cell χ x dV / volume [m]
};

struct CellClipResult {
  /// Cells whose inside fraction (|winding integral| / h³) lies strictly between kPartialTolerance
  /// and 1 − kPartialTolerance, in increasing cell index. Every other cell is wholly inside or wholly outside.
  std::vector<CellPart> partial;
  double volume_m3 = 0.0;  ///< Σ over all cells of the inside volume (the mesh volume within the lattice)
  /// Cells whose winding number integral leaves [0, h³] by more than the tolerance: the mesh is not
  /// consistently outward oriented, or it overlaps itself (two shells over one region). 0 when sound.
  /// Such a cell is taken by the non-zero rule: wholly inside beyond h³, |integral| below 0, which is
  /// exact unless the cell also holds winding 0 beside winding 2 or more (where two shells' surfaces
  /// cross: the part counted twice is then not removed).
  std::size_t winding_anomalies = 0;
  std::size_t wholly_inside = 0;  ///< cells whose inside fraction is 1 (within the tolerance)
  /// Per lattice cell: 1 when wholly inside (fraction ≥ 1 − kPartialTolerance), else 0.
  std::vector<std::uint8_t> inside;
};

/// Fractions of h³ closer than this to 0 or 1 count as wholly outside or inside.
constexpr double kPartialTolerance = 1e-9;

/// Exact inside volumes and centroids of the cells of `lattice` cut by `mesh` (closed, outward
/// oriented; see the formula above). Only the triangles overlapping a column are visited; columns
/// are processed in parallel (OpenMP). Never throws; a mesh that is not consistently oriented shows as
/// winding_anomalies > 0 or a negative volume_m3.
CellClipResult clipCells(const SurfaceData& mesh, const Lattice& lattice);

/// Signed volume of a triangle mesh, Σ_t (a·(b×c))/6: positive for a closed outward-oriented one.
double meshSignedVolume(const SurfaceData& mesh);

}  // namespace topo_gaussian::geometry
