// Rest stiffness K0 of corotated SPH (rest_stiffness.h): the assembled sparse matrix reproduces
// the matrix-free Hessian product at the rest state to round-off for both energy models and both
// gradient orders, with per-particle materials and the hourglass term; it is symmetric; and its
// Cholesky factor inverts K0 + shift with fixed particles as identity rows.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/physics/rest_stiffness.h"

using namespace topo_gaussian;

namespace {

// A 7×4×3 block (or nx × ny × nz) of a 5 mm lattice with one corner cut (irregular boundary) and
// random materials.
CorotatedSph makeSph(SphEnergyModel model, int order, int nx = 7, int ny = 4, int nz = 3) {
  std::vector<Eigen::Vector3d> X;
  std::vector<double> V, mu, la;
  const double dx = 0.005;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.2, 1.0);
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        if (i == nx - 1 && j == ny - 1 && k == nz - 1) continue;
        X.push_back(dx * Eigen::Vector3d(i, j, k));
        V.push_back(dx * dx * dx);
        const LameParameters m = lameFromYoung(1e6 * u(rng), 0.45 * u(rng));
        mu.push_back(m.mu);
        la.push_back(m.lambda);
      }
  CorotatedSphOptions o;
  o.spacing = dx;
  o.smoothing_factor = 1.3;
  o.model = model;
  o.rotation = SphRotationSource::CorrectedGradient;
  o.gradient_order = order;
  o.hourglass_alpha = 0.3;
  CorotatedSph sph(X, V, mu, la, o);
  sph.update(X);
  return sph;
}

}  // namespace

TEST(RestStiffness, MatchesTheHessianProductAtRest) {
  for (auto model : {SphEnergyModel::CorotatedLinear, SphEnergyModel::StVK})
    for (int order : {1, 2}) {
      const CorotatedSph sph = makeSph(model, order);
      const Eigen::SparseMatrix<double> K = restStiffness(sph);
      const std::size_t n = sph.size();
      ASSERT_EQ(K.rows(), static_cast<Eigen::Index>(3 * n));
      std::mt19937 rng(3);
      std::normal_distribution<double> N01;
      std::vector<Eigen::Vector3d> v(n);
      Eigen::VectorXd vf(3 * n);
      for (std::size_t i = 0; i < n; ++i) {
        v[i] = Eigen::Vector3d(N01(rng), N01(rng), N01(rng));
        vf.segment<3>(3 * i) = v[i];
      }
      const auto Hv = sph.hessianProduct(v);
      const Eigen::VectorXd Kv = K * vf;
      double num = 0.0, den = 0.0;
      for (std::size_t i = 0; i < n; ++i) {
        num += (Kv.segment<3>(3 * i) - Hv[i]).squaredNorm();
        den += Hv[i].squaredNorm();
      }
      const double rel = std::sqrt(num / den);
      const double asym = (Eigen::SparseMatrix<double>(K.transpose()) - K).norm() / K.norm();
      std::printf("[rest stiffness] model %d order %d: |K0 v - H v| / |H v| = %.2e, asymmetry %.2e, nnz %ld\n",
                  static_cast<int>(model), order, rel, asym, static_cast<long>(K.nonZeros()));
      EXPECT_LT(rel, 1e-12);
      EXPECT_LT(asym, 1e-13);
    }
}

TEST(RestStiffness, PreconditionerInvertsTheShiftedStiffnessWithFixedParticles) {
  const CorotatedSph sph = makeSph(SphEnergyModel::CorotatedLinear, 1);
  const std::size_t n = sph.size();
  std::vector<std::uint8_t> fixed(n, 0);
  for (std::size_t i = 0; i < n; ++i) fixed[i] = sph.restPositions()[i].x() < 1e-9;  // the x = 0 face
  Eigen::VectorXd shift = Eigen::VectorXd::Constant(3 * n, 10.0);
  const RestStiffnessPreconditioner P(sph, shift, fixed);
  // (K0 + shift) restricted to the free particles, identity on the fixed ones.
  Eigen::SparseMatrix<double> K = restStiffness(sph);
  Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(3 * n, -1.0, 2.0), z;
  for (std::size_t i = 0; i < n; ++i)
    if (fixed[i]) b.segment<3>(3 * i).setZero();
  P.apply(b, &z);
  Eigen::VectorXd zf = z;
  for (std::size_t i = 0; i < n; ++i)
    if (fixed[i]) {
      EXPECT_LT(z.segment<3>(3 * i).norm(), 1e-300);
      zf.segment<3>(3 * i).setZero();
    }
  Eigen::VectorXd Kz = K * zf + shift.cwiseProduct(zf);
  for (std::size_t i = 0; i < n; ++i)
    if (fixed[i]) Kz.segment<3>(3 * i).setZero();
  const double rel = (Kz - b).norm() / b.norm();
  std::printf("[rest stiffness] solve residual %.2e, nnz %zu, factorised in %.3f s\n", rel, P.nonZeros(),
              P.factorSeconds());
  EXPECT_LT(rel, 1e-10);
  // An unsupported body without shift has rigid modes: a clear error, not garbage.
  EXPECT_THROW(RestStiffnessPreconditioner(sph, Eigen::VectorXd(), {}), TopoError);
}

// Every evaluation of an inference factorises the same body with another material: the second
// preconditioner of a pattern takes over the first one's symbolic analysis (ordering) and only
// refactorises numerically (CHOLMOD), and still inverts its own K0 + shift exactly. Another
// pattern (other clamps) gets an analysis of its own.
TEST(RestStiffness, PreconditionerReusesTheAnalysisOfTheSamePattern) {
  CorotatedSph sph = makeSph(SphEnergyModel::StVK, 1);
  const std::size_t n = sph.size();
  std::vector<std::uint8_t> fixed(n, 0);
  for (std::size_t i = 0; i < n; ++i) fixed[i] = sph.restPositions()[i].x() < 1e-9;
  const Eigen::VectorXd shift = Eigen::VectorXd::Constant(3 * n, 10.0);
  { const RestStiffnessPreconditioner first(sph, shift, fixed); }  // leaves its analysis behind
  std::vector<double> mu = sph.shearModuli(), la = sph.lameLambdas();
  for (std::size_t i = 0; i < n; ++i) {
    mu[i] *= 1.0 + 3.0 * (i % 5 == 0);  // a stiffer fifth: another material, same pattern
    la[i] *= 0.5;
  }
  sph.setMaterial(mu, la);
  const RestStiffnessPreconditioner P(sph, shift, fixed);
  // CHOLMOD keeps the analysis without the factor's values; Eigen's SimplicialLDLT (the fallback
  // without SuiteSparse) cannot, so it analyses anew.
  EXPECT_EQ(P.reusedAnalysis(), RestStiffnessPreconditioner::backend() == "cholmod-supernodal");
  Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(3 * n, -1.0, 2.0), z;
  for (std::size_t i = 0; i < n; ++i)
    if (fixed[i]) b.segment<3>(3 * i).setZero();
  P.apply(b, &z);
  Eigen::VectorXd Kz = restStiffness(sph) * z + shift.cwiseProduct(z);
  for (std::size_t i = 0; i < n; ++i)
    if (fixed[i]) Kz.segment<3>(3 * i).setZero();
  const double rel = (Kz - b).norm() / b.norm();
  std::printf("[rest stiffness] reused analysis: solve residual %.2e\n", rel);
  EXPECT_LT(rel, 1e-10);
  std::vector<std::uint8_t> other(n, 0);
  for (std::size_t i = 0; i < n; ++i) other[i] = sph.restPositions()[i].y() < 1e-9;
  const RestStiffnessPreconditioner Q(sph, shift, other);
  EXPECT_FALSE(Q.reusedAnalysis());
}

// Memory is the Cholesky preconditioner's limit, not a particle count: the symbolic analysis
// predicts the factor's size before any value is computed. The prediction lies between the
// matrix's own lower triangle (fill only adds) and a dense square (supernodes store their columns
// as dense rectangles). A byte limit below the factor and K0 together is refused before factorising,
// one below the estimate of K0 alone before assembling, each with the sizes and the fix.
TEST(RestStiffness, FactorSizeIsPredictedAndALimitBelowItIsRefused) {
  const CorotatedSph sph = makeSph(SphEnergyModel::StVK, 1, 20, 8, 6);  // 959 particles
  const std::size_t n = sph.size();
  std::vector<std::uint8_t> fixed(n, 0);
  for (std::size_t i = 0; i < n; ++i) fixed[i] = sph.restPositions()[i].x() < 1e-9;
  const Eigen::VectorXd shift = Eigen::VectorXd::Constant(3 * n, 10.0);
  const RestStiffnessPreconditioner P(sph, shift, fixed);
  const Eigen::SparseMatrix<double> K = restStiffness(sph);
  const double lower = 0.5 * (static_cast<double>(K.nonZeros()) + 3.0 * n);
  const double dense = 9.0 * n * n;
  std::printf("[rest stiffness] factor %.0f bytes predicted (lower triangle of K0 %.0f, dense %.0f entries)\n",
              P.factorBytes(), lower, dense);
  EXPECT_GE(P.factorBytes(), 8.0 * lower * 0.99);
  EXPECT_LE(P.factorBytes(), 8.0 * dense);
  EXPECT_DOUBLE_EQ(P.memoryBytes() - P.factorBytes(), 12.0 * P.nonZeros());  // the assembled lower triangle
  // The estimate of assembling K0 bounds what was assembled.
  const double assembly = RestStiffnessPreconditioner::assemblyBytesEstimate(sph);
  std::printf("[rest stiffness] assembly estimate %.0f bytes, K0 %.0f, factor %.0f\n", assembly,
              P.memoryBytes() - P.factorBytes(), P.factorBytes());
  EXPECT_GE(assembly, P.memoryBytes() - P.factorBytes());
  EXPECT_NO_THROW(RestStiffnessPreconditioner(sph, shift, fixed, 1.01 * std::max(P.memoryBytes(), assembly)));
  // Refused after the analysis (the factor and K0 above the limit, the estimate below it), and before
  // assembling (the estimate above it).
  ASSERT_LT(assembly, 0.99 * P.memoryBytes()) << "this body must let the analysis run before the limit";
  for (const double limit : {0.99 * P.memoryBytes(), 1e3}) {
    try {
      RestStiffnessPreconditioner refused(sph, shift, fixed, limit);
      ADD_FAILURE() << "a limit of " << limit << " bytes must be refused";
    } catch (const TopoError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(limit > 1e4 ? "its Cholesky factor (with the rest stiffness) for "
                                      : "assembling its rest stiffness (about "),
                std::string::npos)
          << what;
      EXPECT_NE(what.find(std::to_string(n) + " particles would take"), std::string::npos) << what;
      EXPECT_NE(what.find("cholesky_max_factor_bytes"), std::string::npos) << what;
    }
  }
  EXPECT_GT(availableMemoryBytes(), 0.0) << "/proc/meminfo has no MemAvailable";
}
