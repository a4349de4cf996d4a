// Peer comparison: a round-bottomed tumbler (sphere contact geometry, centre of mass h below the
// sphere centre, given inertia) rocking on the ground, simulated by Bullet and by our penalty-contact
// simulator. The rocking periods agree within 1 % (and both match the closed form).
#include <gtest/gtest.h>

#include <btBulletDynamicsCommon.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include "topo_gaussian/physics/rigid_body.h"

using namespace topo_gaussian;

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kG = 9.81;

// The tumbler: sphere of radius R (centre at the body origin), com h below the centre.
constexpr double kR = 0.05;
constexpr double kH = 0.015;
constexpr double kMass = 0.8;
const Eigen::Vector3d kInertia(6.0e-4, 5.0e-4, 7.0e-4);  // principal, about the com [kg m²]
constexpr double kTiltDeg = 4.0;
constexpr double kDuration = 4.0;

double periodFromCrossings(const std::vector<double>& t, const std::vector<double>& y, int* count) {
  std::vector<double> tc;
  for (size_t i = 1; i < y.size(); ++i) {
    const double a = y[i - 1], b = y[i];
    if ((a < 0.0 && b >= 0.0) || (a > 0.0 && b <= 0.0)) tc.push_back(t[i - 1] + (t[i] - t[i - 1]) * a / (a - b));
  }
  *count = static_cast<int>(tc.size());
  if (tc.size() < 3) return std::numeric_limits<double>::quiet_NaN();
  const size_t j = (tc.size() - 1) % 2 == 0 ? tc.size() - 1 : tc.size() - 2;  // whole periods only
  return 2.0 * (tc[j] - tc[0]) / static_cast<double>(j);
}

/// Bullet: btCompoundShape whose child sphere sits h above the compound origin (= the com), mass and
/// principal inertia set explicitly, static plane z = 0, friction 1, restitution 0, fixed step 1/2000 s.
double bulletPeriod(int* crossings) {
  btDefaultCollisionConfiguration config;
  btCollisionDispatcher dispatcher(&config);
  btDbvtBroadphase broadphase;
  btSequentialImpulseConstraintSolver solver;
  btDiscreteDynamicsWorld world(&dispatcher, &broadphase, &solver, &config);
  world.setGravity(btVector3(0, 0, -kG));

  btStaticPlaneShape plane(btVector3(0, 0, 1), 0);
  btRigidBody::btRigidBodyConstructionInfo ground_info(0.0, nullptr, &plane);
  ground_info.m_friction = 1.0;
  ground_info.m_restitution = 0.0;
  btRigidBody ground(ground_info);
  world.addRigidBody(&ground);

  btSphereShape sphere(kR);
  btCompoundShape compound;
  btTransform child;
  child.setIdentity();
  child.setOrigin(btVector3(0, 0, kH));
  compound.addChildShape(child, &sphere);

  const double tilt = kTiltDeg * kPi / 180.0;
  const btQuaternion q(btVector3(0, 1, 0), tilt);
  btTransform start;
  start.setIdentity();
  start.setRotation(q);
  // Sphere centre at (0, 0, R) touching the plane; the com is h below it along the tilted body axis.
  start.setOrigin(btVector3(0, 0, kR) + btMatrix3x3(q) * btVector3(0, 0, -kH));
  btDefaultMotionState motion(start);
  btRigidBody::btRigidBodyConstructionInfo info(kMass, &motion, &compound,
                                                btVector3(kInertia.x(), kInertia.y(), kInertia.z()));
  info.m_friction = 1.0;
  info.m_restitution = 0.0;
  info.m_rollingFriction = 0.0;
  info.m_linearDamping = 0.0;
  info.m_angularDamping = 0.0;
  btRigidBody body(info);
  body.setActivationState(DISABLE_DEACTIVATION);
  world.addRigidBody(&body);

  const double dt = 1.0 / 2000.0;
  const int steps = static_cast<int>(std::lround(kDuration / dt));
  std::vector<double> t, y;
  for (int i = 0; i <= steps; ++i) {
    if (i > 0) world.stepSimulation(dt, 1, dt);
    const btMatrix3x3& B = body.getWorldTransform().getBasis();
    t.push_back(i * dt);
    y.push_back(std::atan2(B[0][2], B[2][2]));
  }
  world.removeRigidBody(&body);
  world.removeRigidBody(&ground);
  return periodFromCrossings(t, y, crossings);
}

/// Fibonacci points on the sphere within `cap_deg` of the bottom pole.
std::vector<Eigen::Vector3d> sphereCap(double R, double spacing, double cap_deg) {
  const long n = std::lround(4.0 * kPi * R * R / (spacing * spacing));
  const double golden = kPi * (3.0 - std::sqrt(5.0));
  const double zmax = -std::cos(cap_deg * kPi / 180.0);
  std::vector<Eigen::Vector3d> pts;
  for (long i = 0; i < n; ++i) {
    const double z = -1.0 + (2.0 * i + 1.0) / n;
    if (z > zmax + 1e-12) break;
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    const double phi = golden * i;
    pts.emplace_back(R * r * std::cos(phi), R * r * std::sin(phi), R * z);
  }
  return pts;
}

double ourPeriod(int* crossings, size_t* npts) {
  RigidInertia<double> in;
  in.mass = kMass;
  in.com = Eigen::Vector3d(0, 0, -kH);
  in.inertia = kInertia.asDiagonal();
  // Contact points: the sphere surface within 30° of the bottom, 0.7 mm spacing.
  const std::vector<Eigen::Vector3d> pts = sphereCap(kR, 0.7e-3, 30.0);
  *npts = pts.size();
  RigidSimOptions opt;
  opt.duration_s = kDuration;
  opt.output_dt_s = 1e-3;
  const Eigen::Quaterniond q(Eigen::AngleAxisd(kTiltDeg * kPi / 180.0, Eigen::Vector3d::UnitY()));
  const RigidTrajectory<double> tr = simulateRigid(in, restingState(in, q, pts, opt), pts, opt);
  std::vector<double> y;
  for (const auto& s : tr.states) {
    const Eigen::Matrix3d R = s.orientation.toRotationMatrix();
    y.push_back(std::atan2(R(0, 2), R(2, 2)));
  }
  return periodFromCrossings(tr.time_s, y, crossings);
}

}  // namespace

TEST(PeerBullet, TumblerRockingPeriod) {
  int nb = 0, no = 0;
  size_t npts = 0;
  const double Tb = bulletPeriod(&nb);
  const double To = ourPeriod(&no, &npts);
  const double Tref = 2.0 * kPi * std::sqrt((kInertia.y() + kMass * (kR - kH) * (kR - kH)) / (kMass * kG * kH));
  std::printf(
      "tumbler period: Bullet %.5f s (%d crossings), ours %.5f s (%zu contact points, %d crossings), "
      "closed form %.5f s; ours/Bullet - 1 = %+.3f %%\n",
      Tb, nb, To, npts, no, Tref, 100.0 * (To / Tb - 1.0));
  ASSERT_GE(nb, 8);
  ASSERT_GE(no, 8);
  EXPECT_NEAR(To / Tb, 1.0, 0.01);
  EXPECT_NEAR(Tb / Tref, 1.0, 0.01);
}
