// The boundary of a solid given by surface points (scans, point clouds, 3D Gaussian centres) and the
// inside fraction of the lattice cells it cuts (paper §4 / appendix: particles carry a volume V_i;
// boundary particles get the inside fraction of their cell, V_i = f_i h³).
//
//   f(x) = Σ_i w_i(x) n_iᵀ(x − p_i) / Σ_i w_i(x),   w_i(x) = a_i exp(−|x − p_i|² / r²)
//
// is the implicit moving-least-squares signed distance of an oriented point set (Kolluri 2008,
// "Provably good moving least squares"): negative inside, zero on the sampled surface, exact for a
// plane whatever the sampling, and offset by only ≈ r²/(2R) on a surface of curvature radius R.
// Normals n_i are given, or the PCA normals of the k nearest points, oriented outward by a coarse
// solid (the density fill), which also drops points it cannot orient (floaters inside or outside).
// A cell's inside fraction is that of the plane through its centre that the trilinear field of its
// eight corners defines: f_c + gᵀ(x − ½) ≤ 0 on the unit cube, in closed form
//
//   V(α) = Σ_{c∈{0,1}³} (−1)^{|c|} max(0, α − mᵀc)³ / (6 m₁ m₂ m₃),   m = |g|, α = ½ Σ m − f_c
//
// (inclusion–exclusion of the corner simplices), so the volume changes smoothly with the spacing
// and the lattice's alignment instead of by whole cells.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "topo_gaussian/geometry/lattice.h"

namespace topo_gaussian::geometry {

struct OrientedPoints {
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector3d> normals;  ///< unit, outward once oriented
  std::vector<double> weights;           ///< a_i ≥ 0 (Gaussians: opacity; points: 1; 0 = unused)
};

/// Unit normals of the points' least-variance direction over their k nearest neighbours (sign
/// arbitrary; zero for a point with fewer than 3 distinct neighbours).
std::vector<Eigen::Vector3d> pcaNormals(const std::vector<Eigen::Vector3d>& points, int k = 16);

/// Exact Euclidean distance [m] from every cell centre of `grid` to the nearest centre of a `seeds`
/// cell (Felzenszwalb & Huttenlocher 2012: three separable passes of the 1D lower envelope of
/// parabolas); +inf everywhere when there is no seed. Unlike a 6-neighbour distance in cells it does
/// not depend on the grid's resolution or its alignment with the surface (beyond ±h/2).
std::vector<float> euclideanDistance(const Lattice& grid, const std::vector<std::uint8_t>& seeds);

/// Trilinear interpolation of a cell-centred field (euclideanDistance) at x, clamped to the
/// outermost cell centres; `beyond` outside the lattice.
double interpolateCells(const Lattice& grid, const std::vector<float>& cell_field, const Eigen::Vector3d& x,
                        double beyond);

/// Orients each normal outward and keeps only the outermost points. `outside_m` is, per cell of
/// `grid`, the distance [m] to the nearest cell outside the density shell (euclideanDistance),
/// `solid_m` the distance [m] to the density fill's solid. The depth of a point below the shell's
/// outside is d(p) = outside_m(p) − h/2 (the boundary lies half a cell from the outside cells'
/// centres). A normal is flipped to point where d decreases (looking 1.5, 2.5 and 4 cells along
/// ±n); a point gets weight 0 when no offset tells the sides apart, when it lies deeper than skin_m
/// (points inside a 3D Gaussian model), or farther than skin_m + floater_margin_m from the solid
/// (floaters). All lengths in metres, so which points are kept does not change with the grid.
/// Returns the number of points given weight 0.
std::size_t orientNormals(OrientedPoints& points, const Lattice& grid, const std::vector<float>& outside_m,
                          const std::vector<float>& solid_m, double skin_m, double floater_margin_m);

/// f(x) at the nodes (cell corners, (n+1)³, x fastest) of `lattice`, kernel radius radius_m, from
/// the points within reach_m of the node (at least 3·radius_m is used); NaN where there are none.
std::vector<double> nodeSignedDistance(const OrientedPoints& points, const Lattice& lattice, double radius_m,
                                       double reach_m);

/// Hash key of the cube of side cell_m that holds p (floor(p / cell_m), 21 bits per axis): for
/// binning points in a std::unordered_map.
std::int64_t cubeKey(const Eigen::Vector3d& p, double cell_m);

/// A dense point set as the weighted means of its points per cube of side cell_m: position Σ a_i p_i / Σ a_i,
/// normal the normalised Σ a_i n_i, weight Σ a_i (points of weight 0 left out). With cell_m ≤ r / 2 the
/// field f above changes by O((cell_m / r)²) of r; nodeSignedDistance's cost falls with the number of
/// points (a 2M-point scan at r = 0.56 mm: ~6 000 points within reach of a node, ~1 000 binned).
OrientedPoints binnedPoints(const OrientedPoints& points, double cell_m);

/// Trilinear interpolation of node values (nodeSignedDistance) at x; NaN outside the lattice or
/// where a corner is undefined.
double interpolateNodes(const Lattice& lattice, const std::vector<double>& node_field, const Eigen::Vector3d& x);

/// The field of the outermost layer of the points: a 3D Gaussian model (and a thick scan) has
/// points inside the object too, which would pull f's zero level inwards. Computes f, drops
/// (weight 0) the points lying deeper than `depth_m` inside it (f(p_i) < −depth_m), and repeats
/// until none is dropped (at most `rounds` times). Returns the final node field; *dropped counts.
std::vector<double> outerSurfaceDistance(OrientedPoints& points, const Lattice& lattice, double radius_m,
                                         double reach_m, double depth_m, int rounds = 4,
                                         std::size_t* dropped = nullptr);

/// Fraction of the unit cube where f_c + gᵀ(x − ½) ≤ 0 (f_c the value at the centre, g the gradient
/// in units of the cube's edge), in [0, 1]; exact also when components of g vanish (a plane
/// parallel to faces: the 2D or 1D form of V(α)).
double cubeFractionBelowPlane(double f_centre, const Eigen::Vector3d& gradient);

/// Inside fraction of every cell of `lattice` from its corners' field values (nodeSignedDistance);
/// an undefined corner (beyond reach, at least 2.5 h from every point) takes +2.5 h where
/// `fallback_solid` says its cell is outside, else the mean of the defined ones. A cell with no
/// defined corner is beyond
/// the field's reach: solid (1) where `fallback_solid` is and the fallback solid is connected
/// (6-neighbours, through such cells) to a cell at least half inside by the field, else 0 (a blob of
/// the density fill around points the field left out is not the object). Then cells whose fraction
/// is below min_fraction give their volume to the 26-neighbour with the largest fraction (so no
/// particle is tiny and no volume is lost); a cell with none keeps it.
std::vector<float> cellInsideFractions(const Lattice& lattice, const std::vector<double>& node_field,
                                       const std::vector<std::uint8_t>& fallback_solid, double min_fraction = 0.1);

}  // namespace topo_gaussian::geometry
