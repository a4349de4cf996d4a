// The peer world's reference observations for bench/interiors (`--world peer`): what the experiments
// show of an object whose interior is known, made without this package's simulators or renderer.
//   - Mass moments: exact, from the object's true mesh (signed tetrahedra) and the interior region's
//     closed form (sphere, ellipsoid, box, a sphere cut by a horizontal plane) or the mesh clipped by its plane
//     (half-space):
//       M = ρ_body M(mesh) + (ρ_region − ρ_body) M(region ∩ mesh).
//   - Hanging: the rest pose puts c straight below the point (roll, pitch of inference::targetRotation);
//     a swing on a horizontal axle a through the point (the compound pendulum, exact for a rigid body on
//     a hinge): s = c − p, s⊥ = s − (a·s) a, d = |s⊥|, I_a = aᵀ I_c a + m d²,
//       T = 4 √(I_a / (m g d)) K(sin(A/2))   (K the complete elliptic integral, A the amplitude).
//   - Rocking: Bullet (the mesh's convex hull with the exact mass properties, peer_world/bullet_rocking.h),
//     seen by a level camera along +x through a distorting lens, rendered by the independent rasteriser
//     (peer_world/mesh_renderer.h) with shading, blur, noise and a textured backdrop; the frames go to
//     the motion tracker (silhouette tilt) and the task's rule makes the targets, as `topo track` →
//     `topo infer` would.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <string>
#include <vector>

#include "topo_gaussian/geometry/surface_data.h"
#include "topo_gaussian/inference/task_config.h"
#include "topo_gaussian/physics/mass_properties.h"

namespace topo_gaussian::bench {

/// The interior region R in the object's frame [m]: R = {x : n·(x − centre) > 0} for a half-space;
/// SphereBelow: the sphere (centre, radius half.x()) below the horizontal plane z = cut_z_m (a cavity cut
/// flat under an object's top, as the rig twin's default cavity under its pinned shell).
struct PeerRegion {
  enum Kind { Sphere, Ellipsoid, Box, HalfSpace, SphereBelow } kind = Sphere;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  Eigen::Vector3d half = Eigen::Vector3d::Zero();  ///< radius (x), semi-axes or half edges [m]
  Eigen::Vector3d normal = Eigen::Vector3d::UnitX();
  double cut_z_m = 0.0;  ///< SphereBelow: the cutting plane's height [m]
  bool inside(const Eigen::Vector3d& x) const;
};

/// The exact moments of the part of the sphere (centre, radius) below z = cut_z_m at density_kg_m3: a solid
/// of revolution about the vertical through the centre, its slices' integrals (polynomials of degree ≤ 4 in
/// z) by 5-point Gauss–Legendre. Throws TopoError for a non-positive radius or a plane below the sphere.
MassProperties sphereBelowMoments(const Eigen::Vector3d& centre_m, double radius_m, double cut_z_m,
                                  double density_kg_m3);

/// The object as the peer world knows it: its true mesh and exact moments.
struct PeerObject {
  std::vector<Eigen::Vector3d> vertices;    ///< [m], the frame `topo fill` gives the cloud
  std::vector<Eigen::Vector3i> triangles;   ///< closed, outward
  MassProperties truth;                     ///< body with its interior
  MassProperties plain;                     ///< the body all of its own material (no interior)
};

/// `mesh` is the object's surface in the cloud's frame (read, up axis and scale as `topo fill`). Throws
/// TopoError when the mesh is not closed or the region (sphere, ellipsoid, box) reaches outside it.
PeerObject makePeerObject(const geometry::SurfaceData& mesh, const PeerRegion& region, double density_body_kg_m3,
                          double density_region_kg_m3);

/// The axle swing's period [s] (formula above) of the body with moments `m` hung from `point_m` (body
/// frame), axle `axle_body` (unit, body frame), amplitude [deg], gravity [m/s²]. NaN when c is on the axle.
double axleSwingPeriod(const MassProperties& m, const Eigen::Vector3d& point_m, const Eigen::Vector3d& axle_body,
                       double amplitude_deg, double gravity_m_s2);

/// Rocking seen through the peer camera: Bullet's motion, the tracker's features and the task's targets.
struct PeerRockingVideo {
  int frames = 0;
  double render_ms = 0;                                    ///< mean rasterising time per frame
  double bullet_period_s = NAN, bullet_max_tilt_deg = NAN;  ///< Bullet's tilt signal by the task's rule
  double tracked_period_s = NAN, tracked_max_tilt_deg = NAN;
  double tilt_error_mean_deg = NAN, tilt_error_max_deg = NAN;  ///< |tracked| − |Bullet's| at the frames
  std::vector<std::pair<std::string, double>> targets;        ///< set on the config too
  std::string note, tracker_message;
};

/// Rocks the object (the config's rocking_axis, up_axis, initial_tilt_deg and gravity) for `duration_s` in
/// Bullet, renders it at `fps` (pixel noise σ = 2 × noise_scale grey levels, the frames written as PNGs to
/// `frames_dir` when not empty), tracks the silhouette's tilt and sets the task's targets on `config`.
/// Throws TopoError when the tracker gives no targets.
PeerRockingVideo observeRockingThroughPeerVideo(inference::TaskConfig& config, const PeerObject& object,
                                                double duration_s, double fps, double noise_scale,
                                                const std::string& frames_dir = "");

/// The hanging experiment `config` (its hanging_point, axle_heading_deg, axle_swing_amplitude_deg, gravity)
/// in the peer world: the rest pose (hangingRestPose of the true centre of mass) and the periods of the swings
/// on a horizontal axle through the point along world x turned by axle_heading_deg (axle_swing_period_s) and
/// 90° more (cross_axle_swing_period_s), in that rest pose, by axleSwingPeriod.
struct PeerHang {
  double roll_deg = NAN, pitch_deg = NAN, axle_swing_period_s = NAN, cross_axle_swing_period_s = NAN;
};
PeerHang peerHang(const inference::TaskConfig& config, const PeerObject& object);

/// Bullet's rocking of the object released at the config's tilt about its rocking axis (duration_s), by the
/// task's rule (measured_cycles from the release): period [s] and largest tilt [deg], as numbers (a rocking
/// axis the rig's camera along x does not see edge-on needs no video). Throws TopoError without a full period.
struct PeerRocking {
  double period_s = NAN, max_tilt_deg = NAN;
};
PeerRocking peerRocking(const inference::TaskConfig& config, const PeerObject& object);

/// Bullet's rocking period [s] of the object released at the config's tilt about its rocking axis, by the
/// task's rule (its measured_cycles, from the release): the held-out reference of a rocking experiment.
double peerRockingPeriod(const inference::TaskConfig& config, const PeerObject& object);

}  // namespace topo_gaussian::bench
