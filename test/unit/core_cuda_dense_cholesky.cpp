// The rest stiffness's Cholesky factor on the GPU (the static/implicit path): the dense
// cuSOLVER factor against the host's sparse one (the same matrix: z = A⁻¹ r within 1e-10), a static
// solve with it against the host's (the same Newton iterates: displacement within 1e-9), and what a
// GPU without the memory does (backend auto: the host factorises and the simulator says why; backend
// cuda: the solve stops naming the particles that fit). Without a device these tests skip with the
// reason, and the refusal without one is checked instead.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>

#include "gpu_test.h"
#include "test_clouds.h"
#include "test_soft_bodies.h"
#include "topo_gaussian/common/error.h"
#include "topo_gaussian/cuda/backend.h"
#include "topo_gaussian/cuda/dense_cholesky_cuda.h"
#include "topo_gaussian/cuda/soft_stiffness_cuda.h"
#include "topo_gaussian/physics/soft_body.h"

using namespace topo_gaussian;

namespace {

/// A 16 × 4 × 4-cell cantilever with a soft (1e5) pressurised core, 256 particles.
std::unique_ptr<SoftBodySimulator> makeFinger(const SoftBodyOptions& so) {
  return topo_test::pneumaticCantilever(16, 1e5, 13, so);
}

TEST(DenseCholeskyCuda, ParticlesThatFitFollowTheDenseSize) {
  // (3N)² × 8 bytes: the 9212-particle finger takes 6.1 GB; what fits in that is the finger again.
  EXPECT_NEAR(denseCholeskyBytes(3 * 9212) / 1e9, 6.110, 0.001);
  EXPECT_EQ(denseCholeskyParticlesFitting(denseCholeskyBytes(3 * 9212) + 1.0), 9212u);
  EXPECT_EQ(denseCholeskyParticlesFitting(0.0), 0u);
}

TEST(DenseCholeskyCuda, TheInversesBreakEvenGrowsWithTheUnknowns) {
  // 180 applications at the finger's 27 636 unknowns (the calibration), in proportion elsewhere.
  EXPECT_EQ(denseCholeskyInverseBreakEven(27636), 180);
  EXPECT_EQ(denseCholeskyInverseBreakEven(13818), 90);
  EXPECT_EQ(denseCholeskyInverseBreakEven(768), 6);  // 5.0 rounded up
  EXPECT_EQ(denseCholeskyInverseFactorBreakEven(27636), 48);
  EXPECT_EQ(denseCholeskyInverseFactorBreakEven(768), 2);  // 1.33 rounded up
}

TEST(DenseCholeskyCuda, AFactorAppliedBeyondItsLimitTakesTheInverse) {
  SKIP_WITHOUT_GPU();
  // The pneumatic cantilever's K0 (stiff walls, soft core, clamp), 5 triangular solves, then the inverse:
  // the float64 one (potri) within 1e-9 of the host's CHOLMOD solve (~1e-12 measured), or the float32
  // inverse factor within 3-5e-10 (measured; its rounding errors are incoherent and the product is
  // dominated by K0's softest modes): bounded by 1e-8, and not within 3e-11, so the rounding is there.
  auto sim = makeFinger(SoftBodyOptions());
  const RestStiffnessPreconditioner host(sim->sph(), Eigen::VectorXd(), sim->clamped());
  for (const auto inverse : {DenseCholeskyApply::InverseGemv, DenseCholeskyApply::InverseFactorFloat32}) {
    const bool f32 = inverse == DenseCholeskyApply::InverseFactorFloat32;
    const RestStiffnessPreconditioner gpu(
        sim->sph(), Eigen::VectorXd(), sim->clamped(), 0.0,
        [inverse] { return makeDenseCholeskyCuda(0.0, DenseCholeskyApply::Triangular, 5, inverse); }, true);
    const std::string name =
        f32 ? "inverse factor in float32 after 5 triangular solves" : "explicit inverse after 5 triangular solves";
    std::mt19937 rng(f32 ? 5 : 3);
    std::normal_distribution<double> n01;
    for (int k = 1; k <= 8; ++k) {
      Eigen::VectorXd r(3 * sim->size()), zh, zg;
      for (Eigen::Index j = 0; j < r.size(); ++j) r[j] = n01(rng);
      host.apply(r, &zh);
      gpu.apply(r, &zg);
      EXPECT_LT((zg - zh).norm(), (f32 && k > 5 ? 1e-8 : 1e-9) * zh.norm())
          << "application " << k << " on " << gpu.where();
      if (f32 && k > 5) {
        EXPECT_GT((zg - zh).norm(), 3e-11 * zh.norm()) << "application " << k << ": not float32's rounding";
      }
      EXPECT_EQ(gpu.where().find(name) != std::string::npos, k > 5) << "application " << k << ": " << gpu.where();
    }
    EXPECT_EQ(gpu.applications(), 8);
    EXPECT_GT(gpu.applySeconds(), 0.0);
  }
}

/// Lower triangle (compressed columns) of a dense symmetric matrix.
Eigen::SparseMatrix<double> lowerOf(const Eigen::MatrixXd& A) {
  Eigen::SparseMatrix<double> lower = Eigen::MatrixXd(A.triangularView<Eigen::Lower>()).sparseView();
  lower.makeCompressed();
  return lower;
}

TEST(DenseCholeskyCuda, TheFloat32InverseFactorIsTheGramFormOfTheRoundedFactor) {
  SKIP_WITHOUT_GPU();
  // z = L̃⁻ᵀ L̃⁻¹ r with L̃⁻¹ = L⁻¹ rounded to float32 once, summed in float64: against that formula
  // evaluated on the host within 1e-10 (only the GPU's inversion against Eigen's round-off, which may
  // flip a float's last bit: ~2e-13 in a CPU emulation), and ~ε₃₂ √cond away from A⁻¹ r, so the rounding is really
  // float32's. Sizes: below one tile and chunk, not a multiple of 4 (padding), several row chunks, several column
  // tiles.
  std::mt19937 rng(17);
  std::normal_distribution<double> n01;
  for (const int n : {77, 1000, 2501}) {
    Eigen::MatrixXd B(n, n);
    for (Eigen::Index k = 0; k < B.size(); ++k) B.data()[k] = n01(rng);
    const Eigen::MatrixXd A = B * B.transpose() / n + 0.05 * Eigen::MatrixXd::Identity(n, n);  // cond ~1e2
    auto gpu = makeDenseCholeskyCuda(0.0, DenseCholeskyApply::InverseFactorFloat32);
    ASSERT_TRUE(gpu->factorize(lowerOf(A)));
    EXPECT_NE(gpu->name().find("inverse factor in float32"), std::string::npos) << gpu->name();
    EXPECT_NEAR(gpu->bytes(), 4.0 * n * ((n + 31) / 32 * 32), 0.2 * 4.0 * n * n);  // the float32 rows, no float64
    const Eigen::MatrixXd Linv = A.llt().matrixL().solve(Eigen::MatrixXd::Identity(n, n));
    const Eigen::MatrixXd Lr = Linv.cast<float>().cast<double>().triangularView<Eigen::Lower>();
    Eigen::VectorXd r(n), s(n), zr, zs;
    for (int k = 0; k < n; ++k) r[k] = n01(rng), s[k] = n01(rng);
    gpu->solve(r, &zr);
    gpu->solve(s, &zs);
    const Eigen::VectorXd want = Lr.transpose() * (Lr * r);
    const Eigen::VectorXd exact = A.llt().solve(r);
    EXPECT_LT((zr - want).norm(), 1e-10 * want.norm()) << n << " unknowns";
    EXPECT_GT((zr - exact).norm(), 10.0 * (zr - want).norm()) << n << " unknowns";
    EXPECT_LT((zr - exact).norm(), 1e-5 * exact.norm()) << n << " unknowns";
    // symmetric to float64's round-off, positive
    EXPECT_NEAR(s.dot(zr), r.dot(zs), 1e-12 * zr.norm() * s.norm()) << n << " unknowns";
    EXPECT_GT(r.dot(zr), 0.0);
  }
}

TEST(DenseCholeskyCuda, TheFloat32InverseFactorStaysPositiveDefiniteWhereAFloat32InverseDoesNot) {
  SKIP_WITHOUT_GPU();
  // A = Q diag(λ) Qᵀ with λ from 1e-10 to 1 (cond 1e10): A⁻¹ rounded to float32 has a negative
  // eigenvalue (its rounding, ~ε₃₂ · 1e10, swamps A⁻¹'s smallest eigenvalue 1: −25 to −36 in a CPU
  // emulation); the GPU's operator, built column by column from 77 solves, is symmetric and positive
  // definite, and preconditions A: the eigenvalues of M A stay within ~ε₃₂ √cond(A) of 1 (1e-3 emulated).
  const int n = 77;
  std::mt19937 rng(23);
  std::normal_distribution<double> n01;
  Eigen::MatrixXd G(n, n);
  for (Eigen::Index k = 0; k < G.size(); ++k) G.data()[k] = n01(rng);
  const Eigen::MatrixXd Q = G.householderQr().householderQ();
  Eigen::VectorXd lambda(n);
  for (int k = 0; k < n; ++k) lambda[k] = std::pow(10.0, -10.0 * k / (n - 1));
  const Eigen::MatrixXd A = Q * lambda.asDiagonal() * Q.transpose();
  const Eigen::MatrixXd Ainv32 =
      Eigen::MatrixXd(Q * lambda.cwiseInverse().asDiagonal() * Q.transpose()).cast<float>().cast<double>();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> naive(0.5 * (Ainv32 + Ainv32.transpose()));
  ASSERT_LT(naive.eigenvalues().minCoeff(), 0.0) << "the float32 copy of A⁻¹ should not be positive definite here";
  auto gpu = makeDenseCholeskyCuda(0.0, DenseCholeskyApply::InverseFactorFloat32);
  ASSERT_TRUE(gpu->factorize(lowerOf(0.5 * (A + A.transpose()))));
  Eigen::MatrixXd M(n, n);
  for (int k = 0; k < n; ++k) {
    Eigen::VectorXd z;
    gpu->solve(Eigen::VectorXd::Unit(n, k), &z);
    M.col(k) = z;
  }
  EXPECT_LT((M - M.transpose()).norm(), 1e-12 * M.norm());
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> applied(0.5 * (M + M.transpose()));
  EXPECT_GT(applied.eigenvalues().minCoeff(), 0.0);
  // M A is similar to the SPD M^½ A M^½: its eigenvalues are real and near 1
  Eigen::EigenSolver<Eigen::MatrixXd> ma(M * A);
  const Eigen::VectorXd ev = ma.eigenvalues().real();
  EXPECT_GT(ev.minCoeff(), 0.99);
  EXPECT_LT(ev.maxCoeff(), 1.01);
}

TEST(DenseCholeskyCuda, WithoutADeviceItIsRefusedWithTheReason) {
  if (cudaDeviceInfo().available) GTEST_SKIP() << "a CUDA device is present: " << cudaDeviceInfo().name;
  auto sim = makeFinger(SoftBodyOptions());
  EXPECT_NE(denseCholeskyRefusal(3 * sim->size()).find(cudaDeviceInfo().built ? "no CUDA device" : "no CUDA backend"),
            std::string::npos);
  Eigen::SparseMatrix<double> I(3, 3);
  I.setIdentity();
  try {
    makeDenseCholeskyCuda()->factorize(I);
    FAIL() << "factorised without a device";
  } catch (const TopoError& e) {
    EXPECT_NE(std::string(e.what()).find("backend cpu"), std::string::npos) << e.what();
  }
  // Through the simulator, not required (backend auto): the host factorises and the note says why.
  SoftBodyOptions so;
  so.cholesky_external = [] { return makeDenseCholeskyCuda(); };
  auto with = makeFinger(so);
  with->systemPreconditioner(0.0);
  EXPECT_NE(with->preconditionerNote().find("on the host, not the GPU"), std::string::npos)
      << with->preconditionerNote();
  EXPECT_EQ(with->preconditionerWhere().rfind("host: ", 0), 0u) << with->preconditionerWhere();
}

TEST(DenseCholeskyCuda, SolvesAsTheHostFactorDoes) {
  SKIP_WITHOUT_GPU();
  auto sim = makeFinger(SoftBodyOptions());
  Eigen::VectorXd shift = Eigen::VectorXd::Constant(3 * sim->size(), 0.0);
  for (double inertia : {0.0, 1e6}) {  // static, and an implicit step's m/dt²
    for (std::size_t i = 0; i < sim->size(); ++i) shift.segment<3>(3 * i).setConstant(inertia * sim->masses()[i]);
    const RestStiffnessPreconditioner host(sim->sph(), shift, sim->clamped());
    const RestStiffnessPreconditioner gpu(
        sim->sph(), shift, sim->clamped(), 0.0, [] { return makeDenseCholeskyCuda(); }, true);
    EXPECT_NE(gpu.where().find("cuSOLVER"), std::string::npos) << gpu.where();
    EXPECT_NE(gpu.where().find(cudaDeviceInfo().name), std::string::npos) << gpu.where();
    EXPECT_TRUE(gpu.externalNote().empty()) << gpu.externalNote();
    std::mt19937 rng(7);
    std::normal_distribution<double> n01;
    for (int k = 0; k < 3; ++k) {
      Eigen::VectorXd r(3 * sim->size());
      for (Eigen::Index j = 0; j < r.size(); ++j) r[j] = n01(rng);
      Eigen::VectorXd zh, zg;
      host.apply(r, &zh);
      gpu.apply(r, &zg);
      EXPECT_LT((zg - zh).norm(), 1e-10 * zh.norm()) << "inertia " << inertia << ", right-hand side " << k;
    }
  }
}

TEST(DenseCholeskyCuda, TheExplicitInverseIsAPreconditionerOfTheSameMatrix) {
  SKIP_WITHOUT_GPU();
  auto sim = makeFinger(SoftBodyOptions());
  const Eigen::VectorXd shift;
  const RestStiffnessPreconditioner host(sim->sph(), shift, sim->clamped());
  for (const auto apply : {DenseCholeskyApply::InverseSymv, DenseCholeskyApply::InverseGemv}) {
    const RestStiffnessPreconditioner gpu(
        sim->sph(), shift, sim->clamped(), 0.0, [apply] { return makeDenseCholeskyCuda(0.0, apply); }, true);
    EXPECT_NE(gpu.where().find("explicit inverse"), std::string::npos) << gpu.where();
    std::mt19937 rng(11);
    std::normal_distribution<double> n01;
    Eigen::VectorXd r(3 * sim->size()), zh, zg;
    for (Eigen::Index j = 0; j < r.size(); ++j) r[j] = n01(rng);
    host.apply(r, &zh);
    gpu.apply(r, &zg);
    // cond(K0) × ε: the stiff walls against the soft core and the clamp (measured ~1e-12 here)
    EXPECT_LT((zg - zh).norm(), 1e-9 * zh.norm()) << "apply " << static_cast<int>(apply);
  }
}

TEST(StiffnessCuda, ProductMatchesTheHostAtADeformedState) {
  SKIP_WITHOUT_GPU();
  auto host = makeFinger(SoftBodyOptions());
  host->solveStatic(NewtonOptions(), 2);  // inflated and bent: rotations, large strain, the chamber's term
  SoftBodyOptions so;
  so.stiffness_external = [](const SoftBodySimulator& s) { return makeStiffnessCuda(s); };
  so.cholesky_external_required = true;
  auto gpu = makeFinger(so);
  gpu->evaluateAt(host->positions(), host->time());
  std::mt19937 rng(5);
  std::normal_distribution<double> n01;
  for (double inertia : {0.0, 1e6}) {
    Eigen::VectorXd p(3 * host->size()), kh, kg;
    for (Eigen::Index j = 0; j < p.size(); ++j) p[j] = n01(rng);
    host->systemProduct(p, inertia, &kh);
    gpu->systemProduct(p, inertia, &kg);
    EXPECT_LT((kg - kh).norm(), 1e-12 * kh.norm()) << "inertia " << inertia;
  }
  EXPECT_TRUE(gpu->preconditionerNote().empty()) << gpu->preconditionerNote();
}

TEST(DenseCholeskyCuda, StaticSolveMatchesTheHost) {
  SKIP_WITHOUT_GPU();
  NewtonOptions newton;
  newton.tolerance = 1e-10;
  auto host = makeFinger(SoftBodyOptions());
  const SolveReport rh = host->solveStatic(newton, 2);
  SoftBodyOptions so;
  so.cholesky_external = [] { return makeDenseCholeskyCuda(); };
  so.stiffness_external = [](const SoftBodySimulator& s) { return makeStiffnessCuda(s); };
  so.cholesky_external_required = true;
  auto gpu = makeFinger(so);
  const SolveReport rg = gpu->solveStatic(newton, 2);
  EXPECT_TRUE(gpu->preconditionerNote().empty()) << gpu->preconditionerNote();
  EXPECT_NE(gpu->preconditionerWhere().find("cuSOLVER"), std::string::npos) << gpu->preconditionerWhere();
  double dmax = 0.0, umax = 0.0;
  for (std::size_t i = 0; i < host->size(); ++i) {
    const Eigen::Vector3d u = host->positions()[i] - host->restPositions()[i];
    umax = std::max(umax, u.norm());
    dmax = std::max(dmax, (gpu->positions()[i] - host->positions()[i]).norm());
  }
  EXPECT_GT(umax, 1e-4);  // the chamber bends the beam by more than 0.1 mm
  EXPECT_LT(dmax, 1e-9 * umax) << "largest displacement " << umax << " m";
  EXPECT_EQ(rg.newton.iterations, rh.newton.iterations);
  EXPECT_NEAR(rg.newton.cg_iterations, rh.newton.cg_iterations, 1);
}

TEST(DenseCholeskyCuda, AMatrixThatIsNotPositiveDefiniteIsRefusedAsOnTheHost) {
  SKIP_WITHOUT_GPU();
  // K0 − 1e12 I is negative definite: neither factor exists. The GPU's says so as the host's does (the
  // same TopoError, which the simulator turns into Jacobi), also where the GPU factor is required: that
  // is not a refusal of the GPU (ExternalFactorRefused), which would stop the solve.
  auto sim = makeFinger(SoftBodyOptions());
  const Eigen::VectorXd shift = Eigen::VectorXd::Constant(3 * static_cast<Eigen::Index>(sim->size()), -1e12);
  std::string host_text;
  try {
    RestStiffnessPreconditioner host(sim->sph(), shift, sim->clamped());
    FAIL() << "the host factorised a negative definite matrix";
  } catch (const TopoError& e) {
    host_text = e.what();
  }
  EXPECT_NE(host_text.find("not positive definite"), std::string::npos) << host_text;
  for (const bool required : {false, true}) {
    try {
      RestStiffnessPreconditioner gpu(
          sim->sph(), shift, sim->clamped(), 0.0, [] { return makeDenseCholeskyCuda(); }, required);
      FAIL() << "the GPU factorised a negative definite matrix";
    } catch (const ExternalFactorRefused& e) {
      FAIL() << "refused as a GPU failure: " << e.what();
    } catch (const TopoError& e) {
      EXPECT_EQ(std::string(e.what()), host_text);
    }
  }
}

TEST(DenseCholeskyCuda, AboveTheMemoryLimitAutoFactorisesOnTheHostAndCudaStops) {
  SKIP_WITHOUT_GPU();
  NewtonOptions newton;
  newton.tolerance = 1e-10;
  auto host = makeFinger(SoftBodyOptions());
  host->solveStatic(newton, 2);
  SoftBodyOptions so;
  so.cholesky_external = [] { return makeDenseCholeskyCuda(1e5); };  // 100 kB: nothing fits
  auto fallback = makeFinger(so);
  fallback->solveStatic(newton, 2);
  EXPECT_NE(fallback->preconditionerNote().find("particles would fit"), std::string::npos)
      << fallback->preconditionerNote();
  EXPECT_EQ(fallback->preconditionerWhere().rfind("host: ", 0), 0u) << fallback->preconditionerWhere();
  for (std::size_t i = 0; i < host->size(); ++i)
    EXPECT_LT((fallback->positions()[i] - host->positions()[i]).norm(), 1e-12);
  so.cholesky_external_required = true;
  auto strict = makeFinger(so);
  try {
    strict->solveStatic(newton, 2);
    FAIL() << "solved without the GPU factor it was required to use";
  } catch (const TopoError& e) {
    EXPECT_NE(std::string(e.what()).find("particles would fit"), std::string::npos) << e.what();
  }
}

}  // namespace
