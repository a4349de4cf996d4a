// Rigid-body simulator (paper §6.1, §6.3, §6.4): Newton–Euler on 6 DoF with a unit quaternion,
// RK2 (midpoint) time stepping, gravity, optional linear/angular damping, penalty contact of the
// surface particles with a ground plane E = ½ k min(δ − d, 0)² plus friction, and an optional pivot
// (ball joint: the object hangs from a body point fixed in the world and swings as a physical
// pendulum).
//
// The motion depends on the interior only through the ten MassProperties numbers. The simulator is a
// template on the scalar type: with S = Dual10 (forward-mode dual numbers seeded by seedInertia) every
// state carries its derivative w.r.t. [m, cx, cy, cz, Ixx, Iyy, Izz, Ixy, Ixz, Iyz]. Explicit
// instantiations exist for double and Dual10.
//
// Frames: world z up, gravity (0, 0, −9.81) by default. A body point b (rest/body coordinates, the
// frame the particles were sampled in) is at  x = position + R(orientation) (b − com)  in the world.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <functional>
#include <string>
#include <unsupported/Eigen/AutoDiff>
#include <vector>

#include "topo_gaussian/physics/mass_properties.h"
#include "topo_gaussian/physics/run_limits.h"

namespace topo_gaussian {

/// Forward-mode dual number carrying d/d(the ten MassProperties parameters).
using Dual10 = Eigen::AutoDiffScalar<Eigen::Matrix<double, 10, 1>>;

template <typename S>
using Vec3 = Eigen::Matrix<S, 3, 1>;
template <typename S>
using Mat3 = Eigen::Matrix<S, 3, 3>;

/// Value part of a double or a Dual10.
inline double valueOf(double x) { return x; }
inline double valueOf(const Dual10& x) { return x.value(); }

template <typename S>
struct RigidInertia {
  S mass;           ///< [kg]
  Vec3<S> com;      ///< body frame [m]
  Mat3<S> inertia;  ///< about com, body frame [kg m²]
};

/// Plain copy (double).
RigidInertia<double> toInertia(const MassProperties& props);
/// Dual copy whose derivative vectors are the unit vectors e_k in MassProperties::toVector order
/// (the symmetric off-diagonal pairs share one seed).
RigidInertia<Dual10> seedInertia(const MassProperties& props);

/// Penalty contact with the plane z = height_m (normal +z), applied to the contact points.
struct GroundContact {
  double height_m = 0.0;
  /// Penalty stiffness k per contact point [N/m]. 0 = automatic: chosen from the mass, gravity and
  /// the number of points so the resting penetration is small (see the .cpp); the value used is
  /// reported in RigidTrajectory::stiffness_used.
  double stiffness_n_per_m = 0.0;
  double offset_m = 0.0;       ///< δ: particles are pushed out when closer than δ to the plane
  double damping_ratio = 0.1;  ///< normal damping as a fraction of critical (per contact point)
  double friction_mu = 1.0;    ///< Coulomb coefficient; large enough → rolling without slipping
  bool enabled = true;
  /// Relative weight w_i of each contact point (its share of the surface area over the mean share):
  /// point i gets stiffness k w_i (normal and tangential) and damping c w_i, so the points integrate a
  /// pressure over the surface (Σ_i k w_i pen_i ≈ (k / Ā) ∫ pen dA) instead of counting points. Empty =
  /// all 1; otherwise one positive finite weight per contact point.
  std::vector<double> point_weights;
};

struct RigidSimOptions {
  double duration_s = 2.0;
  double output_dt_s = 5e-3;   ///< sampling interval of the returned trajectory (paper: 5e-3)
  double max_substep_s = 0.0;  ///< 0 = automatic (stable for the contact stiffness)
  Eigen::Vector3d gravity = Eigen::Vector3d(0.0, 0.0, -9.81);
  double linear_damping_per_s = 0.0;
  double angular_damping_per_s = 0.0;
  GroundContact ground;
  bool pivot = false;  ///< ball joint: pivot_body stays at pivot_world
  Eigen::Vector3d pivot_body = Eigen::Vector3d::Zero();
  Eigen::Vector3d pivot_world = Eigen::Vector3d::Zero();
  /// Polled every 64 substeps; true throws SimulationCancelled (physics/run_limits.h).
  StopCheck should_stop;
  /// Called after every output sample (time_s[k] > 0) with the sample's time [s] and orientation
  /// (value part, body → world); returning true ends the simulation there, the trajectory ending with
  /// that sample. A task whose observations are complete before duration_s (the tumbler's first
  /// measured cycles) stops the optimiser's simulations early. Null: the full duration_s.
  std::function<bool(double time_s, const Eigen::Quaterniond& orientation)> stop_after_sample;
};

template <typename S>
struct RigidState {
  Vec3<S> position;                  ///< world position of the centre of mass [m]
  Eigen::Quaternion<S> orientation;  ///< body → world
  Vec3<S> velocity;                  ///< [m/s]
  Vec3<S> angular_velocity;          ///< world frame [rad/s]
};

template <typename S>
struct RigidTrajectory {
  std::vector<double> time_s;
  std::vector<RigidState<S>> states;  ///< states[k] at time_s[k]; states[0] is the initial state
  double substep_s = 0.0;             ///< the integration step used (the smallest one when automatic)
  double stiffness_used = 0.0;        ///< the penalty stiffness used [N/m]
};

/// Simulates from `initial` for options.duration_s. contact_points_body are body-frame points
/// (usually the surface particles). Throws TopoError on bad input (non-positive mass or inertia,
/// dt ≤ 0, NaN) and when the simulation diverges (NaN or energy growth): the message names the step,
/// the time, the likely cause and suggests a smaller step. Before the first step it refuses (TopoError
/// with the numbers) more than kMaxSimulationSteps substeps, kMaxParticleSteps substeps × contact
/// points, or a trajectory over kMaxSimulationBytes (physics/run_limits.h); whenever the automatic
/// substep is chosen (each output sample) it refuses the rest of the run when substeps × points in
/// contact would exceed kMaxContactPointSteps (checkContactWork: a finely sampled flat face landing);
/// throws SimulationCancelled when options.should_stop returns true.
template <typename S>
RigidTrajectory<S> simulateRigid(const RigidInertia<S>& inertia, const RigidState<S>& initial,
                                 const std::vector<Eigen::Vector3d>& contact_points_body,
                                 const RigidSimOptions& options);

/// A state at rest on the ground with the given orientation: zero velocity, the centre of mass placed
/// so that the lowest contact point sits where its penalty force about balances gravity.
template <typename S>
RigidState<S> restingState(const RigidInertia<S>& inertia, const Eigen::Quaterniond& orientation,
                           const std::vector<Eigen::Vector3d>& contact_points_body, const RigidSimOptions& options);

/// A state hanging from the pivot with the given orientation, zero velocity (position follows from
/// the pivot constraint).
template <typename S>
RigidState<S> pivotState(const RigidInertia<S>& inertia, const Eigen::Quaterniond& orientation,
                         const RigidSimOptions& options);

/// Total energy (kinetic + gravitational + contact penalty) of a state; used for divergence checks
/// and tests.
template <typename S>
S rigidEnergy(const RigidInertia<S>& inertia, const RigidState<S>& state,
              const std::vector<Eigen::Vector3d>& contact_points_body, const RigidSimOptions& options);

}  // namespace topo_gaussian
