// Contact samples embedded in a soft body (contact_embedding.h, soft_contact.h), on the default pear
// (lattice particles, samples on the exact surface):
//  - the MLS weights reproduce affine maps (partition of unity, Σ φ X = Y, rigid rotation + stretch)
//    to 1e-12 m;
//  - the embedded contact's particle forces are −∂E/∂x (central differences), its Hessian product is
//    the central difference of the forces, its Hessian diagonal is e_jᵀ H e_j, the friction adjoint
//    is the central difference of a·f_friction in x and v — for the ground and a box obstacle;
//  - the particle forces sum to the sample forces (Σ φ = 1: nothing is created by the embedding);
//  - bad input (a sample far from the body, sizes that disagree) is refused with a message.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <random>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/physics/default_shapes.h"
#include "topo_gaussian/physics/soft_body.h"
#include "topo_gaussian/physics/soft_contact.h"

using namespace topo_gaussian;
using Vec3s = std::vector<Eigen::Vector3d>;

namespace {

std::vector<double> areaWeights(const ContactSamples& c, double h) {
  std::vector<double> w;
  for (double a : c.area) w.push_back(a / (h * h));
  return w;
}

struct Embedded {
  VolumeCloud cloud;
  std::shared_ptr<const ContactEmbedding> emb;
  Vec3s x, v;  ///< a deformed, moving state whose bottom is pushed into the ground
};

Embedded pearSetup(double h) {
  Embedded s;
  s.cloud = defaultShapeCloud("pear", h);
  s.emb = std::make_shared<ContactEmbedding>(s.cloud.X, s.cloud.contact.X, areaWeights(s.cloud.contact, h), h);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 0.5, 0).normalized()).toRotationMatrix();
  for (const auto& X : s.cloud.X) {
    // A smooth non-affine deformation + noise, tilted, bottom ~3 mm below z = 0.
    const Eigen::Vector3d d(0.02 * X.z() * X.z(), -0.01 * X.x() * X.z() / 0.04, 0.05 * X.x() * X.y() / 0.04);
    s.x.push_back(R * (X + d) + Eigen::Vector3d(0.001, -0.002, -0.003) +
                  2e-4 * Eigen::Vector3d(U(rng), U(rng), U(rng)));
    s.v.emplace_back(0.3 + 0.05 * U(rng), -0.2 + 0.05 * U(rng), -0.5 + 0.05 * U(rng));
  }
  return s;
}

SoftContact makeContact(const Embedded& s, bool with_box) {
  SoftContactOptions o;
  o.stiffness = 3e3;
  o.friction = 0.6;
  o.slip_velocity = 0.05;
  o.margin = 2e-4;
  std::vector<ContactObstacle> obs{ContactObstacle::ground(0.0)};
  if (with_box)
    obs.push_back(ContactObstacle::box(Eigen::Vector3d(0.0, -0.05, -0.05), Eigen::Vector3d(0.1, 0.05, 0.03)));
  return SoftContact(obs, o, s.emb);
}

Vec3s forces(const SoftContact& c, const Vec3s& x) {
  Vec3s f(x.size(), Eigen::Vector3d::Zero());
  c.addNormalForces(x, &f);
  return f;
}

double maxNorm(const Vec3s& a) {
  double m = 0.0;
  for (const auto& p : a) m = std::max(m, p.norm());
  return m;
}

/// Particle components that carry an active sample (their derivatives are non-trivial).
std::vector<std::pair<std::size_t, int>> activeComponents(const Embedded& s, const SoftContact& c, std::size_t count) {
  const Vec3s f = forces(c, s.x);
  std::vector<std::pair<std::size_t, int>> out;
  for (std::size_t i = 0; i < f.size() && out.size() < count; i += 1)
    if (f[i].norm() > 1e-3 * maxNorm(f)) out.emplace_back(i, static_cast<int>(i % 3));
  return out;
}

}  // namespace

TEST(ContactEmbedding, ReproducesAffineMapsOnThePear) {
  const Embedded s = pearSetup(0.008);
  const ContactEmbedding& E = *s.emb;
  ASSERT_GT(E.size(), 500u);
  double unity = 0.0, first = 0.0, phi_min = 0.0, abs_sum = 0.0;
  for (std::size_t k = 0; k < E.size(); ++k) {
    double sum = 0.0, asum = 0.0;
    Eigen::Vector3d m = Eigen::Vector3d::Zero();
    for (int q = E.offsets()[k]; q < E.offsets()[k + 1]; ++q) {
      sum += E.phi()[q];
      asum += std::abs(E.phi()[q]);
      m += E.phi()[q] * s.cloud.X[E.particles()[q]];
      phi_min = std::min(phi_min, E.phi()[q]);
    }
    unity = std::max(unity, std::abs(sum - 1.0));
    first = std::max(first, (m - E.restPositions()[k]).norm());
    abs_sum = std::max(abs_sum, asum);
  }
  std::printf("[embedding] %zu samples in %zu particles, %.1f particles per sample, min phi %.3f, max sum|phi| %.3f\n",
              E.size(), s.cloud.size(), E.meanSupport(), phi_min, abs_sum);
  EXPECT_LT(unity, 1e-12);
  EXPECT_LT(first, 1e-12);
  // Some weights are negative: the samples lie outside the outermost particles (extrapolation).
  EXPECT_LT(phi_min, 0.0);
  // A rotation with stretch and a translation moves the samples by the same map.
  const Eigen::Matrix3d A = Eigen::AngleAxisd(1.1, Eigen::Vector3d(0.2, -1, 0.4).normalized()).toRotationMatrix() *
                            Eigen::Vector3d(1.3, 0.8, 1.1).asDiagonal();
  const Eigen::Vector3d b(0.4, -0.7, 2.5);
  Vec3s x, y;
  for (const auto& X : s.cloud.X) x.push_back(A * X + b);
  E.gather(x, &y);
  double err = 0.0;
  for (std::size_t k = 0; k < E.size(); ++k) err = std::max(err, (y[k] - (A * E.restPositions()[k] + b)).norm());
  std::printf("[embedding] affine map reproduced to %.3g m\n", err);
  EXPECT_LT(err, 1e-12);
}

TEST(ContactEmbedding, ForcesAreMinusTheEnergyGradient) {
  for (bool box : {false, true}) {
    const Embedded s = pearSetup(0.012);
    const SoftContact c = makeContact(s, box);
    ASSERT_GT(c.activeCount(s.x), 20u);
    const Vec3s f = forces(c, s.x);
    const double scale = maxNorm(f);
    double worst = 0.0;
    const auto comps = activeComponents(s, c, 30);
    ASSERT_GE(comps.size(), 10u);
    for (const auto& [i, a] : comps) {
      const double eps = 1e-7;
      Vec3s xp = s.x, xm = s.x;
      xp[i](a) += eps;
      xm[i](a) -= eps;
      const double fd = -(c.energy(xp) - c.energy(xm)) / (2 * eps);
      worst = std::max(worst, std::abs(fd - f[i](a)) / scale);
    }
    std::printf("[embedding%s] forces vs -dE/dx: max error %.3g of the largest force %.3g N\n", box ? " + box" : "",
                worst, scale);
    EXPECT_LT(worst, 1e-6);
  }
}

TEST(ContactEmbedding, HessianProductAndDiagonalMatchForceDifferences) {
  for (bool box : {false, true}) {
    const Embedded s = pearSetup(0.012);
    const SoftContact c = makeContact(s, box);
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> U(-1.0, 1.0);
    Vec3s dx(s.x.size());
    for (auto& d : dx) d = Eigen::Vector3d(U(rng), U(rng), U(rng));
    Vec3s Hd(s.x.size(), Eigen::Vector3d::Zero());
    c.addHessianProduct(s.x, dx, &Hd);
    const double eps = 1e-8;
    Vec3s xp = s.x, xm = s.x;
    for (std::size_t i = 0; i < dx.size(); ++i) {
      xp[i] += eps * dx[i];
      xm[i] -= eps * dx[i];
    }
    const Vec3s fp = forces(c, xp), fm = forces(c, xm);
    double worst = 0.0;
    for (std::size_t i = 0; i < dx.size(); ++i) worst = std::max(worst, (-(fp[i] - fm[i]) / (2 * eps) - Hd[i]).norm());
    std::printf("[embedding%s] H dx vs force differences: max error %.3g of %.3g N/m\n", box ? " + box" : "", worst,
                maxNorm(Hd));
    EXPECT_LT(worst, 1e-6 * maxNorm(Hd));
    // Diagonal: e_jᵀ H e_j.
    Vec3s diag(s.x.size(), Eigen::Vector3d::Zero());
    c.addHessianDiagonal(s.x, &diag);
    double dworst = 0.0, dscale = maxNorm(diag);
    for (const auto& [i, a] : activeComponents(s, c, 25)) {
      Vec3s e(s.x.size(), Eigen::Vector3d::Zero()), He(s.x.size(), Eigen::Vector3d::Zero());
      e[i](a) = 1.0;
      c.addHessianProduct(s.x, e, &He);
      dworst = std::max(dworst, std::abs(He[i](a) - diag[i](a)));
    }
    EXPECT_GT(dscale, 0.0);
    EXPECT_LT(dworst, 1e-12 * dscale);
  }
}

TEST(ContactEmbedding, FrictionAdjointMatchesDifferences) {
  for (bool box : {false, true}) {
    const Embedded s = pearSetup(0.012);
    const SoftContact c = makeContact(s, box);
    std::mt19937 rng(9);
    std::uniform_real_distribution<double> U(-1.0, 1.0);
    Vec3s a(s.x.size());
    for (auto& p : a) p = Eigen::Vector3d(U(rng), U(rng), U(rng));
    auto phi = [&](const Vec3s& x, const Vec3s& v) {
      Vec3s f(x.size(), Eigen::Vector3d::Zero());
      c.addFrictionForces(x, v, &f);
      double sum = 0.0;
      for (std::size_t i = 0; i < x.size(); ++i) sum += a[i].dot(f[i]);
      return sum;
    };
    Vec3s xb(s.x.size(), Eigen::Vector3d::Zero()), vb(s.x.size(), Eigen::Vector3d::Zero());
    c.frictionAdjoint(s.x, s.v, a, &xb, &vb);
    const double xs = maxNorm(xb), vs = maxNorm(vb);
    ASSERT_GT(xs, 0.0);
    ASSERT_GT(vs, 0.0);
    double wx = 0.0, wv = 0.0;
    for (const auto& [i, k] : activeComponents(s, c, 30)) {
      const double ex = 1e-7, ev = 1e-6;
      Vec3s xp = s.x, xm = s.x, vp = s.v, vm = s.v;
      xp[i](k) += ex;
      xm[i](k) -= ex;
      vp[i](k) += ev;
      vm[i](k) -= ev;
      wx = std::max(wx, std::abs((phi(xp, s.v) - phi(xm, s.v)) / (2 * ex) - xb[i](k)) / xs);
      wv = std::max(wv, std::abs((phi(s.x, vp) - phi(s.x, vm)) / (2 * ev) - vb[i](k)) / vs);
    }
    std::printf("[embedding%s] friction adjoint vs differences: x %.3g, v %.3g (relative)\n", box ? " + box" : "", wx,
                wv);
    EXPECT_LT(wx, 1e-6);
    EXPECT_LT(wv, 1e-6);
  }
}

TEST(ContactEmbedding, ParticleForcesSumToTheSampleForces) {
  const Embedded s = pearSetup(0.008);
  const SoftContact c = makeContact(s, false);
  const Vec3s f = forces(c, s.x);
  Eigen::Vector3d total = Eigen::Vector3d::Zero();
  for (const auto& p : f) total += p;
  // Σ_k k ω_k (δ − z_k)⁺ ẑ from the sample positions directly.
  const Vec3s y = c.contactPositions(s.x);
  double fz = 0.0;
  for (std::size_t k = 0; k < y.size(); ++k) fz += 3e3 * s.emb->weights()[k] * std::max(2e-4 - y[k].z(), 0.0);
  ASSERT_GT(fz, 0.0);
  EXPECT_NEAR(total.z(), fz, 1e-12 * fz);
  EXPECT_LT(std::hypot(total.x(), total.y()), 1e-12 * fz);
}

TEST(ContactEmbedding, BadInputIsRefused) {
  const VolumeCloud cloud = defaultShapeCloud("pear", 0.012);
  std::vector<double> w(cloud.contact.size(), 1.0);
  // A sample 10 cm away from the body (wrong frame or units).
  Vec3s Y = cloud.contact.X;
  Y[7] += Eigen::Vector3d(0.1, 0, 0);
  try {
    ContactEmbedding e(cloud.X, Y, w, cloud.spacing);
    FAIL() << "a sample far from the body was embedded";
  } catch (const TopoError& e) {
    EXPECT_NE(std::string(e.what()).find("contact sample 7"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("topo fill"), std::string::npos) << e.what();
  }
  EXPECT_THROW(ContactEmbedding(cloud.X, cloud.contact.X, std::vector<double>(3, 1.0), cloud.spacing), TopoError);
  EXPECT_THROW(ContactEmbedding(cloud.X, cloud.contact.X, w, 0.0), TopoError);
  EXPECT_THROW(SoftContact({ContactObstacle::ground()}, SoftContactOptions(), nullptr), TopoError);
  // An embedding of another body is refused by the simulator.
  auto emb = std::make_shared<ContactEmbedding>(cloud.X, cloud.contact.X, w, cloud.spacing);
  const VolumeCloud other = defaultShapeCloud("pear", 0.01);
  CorotatedSphOptions o;
  o.spacing = other.spacing;
  const std::vector<double> mu(other.size(), 1e5), lam(other.size(), 1e5);
  SoftBodySimulator sim(CorotatedSph(other.X, other.V, mu, lam, o));
  try {
    sim.setContact(SoftContact({ContactObstacle::ground()}, SoftContactOptions(), emb));
    FAIL() << "an embedding of another body was accepted";
  } catch (const TopoError& e) {
    EXPECT_NE(std::string(e.what()).find("embedded in"), std::string::npos) << e.what();
  }
}

// A stiff block released just above the ground settles (damped leapfrog) on the penalty foundation:
// every bottom sample of its true face sinks by d = m g / (k Σ_bottom ω) = m g h² / (k A) (force
// balance of a rigid flat face; the elastic shortening ρ g H / E is 3e-9 of H here). The face stays
// flat to a few p h / E (p = m g / A, the soft SPH boundary layer under the contact load): 2 % of d. With the contact
// on the particles (the old staircase) the bottom particles sink by the same d, and the true bottom
// face — half a spacing below them — ends h/2 + d below the ground.
TEST(ContactEmbedding, StiffBlockRestsOnItsTrueBottomFace) {
  const double h = 0.01, k = 500.0;
  const int nx = 4, ny = 4, nz = 3;
  std::vector<Eigen::Vector3d> X, Y;
  std::vector<double> V, w;
  for (int i = 0; i < nx; ++i)
    for (int j = 0; j < ny; ++j)
      for (int l = 0; l < nz; ++l) {
        X.emplace_back(h * (i + 0.5), h * (j + 0.5), h * (l + 0.5));
        V.push_back(h * h * h);
      }
  // Samples on a (h/2)-grid of the six faces, weight (h/2)²/h².
  const Eigen::Vector3d L(nx * h, ny * h, nz * h);
  std::vector<char> bottom;
  for (int a = 0; a < 3; ++a) {
    const int u = (a + 1) % 3, v = (a + 2) % 3;
    for (double side : {0.0, L(a)})
      for (int i = 0; i < std::lround(L(u) / (0.5 * h)); ++i)
        for (int j = 0; j < std::lround(L(v) / (0.5 * h)); ++j) {
          Eigen::Vector3d p;
          p(a) = side;
          p(u) = (i + 0.5) * 0.5 * h;
          p(v) = (j + 0.5) * 0.5 * h;
          Y.push_back(p);
          w.push_back(0.25);
          bottom.push_back(a == 2 && side == 0.0);
        }
  }
  const double E = 1e7, nu = 0.3, rho = 1000.0;
  const double mass = rho * L.prod(), A = L.x() * L.y();
  const double d = mass * 9.81 * h * h / (k * A);
  SoftContactOptions co;
  co.stiffness = k;
  co.friction = 0.0;
  double z_true[2] = {0, 0}, spread = 0.0;
  for (int model = 0; model < 2; ++model) {
    CorotatedSphOptions o;
    o.spacing = h;
    const LameParameters lame = lameFromYoung(E, nu);
    SoftBodyOptions so;
    so.damping = 150.0;
    SoftBodySimulator sim(
        CorotatedSph(X, V, std::vector<double>(X.size(), lame.mu), std::vector<double>(X.size(), lame.lambda), o), so);
    auto emb = std::make_shared<ContactEmbedding>(X, Y, w, h);
    if (model == 0)
      sim.setContact(SoftContact({ContactObstacle::ground()}, co, emb));
    else
      sim.setContact(SoftContact({ContactObstacle::ground()}, co));  // every particle may touch
    std::vector<Eigen::Vector3d> x0 = X;
    const double lift = model == 0 ? 1e-4 : 1e-4 - 0.5 * h;  // the true bottom (resp. bottom particles) 0.1 mm up
    for (auto& p : x0) p.z() += lift;
    sim.setPositions(x0);
    sim.advance(0.12);
    std::vector<Eigen::Vector3d> y;
    emb->gather(sim.positions(), &y);  // the true surface, measured the same way for both models
    double sum = 0.0, lo = 1e300, hi = -1e300;
    int count = 0;
    for (std::size_t q = 0; q < y.size(); ++q)
      if (bottom[q]) {
        sum += y[q].z();
        lo = std::min(lo, y[q].z());
        hi = std::max(hi, y[q].z());
        ++count;
      }
    z_true[model] = sum / count;
    if (model == 0) spread = std::max(std::abs(lo + d), std::abs(hi + d));
  }
  std::printf(
      "[block rest] d = m g h^2/(k A) = %.4f mm; true bottom face: embedded samples %+.4f mm (worst sample "
      "%.2g mm off), particle contact %+.4f mm\n",
      d * 1e3, z_true[0] * 1e3, spread * 1e3, z_true[1] * 1e3);
  EXPECT_NEAR(z_true[0], -d, 1e-3 * d);
  EXPECT_LT(spread, 0.05 * d);
  EXPECT_NEAR(z_true[1], -d - 0.5 * h, 1e-2 * d);
}

// Merging `topo fill`-fine samples (0.8 mm) into cells of h/2 (soft tasks do this): the area is kept,
// the merged samples are points of the surface (the fine samples' bisection accuracy), and the ground
// force on the pear pushed 1 mm into the ground is the fine samples' within 2 %.
TEST(ContactEmbedding, MergedSamplesKeepAreaSurfaceAndForce) {
  const double h = 0.008;
  const VolumeCloud cloud = defaultShapeCloud("pear", h);
  const ContactSamples fine = shapeContactSamples(defaultShape("pear"), 0.0008);
  std::vector<Eigen::Vector3d> Y = fine.X, n = fine.normal;
  std::vector<double> a = fine.area;
  mergeContactSamples(0.5 * h, &Y, &n, &a);
  double area = 0.0, off = 0.0;
  for (std::size_t k = 0; k < Y.size(); ++k) {
    area += a[k];
    off = std::max(off, std::abs(pearField(Y[k])));
  }
  std::printf("[merge] %zu samples -> %zu, area %.6g -> %.6g m^2, farthest from the surface %.3f mm\n", fine.size(),
              Y.size(), fine.totalArea(), area, off * 1e3);
  EXPECT_LT(Y.size(), fine.size() / 10);
  EXPECT_NEAR(area, fine.totalArea(), 1e-12 * area);
  EXPECT_LT(off, 1e-9);
  auto force = [&](const std::vector<Eigen::Vector3d>& S, const std::vector<double>& A) {
    std::vector<double> w;
    for (double x : A) w.push_back(x / (h * h));
    SoftContactOptions o;
    o.stiffness = 1e4;
    const SoftContact c({ContactObstacle::ground(0.001)}, o, std::make_shared<ContactEmbedding>(cloud.X, S, w, h));
    Vec3s f(cloud.size(), Eigen::Vector3d::Zero());
    c.addNormalForces(cloud.X, &f);
    double fz = 0.0;
    for (const auto& p : f) fz += p.z();
    return fz;
  };
  const double f_fine = force(fine.X, fine.area), f_merged = force(Y, a);
  // The bulb's bottom is a sphere (R = 4 cm): the area between depths δ and δ + dδ is 2πR dδ, so the
  // springs 1 mm deep push k / h² · π R d². Measured: the 0.8 mm samples −0.12 %, merged to 4 mm +1.96 %
  // (a 4 mm sample straddles the 8.9 mm contact patch's rim, where the penetration is cut at 0).
  const double f_exact = 1e4 / (h * h) * M_PI * default_shape_dims::kPearBulbRadius * 1e-6;
  std::printf("[merge] ground force 1 mm deep: fine %.4f N, merged %.4f N, exact %.4f N\n", f_fine, f_merged, f_exact);
  EXPECT_NEAR(f_fine, f_exact, 0.005 * f_exact);
  EXPECT_NEAR(f_merged, f_exact, 0.03 * f_exact);
  EXPECT_THROW(mergeContactSamples(0.0, &Y, &n, &a), TopoError);
}
