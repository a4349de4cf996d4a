// Contact samples on the object's true surface (issue: contact on the real surface, not the lattice).
// The particles of a fill sit on a lattice; the ones at the boundary form a staircase whose rocking on
// the ground differs from the smooth body's by several % (a filled hemisphere of R = 0.1 m at 3.5 mm:
// period 0.788 s against the exact 0.8404 s). The samples returned here are points y_k on the input
// surface with outward normals n_k and the area A_k each stands for (Σ A_k ≈ the surface area), evenly
// spread at spacing s: dense candidates (≈ 9 per s²) are thinned to a maximal Poisson-disk set of radius
// 0.85 s, each candidate's area going to the nearest kept sample (an irregular sampling makes the
// contact bumpy: random points at s = 1.5 mm rock a hemisphere 10 % slow at 3°). The candidates:
//  - closed or open meshes: n_t = max(1, round(9 A_t / s²)) points on every face (its centroid, or the
//    R2 low-discrepancy sequence folded into the triangle), each standing for A_t / n_t, with the face
//    normal oriented by the sign of the mesh's signed volume V = ⅙ Σ (a × b)·c (an inverted mesh is
//    flipped, with a warning; an open mesh face by face, away from the filled particles);
//  - point clouds: the points averaged per cube of edge s/3, then moved onto the quadric height field
//    fitted to their neighbours within R_f = 8 s in the frame of their weighted plane (one second-order
//    moving-least-squares step: it removes most of a scan's noise without the inward pull of a plane
//    fit), the normal the fit's, turned away from the filled particles (or along the given normals);
//    each point's patch then carries candidates ≈ 36 per s² (R2 sequence over a disk), those of its
//    Voronoi cell on the surface (the candidates nearer to it than to any other point), each standing
//    for its patch area: the cells tile the surface, so after the thinning every sample stands for the
//    area around it whatever the scan's own layout (a dense scan's means: their kernel-density share);
//  - 3D Gaussians: the same with the centres of the opaque Gaussians (opacity ≥ 0.5), which sit on
//    the splat shell's mid-surface.
// A noisy scan's patches widen until the noise no longer bends the surface: R_f grows until the
// curvature its fitted heights' noise puts in (~√3 σ_h / (R_f/2)², σ_h the fit's height noise) is at
// most 0.5 % of 2 / the body's diagonal, up to a quarter of the diagonal, and stops short where an edge
// or a feature raises the scatter about the fit above 1.5 × the scan's. A scan whose points scatter
// about their local fits by more than s/20 gets a warning saying how far the patches widened.
// Points farther than two lattice spacings from every boundary particle of the fill (floaters, a
// scanner's stray returns) are not contact samples.
#pragma once

#include <string>
#include <vector>

#include "topo_gaussian/geometry/surface_data.h"
#include "topo_gaussian/physics/volume_cloud.h"

namespace topo_gaussian::geometry {

struct ContactSampleOptions {
  bool enabled = true;
  /// Spacing s of the samples [m]; 0 = automatic: defaultContactSpacing (finer than the particles).
  double spacing_m = 0.0;
  /// Refuse more samples than this (the spacing is too fine for the surface): TopoError with the
  /// spacing that would fit.
  double max_samples = 2e7;
  double min_opacity = 0.5;  ///< Gaussians: centres of Gaussians at least this opaque
};

/// Half the lattice spacing h, and at most a fraction of the bounding-box diagonal d of the filled
/// particles: d / 400 on a mesh, d / 200 on points and Gaussians (their own spacing and noise limit
/// what finer samples could add). Rocking within 1 % of the smooth body needs s ≲ 0.3 R θ at the
/// contact; a wobbly doll whose centre of mass sits only 0.17 R below its sphere's centre is ~5× more
/// sensitive: filled at 4 mm its period over release tilts 5…25° wanders −0.79…+0.08 % with samples at
/// d / 200 (0.78 mm) and −0.12…+0.21 % at d / 400 (RigTwin.TumblerPeriodOverReleaseTilts). The penalty
/// sum over the ~35 samples under the doll moves its resting height by bumps ∝ s.
double defaultContactSpacing(const VolumeCloud& filled, SurfaceKind kind);

/// Samples of `surface` (the input the cloud was filled from; meshes already repaired). `filled` gives
/// the lattice spacing, the boundary particles (floater rejection) and the inside (normal orientation).
/// Appends a line to *warnings for an inverted mesh, dropped floaters and degenerate faces. Throws
/// TopoError naming surface.source when no sample remains (e.g. every point is a floater) or there
/// would be more than max_samples.
ContactSamples sampleContactSurface(const SurfaceData& surface, const VolumeCloud& filled,
                                    const ContactSampleOptions& options, std::vector<std::string>* warnings);

}  // namespace topo_gaussian::geometry
