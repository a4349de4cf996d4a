// Default shapes for the soft-body tasks: analytic solids with an exact inside test, used when a
// task needs a shape of its own (finger, pear, beam) and no surface is given, and written by
// `topo shape NAME --output FILE.obj` for users to inspect or print. Eigen only.
//
// Dimensions (metres, world z-up):
//   beam     box x ∈ [0, 0.2], y ∈ [−0.01, 0.01], z ∈ [−0.01, 0.01]: a cantilever clamped at its
//            min-x end (x = 0). Volume 8.0e-5 m³.
//   finger   a pneumatic finger lying along +x with its base at x = 0: box x ∈ [0, 0.1],
//            y ∈ [−0.01, 0.01], z ∈ [−0.0075, 0.0075] with a rounded tip — the last 7.5 mm in x is a
//            half-cylinder of radius 7.5 mm about the y axis (a point with x > 0.0925 is inside iff
//            (x − 0.0925)² + z² ≤ 0.0075²). Volume 0.0925·0.02·0.015 + ½π·0.0075²·0.02 ≈ 2.952e-5 m³.
//   pear     a solid of revolution about z, bottom at z = 0, top at z = 0.12: the smooth union of a
//            bulb (sphere of radius 0.04 centred at z = 0.04) and a head (sphere of radius 0.02
//            centred at z = 0.10), with the quadratic smooth minimum of their signed distances,
//              d(x) = min(a, b) − k h²/4,  h = max(k − |a − b|, 0)/k,  k = 0.04 m,
//            a = |x − (0,0,0.04)| − 0.04, b = |x − (0,0,0.10)| − 0.02; inside iff d ≤ 0. The blend
//            fills the waist between the spheres, so the radius falls monotonically from 0.04 m at
//            z = 0.04 to ≈ 0.022 m at z = 0.10 and the ends stay the spheres' poles (rounded, closed,
//            exactly at z = 0 and z = 0.12). Volume ≈ 3.383e-4 m³ (pearRadius integrated).
//   tumbler  a sphere of radius 0.05 centred at the origin, cut flat at z = 0.02 (the round-bottomed
//            tumbler body; the same solid as tumblerCloud(0.05, 0.4, h) in the tests). Volume
//            4/3 π R³ − π (R − c)² (2R + c)/3 with R = 0.05, c = 0.02 ≈ 4.105e-4 m³.
#pragma once

#include <Eigen/Core>
#include <functional>
#include <string>
#include <vector>

#include "topo_gaussian/physics/volume_cloud.h"

namespace topo_gaussian {

/// The dimensions above, for code that builds the same solids another way (meshes, tasks).
namespace default_shape_dims {
constexpr double kBeamLength = 0.2, kBeamHalfWidth = 0.01, kBeamHalfHeight = 0.01;
constexpr double kFingerLength = 0.1, kFingerHalfWidth = 0.01, kFingerHalfHeight = 0.0075;
constexpr double kFingerTipRadius = kFingerHalfHeight;                  ///< half-cylinder about y
constexpr double kFingerTipCentreX = kFingerLength - kFingerTipRadius;  ///< 0.0925
constexpr double kPearHeight = 0.12;
constexpr double kPearBulbRadius = 0.04, kPearBulbCentreZ = 0.04;
constexpr double kPearHeadRadius = 0.02, kPearHeadCentreZ = 0.10;
constexpr double kPearBlend = 0.04;  ///< smooth-minimum width k
constexpr double kTumblerRadius = 0.05, kTumblerCutZ = 0.02;
}  // namespace default_shape_dims

/// How a closed surface of a shape is built (geometry/shape_generator.h meshes it), in the shape's
/// own terms so that a shape is declared in one place: the box [lo, hi]; a convex polygon in the x-z
/// plane, counter-clockwise (x right, z up), extruded along y ∈ [−half_width, half_width]; or a
/// meridian profile (r, z) from the bottom pole (r = 0) to the top pole (r = 0), the solid on its left,
/// revolved about z.
struct ShapeOutline {
  enum class Kind { Box, ExtrudedAlongY, RevolvedAboutZ };
  Kind kind = Kind::Box;
  std::vector<Eigen::Vector2d> curve;  ///< the polygon (x, z) or the profile (r, z); empty for the box
  double half_width = 0.0;             ///< of the extrusion [m]
};

struct DefaultShape {
  std::string name;
  std::string description;   ///< one line with the dimensions, for help texts and messages
  Eigen::Vector3d lo, hi;    ///< tight axis-aligned bounds [m]
  double thickness_m = 0.0;  ///< thinnest dimension (beam 0.02, finger 0.015, pear 0.04 = head, tumbler 0.07)
  double volume_m3 = 0.0;    ///< exact volume (pear: its profile integrated to 1e-9 relative)
  std::function<bool(const Eigen::Vector3d&)> inside;  ///< closed solid: the boundary counts as inside
  /// Its surface at `resolution` segments around a full circle (8..4096; a half-round part gets
  /// resolution / 2).
  std::function<ShapeOutline(int resolution)> outline;
};

/// {"finger", "pear", "beam", "tumbler"}: the shapes of the one list in default_shapes.cpp, where
/// each shape declares its dimensions, inside test and outline (a new shape is one entry there).
const std::vector<std::string>& defaultShapeNames();

/// The shape by name. Throws TopoError for an unknown name, listing the valid ones.
DefaultShape defaultShape(const std::string& name);

/// Signed distance-like field of the pear (negative inside, zero on the surface; it is the smooth
/// minimum above, exact distance away from the blend).
double pearField(const Eigen::Vector3d& x);
/// Radius of the pear's cross-section at height z [m] (0 outside [0, 0.12]); the surface of the
/// pear is { (r cos φ, r sin φ, z) : r = pearRadius(z) }.
double pearRadius(double z_m);

/// Cell-centred lattice cloud of the shape: cells of edge `spacing_m` centred on the shape's
/// bounding box, one particle per cell whose centre is inside, V_i = spacing³, surface_i = 1 when
/// one of the 6 neighbouring cell centres is outside. Throws TopoError for a spacing that is not a
/// positive finite number, one too coarse for 3 particles across the thinnest dimension (the
/// message gives the largest spacing to use), or one so fine that the lattice would exceed 2·10⁷
/// cells (the message gives the finest spacing to use).
/// A spacing that divides the dimensions (2.5 mm, 1 mm, 0.5 mm) makes the box parts exact; any
/// other rounds each thin dimension to a whole number of cells (finger at 1.1 mm: +7 % volume).
/// The cloud carries contact samples on the exact surface (shapeContactSamples at spacing h / 2, or h
/// when the finer lattice would exceed 2·10⁷ points).
VolumeCloud defaultShapeCloud(const std::string& name, double spacing_m);
VolumeCloud defaultShapeCloud(const DefaultShape& shape, double spacing_m);

/// Points on the shape's exact surface: along every line of a lattice of spacing s (cells centred on
/// the bounding box grown by one cell) where `inside` changes between neighbouring points, the
/// crossing found by bisection to 1e-12 m. Normals from the plane of the crossings within 2.5 s
/// (oriented by the crossing's direction); a crossing along axis a stands for the area s² |n_a| (the
/// crossings along a have areal density |n_a| / s², so Σ_a |n_a|² = 1 gives the area).
ContactSamples shapeContactSamples(const DefaultShape& shape, double spacing_m);

}  // namespace topo_gaussian
