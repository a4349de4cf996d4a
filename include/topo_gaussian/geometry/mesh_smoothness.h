// Smoothness of a surface: the paper's quality metric, "the Laplacian of the surface normal"
// (TopoGaussian §8, Metrics; lower is smoother, better for 3D printing).
//
// Definition used here. n_i is the unit vertex normal (area-weighted mean of the incident triangles'
// normals) and N(i) the vertices sharing an edge with i. The uniform ("umbrella") Laplacian of the
// normal field at i is
//     U_i = (1 / |N(i)|) Σ_{j ∈ N(i)} n_j − n_i ,
// and the metric is the mean of |U_i| over the vertices. U_i is already dimensionless: on a smooth
// surface with edge length ℓ it approximates (ℓ²/4)·Δn (Δn in 1/m², e.g. −2n/R² on a sphere of radius
// R), so it is the continuous |Δn| made dimensionless by the squared mean edge length, and it tends to
// 0 as a smooth surface is sampled more finely (on the irregular triangles of a marching-tetrahedra
// mesh roughly like ℓ/R: 0.051 → 0.031 for a sphere of 4.4 → 8.75 spacings). On a staircase (a voxel
// surface) the normals turn by 90° at every step and |U_i| stays of order 0.1–1 at any resolution
// (0.245 for the voxelised sphere; a box with flat faces 0.047, from its edges).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "topo_gaussian/geometry/surface_data.h"

namespace topo_gaussian::geometry {

struct NormalSmoothness {
  double mean = 0.0;                ///< mean |U_i|: the metric (dimensionless, 0 for a plane)
  double rms = 0.0;                 ///< sqrt(mean |U_i|²)
  double max = 0.0;                 ///< largest |U_i|
  double mean_edge_length_m = 0.0;  ///< ℓ (for |Δn| ≈ 4 |U| / ℓ² in 1/m²)
  std::size_t vertices = 0;         ///< vertices with a normal and at least one neighbour
};

/// Needs a triangle mesh (any; a closed one for a meaningful value). Vertices without triangles or
/// with a zero normal are skipped. With `only` (one flag per point), the statistics are taken over
/// the flagged vertices (their neighbours may be any). Throws nothing; no vertex gives all zeros.
NormalSmoothness normalSmoothness(const SurfaceData& mesh, const std::vector<std::uint8_t>* only = nullptr);

}  // namespace topo_gaussian::geometry
