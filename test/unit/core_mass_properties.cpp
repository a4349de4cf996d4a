// MassProperties: closed forms on a lattice box, and finite-difference checks of the derivatives
// w.r.t. the particle masses (relative error < 1e-6).
#include <gtest/gtest.h>

#include <random>
#ifdef _OPENMP
#include <omp.h>
#endif

#include "topo_gaussian/common/block_sum.h"
#include "topo_gaussian/common/error.h"
#include "topo_gaussian/physics/mass_properties.h"

using namespace topo_gaussian;

namespace {

// Cell-centred lattice of an a×b×c box centred at `centre`; each particle carries its cell's mass.
void latticeBox(double a, double b, double c, int n, const Eigen::Vector3d& centre, double density,
                std::vector<Eigen::Vector3d>* X, std::vector<double>* m) {
  const Eigen::Vector3d size(a, b, c);
  const Eigen::Vector3d h = size / n;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      for (int k = 0; k < n; ++k) {
        X->push_back(centre - size / 2 + Eigen::Vector3d((i + 0.5) * h[0], (j + 0.5) * h[1], (k + 0.5) * h[2]));
        m->push_back(density * h.prod());
      }
}

}  // namespace

TEST(MassProperties, LatticeBoxMatchesClosedForm) {
  std::vector<Eigen::Vector3d> X;
  std::vector<double> m;
  const double a = 0.2, b = 0.1, c = 0.05, rho = 1000.0;
  const Eigen::Vector3d centre(0.3, -0.1, 0.7);
  latticeBox(a, b, c, 40, centre, rho, &X, &m);
  const MassProperties p = computeMassProperties(X, m);
  const double M = rho * a * b * c;
  EXPECT_NEAR(p.mass, M, 1e-12 * M);
  EXPECT_LT((p.com - centre).norm(), 1e-12);
  // Midpoint lattice: the discrete second moment is (n²−1)/n² of the continuous one.
  const double f = (40.0 * 40.0 - 1.0) / (40.0 * 40.0);
  EXPECT_NEAR(p.inertia(0, 0), f * M * (b * b + c * c) / 12.0, 1e-10 * M);
  EXPECT_NEAR(p.inertia(1, 1), f * M * (a * a + c * c) / 12.0, 1e-10 * M);
  EXPECT_NEAR(p.inertia(2, 2), f * M * (a * a + b * b) / 12.0, 1e-10 * M);
  EXPECT_NEAR(p.inertia(0, 1), 0.0, 1e-12);
  Eigen::Vector3d pm;
  p.principal(&pm, nullptr);
  EXPECT_NEAR(pm[0], p.inertia(0, 0), 1e-12);  // ascending: x has the smallest moment
  EXPECT_NEAR(pm[2], p.inertia(2, 2), 1e-12);
}

TEST(MassProperties, CellSecondMomentMakesTheLatticeBoxExact) {
  // Each particle stands for its h×h×h cell: with Σ_cell = h²/12 the box's inertia is the closed
  // form m(b²+c²)/12 exactly, at any resolution (here 7 cells a side, where the points alone are 2 % low).
  std::vector<Eigen::Vector3d> X;
  std::vector<double> m;
  const double a = 0.07, rho = 800.0, h = a / 7;
  const Eigen::Vector3d centre(0.3, -0.1, 0.7);
  latticeBox(a, a, a, 7, centre, rho, &X, &m);
  const MassProperties p = computeMassProperties(X, m, cubeCellVariance(h));
  const double M = rho * a * a * a, I = M * (a * a + a * a) / 12.0;
  EXPECT_NEAR(p.mass, M, 1e-12 * M);
  EXPECT_LT((p.com - centre).norm(), 1e-12);
  for (int k = 0; k < 3; ++k)
    EXPECT_NEAR(p.inertia(k, k), I, 1e-10 * I) << k;  // cancellation of M2 − M1M1ᵀ/M0 off-centre
  EXPECT_NEAR(p.inertia(0, 1), 0.0, 1e-12 * I);
  EXPECT_NEAR(computeMassProperties(X, m).inertia(0, 0) / I, 48.0 / 49.0, 1e-10);  // without: (n²−1)/n²
}

TEST(MassProperties, DerivativesWithCellSecondMomentMatchFiniteDifferences) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0), pos(0.2, 1.0);
  std::vector<Eigen::Vector3d> X;
  std::vector<double> m;
  for (int i = 0; i < 120; ++i) {
    X.emplace_back(0.02 * u(rng), 0.1 + 0.03 * u(rng), 0.05 * u(rng));
    m.push_back(pos(rng));
  }
  const double var = cubeCellVariance(0.01);
  const MassMoments mom = computeMassMoments(X, m, var);
  std::vector<double> grad;
  for (int k = 0; k < 10; ++k) {
    Eigen::Matrix<double, 10, 1> e = Eigen::Matrix<double, 10, 1>::Zero();
    e[k] = 1.0;
    massPropertiesGradientToParticles(X, mom, e, &grad, var);
    for (int i : {5, 60 + k}) {
      std::vector<double> mp = m, mn = m;
      const double step = 1e-5;
      mp[i] += step;
      mn[i] -= step;
      const double fd =
          (computeMassProperties(X, mp, var).toVector()[k] - computeMassProperties(X, mn, var).toVector()[k]) /
          (2 * step);
      EXPECT_NEAR(grad[i], fd, 1e-7 * std::max(1e-4, std::abs(fd))) << "output " << k << " particle " << i;
    }
  }
}

TEST(MassProperties, PackingRoundTrips) {
  MassProperties p;
  p.mass = 2.0;
  p.com = Eigen::Vector3d(0.1, 0.2, 0.3);
  p.inertia << 3, 0.1, 0.2, 0.1, 4, 0.3, 0.2, 0.3, 5;
  const MassProperties q = MassProperties::fromVector(p.toVector());
  EXPECT_EQ(q.mass, p.mass);
  EXPECT_EQ(q.com, p.com);
  EXPECT_EQ(q.inertia, p.inertia);
}

TEST(MassProperties, DerivativesMatchFiniteDifferences) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0), pos(0.2, 1.0);
  std::vector<Eigen::Vector3d> X;
  std::vector<double> m;
  for (int i = 0; i < 200; ++i) {
    X.emplace_back(0.3 + 0.1 * u(rng), -0.2 + 0.05 * u(rng), 0.1 * u(rng));
    m.push_back(pos(rng));
  }
  Eigen::Matrix<double, 10, 1> w;
  for (int k = 0; k < 10; ++k) w[k] = u(rng);
  // L = w · props(m); gradient by the Jacobian chain, checked against central differences.
  auto loss = [&](const std::vector<double>& mm) { return w.dot(computeMassProperties(X, mm).toVector()); };
  std::vector<double> grad;
  massPropertiesGradientToParticles(X, computeMassMoments(X, m), w, &grad);
  ASSERT_EQ(grad.size(), m.size());
  for (int i = 0; i < 200; i += 7) {
    std::vector<double> mp = m, mn = m;
    const double step = 1e-5;
    mp[i] += step;
    mn[i] -= step;
    const double fd = (loss(mp) - loss(mn)) / (2 * step);
    EXPECT_NEAR(grad[i], fd, 1e-6 * std::max(1.0, std::abs(fd))) << "particle " << i;
  }
  // Each of the ten outputs separately (the full Jacobian, not one projection).
  const MassMoments mom = computeMassMoments(X, m);
  for (int k = 0; k < 10; ++k) {
    Eigen::Matrix<double, 10, 1> e = Eigen::Matrix<double, 10, 1>::Zero();
    e[k] = 1.0;
    massPropertiesGradientToParticles(X, mom, e, &grad);
    const int i = 3 + 11 * k;
    std::vector<double> mp = m, mn = m;
    const double step = 1e-5;
    mp[i] += step;
    mn[i] -= step;
    const double fd =
        (computeMassProperties(X, mp).toVector()[k] - computeMassProperties(X, mn).toVector()[k]) / (2 * step);
    EXPECT_NEAR(grad[i], fd, 1e-6 * std::max(1e-3, std::abs(fd))) << "output " << k;
  }
}

TEST(MassProperties, RejectsMasslessAndMismatchedInput) {
  std::vector<Eigen::Vector3d> X = {Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones()};
  EXPECT_THROW(computeMassProperties(X, {0.0, 0.0}), TopoError);
  EXPECT_THROW(computeMassProperties(X, {1.0}), TopoError);
  try {
    computeMassProperties(X, {std::nan(""), 1.0});
    FAIL() << "NaN mass accepted";
  } catch (const TopoError& e) {
    EXPECT_NE(std::string(e.what()).find("mass"), std::string::npos);
  }
}

// The moments are summed in fixed blocks (common/block_sum.h): the same bits on 1, 2, 3 or 7 threads, and
// equal to the plain ordered sum within rounding. (With an OpenMP reduction they differed in the last
// bits between thread counts and runs, which sent the tumbler inference to another design.)
TEST(MassProperties, MomentsAreTheSameBitsOnAnyNumberOfThreads) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-0.1, 0.1), w(0.001, 0.01);
  const int n = 5 * static_cast<int>(topo_gaussian::kSumBlock) + 17;  // several blocks and a partial one
  std::vector<Eigen::Vector3d> X(n);
  std::vector<double> m(n);
  for (int i = 0; i < n; ++i) {
    X[i] = Eigen::Vector3d(u(rng), u(rng), u(rng));
    m[i] = w(rng);
  }
  std::vector<topo_gaussian::MassMoments> runs;
#ifdef _OPENMP
  const int before = omp_get_max_threads();
#endif
  for (int threads : {1, 2, 3, 7}) {
#ifdef _OPENMP
    omp_set_num_threads(threads);
#endif
    runs.push_back(topo_gaussian::computeMassMoments(X, m, 1e-6));
  }
#ifdef _OPENMP
  omp_set_num_threads(before);
#endif
  for (const auto& r : runs) {
    EXPECT_EQ(r.m0, runs[0].m0);  // bitwise
    EXPECT_TRUE(r.m1 == runs[0].m1);
    EXPECT_TRUE(r.m2 == runs[0].m2);
  }
  double m0 = 0;
  Eigen::Vector3d m1 = Eigen::Vector3d::Zero();
  for (int i = 0; i < n; ++i) m0 += m[i], m1 += m[i] * X[i];
  EXPECT_NEAR(runs[0].m0, m0, 1e-13 * m0);
  EXPECT_LT((runs[0].m1 - m1).norm(), 1e-13 * m0 * 0.1);
}
