// CUDA backend: the backend switch everywhere; on a machine with a CUDA GPU, the device's
// explicit soft-body step against SoftBodySimulator::step (float64: one step < 1e-9 relative, a
// 100-step rollout < 1e-6; float32 within its stated tolerance) and its polar rotation against the
// SVD. Without a device (CI: nvcc but no GPU; a build without nvcc) the GPU tests skip with the
// reason, and what must be refused is checked instead.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <random>

#include "gpu_test.h"
#include "test_clouds.h"
#include "topo_gaussian/common/error.h"
#include "topo_gaussian/cuda/backend.h"
#include "topo_gaussian/cuda/soft_body_cuda.h"
#include "topo_gaussian/cuda/soft_rollout_cuda.h"

using namespace topo_gaussian;
using Vec3s = std::vector<Eigen::Vector3d>;

namespace {

constexpr double kSpacing = 0.005;

/// A 12 × 4 × 4-cell cantilever (5 mm lattice), clamped at x = min, E 1e6, ν 0.3.
struct Beam {
  VolumeCloud cloud;
  std::unique_ptr<SoftBodySimulator> sim;
};

Beam makeBeam(SphEnergyModel model, SphRotationSource rotation, double smoothing_factor, bool chamber, double damping,
              int cells_x = 12) {
  Beam b;
  b.cloud = topo_test::boxCloud(cells_x * kSpacing, 4 * kSpacing, 4 * kSpacing, kSpacing);
  CorotatedSphOptions o;
  o.spacing = kSpacing;
  o.smoothing_factor = smoothing_factor;
  o.model = model;
  o.rotation = rotation;
  SoftBodyOptions so;
  so.damping = damping;
  so.gravity = Eigen::Vector3d(0.0, 0.0, -9.81);
  b.sim = std::make_unique<SoftBodySimulator>(CorotatedSph::fromCloud(b.cloud, lameFromYoung(1e6, 0.3), o), so);
  double xmin = 1e300;
  for (const auto& X : b.cloud.X) xmin = std::min(xmin, X.x());
  std::vector<std::uint8_t> clamp(b.cloud.size(), 0);
  for (std::size_t i = 0; i < clamp.size(); ++i) clamp[i] = b.cloud.X[i].x() < xmin + 0.5 * kSpacing;
  b.sim->setClamped(clamp);
  if (chamber) {  // a pressurised core along the beam, ramped over 5 ms
    PneumaticActuation a;
    a.chamber.assign(b.cloud.size(), 0.0);
    for (std::size_t i = 0; i < clamp.size(); ++i)
      if (std::abs(b.cloud.X[i].y()) < kSpacing && std::abs(b.cloud.X[i].z()) < kSpacing && !clamp[i])
        a.chamber[i] = 1.0;
    a.pressure_pa = 2e4;
    a.ramp_s = 5e-3;
    b.sim->setActuation(a);
  }
  // A smooth initial velocity field (bending and twisting), so that every term moves.
  Vec3s v(b.cloud.size());
  for (std::size_t i = 0; i < v.size(); ++i) {
    const Eigen::Vector3d& X = b.cloud.X[i];
    v[i] = Eigen::Vector3d(0.02 * X.z(), -3.0 * X.z() * (X.x() - xmin), 4.0 * (X.x() - xmin) + 20.0 * X.y());
  }
  b.sim->setVelocities(v);
  return b;
}

double maxNorm(const Vec3s& a) {
  double m = 0.0;
  for (const auto& x : a) m = std::max(m, x.norm());
  return m;
}
double maxDiff(const Vec3s& a, const Vec3s& b) {
  double m = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) m = std::max(m, (a[i] - b[i]).norm());
  return m;
}
Vec3s displacement(const Vec3s& x, const Vec3s& X) {
  Vec3s u(x.size());
  for (std::size_t i = 0; i < x.size(); ++i) u[i] = x[i] - X[i];
  return u;
}

struct Parity {
  double x = 0, v = 0, f = 0;  // max error / max magnitude (displacement, velocity, force)
};

/// Runs `steps` steps on the CPU and on the GPU from the same state; relative errors at the end.
/// lanes: 0 automatic; warp, capped: SoftBodyCuda::setWarpEvaluation's and setCappedEvaluation's modes
/// (1: asserts that it runs); x_gpu: the GPU's final positions.
Parity compare(Beam& b, CudaPrecision precision, int steps, double dt_fraction = 0.5, int lanes = 0, int warp = -1,
               int capped = -1, Vec3s* x_gpu = nullptr) {
  SoftBodyCuda gpu(*b.sim, precision, lanes);
  gpu.setWarpEvaluation(warp);
  gpu.setCappedEvaluation(capped);
  if (warp == 1) {
    EXPECT_TRUE(gpu.warpEvaluation());
  }
  if (capped == 1) {
    EXPECT_TRUE(gpu.cappedEvaluation());
  }
  const double dt = dt_fraction * b.sim->stableTimeStep();
  for (int s = 0; s < steps; ++s) b.sim->step(dt);
  gpu.step(dt, steps);
  Vec3s x, v;
  gpu.download(&x, &v);
  if (x_gpu) *x_gpu = x;
  const Vec3s f = gpu.forces();
  Parity p;
  const Vec3s u_cpu = displacement(b.sim->positions(), b.cloud.X);
  p.x = maxDiff(displacement(x, b.cloud.X), u_cpu) / maxNorm(u_cpu);
  p.v = maxDiff(v, b.sim->velocities()) / maxNorm(b.sim->velocities());
  p.f = maxDiff(f, b.sim->conservativeForces()) / maxNorm(b.sim->conservativeForces());
  EXPECT_NEAR(gpu.time(), b.sim->time(), 1e-15);
  EXPECT_EQ(gpu.stepCount(), b.sim->stepCount());
  return p;
}

}  // namespace

// ------------------------------------------------------------------ everywhere

TEST(CudaBackend, ParsesAndResolvesTheSwitch) {
  EXPECT_EQ(parseComputeBackend("auto"), ComputeBackend::Auto);
  EXPECT_EQ(parseComputeBackend("CPU"), ComputeBackend::Cpu);
  EXPECT_EQ(parseComputeBackend("cuda"), ComputeBackend::Cuda);
  try {
    parseComputeBackend("opencl", "task backend");
    FAIL() << "opencl accepted";
  } catch (const TopoError& e) {
    EXPECT_NE(std::string(e.what()).find("task backend"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("opencl"), std::string::npos) << e.what();
  }
  std::string line;
  EXPECT_EQ(resolveBackend(ComputeBackend::Cpu, "x", &line), ComputeBackend::Cpu);
  EXPECT_EQ(line, "backend cpu: CPU");
  const CudaDeviceInfo& info = cudaDeviceInfo();
  const ComputeBackend a = resolveBackend(ComputeBackend::Auto, "x", &line);
  if (info.available) {
    EXPECT_EQ(a, ComputeBackend::Cuda);
    EXPECT_NE(line.find(info.name), std::string::npos) << line;
    EXPECT_EQ(resolveBackend(ComputeBackend::Cuda), ComputeBackend::Cuda);
  } else {
    EXPECT_EQ(a, ComputeBackend::Cpu);
    EXPECT_NE(line.find(info.reason), std::string::npos) << line;
    EXPECT_FALSE(info.reason.empty());
    EXPECT_THROW(resolveBackend(ComputeBackend::Cuda), TopoError);
  }
}

TEST(CudaBackend, WithoutADeviceTheGpuBodyIsRefusedWithTheReason) {
  if (cudaDeviceInfo().available) GTEST_SKIP() << "a CUDA device is present (" << cudaDeviceInfo().name << ")";
  Beam b = makeBeam(SphEnergyModel::StVK, SphRotationSource::ShapeMatchingApq, 1.5, false, 0.0);
  try {
    SoftBodyCuda gpu(*b.sim);
    FAIL() << "constructed without a device";
  } catch (const TopoError& e) {
    EXPECT_NE(std::string(e.what()).find(cudaDeviceInfo().reason), std::string::npos) << e.what();
  }
}

// ------------------------------------------------------------------ on a GPU

TEST(CudaSoftBody, PolarRotationMatchesTheSvd) {
  SKIP_WITHOUT_GPU();
  std::mt19937 rng(7);
  std::normal_distribution<double> nd;
  std::vector<Eigen::Matrix3d> A;
  for (int k = 0; k < 2000; ++k) {
    Eigen::Matrix3d M;
    for (int q = 0; q < 9; ++q) M.data()[q] = nd(rng);
    if (k % 4 == 0)
      M = Eigen::AngleAxisd(nd(rng), Eigen::Vector3d(nd(rng), nd(rng), nd(rng)).normalized()).matrix() *
          (Eigen::Matrix3d::Identity() + 0.01 * M);  // near a rotation (the usual case)
    A.push_back(M);                                  // about half are reflections: the fallback's proper rotation
  }
  for (CudaPrecision p : {CudaPrecision::Float64, CudaPrecision::Float32}) {
    long fallbacks = -1;
    const auto R = cudaPolarRotations(A, p, &fallbacks);
    double worst = 0.0;
    for (std::size_t k = 0; k < A.size(); ++k) {
      Eigen::JacobiSVD<Eigen::Matrix3d> svd(A[k], Eigen::ComputeFullU | Eigen::ComputeFullV);
      Eigen::Matrix3d U = svd.matrixU();
      if ((U * svd.matrixV().transpose()).determinant() < 0.0) U.col(2) = -U.col(2);
      const Eigen::Vector3d sv = svd.singularValues();
      if (sv(2) < 1e-3 * sv(0)) continue;  // nearly singular: the rotation is ill-determined
      worst = std::max(worst, (R[k] - U * svd.matrixV().transpose()).cwiseAbs().maxCoeff());
    }
    EXPECT_GT(fallbacks, 0);  // reflections took the fallback
    EXPECT_LT(worst, p == CudaPrecision::Float64 ? 1e-10 : 2e-4) << (p == CudaPrecision::Float64 ? "f64" : "f32");
  }
}

TEST(CudaSoftBody, OneStepMatchesTheCpuInFloat64) {
  SKIP_WITHOUT_GPU();
  Beam b = makeBeam(SphEnergyModel::StVK, SphRotationSource::ShapeMatchingApq, 1.5, false, 0.0);
  const Parity p = compare(b, CudaPrecision::Float64, 1);
  EXPECT_LT(p.x, 1e-9);
  EXPECT_LT(p.v, 1e-9);
  EXPECT_LT(p.f, 1e-9);
}

TEST(CudaSoftBody, RolloutOf100StepsMatchesTheCpuInFloat64) {
  SKIP_WITHOUT_GPU();
  // StVK with the paper's A_pq rotations and hourglass; corotated linear with corrected-gradient
  // rotations, damping and a ramped chamber pressure; h = 1.0 and 1.5 spacings.
  Beam a = makeBeam(SphEnergyModel::StVK, SphRotationSource::ShapeMatchingApq, 1.5, false, 0.0);
  const Parity pa = compare(a, CudaPrecision::Float64, 100);
  EXPECT_LT(pa.x, 1e-6);
  EXPECT_LT(pa.v, 1e-6);
  Beam b = makeBeam(SphEnergyModel::CorotatedLinear, SphRotationSource::CorrectedGradient, 1.0, true, 3.0);
  const Parity pb = compare(b, CudaPrecision::Float64, 100);
  EXPECT_LT(pb.x, 1e-6);
  EXPECT_LT(pb.v, 1e-6);
  EXPECT_LT(pb.f, 1e-6);
  std::printf("[ parity   ] float64, 100 steps: StVK/A_pq dx %.2e dv %.2e; corotated/chamber dx %.2e dv %.2e df %.2e\n",
              pa.x, pa.v, pb.x, pb.v, pb.f);
}

TEST(CudaSoftBody, Float32StaysWithinItsStatedTolerance) {
  SKIP_WITHOUT_GPU();
  // Stated tolerance of float32 over 100 steps: 1e-3 of the displacement and of the velocity.
  Beam a = makeBeam(SphEnergyModel::StVK, SphRotationSource::ShapeMatchingApq, 1.5, false, 0.0);
  const Parity p = compare(a, CudaPrecision::Float32, 100);
  EXPECT_LT(p.x, 1e-3);
  EXPECT_LT(p.v, 1e-3);
  std::printf("[ parity   ] float32, 100 steps: dx %.2e dv %.2e df %.2e\n", p.x, p.v, p.f);
}

TEST(CudaSoftBody, GraphBatchesEqualSingleSteps) {
  SKIP_WITHOUT_GPU();
  Beam a = makeBeam(SphEnergyModel::StVK, SphRotationSource::ShapeMatchingApq, 1.5, true, 1.0);
  SoftBodyCuda g1(*a.sim), g2(*a.sim);
  const double dt = 0.5 * a.sim->stableTimeStep();
  g1.step(dt, 137);  // two graph replays of 50 and 37 single launches
  for (int s = 0; s < 137; ++s) g2.step(dt, 1);
  Vec3s x1, v1, x2, v2;
  g1.download(&x1, &v1);
  g2.download(&x2, &v2);
  EXPECT_EQ(maxDiff(x1, x2), 0.0);
  EXPECT_EQ(maxDiff(v1, v2), 0.0);
  EXPECT_EQ(g1.stepCount(), 137);
}

TEST(CudaSoftBody, AnInvertedParticleIsReportedWithItsStep) {
  SKIP_WITHOUT_GPU();
  Beam a = makeBeam(SphEnergyModel::StVK, SphRotationSource::CorrectedGradient, 1.5, false, 0.0);
  // Crush the free end: every free particle flies towards the beam's axis at 300 m/s.
  Vec3s v(a.cloud.size(), Eigen::Vector3d::Zero());
  for (std::size_t i = 0; i < v.size(); ++i) v[i] = -3e4 * Eigen::Vector3d(0.0, a.cloud.X[i].y(), a.cloud.X[i].z());
  a.sim->setVelocities(v);
  SoftBodyCuda gpu(*a.sim);
  try {
    gpu.step(0.9 * a.sim->stableTimeStep(), 200);
    FAIL() << "no inversion reported";
  } catch (const TopoError& e) {
    const std::string m = e.what();
    EXPECT_TRUE(m.find("inverted") != std::string::npos || m.find("non-finite") != std::string::npos) << m;
    EXPECT_NE(m.find("at step"), std::string::npos) << m;
  }
}

// ------------------------------------------------------------------ the rollout and its adjoint

namespace {

/// ℓ_k = Σ_i [q_i · (x_i − X_i) + 0.05 |v_i|²] with a fixed per-particle direction q_i: every design
/// variable reaches it (mass through gravity and inertia, μ and λ through the forces, w through the
/// chamber pressure).
SoftStepLoss testLoss(const VolumeCloud& cloud) {
  return [&cloud](int, double, const Vec3s& x, const Vec3s& v, Vec3s* dx, Vec3s* dv) {
    double l = 0.0;
    for (std::size_t i = 0; i < x.size(); ++i) {
      const Eigen::Vector3d q(std::sin(3.0 * i), std::cos(5.0 * i), 1.0);
      l += q.dot(x[i] - cloud.X[i]) + 0.05 * v[i].squaredNorm();
      if (dx) (*dx)[i] += q;
      if (dv) (*dv)[i] += 0.1 * v[i];
    }
    return l;
  };
}

double relDiff(const std::vector<double>& a, const std::vector<double>& b) {
  double d = 0.0, m = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    d = std::max(d, std::abs(a[i] - b[i]));
    m = std::max(m, std::abs(b[i]));
  }
  return m > 0.0 ? d / m : d;
}

}  // namespace

namespace {

/// A 6 × 6 × 6-cell cube (5 mm) 1 mm above a ground plane at z = zmin − 1 mm, falling at 0.3 m/s and
/// sliding at 0.2 m/s, spinning slowly; its contact on the particles or on samples of its faces
/// (embedded, 4 per cell face, ω = area / h²), with friction 0.5 and a box obstacle beside it.
struct Block {
  VolumeCloud cloud;
  std::unique_ptr<SoftBodySimulator> sim;
};

Block makeBlock(bool embedded) {
  Block b;
  b.cloud = topo_test::boxCloud(6 * kSpacing, 6 * kSpacing, 6 * kSpacing, kSpacing);
  CorotatedSphOptions o;
  o.spacing = kSpacing;
  o.smoothing_factor = 1.0;
  b.sim = std::make_unique<SoftBodySimulator>(CorotatedSph::fromCloud(b.cloud, lameFromYoung(2e5, 0.3), o));
  double zmin = 1e300, xmax = -1e300;
  for (const auto& X : b.cloud.X) zmin = std::min(zmin, X.z()), xmax = std::max(xmax, X.x());
  const double ground = zmin - 0.5 * kSpacing - 1e-3;  // the cube's true bottom face is half a cell below
  std::vector<ContactObstacle> obstacles = {
      ContactObstacle::ground(ground),
      ContactObstacle::box(Eigen::Vector3d(xmax + 0.5 * kSpacing + 2e-3, -1, -1), Eigen::Vector3d(1, 1, 1))};
  SoftContactOptions co;
  co.friction = 0.5;
  if (embedded) {
    std::vector<Eigen::Vector3d> Y;
    std::vector<double> w;
    const double half = 3 * kSpacing, q = kSpacing / 2;
    for (int axis = 0; axis < 3; ++axis)
      for (int side : {-1, 1})
        for (double u = -half + q / 2; u < half; u += q)
          for (double v = -half + q / 2; v < half; v += q) {
            Eigen::Vector3d y;
            y(axis) = side * half;
            y((axis + 1) % 3) = u;
            y((axis + 2) % 3) = v;
            Y.push_back(y);
            w.push_back(q * q / (kSpacing * kSpacing));
          }
    auto E = std::make_shared<const ContactEmbedding>(b.cloud.X, Y, w, kSpacing);
    b.sim->setContact(SoftContact(obstacles, co, E));
  } else {
    b.sim->setContact(SoftContact(obstacles, co));
  }
  Vec3s v(b.cloud.size());
  for (std::size_t i = 0; i < v.size(); ++i)
    v[i] = Eigen::Vector3d(0.2, 0.0, -0.3) + Eigen::Vector3d(0, 0, 3.0).cross(b.cloud.X[i]);
  b.sim->setVelocities(v);
  return b;
}

}  // namespace

TEST(CudaSoftBody, ContactMatchesTheCpuInFloat64) {
  SKIP_WITHOUT_GPU();
  // Penalty contact makes the motion sensitive to round-off (stiff, with kinks where contacts begin
  // and end), so the GPU is held to the CPU's own sensitivity: a CPU run from velocities changed by
  // 1e-13 (relative) departs from the reference by some amount e; the GPU must stay within
  // max(1e-9, 10 e) of the reference. Both numbers are printed.
  for (bool embedded : {false, true}) {
    Block b = makeBlock(embedded), p = makeBlock(embedded);
    Vec3s vp = p.sim->velocities();
    for (auto& v : vp) v *= 1.0 + 1e-13;
    p.sim->setVelocities(vp);
    SoftBodyCuda gpu(*b.sim);
    const double dt = 0.5 * b.sim->stableTimeStep();
    const int steps = 400;  // the block reaches the ground within ~100 steps and stays in contact
    std::size_t contacts = 0;
    for (int s = 0; s < steps; ++s) {
      b.sim->step(dt);
      p.sim->step(dt);
      contacts += b.sim->contact().activeCount(b.sim->positions());
    }
    gpu.step(dt, steps);
    Vec3s x, v;
    gpu.download(&x, &v);
    EXPECT_GT(contacts, 100u) << "the block must touch the ground";
    const Vec3s u = displacement(b.sim->positions(), b.cloud.X);
    const double dx = maxDiff(displacement(x, b.cloud.X), u) / maxNorm(u);
    const double dv = maxDiff(v, b.sim->velocities()) / maxNorm(b.sim->velocities());
    const double ex = maxDiff(displacement(p.sim->positions(), b.cloud.X), u) / maxNorm(u);
    const double ev = maxDiff(p.sim->velocities(), b.sim->velocities()) / maxNorm(b.sim->velocities());
    EXPECT_LT(dx, std::max(1e-9, 10.0 * ex)) << (embedded ? "embedded" : "particles");
    EXPECT_LT(dv, std::max(1e-9, 10.0 * ev)) << (embedded ? "embedded" : "particles");
    std::printf(
        "[ parity   ] contact on %s, %d steps (%zu point-steps in contact): GPU dx %.2e dv %.2e; CPU from v(1 + 1e-13) "
        "dx %.2e dv %.2e\n",
        embedded ? "embedded samples" : "particles", steps, contacts, dx, dv, ex, ev);
  }
}

namespace {
/// The rollout with its gradient on the CPU and on the GPU from the same state (dt half the stable step).
void runBoth(SoftBodySimulator* cpu, SoftBodySimulator* gpu, const SoftStepLoss& loss_cpu, const SoftStepLoss& loss_gpu,
             int steps, int checkpoint_every, SoftRolloutResult* rc, SoftRolloutResult* rg) {
  SoftRolloutOptions o;
  o.dt = 0.5 * cpu->stableTimeStep();
  o.steps = steps;
  o.checkpoint_every = checkpoint_every;
  *rc = SoftRollout(cpu, o).run(loss_cpu, true);
  *rg = runSoftRolloutCuda(gpu, o, loss_gpu, true);
}
}  // namespace

TEST(CudaSoftRollout, GradientWithContactMatchesTheCpuInFloat64) {
  SKIP_WITHOUT_GPU();
  // every 0 (auto): the 151 states kept; 7: checkpoints and segments recomputed through the contact
  for (const int every : {0, 7})
    for (bool embedded : {false, true}) {
      Block cpu = makeBlock(embedded), gpu = makeBlock(embedded);
      SoftRolloutResult rc, rg;
      runBoth(cpu.sim.get(), gpu.sim.get(), testLoss(cpu.cloud), testLoss(gpu.cloud), 150, every, &rc, &rg);
      const SoftDesignGradient &a = rg.gradient, &c = rc.gradient;
      const double dm = relDiff(a.mass, c.mass), dmu = relDiff(a.mu, c.mu), dla = relDiff(a.lambda, c.lambda);
      const double dx0 = maxDiff(a.x0, c.x0) / maxNorm(c.x0), dv0 = maxDiff(a.v0, c.v0) / maxNorm(c.v0);
      EXPECT_NEAR(rg.loss, rc.loss, 1e-9 * std::abs(rc.loss));
      EXPECT_LT(dm, 1e-6);
      EXPECT_LT(dmu, 1e-6);
      EXPECT_LT(dla, 1e-6);
      EXPECT_LT(dx0, 1e-6);
      EXPECT_LT(dv0, 1e-6);
      // √N: a checkpoint at each segment's start before the last (⌈(150 − 7) / 7⌉ = 21), the last segment's
      // 7 + 1 states kept by the forward.
      EXPECT_EQ(rg.peak_states, every == 0 ? 151u : 21u + 8u) << "checkpoint every " << every;
      std::printf(
          "[ parity   ] rollout gradient with contact on %s, checkpoint every %d: mass %.2e mu %.2e lambda %.2e x0 "
          "%.2e "
          "v0 %.2e\n",
          embedded ? "embedded samples" : "particles", every, dm, dmu, dla, dx0, dv0);
    }
}

TEST(CudaSoftBody, LaneCountsAgree) {
  SKIP_WITHOUT_GPU();
  // The neighbour sums split over 1 … 32 lanes differ only in summation order.
  Beam a = makeBeam(SphEnergyModel::StVK, SphRotationSource::ShapeMatchingApq, 1.5, true, 0.0);
  const double dt = 0.5 * a.sim->stableTimeStep();
  Vec3s x1, v1;
  {
    SoftBodyCuda g(*a.sim, CudaPrecision::Float64, 1);
    g.step(dt, 100);
    g.download(&x1, &v1);
  }
  for (int lanes : {2, 4, 8, 16, 32}) {
    SoftBodyCuda g(*a.sim, CudaPrecision::Float64, lanes);
    g.step(dt, 100);
    Vec3s x, v;
    g.download(&x, &v);
    EXPECT_LT(maxDiff(v, v1) / maxNorm(v1), 1e-10) << lanes << " lanes";
    EXPECT_LT(maxDiff(displacement(x, a.cloud.X), displacement(x1, a.cloud.X)) / maxNorm(displacement(x1, a.cloud.X)),
              1e-10)
        << lanes << " lanes";
  }
  EXPECT_THROW(SoftBodyCuda(*a.sim, CudaPrecision::Float64, 3), TopoError);
}

// The evaluation with its registers capped (chosen for large grids) does the same arithmetic: the same
// bits as the uncapped one after 100 steps, in both precisions, with 2 and 4 lanes, and when the mode is
// switched between steps of one body (its captured graph made again). The beam's small grid fits on the
// SMs, so by default it runs uncapped; 8 lanes have no capped kernel.
TEST(CudaSoftBody, TheCappedEvaluationGivesTheSameBits) {
  SKIP_WITHOUT_GPU();
  Beam a = makeBeam(SphEnergyModel::StVK, SphRotationSource::ShapeMatchingApq, 1.5, true, 0.0);
  const double dt = 0.5 * a.sim->stableTimeStep();
  for (CudaPrecision precision : {CudaPrecision::Float64, CudaPrecision::Float32})
    for (int lanes : {2, 4}) {
      Vec3s x[3], v[3];
      for (int capped : {0, 1}) {
        SoftBodyCuda g(*a.sim, precision, lanes);
        EXPECT_FALSE(g.cappedEvaluation()) << "the default on a small grid";
        g.setCappedEvaluation(capped);
        EXPECT_EQ(g.cappedEvaluation(), capped == 1);
        g.step(dt, 100);
        g.download(&x[capped], &v[capped]);
      }
      {
        SoftBodyCuda g(*a.sim, precision, lanes);  // 50 steps uncapped, then 50 capped
        g.setCappedEvaluation(0);
        g.step(dt, 50);
        g.setCappedEvaluation(1);
        g.step(dt, 50);
        g.download(&x[2], &v[2]);
      }
      for (int k : {1, 2}) {
        EXPECT_EQ(maxDiff(x[0], x[k]), 0.0) << lanes << " lanes, run " << k;
        EXPECT_EQ(maxDiff(v[0], v[k]), 0.0) << lanes << " lanes, run " << k;
      }
      EXPECT_GT(maxNorm(displacement(x[0], a.cloud.X)), 0.0);
    }
  SoftBodyCuda eight(*a.sim, CudaPrecision::Float32, 8);
  eight.setCappedEvaluation(1);
  EXPECT_FALSE(eight.cappedEvaluation());
}

// float32's evaluation finished one thread a particle (evaluateWarpKernel, chosen for large grids)
// against the CPU at float32's stated tolerance (1e-3 over 100 steps) and against the group kernel
// (the same formulas, float32 rounding apart), with 2 and 4 lanes, uncapped and capped (the variant
// large grids run): the paper's StVK/A_pq body with hourglass, and the corotated one with damping and a
// ramped chamber pressure (whose term is in the finishing work). The beams have 13 × 4 × 4 particles,
// so the last warp is partial. The small grid runs the group kernel by default; float64 and 8 lanes
// never run the warp one.
TEST(CudaSoftBody, TheWarpEvaluationStaysWithinTheFloat32Tolerance) {
  SKIP_WITHOUT_GPU();
  const auto make = [](int which) {
    return which == 0
               ? makeBeam(SphEnergyModel::StVK, SphRotationSource::ShapeMatchingApq, 1.5, false, 0.0, 13)
               : makeBeam(SphEnergyModel::CorotatedLinear, SphRotationSource::CorrectedGradient, 1.0, true, 3.0, 13);
  };
  for (int which : {0, 1})
    for (int lanes : {2, 4}) {
      Beam g = make(which);
      ASSERT_NE(g.cloud.size() % 32, 0u) << "a partial last warp";
      Vec3s x_group;
      const Parity pg = compare(g, CudaPrecision::Float32, 100, 0.5, lanes, 0, -1, &x_group);
      const double u_max = maxNorm(displacement(x_group, g.cloud.X));
      ASSERT_GT(u_max, 0.0);
      for (int capped : {0, 1}) {
        Beam w = make(which);
        Vec3s x_warp;
        const Parity pw = compare(w, CudaPrecision::Float32, 100, 0.5, lanes, 1, capped, &x_warp);
        const double d = maxDiff(x_warp, x_group) / u_max;
        EXPECT_LT(pw.x, 1e-3) << which << ", " << lanes << " lanes, capped " << capped;
        EXPECT_LT(pw.v, 1e-3) << which << ", " << lanes << " lanes, capped " << capped;
        EXPECT_LT(pw.f, 2e-3) << which << ", " << lanes << " lanes, capped " << capped;
        EXPECT_LT(d, 1e-4) << which << ", " << lanes << " lanes, capped " << capped;
        std::printf(
            "[ parity   ] float32, 100 steps, %s, %d lanes: group kernel dx %.2e dv %.2e df %.2e; warp kernel%s "
            "dx %.2e dv %.2e df %.2e, from the group kernel's %.2e\n",
            which == 0 ? "StVK/A_pq" : "corotated/chamber", lanes, pg.x, pg.v, pg.f, capped ? " capped" : "", pw.x,
            pw.v, pw.f, d);
      }
    }
  Beam c = makeBeam(SphEnergyModel::StVK, SphRotationSource::ShapeMatchingApq, 1.5, true, 0.0);
  SoftBodyCuda g(*c.sim, CudaPrecision::Float32, 4);
  EXPECT_FALSE(g.warpEvaluation()) << "the default on a small grid";
  SoftBodyCuda d(*c.sim, CudaPrecision::Float64, 4), e(*c.sim, CudaPrecision::Float32, 8);
  d.setWarpEvaluation(1);
  e.setWarpEvaluation(1);
  EXPECT_FALSE(d.warpEvaluation());
  EXPECT_FALSE(e.warpEvaluation());
}

TEST(CudaSoftRollout, GradientOfA100StepRolloutMatchesTheCpuInFloat64) {
  SKIP_WITHOUT_GPU();
  // every 7: checkpoints and recomputed segments of unequal length; 0 (auto): the 101 states fit, all kept
  for (const int every : {7, 0})
    for (int variant = 0; variant < 2; ++variant) {
      // 0: StVK, A_pq rotations (Hessian with R held, as on the CPU), h = 1.5; 1: corotated linear with
      // corrected-gradient rotations (exact rotation derivative), damping, ramped chamber, h = 1.0.
      auto make = [&] {
        return variant == 0
                   ? makeBeam(SphEnergyModel::StVK, SphRotationSource::ShapeMatchingApq, 1.5, false, 0.0)
                   : makeBeam(SphEnergyModel::CorotatedLinear, SphRotationSource::CorrectedGradient, 1.0, true, 2.0);
      };
      Beam cpu = make(), gpu = make();
      SoftRolloutResult rc, rg;
      runBoth(cpu.sim.get(), gpu.sim.get(), testLoss(cpu.cloud), testLoss(gpu.cloud), 100, every, &rc, &rg);
      EXPECT_NEAR(rg.loss, rc.loss, 1e-9 * std::abs(rc.loss)) << variant;
      // ⌈(100 − 7) / 7⌉ = 14 checkpoints and the last segment's 8 states (kept by the forward).
      EXPECT_EQ(rg.peak_states, every == 0 ? 101u : 14u + 8u) << "checkpoint every " << every;
      const SoftDesignGradient &a = rg.gradient, &c = rc.gradient;
      const double dm = relDiff(a.mass, c.mass), dmu = relDiff(a.mu, c.mu), dla = relDiff(a.lambda, c.lambda);
      const double dx0 = maxDiff(a.x0, c.x0) / maxNorm(c.x0), dv0 = maxDiff(a.v0, c.v0) / maxNorm(c.v0);
      EXPECT_LT(dm, 1e-6) << variant;
      EXPECT_LT(dmu, 1e-6) << variant;
      EXPECT_LT(dla, 1e-6) << variant;
      EXPECT_LT(dx0, 1e-6) << variant;
      EXPECT_LT(dv0, 1e-6) << variant;
      double dch = 0.0;
      if (variant == 1) {
        dch = relDiff(a.chamber, c.chamber);
        EXPECT_LT(dch, 1e-6);
      }
      // The simulator is left at the final state, as SoftRollout leaves it.
      EXPECT_LT(
          maxDiff(displacement(gpu.sim->positions(), gpu.cloud.X), displacement(cpu.sim->positions(), cpu.cloud.X)) /
              maxNorm(displacement(cpu.sim->positions(), cpu.cloud.X)),
          1e-9);
      std::printf(
          "[ parity   ] rollout gradient, checkpoint every %d, variant %d: loss %.2e, mass %.2e, mu %.2e, lambda %.2e, "
          "chamber %.2e, x0 %.2e, "
          "v0 %.2e; forward %.3f s / backward %.3f s (CPU %.3f / %.3f s)\n",
          every, variant, std::abs(rg.loss - rc.loss) / std::abs(rc.loss), dm, dmu, dla, dch, dx0, dv0, rg.forward_s,
          rg.backward_s, rc.forward_s, rc.backward_s);
    }
}

TEST(CudaSoftRollout, RefusesWhatIsNotOnTheGpu) {
  Beam a = makeBeam(SphEnergyModel::StVK, SphRotationSource::ShapeMatchingApq, 1.5, false, 0.0);
  SoftRolloutOptions o;
  o.dt = 0.5 * a.sim->stableTimeStep();
  o.steps = 3;
  o.integrator = SoftIntegrator::ImplicitEuler;
  try {
    runSoftRolloutCuda(a.sim.get(), o, testLoss(a.cloud), true);
    FAIL() << "implicit accepted";
  } catch (const TopoError& e) {
    const std::string m = e.what();
    // Without a device the reason is the device; with one, the implicit integrator.
    EXPECT_TRUE(m.find("implicit") != std::string::npos || m.find(cudaDeviceInfo().reason) != std::string::npos) << m;
  }
}

TEST(CudaSoftRollout, ALossAtSomeStepsOnlyMatchesTheCpu) {
  SKIP_WITHOUT_GPU();
  // loss_at: the loss counts every 10th step; the GPU copies only those states to the host. Also
  // float32 against the CPU's float64 (stated tolerance 1e-3 of each gradient's largest entry).
  Beam cpu = makeBeam(SphEnergyModel::StVK, SphRotationSource::ShapeMatchingApq, 1.5, true, 1.0);
  Beam gpu = makeBeam(SphEnergyModel::StVK, SphRotationSource::ShapeMatchingApq, 1.5, true, 1.0);
  Beam g32 = makeBeam(SphEnergyModel::StVK, SphRotationSource::ShapeMatchingApq, 1.5, true, 1.0);
  SoftRolloutOptions o;
  o.dt = 0.5 * cpu.sim->stableTimeStep();
  o.steps = 100;
  o.loss_at = [](int k) { return k % 10 == 0; };
  const SoftStepLoss full = testLoss(cpu.cloud);
  int calls = 0;
  const SoftStepLoss counted = [&](int k, double t, const Vec3s& x, const Vec3s& v, Vec3s* dx, Vec3s* dv) {
    EXPECT_EQ(k % 10, 0) << "the loss was called at a step loss_at excludes";
    ++calls;
    return full(k, t, x, v, dx, dv);
  };
  const SoftRolloutResult rc = SoftRollout(cpu.sim.get(), o).run(counted, true);
  const int cpu_calls = calls;
  calls = 0;
  const SoftRolloutResult rg = runSoftRolloutCuda(gpu.sim.get(), o, counted, true);
  EXPECT_EQ(calls, cpu_calls);
  EXPECT_EQ(cpu_calls, 2 * 11);  // 11 counted states, forward and backward
  EXPECT_NEAR(rg.loss, rc.loss, 1e-9 * std::abs(rc.loss));
  EXPECT_LT(relDiff(rg.gradient.mu, rc.gradient.mu), 1e-6);
  EXPECT_LT(relDiff(rg.gradient.chamber, rc.gradient.chamber), 1e-6);
  EXPECT_LT(maxDiff(rg.gradient.x0, rc.gradient.x0) / maxNorm(rc.gradient.x0), 1e-6);
  const SoftRolloutResult r32 = runSoftRolloutCuda(g32.sim.get(), o, full, true, CudaPrecision::Float32);
  const double e_mass = relDiff(r32.gradient.mass, rc.gradient.mass), e_mu = relDiff(r32.gradient.mu, rc.gradient.mu);
  const double e_x0 = maxDiff(r32.gradient.x0, rc.gradient.x0) / maxNorm(rc.gradient.x0);
  EXPECT_LT(e_mass, 1e-3);
  EXPECT_LT(e_mu, 1e-3);
  EXPECT_LT(e_x0, 1e-3);
  std::printf("[ parity   ] float32 rollout gradient: mass %.2e mu %.2e x0 %.2e\n", e_mass, e_mu, e_x0);
}

TEST(CudaSoftRollout, TooLittleGpuMemoryIsRefusedBeforeAnythingRuns) {
  SKIP_WITHOUT_GPU();
  // 10⁸ steps with a checkpoint at every step: 72 B × 10⁸ per particle, over 20 TB for the beam.
  Beam a = makeBeam(SphEnergyModel::StVK, SphRotationSource::ShapeMatchingApq, 1.5, false, 0.0);
  SoftRolloutOptions o;
  o.dt = 0.5 * a.sim->stableTimeStep();
  o.steps = 100000000;
  o.checkpoint_every = 1;
  const Vec3s x0 = a.sim->positions();
  try {
    runSoftRolloutCuda(a.sim.get(), o, testLoss(a.cloud), true);
    FAIL() << "accepted";
  } catch (const GpuMemoryError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("MiB are free"), std::string::npos) << m;
    EXPECT_NE(m.find("particles would fit"), std::string::npos) << m;
    EXPECT_NE(m.find("backend cpu"), std::string::npos) << m;
  }
  EXPECT_EQ(maxDiff(a.sim->positions(), x0), 0.0);  // nothing ran
}
