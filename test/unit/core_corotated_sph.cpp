// Corotated SPH: cubic spline kernel, patch tests (rigid motion, uniform stretch), forces against
// finite differences of the energy with frozen rotations, hourglass penalty, bad input.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/physics/corotated_sph.h"
#include "topo_gaussian/physics/sph_kernel.h"

using namespace topo_gaussian;

namespace {

constexpr double kSpacing = 0.01;

// Cell-centred lattice nx×ny×nz at kSpacing; lattice indices in *ijk.
void lattice(int nx, int ny, int nz, std::vector<Eigen::Vector3d>* X, std::vector<double>* V,
             std::vector<Eigen::Vector3i>* ijk = nullptr) {
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        X->push_back(kSpacing * Eigen::Vector3d(i + 0.5, j + 0.5, k + 0.5));
        V->push_back(kSpacing * kSpacing * kSpacing);
        if (ijk) ijk->push_back(Eigen::Vector3i(i, j, k));
      }
}

CorotatedSphOptions opts(SphEnergyModel model, double alpha = 0.1,
                         SphRotationSource rot = SphRotationSource::ShapeMatchingApq) {
  CorotatedSphOptions o;
  o.spacing = kSpacing;
  o.smoothing_factor = 1.5;
  o.model = model;
  o.hourglass_alpha = alpha;
  o.rotation = rot;
  return o;
}

const LameParameters kMat = lameFromYoung(1e5, 0.3);

std::vector<Eigen::Vector3d> apply(const std::vector<Eigen::Vector3d>& X, const Eigen::Matrix3d& A,
                                   const Eigen::Vector3d& t) {
  std::vector<Eigen::Vector3d> x(X.size());
  for (std::size_t i = 0; i < X.size(); ++i) x[i] = A * X[i] + t;
  return x;
}

}  // namespace

TEST(SphKernel, NormalisedAndGradientMatchesFiniteDifferences) {
  const double h = 0.015;
  // Midpoint quadrature of ∫ W dV on [−2h, 2h]³.
  const int n = 160;
  const double d = 4.0 * h / n;
  double sum = 0.0;
  for (int a = 0; a < n; ++a)
    for (int b = 0; b < n; ++b)
      for (int c = 0; c < n; ++c) {
        const Eigen::Vector3d r(-2 * h + (a + 0.5) * d, -2 * h + (b + 0.5) * d, -2 * h + (c + 0.5) * d);
        sum += cubicSplineW(r, h);
      }
  sum *= d * d * d;
  std::printf("[kernel] integral of W = %.8f\n", sum);
  EXPECT_NEAR(sum, 1.0, 1e-3);
  EXPECT_EQ(cubicSplineW(2.0 * h, h), 0.0);
  EXPECT_EQ(cubicSplineW(2.5 * h, h), 0.0);

  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-2.2 * h, 2.2 * h);
  double worst = 0.0;
  for (int t = 0; t < 200; ++t) {
    const Eigen::Vector3d r(u(rng), u(rng), u(rng));
    const Eigen::Vector3d g = cubicSplineGradW(r, h);
    const double eps = 1e-7 * h;
    Eigen::Vector3d fd;
    for (int k = 0; k < 3; ++k) {
      Eigen::Vector3d rp = r, rm = r;
      rp[k] += eps;
      rm[k] -= eps;
      fd[k] = (cubicSplineW(rp, h) - cubicSplineW(rm, h)) / (2 * eps);
    }
    const double scale = 1.0 / (M_PI * std::pow(h, 4));
    worst = std::max(worst, (fd - g).norm() / scale);
  }
  std::printf("[kernel] max |gradW - FD| / (1/(pi h^4)) = %.3e\n", worst);
  EXPECT_LT(worst, 1e-6);
}

TEST(CorotatedSph, LameFromYoung) {
  const LameParameters p = lameFromYoung(1e5, 0.3);
  EXPECT_NEAR(p.mu, 1e5 / 2.6, 1e-9);
  EXPECT_NEAR(p.lambda, 1e5 * 0.3 / (1.3 * 0.4), 1e-9);
  EXPECT_THROW(lameFromYoung(1e5, 0.5), TopoError);
  EXPECT_THROW(lameFromYoung(-1.0, 0.3), TopoError);
}

TEST(CorotatedSph, RestStateAndCorrection) {
  std::vector<Eigen::Vector3d> X;
  std::vector<double> V;
  lattice(10, 6, 6, &X, &V);
  CorotatedSph sph(X, V, kMat, opts(SphEnergyModel::StVK));
  EXPECT_NEAR(sph.smoothingLength(), 0.015, 1e-15);
  int min_n = 1000, max_n = 0;
  for (std::size_t i = 0; i < sph.size(); ++i) {
    min_n = std::min(min_n, sph.neighborCount(i));
    max_n = std::max(max_n, sph.neighborCount(i));
  }
  std::printf("[rest] neighbours per particle: %d .. %d; rho range check\n", min_n, max_n);
  EXPECT_GT(min_n, 6);
  // Interior density close to ρ0, boundary below.
  double rho_max = 0.0;
  for (double r : sph.restDensity()) rho_max = std::max(rho_max, r);
  EXPECT_NEAR(rho_max, 1000.0, 30.0);
  sph.update(X);
  EXPECT_LT(std::abs(sph.energy()), 1e-20);
}

TEST(CorotatedSph, RigidMotionPatchTest) {
  std::vector<Eigen::Vector3d> X;
  std::vector<double> V;
  lattice(10, 6, 6, &X, &V);
  const Eigen::Matrix3d Q =
      Eigen::AngleAxisd(30.0 * M_PI / 180.0, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  const auto x = apply(X, Q, Eigen::Vector3d(0.1, -0.2, 0.3));
  for (SphEnergyModel model : {SphEnergyModel::StVK, SphEnergyModel::CorotatedLinear}) {
    for (SphRotationSource rot : {SphRotationSource::ShapeMatchingApq, SphRotationSource::CorrectedGradient}) {
      CorotatedSph sph(X, V, kMat, opts(model, 0.1, rot));
      sph.update(x);
      const double h = sph.smoothingLength();
      const double fscale = kMat.mu * h * h;
      double errF = 0.0, errR = 0.0, fmax = 0.0;
      for (std::size_t i = 0; i < sph.size(); ++i) {
        errF = std::max(errF, (sph.F(i) - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff());
        errR = std::max(errR, (sph.R(i) - Q).cwiseAbs().maxCoeff());
        fmax = std::max(fmax, sph.forces()[i].norm());
      }
      std::printf(
          "[rigid] model %d rot %d: max|F-I| = %.2e, max|R-Q| = %.2e, E_el = %.2e J, E_hg = %.2e J, "
          "max|f|/(mu h^2) = %.2e\n",
          static_cast<int>(model), static_cast<int>(rot), errF, errR, sph.elasticEnergy(), sph.hourglassEnergy(),
          fmax / fscale);
      EXPECT_LT(errF, 1e-10);
      EXPECT_LT(errR, 1e-10);
      EXPECT_LT(std::abs(sph.elasticEnergy()), 1e-20);
      EXPECT_LT(std::abs(sph.hourglassEnergy()), 1e-20);
      EXPECT_LT(fmax, 1e-9 * fscale);
    }
  }
}

TEST(CorotatedSph, UniformStretchPatchTest) {
  std::vector<Eigen::Vector3d> X;
  std::vector<double> V;
  std::vector<Eigen::Vector3i> ijk;
  const Eigen::Vector3i dims(10, 6, 6);
  lattice(dims.x(), dims.y(), dims.z(), &X, &V, &ijk);
  // Neighbour offsets are < 3 lattice steps (2h = 3 spacings): an axis is truncated for a particle
  // within 2 layers of a face. With at most one truncated axis the moment matrix Σ m W X_ji X_jiᵀ
  // is diagonal, so A_pq = S·diag is symmetric positive and R_i = I.
  auto truncatedAxes = [&](std::size_t i) {
    int t = 0;
    for (int a = 0; a < 3; ++a) t += (ijk[i][a] < 2 || ijk[i][a] > dims[a] - 3) ? 1 : 0;
    return t;
  };
  const Eigen::Matrix3d S = Eigen::Vector3d(1.01, 0.99, 1.02).asDiagonal();
  const auto x = apply(X, S, Eigen::Vector3d(0.01, 0.0, -0.02));
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  for (SphEnergyModel model : {SphEnergyModel::StVK, SphEnergyModel::CorotatedLinear}) {
    // Analytic first Piola stress of the stretch, written out independently of the library.
    Eigen::Matrix3d P_exact;
    if (model == SphEnergyModel::StVK) {
      const Eigen::Matrix3d E = 0.5 * (S * S - I);
      P_exact = S * (2 * kMat.mu * E + kMat.lambda * E.trace() * I);
    } else {
      const Eigen::Matrix3d e = S - I;
      P_exact = 2 * kMat.mu * e + kMat.lambda * e.trace() * I;
    }
    const double pscale = P_exact.cwiseAbs().maxCoeff();

    // (a) R from the polar decomposition of the corrected gradient: F_i = S on every particle.
    {
      CorotatedSph sph(X, V, kMat, opts(model, 0.1, SphRotationSource::CorrectedGradient));
      sph.update(x);
      double errF = 0.0, errP = 0.0;
      for (std::size_t i = 0; i < sph.size(); ++i) {
        errF = std::max(errF, (sph.F(i) - S).cwiseAbs().maxCoeff());
        errP = std::max(errP, (sph.stress(i) - P_exact).cwiseAbs().maxCoeff() / pscale);
      }
      std::printf(
          "[stretch] model %d rot=F~ : all %zu particles max|F-S| = %.2e, max rel |P-P_exact| = %.2e, "
          "E_hg = %.2e\n",
          static_cast<int>(model), sph.size(), errF, errP, sph.hourglassEnergy());
      EXPECT_LT(errF, 1e-10);
      EXPECT_LT(errP, 1e-9);
      EXPECT_LT(std::abs(sph.hourglassEnergy()), 1e-18);
    }
    // (b) Paper's A_pq rotation: the full (rotated) gradient R_i F_i is S on every particle; F_i
    // itself is S wherever R_i = I, i.e. where Σ m W X_ji X_jiᵀ commutes with S (all but the
    // edge/corner particles of the box, whose truncated neighbourhoods have off-diagonal moments).
    {
      CorotatedSph sph(X, V, kMat, opts(model, 0.1, SphRotationSource::ShapeMatchingApq));
      sph.update(x);
      double errRF = 0.0, errF = 0.0, errP = 0.0, maxRdev = 0.0, errRP = 0.0;
      int exact = 0, expected = 0;
      for (std::size_t i = 0; i < sph.size(); ++i) {
        errRF = std::max(errRF, (sph.R(i) * sph.F(i) - S).cwiseAbs().maxCoeff());
        const double rdev = (sph.R(i) - I).cwiseAbs().maxCoeff();
        maxRdev = std::max(maxRdev, rdev);
        if (truncatedAxes(i) <= 1) {
          ++expected;
          EXPECT_LT(rdev, 1e-12) << "particle " << i;
        }
        if (rdev < 1e-12) {
          ++exact;
          errF = std::max(errF, (sph.F(i) - S).cwiseAbs().maxCoeff());
          errP = std::max(errP, (sph.stress(i) - P_exact).cwiseAbs().maxCoeff() / pscale);
        }
        // StVK is rotation invariant: R_i P(R_iᵀ S) = P(S) on every particle.
        if (model == SphEnergyModel::StVK) {
          errRP = std::max(errRP, (sph.R(i) * sph.stress(i) - P_exact).cwiseAbs().maxCoeff() / pscale);
        }
      }
      std::printf(
          "[stretch] model %d rot=Apq: max|R F - S| = %.2e (all), R=I on %d/%zu particles (%d required) with max|F-S| "
          "= %.2e, rel|P-P_exact| = %.2e; max|R-I| elsewhere = %.2e; StVK max rel|R P - P(S)| = %.2e\n",
          static_cast<int>(model), errRF, exact, sph.size(), expected, errF, errP, maxRdev, errRP);
      EXPECT_LT(errRF, 1e-10);
      EXPECT_GE(exact, expected);
      EXPECT_GT(expected, 100);
      EXPECT_LT(errF, 1e-10);
      EXPECT_LT(errP, 1e-9);
      if (model == SphEnergyModel::StVK) {
        EXPECT_LT(errRP, 1e-9);
      }
    }
  }
}

TEST(CorotatedSph, ForcesMatchFiniteDifferencesOfFrozenRotationEnergy) {
  std::vector<Eigen::Vector3d> X;
  std::vector<double> V;
  lattice(6, 5, 4, &X, &V);
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const Eigen::Matrix3d Q = Eigen::AngleAxisd(0.4, Eigen::Vector3d(0.3, -1, 0.5).normalized()).toRotationMatrix();
  std::vector<Eigen::Vector3d> x(X.size());
  for (std::size_t i = 0; i < X.size(); ++i) x[i] = Q * X[i] + 0.1 * kSpacing * Eigen::Vector3d(u(rng), u(rng), u(rng));
  for (SphEnergyModel model : {SphEnergyModel::StVK, SphEnergyModel::CorotatedLinear}) {
    for (double alpha : {0.0, 0.5}) {
      CorotatedSph sph(X, V, kMat, opts(model, alpha));
      sph.update(x);
      std::vector<Eigen::Matrix3d> R(sph.size());
      for (std::size_t i = 0; i < sph.size(); ++i) R[i] = sph.R(i);
      EXPECT_NEAR(sph.energyWithRotations(x, R), sph.energy(), 1e-14 * sph.energy());
      const double eps = 1e-7;
      double maxf = 0.0, maxerr = 0.0;
      for (std::size_t i = 0; i < sph.size(); ++i) {
        for (int k = 0; k < 3; ++k) {
          auto xp = x, xm = x;
          xp[i][k] += eps;
          xm[i][k] -= eps;
          const double fd = -(sph.energyWithRotations(xp, R) - sph.energyWithRotations(xm, R)) / (2 * eps);
          maxerr = std::max(maxerr, std::abs(fd - sph.forces()[i][k]));
          maxf = std::max(maxf, std::abs(sph.forces()[i][k]));
        }
      }
      Eigen::Vector3d fsum = Eigen::Vector3d::Zero();
      for (const auto& f : sph.forces()) fsum += f;
      std::printf(
          "[fd] model %d alpha %.1f: E = %.4e J (E_hg %.3e), max|f| = %.4e N, max|f - f_FD|/max|f| = %.2e, "
          "|sum f|/max|f| = %.1e\n",
          static_cast<int>(model), alpha, sph.energy(), sph.hourglassEnergy(), maxf, maxerr / maxf, fsum.norm() / maxf);
      EXPECT_GT(maxf, 0.0);
      EXPECT_LT(maxerr / maxf, 1e-6);
      EXPECT_LT(fsum.norm() / maxf, 1e-10);  // internal forces sum to zero
    }
  }
}

TEST(CorotatedSph, DeterministicAcrossRuns) {
  std::vector<Eigen::Vector3d> X;
  std::vector<double> V;
  lattice(10, 6, 6, &X, &V);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<Eigen::Vector3d> x(X.size());
  for (std::size_t i = 0; i < X.size(); ++i) x[i] = X[i] + 0.05 * kSpacing * Eigen::Vector3d(u(rng), u(rng), u(rng));
  CorotatedSph a(X, V, kMat, opts(SphEnergyModel::StVK)), b(X, V, kMat, opts(SphEnergyModel::StVK));
  a.update(x);
  b.update(x);
  EXPECT_EQ(a.energy(), b.energy());
  for (std::size_t i = 0; i < X.size(); ++i) EXPECT_EQ(a.forces()[i], b.forces()[i]);
}

TEST(CorotatedSph, HourglassModeIsPenalised) {
  std::vector<Eigen::Vector3d> X;
  std::vector<double> V;
  std::vector<Eigen::Vector3i> ijk;
  lattice(10, 6, 6, &X, &V, &ijk);
  const double delta = 1e-3 * kSpacing;
  std::vector<Eigen::Vector3d> x(X.size()), du(X.size());
  for (std::size_t i = 0; i < X.size(); ++i) {
    const int s = ((ijk[i].sum()) % 2 == 0) ? 1 : -1;
    du[i] = delta * s * Eigen::Vector3d(0, 0, 1);
    x[i] = X[i] + du[i];
  }
  CorotatedSph with(X, V, kMat, opts(SphEnergyModel::StVK, 0.1));
  CorotatedSph without(X, V, kMat, opts(SphEnergyModel::StVK, 0.0));
  with.update(x);
  without.update(x);
  // The checkerboard is (nearly) invisible to the SPH gradient in the interior: F_i ≈ I there.
  double interiorF = 0.0;
  for (std::size_t i = 0; i < X.size(); ++i) {
    const Eigen::Vector3i c = ijk[i];
    if (c.x() >= 3 && c.x() <= 6 && c.y() == 3 && c.z() == 3)
      interiorF = std::max(interiorF, (without.F(i) - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff());
  }
  double work = 0.0;
  for (std::size_t i = 0; i < X.size(); ++i) work += (with.forces()[i] - without.forces()[i]).dot(du[i]);
  std::printf(
      "[hourglass] checkerboard delta = %.1e m: interior max|F-I| = %.2e (delta/h = %.2e), E_el = %.3e J, "
      "E_hg = %.3e J, hourglass force work = %.3e J\n",
      delta, interiorF, delta / with.smoothingLength(), without.elasticEnergy(), with.hourglassEnergy(), work);
  EXPECT_LT(interiorF, 1e-10);
  EXPECT_GT(with.hourglassEnergy(), 0.0);
  EXPECT_EQ(without.hourglassEnergy(), 0.0);
  EXPECT_LT(work, 0.0);  // the hourglass forces oppose the mode
}

TEST(CorotatedSph, BadInput) {
  std::vector<Eigen::Vector3d> X;
  std::vector<double> V;
  lattice(5, 4, 4, &X, &V);
  // Isolated particle.
  {
    auto X2 = X;
    auto V2 = V;
    X2.push_back(Eigen::Vector3d(1.0, 1.0, 1.0));
    V2.push_back(V[0]);
    try {
      CorotatedSph sph(X2, V2, kMat, opts(SphEnergyModel::StVK));
      FAIL() << "isolated particle accepted";
    } catch (const TopoError& e) {
      const std::string msg = e.what();
      std::printf("[bad] %s\n", msg.c_str());
      EXPECT_NE(msg.find("neighbour"), std::string::npos);
      EXPECT_NE(msg.find(std::to_string(X.size())), std::string::npos);  // names the index
      EXPECT_NE(msg.find("smoothing length"), std::string::npos);
    }
  }
  // Non-finite input.
  {
    auto X2 = X;
    X2[3].y() = std::nan("");
    EXPECT_THROW(CorotatedSph(X2, V, kMat, opts(SphEnergyModel::StVK)), TopoError);
    auto V2 = V;
    V2[2] = -1.0;
    EXPECT_THROW(CorotatedSph(X, V2, kMat, opts(SphEnergyModel::StVK)), TopoError);
    CorotatedSph sph(X, V, kMat, opts(SphEnergyModel::StVK));
    auto x = X;
    x[5].x() = std::numeric_limits<double>::infinity();
    EXPECT_THROW(sph.update(x), TopoError);
    EXPECT_THROW(sph.update(std::vector<Eigen::Vector3d>(3)), TopoError);
  }
  // Inverted (reflected) block.
  for (SphRotationSource rot : {SphRotationSource::ShapeMatchingApq, SphRotationSource::CorrectedGradient}) {
    CorotatedSph sph(X, V, kMat, opts(SphEnergyModel::StVK, 0.1, rot));
    const auto x = apply(X, Eigen::Vector3d(-1, 1, 1).asDiagonal(), Eigen::Vector3d::Zero());
    try {
      sph.update(x);
      FAIL() << "inverted block accepted";
    } catch (const TopoError& e) {
      const std::string msg = e.what();
      std::printf("[bad] %s\n", msg.c_str());
      EXPECT_NE(msg.find("det"), std::string::npos);
      EXPECT_NE(msg.find("particle 0"), std::string::npos);
    }
  }
}

// Hessian products and mixed material derivatives against central differences of the forces, for
// every model whose forces are the exact gradient of a conservative energy (StVK; corotated linear
// with rotations from the corrected gradient, whose derivative is included), at a large random
// deformation, with first- and second-order kernel gradients and heterogeneous material.
TEST(CorotatedSph, HessianProductAndMaterialDerivativesMatchFiniteDifferences) {
  std::vector<Eigen::Vector3d> X;
  std::vector<double> V;
  lattice(5, 4, 4, &X, &V);
  const std::size_t n = X.size();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  std::vector<double> mu(n), lam(n);
  for (std::size_t i = 0; i < n; ++i) {
    const LameParameters m = lameFromYoung(1e5 * (1.0 + 0.8 * U(rng)), 0.3 + 0.1 * U(rng));
    mu[i] = m.mu;
    lam[i] = m.lambda;
  }
  const Eigen::Matrix3d A = (Eigen::AngleAxisd(0.6, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix() *
                             (Eigen::Matrix3d() << 1.1, 0.1, 0.0, 0.05, 0.9, 0.08, 0.0, -0.06, 1.05).finished());
  std::vector<Eigen::Vector3d> x = apply(X, A, Eigen::Vector3d(0.1, 0, 0));
  for (auto& p : x) p += 0.001 * Eigen::Vector3d(U(rng), U(rng), U(rng));
  std::vector<Eigen::Vector3d> dx(n), w(n);
  for (std::size_t i = 0; i < n; ++i) {
    dx[i] = Eigen::Vector3d(U(rng), U(rng), U(rng));
    w[i] = Eigen::Vector3d(U(rng), U(rng), U(rng));
  }
  struct Case {
    SphEnergyModel model;
    SphRotationSource rot;
    int order;
    const char* name;
  };
  for (const Case& c :
       {Case{SphEnergyModel::StVK, SphRotationSource::ShapeMatchingApq, 1, "StVK"},
        Case{SphEnergyModel::StVK, SphRotationSource::ShapeMatchingApq, 2, "StVK order 2"},
        Case{SphEnergyModel::CorotatedLinear, SphRotationSource::CorrectedGradient, 1, "corotated"},
        Case{SphEnergyModel::CorotatedLinear, SphRotationSource::CorrectedGradient, 2, "corotated order 2"}}) {
    CorotatedSphOptions o = opts(c.model, 0.1, c.rot);
    o.gradient_order = c.order;
    CorotatedSph sph(X, V, mu, lam, o);
    sph.update(x);
    const std::vector<Eigen::Vector3d> Hdx = sph.hessianProduct(dx);
    const double eps = 1e-7;
    auto forcesAt = [&](double s) {
      std::vector<Eigen::Vector3d> xs(n);
      for (std::size_t i = 0; i < n; ++i) xs[i] = x[i] + s * dx[i];
      CorotatedSph t = sph;
      t.update(xs);
      return t.forces();
    };
    const auto fp = forcesAt(eps), fm = forcesAt(-eps);
    double err = 0.0, scale = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      const Eigen::Vector3d fd = -(fp[i] - fm[i]) / (2 * eps);
      err = std::max(err, (fd - Hdx[i]).norm());
      scale = std::max(scale, Hdx[i].norm());
    }
    std::printf("[hessian] %s: max |H dx - FD| / max |H dx| = %.3g\n", c.name, err / scale);
    EXPECT_LT(err / scale, 1e-6) << c.name;

    // w · ∂f/∂μ_i = −d_mu[i]: perturb one particle's μ (and λ) and difference w · f.
    std::vector<double> d_mu, d_lam;
    sph.materialDirectional(w, &d_mu, &d_lam);
    std::vector<double> e_mu, e_lam;
    sph.materialEnergies(&e_mu, &e_lam);
    double merr = 0.0, mscale = 0.0, eerr = 0.0;
    for (std::size_t i : {std::size_t(0), std::size_t(17), n / 2, n - 1}) {
      for (int which = 0; which < 2; ++which) {
        const double hmat = 1e-3 * (which == 0 ? mu[i] : lam[i]);
        auto wf = [&](double s, double* energy) {
          std::vector<double> m2 = mu, l2 = lam;
          (which == 0 ? m2 : l2)[i] += s;
          CorotatedSph t = sph;
          t.setMaterial(m2, l2);
          *energy = t.energy();
          double d = 0.0;
          for (std::size_t k = 0; k < n; ++k) d += w[k].dot(t.forces()[k]);
          return d;
        };
        double ep, em;
        const double fd = (wf(hmat, &ep) - wf(-hmat, &em)) / (2 * hmat);
        const double an = -(which == 0 ? d_mu[i] : d_lam[i]);
        merr = std::max(merr, std::abs(fd - an));
        mscale = std::max(mscale, std::abs(an));
        const double efd = (ep - em) / (2 * hmat), ean = which == 0 ? e_mu[i] : e_lam[i];
        eerr = std::max(eerr, std::abs(efd - ean) / std::max(std::abs(ean), 1e-30));
      }
    }
    std::printf("[material] %s: mixed derivative rel. error %.3g, dE/dmaterial rel. error %.3g\n", c.name,
                merr / mscale, eerr);
    EXPECT_LT(merr / mscale, 1e-6) << c.name;
    EXPECT_LT(eerr, 1e-6) << c.name;
  }
}

// Second-order (quadratic MLS) gradients reproduce a quadratic deformation exactly at every particle,
// including edges and corners of a box; first-order ones do not at the boundary.
TEST(CorotatedSph, QuadraticGradientIsExactForQuadraticFields) {
  std::vector<Eigen::Vector3d> X;
  std::vector<double> V;
  lattice(6, 5, 4, &X, &V);
  auto field = [](const Eigen::Vector3d& p) {
    return Eigen::Vector3d(p.x() + 3.0 * p.x() * p.z(), p.y() + 2.0 * p.x() * p.x(), p.z() - 1.5 * p.x() * p.x());
  };
  auto grad = [](const Eigen::Vector3d& p) {
    Eigen::Matrix3d G;
    G << 1 + 3 * p.z(), 0, 3 * p.x(), 4 * p.x(), 1, 0, -3 * p.x(), 0, 1;
    return G;
  };
  std::vector<Eigen::Vector3d> x(X.size());
  for (std::size_t i = 0; i < X.size(); ++i) x[i] = field(X[i]);
  double err1 = 0.0, err2 = 0.0;
  for (int order : {1, 2}) {
    CorotatedSphOptions o = opts(SphEnergyModel::StVK);
    o.gradient_order = order;
    CorotatedSph sph(X, V, kMat, o);
    EXPECT_EQ(sph.linearFallbacks(), 0u);
    const auto G = sph.gradientField(x);
    double e = 0.0;
    for (std::size_t i = 0; i < X.size(); ++i) e = std::max(e, (G[i] - grad(X[i])).norm());
    (order == 1 ? err1 : err2) = e;
  }
  std::printf("[quadratic] max |F~ - grad u| order 1: %.3g, order 2: %.3g\n", err1, err2);
  EXPECT_LT(err2, 1e-10);
  EXPECT_GT(err1, 1e-3);
  CorotatedSphOptions bad = opts(SphEnergyModel::StVK);
  bad.gradient_order = 3;
  EXPECT_THROW(CorotatedSph(X, V, kMat, bad), TopoError);
}
