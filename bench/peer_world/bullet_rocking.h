// θ(t) = atan2(u·(a × e_z), u·e_z), u = R(t) û_body: a rigid object rocking on the ground plane z = 0,
// simulated by Bullet (not by this package's rigid simulator) with exact mass properties, for ground
// truth in the peer world.
//
// Conventions (those of the tumbler task, src/inference/tumbler_task.cpp with physics::restingState):
//   - Upright: U, the smallest rotation taking up_axis_body to world +z (a half turn about the rocking
//     axis when up_axis_body is −z). With the default up_axis_body = z, U = 1: the body frame is the world
//     frame, as the task's release q0 = AngleAxis(θ0, axis) is applied to the body frame as it is.
//   - Rocking axis in the world: a = U â_body (horizontal; rocking_axis_body must be perpendicular to
//     up_axis_body). The release orientation is R0 = AngleAxis(θ0, a) U: a positive initial_tilt_deg turns
//     the body right-handed about a, so its up axis goes from e_z to cos θ0 e_z + sin θ0 (a × e_z). With
//     the defaults (a = x) a positive tilt leans the up axis towards −y.
//   - Tilt signal: θ(t) = atan2(u·(a × e_z), u·e_z) [deg], u = R(t) up_axis_body: the task's tilt_deg, so
//     θ(0) = initial_tilt_deg exactly.
//   - Release position: the centre of mass at x = y = 0 (as the task's restingState), at the height that
//     puts the hull's lowest vertex at z = 0 (Bullet's collision margin 0: exactly touching; the task's
//     penalty contact starts that far minus its rest penetration), at rest.
//   - world_from_body maps points given in the mesh's frame (the frame of vertices_body and of
//     MassMoments) to the world: x_world = world_from_body · x_body.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

#include "peer_world/exact_mass.h"

namespace topo_gaussian::peer {

struct RockingOptions {
  Eigen::Vector3d rocking_axis_body = Eigen::Vector3d::UnitX();  ///< unitless direction, any length
  Eigen::Vector3d up_axis_body = Eigen::Vector3d::UnitZ();       ///< unitless direction, ⟂ rocking axis
  double initial_tilt_deg = 10;                                  ///< release tilt about the rocking axis, |θ0| < 90
  double duration_s = 4;
  double sample_dt_s = 1.0 / 240;
  double gravity_m_s2 = 9.81;  ///< magnitude, along world −z
  double friction = 1;         ///< Coulomb coefficient of the body and of the ground (Bullet multiplies them)
  double restitution = 0;
  double bullet_dt_s = 1.0 / 2000;
  int solver_iterations = 10;
};

/// Samples k = 0 … floor(duration_s / sample_dt_s) at time_s[k] = k sample_dt_s.
struct RockingRun {
  std::vector<double> time_s;
  std::vector<Eigen::Isometry3d> world_from_body;  ///< x_world = world_from_body[k] · x_body (mesh frame)
  std::vector<double> tilt_deg;  ///< atan2(u·(a × e_z), u·e_z), u = R up_axis_body, a the rocking axis in the world
};

/// θ(t) of the convex hull of `vertices_body` (mesh frame) with mass properties `m` (exact, e.g. meshMoments
/// and combine; inertia about the centre of mass in the mesh frame), released at rest at initial_tilt_deg
/// touching the plane z = 0 (conventions above), simulated by Bullet with friction, restitution, bullet_dt_s
/// and solver_iterations as given (rolling friction and damping 0). Bullet integrates in the principal frame:
/// I = Q diag(I_1, I_2, I_3) Qᵀ (det Q = +1), hull points v' = Qᵀ (v − c), world_from_body =
/// world_from_principal · principal_from_body. Sample 0 is the release pose itself; later samples interpolate
/// Bullet's steps (linear in position, slerp in rotation). Throws TopoError for empty or non-finite
/// vertices, a non-positive or non-finite mass, an inertia that is not symmetric positive definite, zero or
/// parallel axes, |initial_tilt_deg| ≥ 90, non-positive durations or steps, negative friction, restitution
/// outside [0, 1], non-positive gravity or solver_iterations, and a state that becomes non-finite.
RockingRun rockOnGround(const std::vector<Eigen::Vector3d>& vertices_body, const MassMoments& m,
                        const RockingOptions& o);

}  // namespace topo_gaussian::peer
