// R0 = AngleAxis(θ0, a) U, hull points v' = Qᵀ (v − c), I = Q diag(I_p) Qᵀ: the peer world's rocking object
// released on the ground and simulated by Bullet in its principal frame.
#include "peer_world/bullet_rocking.h"

#include <btBulletDynamicsCommon.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <string>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/number_text.h"

namespace topo_gaussian::peer {

namespace {

constexpr double kPi = 3.14159265358979323846;

void requirePositive(const std::string& name, double value, const std::string& fix) {
  if (!(value > 0) || !std::isfinite(value))
    throw TopoError("rockOnGround: " + name, "is " + numberText(value) + ", not a positive finite number", fix);
}

void validate(const std::vector<Eigen::Vector3d>& vertices, const MassMoments& m, const RockingOptions& o) {
  if (vertices.empty())
    throw TopoError("rockOnGround: vertices_body", "is empty",
                    "pass the object's mesh vertices (its convex hull rocks)");
  for (std::size_t i = 0; i < vertices.size(); ++i)
    if (!vertices[i].allFinite())
      throw TopoError("rockOnGround: vertices_body", "vertex " + std::to_string(i) + " is not finite",
                      "pass finite coordinates");
  requirePositive("mass_kg", m.mass_kg, "pass the object's mass moments (peer::meshMoments, peer::combine)");
  if (!m.com_m.allFinite()) throw TopoError("rockOnGround: com_m", "is not finite", "pass the object's centre of mass");
  const Eigen::Matrix3d& I = m.inertia_com_kg_m2;
  if (!I.allFinite() || (I - I.transpose()).norm() > 1e-9 * std::max(I.norm(), 1e-300))
    throw TopoError("rockOnGround: inertia_com_kg_m2", "is not a finite symmetric matrix",
                    "pass the inertia about the centre of mass (peer::meshMoments, peer::combine)");
  if (!(o.rocking_axis_body.allFinite() && o.rocking_axis_body.norm() > 0))
    throw TopoError("rockOnGround: rocking_axis_body", "is zero or not finite", "give a non-zero direction");
  if (!(o.up_axis_body.allFinite() && o.up_axis_body.norm() > 0))
    throw TopoError("rockOnGround: up_axis_body", "is zero or not finite", "give a non-zero direction");
  const double cosine = o.rocking_axis_body.normalized().dot(o.up_axis_body.normalized());
  if (std::abs(cosine) > 1e-6)
    throw TopoError("rockOnGround: rocking_axis_body and up_axis_body",
                    "are not perpendicular (cosine " + numberText(cosine) + ")",
                    "give a rocking axis perpendicular to the up axis (it is horizontal when the body is upright)");
  if (!std::isfinite(o.initial_tilt_deg) || std::abs(o.initial_tilt_deg) >= 90.0)
    throw TopoError("rockOnGround: initial_tilt_deg", "is " + numberText(o.initial_tilt_deg) + " deg",
                    "give a release tilt between −90 and 90 deg");
  requirePositive("duration_s", o.duration_s, "give a positive duration");
  requirePositive("sample_dt_s", o.sample_dt_s, "give a positive sample interval");
  requirePositive("bullet_dt_s", o.bullet_dt_s, "give a positive Bullet step");
  requirePositive("gravity_m_s2", o.gravity_m_s2, "give the gravity's magnitude (9.81)");
  if (!(o.friction >= 0) || !std::isfinite(o.friction))
    throw TopoError("rockOnGround: friction", "is " + numberText(o.friction), "give a coefficient ≥ 0");
  if (!(o.restitution >= 0 && o.restitution <= 1))
    throw TopoError("rockOnGround: restitution", "is " + numberText(o.restitution), "give a value in [0, 1]");
  if (o.solver_iterations < 1)
    throw TopoError("rockOnGround: solver_iterations", "is " + std::to_string(o.solver_iterations), "give at least 1");
}

/// U: the smallest rotation taking `up` (unit) to e_z; a half turn about `axis` (unit, ⟂ up) when up = −e_z.
Eigen::Quaterniond uprightRotation(const Eigen::Vector3d& up, const Eigen::Vector3d& axis) {
  if (up.z() < -1.0 + 1e-12) return Eigen::Quaterniond(Eigen::AngleAxisd(kPi, axis));
  return Eigen::Quaterniond::FromTwoVectors(up, Eigen::Vector3d::UnitZ()).normalized();
}

/// World from principal frame: rotation and centre-of-mass position.
struct PrincipalPose {
  Eigen::Quaterniond rotation;
  Eigen::Vector3d com_m;
};

PrincipalPose poseOf(const btRigidBody& body) {
  const btTransform& T = body.getWorldTransform();
  const btQuaternion q = T.getRotation();
  const btVector3& p = T.getOrigin();
  return {Eigen::Quaterniond(q.w(), q.x(), q.y(), q.z()).normalized(), Eigen::Vector3d(p.x(), p.y(), p.z())};
}

/// A rigid body's construction info with the run's contact law (friction, restitution) and nothing that
/// damps the motion (no rolling or spinning friction, no damping); mass 0 for the static ground.
btRigidBody::btRigidBodyConstructionInfo contactBody(double mass_kg, btMotionState* motion, btCollisionShape* shape,
                                                     const Eigen::Vector3d& principal_inertia_kg_m2,
                                                     const RockingOptions& o) {
  const Eigen::Vector3d& I = principal_inertia_kg_m2;
  btRigidBody::btRigidBodyConstructionInfo info(mass_kg, motion, shape, btVector3(I.x(), I.y(), I.z()));
  info.m_friction = o.friction;
  info.m_restitution = o.restitution;
  info.m_rollingFriction = info.m_spinningFriction = 0.0;
  info.m_linearDamping = info.m_angularDamping = 0.0;
  return info;
}

}  // namespace

RockingRun rockOnGround(const std::vector<Eigen::Vector3d>& vertices_body, const MassMoments& m,
                        const RockingOptions& o) {
  validate(vertices_body, m, o);
  // Principal frame: I = Q diag(I_p) Qᵀ with det Q = +1.
  const Eigen::Matrix3d I = 0.5 * (m.inertia_com_kg_m2 + m.inertia_com_kg_m2.transpose());
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(I);
  if (eig.info() != Eigen::Success || !(eig.eigenvalues().minCoeff() > 0))
    throw TopoError("rockOnGround: inertia_com_kg_m2",
                    "is not positive definite (principal moments " + numberText(eig.eigenvalues().x()) + ", " +
                        numberText(eig.eigenvalues().y()) + ", " + numberText(eig.eigenvalues().z()) + " kg m²)",
                    "pass the inertia of a solid about its centre of mass (peer::meshMoments, peer::combine)");
  Eigen::Matrix3d Q = eig.eigenvectors();
  if (Q.determinant() < 0) Q.col(2) = -Q.col(2);
  const Eigen::Vector3d Ip = eig.eigenvalues();
  Eigen::Isometry3d principal_from_body = Eigen::Isometry3d::Identity();
  principal_from_body.linear() = Q.transpose();
  principal_from_body.translation() = -Q.transpose() * m.com_m;

  // Release: R0 = AngleAxis(θ0, a) U, centre of mass at x = y = 0, lowest hull vertex at z = 0.
  const Eigen::Vector3d up = o.up_axis_body.normalized(), axis_body = o.rocking_axis_body.normalized();
  const Eigen::Quaterniond U = uprightRotation(up, axis_body);
  const Eigen::Vector3d axis = (U * axis_body).normalized(), ez = Eigen::Vector3d::UnitZ(), side = axis.cross(ez);
  const Eigen::Quaterniond R0 = Eigen::AngleAxisd(o.initial_tilt_deg * kPi / 180.0, axis) * U;
  double lowest = 1e300;
  for (const Eigen::Vector3d& v : vertices_body) lowest = std::min(lowest, (R0 * (v - m.com_m)).z());
  const PrincipalPose release{(R0 * Eigen::Quaterniond(Q)).normalized(), Eigen::Vector3d(0, 0, -lowest)};

  btDefaultCollisionConfiguration config;
  btCollisionDispatcher dispatcher(&config);
  btDbvtBroadphase broadphase;
  btSequentialImpulseConstraintSolver solver;

  btStaticPlaneShape plane(btVector3(0, 0, 1), 0);
  btRigidBody ground(contactBody(0.0, nullptr, &plane, Eigen::Vector3d::Zero(), o));

  btConvexHullShape hull;
  for (const Eigen::Vector3d& v : vertices_body) {
    const Eigen::Vector3d p = principal_from_body * v;
    hull.addPoint(btVector3(p.x(), p.y(), p.z()), false);
  }
  hull.recalcLocalAabb();
  hull.setMargin(0.0);  // the hull itself is the surface

  btTransform start;
  start.setIdentity();
  start.setRotation(
      btQuaternion(release.rotation.x(), release.rotation.y(), release.rotation.z(), release.rotation.w()));
  start.setOrigin(btVector3(release.com_m.x(), release.com_m.y(), release.com_m.z()));
  btDefaultMotionState motion(start);
  btRigidBody body(contactBody(m.mass_kg, &motion, &hull, Ip, o));
  body.setActivationState(DISABLE_DEACTIVATION);

  // Declared last so that it is destroyed first, while the bodies it refers to still exist.
  btDiscreteDynamicsWorld world(&dispatcher, &broadphase, &solver, &config);
  world.setGravity(btVector3(0, 0, -o.gravity_m_s2));
  world.getSolverInfo().m_numIterations = o.solver_iterations;
  world.addRigidBody(&ground);
  world.addRigidBody(&body);

  const double dt = o.bullet_dt_s;
  const long samples = static_cast<long>(std::floor(o.duration_s / o.sample_dt_s + 1e-9));
  RockingRun run;
  run.time_s.reserve(samples + 1);
  run.world_from_body.reserve(samples + 1);
  run.tilt_deg.reserve(samples + 1);
  PrincipalPose previous = release, current = release;
  long steps = 0;
  for (long k = 0; k <= samples; ++k) {
    const double t = k * o.sample_dt_s;
    const long needed = std::max(0L, static_cast<long>(std::ceil(t / dt - 1e-9)));
    while (steps < needed) {
      world.stepSimulation(dt, 1, dt);
      ++steps;
      previous = current;
      current = poseOf(body);
      if (!current.com_m.allFinite() || !current.rotation.coeffs().allFinite())
        throw TopoError(
            "rockOnGround: Bullet simulation",
            "the state became non-finite at step " + std::to_string(steps) + " (t = " + numberText(steps * dt) + " s)",
            "check the mass moments and the mesh, or use a smaller bullet_dt_s");
    }
    PrincipalPose p = current;
    if (steps > 0) {
      const double w = std::clamp((t - (steps - 1) * dt) / dt, 0.0, 1.0);
      p.rotation = previous.rotation.slerp(w, current.rotation).normalized();
      p.com_m = (1.0 - w) * previous.com_m + w * current.com_m;
    }
    Eigen::Isometry3d world_from_principal = Eigen::Isometry3d::Identity();
    world_from_principal.linear() = p.rotation.toRotationMatrix();
    world_from_principal.translation() = p.com_m;
    const Eigen::Isometry3d world_from_body = world_from_principal * principal_from_body;
    const Eigen::Vector3d u = world_from_body.linear() * up;
    run.time_s.push_back(t);
    run.world_from_body.push_back(world_from_body);
    run.tilt_deg.push_back(std::atan2(u.dot(side), u.dot(ez)) * 180.0 / kPi);
  }
  world.removeRigidBody(&body);
  world.removeRigidBody(&ground);
  return run;
}

}  // namespace topo_gaussian::peer
