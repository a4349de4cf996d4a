// Peer comparison on the user path: one solid hemisphere mesh (R = 0.1 m, flat face
// up) rocking from 10°, simulated
//  - by Bullet with the mesh itself as its collision shape (btConvexHullShape of the mesh's vertices:
//    the hemisphere is convex, so the hull is the mesh), the exact mass properties of the solid
//    hemisphere (m = 2/3 π R³ ρ, centre of mass 3R/8 below the flat face, I = 83/320 m R² about the
//    horizontal axes, 2/5 m R² about the axis), friction 1, restitution 0;
//  - by us as a user runs it: `topo fill` of the same mesh (geometry::ingestSurface with the command's
//    defaults), then `topo simulate --task tumbler --set initial_tilt_deg=10` (inference::simulateInterior
//    with the task's default contact settings).
// Bullet is first held to the exact rolling period (rolling_closed_form.h); then our period and tilt
// trajectory are held to Bullet's within 1 %. test/unit/peer_bullet_tumbler.cpp is the same comparison
// with ideal inputs (a Bullet sphere, Fibonacci contact points), linked with topo_physics only.
#include <gtest/gtest.h>

#include <btBulletDynamicsCommon.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include "rolling_closed_form.h"
#include "topo_gaussian/geometry/ingest.h"
#include "topo_gaussian/geometry/surface_data.h"
#include "topo_gaussian/inference/pipeline.h"
#include "topo_gaussian/inference/task_config.h"
#include "user_path_helpers.h"

using namespace topo_gaussian;
using topo_test::kRollPi;

namespace {

constexpr double kG = 9.81;
constexpr double kR = 0.1;
constexpr double kRho = 1000.0;  // the tumbler task's default density_solid
constexpr double kTiltDeg = 10.0;
constexpr double kDuration = 2.0;   // the tumbler task's default duration_s
constexpr double kSampleDt = 5e-3;  // the tumbler task's default dt_s

/// Period from linearly interpolated zero crossings over whole periods: T = 2 (t_j − t_0) / j, j even.
double periodFromCrossings(const std::vector<double>& t, const std::vector<double>& y, int* count) {
  std::vector<double> tc;
  for (std::size_t i = 1; i < y.size(); ++i) {
    const double a = y[i - 1], b = y[i];
    if ((a < 0.0 && b >= 0.0) || (a > 0.0 && b <= 0.0)) tc.push_back(t[i - 1] + (t[i] - t[i - 1]) * a / (a - b));
  }
  *count = static_cast<int>(tc.size());
  if (tc.size() < 3) return std::numeric_limits<double>::quiet_NaN();
  const std::size_t j = (tc.size() - 1) % 2 == 0 ? tc.size() - 1 : tc.size() - 2;
  return 2.0 * (tc[j] - tc[0]) / static_cast<double>(j);
}

struct BulletSettings {
  double dt = 1.0 / 2000.0;
  int solver_iterations = 10;
  double margin = 0.0;  ///< collision margin [m]; the hull is shrunk by it so the surface stays at R
};

/// Bullet: the hemisphere mesh's vertices as a btConvexHullShape (child of a compound whose origin is
/// the centre of mass), released at rest at kTiltDeg about x touching the plane z = 0. Returns the tilt
/// [deg] about x sampled every kSampleDt (the tumbler task's signed tilt: atan2(−u_y, u_z) of the
/// body's up axis u).
std::vector<double> bulletTilt(const geometry::SurfaceData& mesh, const BulletSettings& set,
                               std::vector<double>* time_s) {
  btDefaultCollisionConfiguration config;
  btCollisionDispatcher dispatcher(&config);
  btDbvtBroadphase broadphase;
  btSequentialImpulseConstraintSolver solver;
  btDiscreteDynamicsWorld world(&dispatcher, &broadphase, &solver, &config);
  world.setGravity(btVector3(0, 0, -kG));
  world.getSolverInfo().m_numIterations = set.solver_iterations;

  btStaticPlaneShape plane(btVector3(0, 0, 1), 0);
  btRigidBody::btRigidBodyConstructionInfo ground_info(0.0, nullptr, &plane);
  ground_info.m_friction = 1.0;
  ground_info.m_restitution = 0.0;
  btRigidBody ground(ground_info);
  world.addRigidBody(&ground);

  const topo_test::AxialMoments mom = topo_test::hemisphereMoments(kR);
  const double mass = kRho * mom.volume, a = 3.0 * kR / 8.0;
  const double Ixx = 83.0 / 320.0 * mass * kR * kR, Izz = 0.4 * mass * kR * kR;
  btConvexHullShape hull;
  const double shrink = (kR - set.margin) / kR;  // hull ⊕ margin sphere = the mesh's surface
  for (const auto& p : mesh.points) hull.addPoint(btVector3(p.x() * shrink, p.y() * shrink, p.z() * shrink), false);
  hull.recalcLocalAabb();
  hull.setMargin(set.margin);
  btCompoundShape compound;
  btTransform child;
  child.setIdentity();
  child.setOrigin(btVector3(0, 0, a));  // mesh origin (sphere centre) is a above the centre of mass
  compound.addChildShape(child, &hull);

  const double tilt = kTiltDeg * kRollPi / 180.0;
  const btQuaternion q(btVector3(1, 0, 0), tilt);
  btTransform start;
  start.setIdentity();
  start.setRotation(q);
  start.setOrigin(btVector3(0, 0, kR) + btMatrix3x3(q) * btVector3(0, 0, -a));  // sphere centre at height R
  btDefaultMotionState motion(start);
  btRigidBody::btRigidBodyConstructionInfo info(mass, &motion, &compound, btVector3(Ixx, Ixx, Izz));
  info.m_friction = 1.0;
  info.m_restitution = 0.0;
  info.m_rollingFriction = 0.0;
  info.m_linearDamping = 0.0;
  info.m_angularDamping = 0.0;
  btRigidBody body(info);
  body.setActivationState(DISABLE_DEACTIVATION);
  world.addRigidBody(&body);

  const int per_sample = static_cast<int>(std::lround(kSampleDt / set.dt));
  const int samples = static_cast<int>(std::lround(kDuration / kSampleDt));
  std::vector<double> y;
  for (int k = 0; k <= samples; ++k) {
    if (k > 0)
      for (int i = 0; i < per_sample; ++i) world.stepSimulation(set.dt, 1, set.dt);
    const btMatrix3x3& B = body.getWorldTransform().getBasis();
    time_s->push_back(k * kSampleDt);
    y.push_back(std::atan2(-B[1][2], B[2][2]) * 180.0 / kRollPi);
  }
  world.removeRigidBody(&body);
  world.removeRigidBody(&ground);
  return y;
}

/// The period_s feature the tumbler task reports (its own analysis of the first cycles).
double taskPeriod(const inference::ProblemEvaluation& ev) {
  for (const auto& f : ev.task.features)
    if (f.name == "period_s") return f.value;
  return std::numeric_limits<double>::quiet_NaN();
}

/// RMS of (ours − Bullet) over the first full period (from the release), relative to the release tilt.
double trajectoryRmsOverFirstPeriod(const std::vector<double>& t, const std::vector<double>& ours,
                                    const std::vector<double>& bullet, double period) {
  double sum = 0;
  int n = 0;
  for (std::size_t k = 0; k < std::min({t.size(), ours.size(), bullet.size()}) && t[k] <= period; ++k, ++n)
    sum += (ours[k] - bullet[k]) * (ours[k] - bullet[k]);
  return std::sqrt(sum / std::max(n, 1)) / kTiltDeg;
}

}  // namespace

TEST(PeerBulletMesh, HemisphereMeshRockingPeriodAndTrajectory) {
  // 512 segments around, 128 rings: Bullet rolls the hull from vertex to vertex, and its period moves
  // with the faceting (10°, this file's settings: 64 segments −5.5 %, 128 +5.1 %, 256 −0.63 %, 384 −0.23 %,
  // 512 −0.04 %, 768 +0.11 %, 1024 +0.21 %; the step 1/2000 → 1/8000 s, 10 → 50 solver iterations
  // and margins 0–1 mm change it by < 0.1 %).
  const geometry::SurfaceData mesh = topo_test::hemisphereMesh(kR, 512, 128);
  const double Tref = topo_test::rockingPeriod(topo_test::solidHemisphere(kR), kTiltDeg * kRollPi / 180.0);

  // Bullet against the closed form first.
  std::vector<double> tb;
  const std::vector<double> yb = bulletTilt(mesh, BulletSettings{}, &tb);
  int nb = 0;
  const double Tb = periodFromCrossings(tb, yb, &nb);
  std::printf(
      "[user-path] Bullet, hemisphere mesh as btConvexHullShape (%zu vertices), 10 deg | Bullet %.5f s | reference "
      "%.5f s | error %+.2f %% (%d crossings)\n",
      mesh.points.size(), Tb, Tref, 100.0 * (Tb / Tref - 1.0), nb);
  ASSERT_GE(nb, 4);
  EXPECT_NEAR(Tb / Tref, 1.0, 0.01) << "Bullet itself is off the closed form: the peer needs tuning";

  // Ours through the user path, on the same mesh: the default fill and a 2 mm fill.
  for (double spacing : {0.0, 0.002}) {
    geometry::IngestOptions o;
    o.fill.spacing_m = spacing;
    const VolumeCloud cloud = geometry::ingestSurface(mesh, o).cloud;
    inference::TaskConfig c = inference::TaskConfig::defaults("tumbler");
    c.setNumber("initial_tilt_deg", kTiltDeg);
    const inference::ProblemEvaluation ev = inference::simulateInterior(c, cloud, {});
    int no = 0;
    const double To = periodFromCrossings(ev.task.signal_time_s, ev.task.signal, &no);
    const double rms = trajectoryRmsOverFirstPeriod(ev.task.signal_time_s, ev.task.signal, yb, Tb);
    std::printf(
        "[user-path] ours vs Bullet, hemisphere mesh, topo fill %s (%zu particles), tumbler 10 deg | ours %.5f s | "
        "Bullet %.5f s | error %+.2f %%; tilt trajectory over the first period: RMS difference %.2f %% of the "
        "release tilt; the task's own period_s %.5f s\n",
        spacing > 0 ? ("--spacing " + std::to_string(spacing)).c_str() : "default", cloud.size(), To, Tb,
        100.0 * (To / Tb - 1.0), 100.0 * rms, taskPeriod(ev));
    ASSERT_EQ(ev.task.signal.size(), yb.size()) << "both sampled every " << kSampleDt << " s for " << kDuration << " s";
    EXPECT_GE(no, 4) << "spacing " << spacing;
    EXPECT_NEAR(To / Tb, 1.0, 0.01) << "spacing " << spacing;
    EXPECT_LT(rms, 0.01) << "spacing " << spacing;
  }
}
