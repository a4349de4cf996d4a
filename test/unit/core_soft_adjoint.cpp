// Reverse-mode gradients of the soft-body simulator against central finite differences: the loss
// is differentiated w.r.t. the topology indicator r_i, which sets each particle's mass, Young's
// modulus (hence μ_i, λ_i) and chamber weight, and w.r.t. the initial state. Every case includes
// gravity, damping, ground contact with friction (particles start in and above contact, sliding)
// and a ramped pneumatic chamber. Cases: one explicit step, one implicit step, a 50-step explicit
// rollout and a 50-step implicit rollout, both with checkpointing (K = 7, not a divisor of 50), and
// a 50-step explicit and a 20-step implicit rollout again with the ground contact on contact samples on the block's
// true faces embedded in the particles (contact_embedding.h) instead of on the particles.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include <memory>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/physics/soft_rollout.h"
#include "topo_gaussian/topology/materials.h"

using namespace topo_gaussian;

namespace {

constexpr double kDx = 0.01;

struct Body {
  std::vector<Eigen::Vector3d> X;
  std::vector<double> V;
};

Body block(int nx, int ny, int nz) {
  Body b;
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        b.X.emplace_back(kDx * (i + 0.5), kDx * (j + 0.5), kDx * (k + 0.5));
        b.V.push_back(kDx * kDx * kDx);
      }
  return b;
}

struct Design {
  MaterialInterpolation density{200.0, 1000.0, 1.0, 1e-3, false};
  MaterialInterpolation young{2e4, 1e5, 1.0, 1e-3, false};
  double nu = 0.3;
  // chamber weight w_i = 1 − r_i on the chamber particles
};

struct Scenario {
  Body body;
  std::vector<std::uint8_t> chamber_mask, clamp;
  SoftIntegrator integrator = SoftIntegrator::SymplecticEuler;
  double dt = 0.0;
  int steps = 1;
  bool clamp_base = false;
  /// Contact on samples of the block's true faces (spacing kDx/2, weight (kDx/2)²/kDx²) embedded
  /// in the particles, with the ground at ground_z; else on the particles.
  std::shared_ptr<const ContactEmbedding> embedding;
  double ground_z = 0.0053;
};

/// Samples at the centres of a (kDx/2)-grid on the 6 faces of the block [0, nx kDx] × … .
std::shared_ptr<const ContactEmbedding> faceSamples(const Body& b, int nx, int ny, int nz) {
  const Eigen::Vector3d L(nx * kDx, ny * kDx, nz * kDx);
  const double s = 0.5 * kDx;
  std::vector<Eigen::Vector3d> Y;
  for (int a = 0; a < 3; ++a) {
    const int u = (a + 1) % 3, w = (a + 2) % 3;
    const int nu = static_cast<int>(std::lround(L(u) / s)), nw = static_cast<int>(std::lround(L(w) / s));
    for (double side : {0.0, L(a)})
      for (int i = 0; i < nu; ++i)
        for (int j = 0; j < nw; ++j) {
          Eigen::Vector3d p;
          p(a) = side;
          p(u) = (i + 0.5) * s;
          p(w) = (j + 0.5) * s;
          Y.push_back(p);
        }
  }
  return std::make_shared<ContactEmbedding>(b.X, Y, std::vector<double>(Y.size(), s * s / (kDx * kDx)), kDx);
}

// Builds the simulator for design r, runs the rollout and returns L and dL/dr, dL/dx0, dL/dv0.
struct Outcome {
  double loss = 0.0;
  std::vector<double> dL_dr;
  std::vector<Eigen::Vector3d> dL_dx0, dL_dv0;
  SoftRolloutResult raw;
  std::size_t contacts = 0;  ///< particles in contact at the start
  double pressure = 0.0;     ///< chamber pressure at the start [Pa]
};

Outcome runCase(const Scenario& S, const std::vector<double>& r, const std::vector<Eigen::Vector3d>& x0,
                const std::vector<Eigen::Vector3d>& v0, bool grad, double dt_override = 0.0) {
  const Design D;
  const std::size_t n = S.body.X.size();
  std::vector<double> rho, drho, E, dE;
  D.density.apply(r, &rho, &drho);
  D.young.apply(r, &E, &dE);
  std::vector<double> mu(n), lam(n), m(n);
  const double cmu = 1.0 / (2.0 * (1.0 + D.nu)), clam = D.nu / ((1.0 + D.nu) * (1.0 - 2.0 * D.nu));
  for (std::size_t i = 0; i < n; ++i) {
    mu[i] = cmu * E[i];
    lam[i] = clam * E[i];
    m[i] = rho[i] * S.body.V[i];
  }
  CorotatedSphOptions o;
  o.spacing = kDx;
  o.model = SphEnergyModel::CorotatedLinear;
  o.rotation = SphRotationSource::CorrectedGradient;
  SoftBodyOptions so;
  so.damping = 0.5;
  SoftBodySimulator sim(CorotatedSph(S.body.X, S.body.V, mu, lam, o), so);
  sim.setMasses(m);
  if (S.clamp_base) sim.setClamped(S.clamp);
  PneumaticActuation act;
  act.chamber.assign(n, 0.0);
  for (std::size_t i = 0; i < n; ++i)
    if (S.chamber_mask[i]) act.chamber[i] = 1.0 - r[i];
  act.pressure_pa = 3e3;
  act.ramp_s = 0.01;
  sim.setActuation(act);
  SoftContactOptions co;
  co.stiffness = 2e3;
  co.friction = 0.4;
  co.slip_velocity = 0.05;
  if (S.embedding)
    sim.setContact(SoftContact({ContactObstacle::ground(S.ground_z)}, co, S.embedding));
  else
    sim.setContact(SoftContact({ContactObstacle::ground(S.ground_z)}, co));
  sim.setTime(0.002);
  sim.setPositions(x0);
  sim.setVelocities(v0);
  SoftRolloutOptions ro;
  ro.integrator = S.integrator;
  ro.dt = dt_override > 0 ? dt_override : S.dt;
  ro.steps = S.steps;
  ro.checkpoint_every = 7;
  ro.newton.tolerance = 1e-11;
  ro.newton.cg_tolerance = 1e-12;
  SoftRollout roll(&sim, ro);
  // ℓ_k = Σ_i c_i · x_i,k over all k (a trajectory term) + ½|x_N − X|² + ½ s |v_N|².
  const int N = S.steps;
  SoftStepLoss loss = [&](int k, double, const std::vector<Eigen::Vector3d>& x, const std::vector<Eigen::Vector3d>& v,
                          std::vector<Eigen::Vector3d>* gx, std::vector<Eigen::Vector3d>* gv) {
    double l = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      const Eigen::Vector3d c(std::sin(1.0 + i), std::cos(2.0 * i), 0.5 * std::sin(3.0 * i + 0.3));
      l += 1e-2 * c.dot(x[i]) / N;
      if (gx) (*gx)[i] += 1e-2 * c / N;
      if (k == N) {
        l += 0.5 * (x[i] - S.body.X[i]).squaredNorm() + 0.05 * v[i].squaredNorm();
        if (gx) (*gx)[i] += x[i] - S.body.X[i];
        if (gv) (*gv)[i] += 0.1 * v[i];
      }
    }
    return l;
  };
  Outcome out;
  out.contacts = sim.contact().activeCount(sim.positions());
  out.pressure = sim.pressureNow();
  out.raw = roll.run(loss, grad);
  out.loss = out.raw.loss;
  if (grad) {
    const auto& G = out.raw.gradient;
    out.dL_dr.assign(n, 0.0);
    for (std::size_t i = 0; i < n; ++i) {
      out.dL_dr[i] = G.mass[i] * drho[i] * S.body.V[i] + (G.mu[i] * cmu + G.lambda[i] * clam) * dE[i];
      if (S.chamber_mask[i]) out.dL_dr[i] -= G.chamber[i];
    }
    out.dL_dx0 = G.x0;
    out.dL_dv0 = G.v0;
  }
  return out;
}

struct Check {
  double max_rel_r = 0.0, max_rel_x = 0.0;
};

Check checkGradients(const Scenario& S, const char* name) {
  const std::size_t n = S.body.X.size();
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> U(0.2, 0.8), W(-1.0, 1.0);
  std::vector<double> r(n);
  for (auto& v : r) v = U(rng);
  std::vector<Eigen::Vector3d> x0 = S.body.X, v0(n);
  for (std::size_t i = 0; i < n; ++i) {
    x0[i] += 2e-4 * Eigen::Vector3d(W(rng), W(rng), W(rng));
    v0[i] = Eigen::Vector3d(0.05 + 0.02 * W(rng), 0.02 * W(rng), -0.05 + 0.02 * W(rng));
  }
  const Outcome base = runCase(S, r, x0, v0, true);
  Check c;
  // The case really exercises contact (with sliding friction) and actuation.
  EXPECT_GT(base.contacts, 5u);
  EXPECT_GT(base.pressure, 0.0);
  double gscale = 0.0;
  for (double g : base.dL_dr) gscale = std::max(gscale, std::abs(g));
  for (std::size_t i : {std::size_t(0), std::size_t(5), n / 3, n / 2, n - 7, n - 1}) {
    const double h = 1e-6;
    std::vector<double> rp = r, rm = r;
    rp[i] += h;
    rm[i] -= h;
    const double fd = (runCase(S, rp, x0, v0, false).loss - runCase(S, rm, x0, v0, false).loss) / (2 * h);
    const double rel = std::abs(fd - base.dL_dr[i]) / std::max(std::abs(fd), 1e-3 * gscale);
    std::printf("[fd %s] r_%zu: adjoint %.9g  fd %.9g  rel %.2g\n", name, i, base.dL_dr[i], fd, rel);
    c.max_rel_r = std::max(c.max_rel_r, rel);
  }
  // Initial state: one position and one velocity component.
  for (int which = 0; which < 2; ++which) {
    const std::size_t i = n / 2 + 1;
    const double h = 1e-7;
    auto xp = x0, xm = x0, vp = v0, vm = v0;
    (which == 0 ? xp : vp)[i].z() += h;
    (which == 0 ? xm : vm)[i].z() -= h;
    const double fd = (runCase(S, r, xp, vp, false).loss - runCase(S, r, xm, vm, false).loss) / (2 * h);
    const double an = which == 0 ? base.dL_dx0[i].z() : base.dL_dv0[i].z();
    const double rel = std::abs(fd - an) / std::max(std::abs(fd), 1e-12);
    std::printf("[fd %s] %s_%zu.z: adjoint %.9g  fd %.9g  rel %.2g\n", name, which == 0 ? "x0" : "v0", i, an, fd, rel);
    c.max_rel_x = std::max(c.max_rel_x, rel);
  }
  std::printf("[fd %s] peak stored states %zu, forward %.3f s, backward %.3f s\n", name, base.raw.peak_states,
              base.raw.forward_s, base.raw.backward_s);
  return c;
}

Scenario makeSetup(SoftIntegrator integ, int steps) {
  Scenario S;
  S.body = block(5, 4, 4);
  const std::size_t n = S.body.X.size();
  S.chamber_mask.assign(n, 0);
  S.clamp.assign(n, 0);
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d& p = S.body.X[i];
    S.chamber_mask[i] = (p.x() > 0.015 && p.x() < 0.04 && p.z() > 0.015) ? 1 : 0;
  }
  S.integrator = integ;
  S.steps = steps;
  S.dt = integ == SoftIntegrator::SymplecticEuler ? 2e-4 : 1e-3;
  return S;
}

}  // namespace

TEST(SoftAdjoint, OneExplicitStep) {
  const Check c = checkGradients(makeSetup(SoftIntegrator::SymplecticEuler, 1), "explicit 1");
  EXPECT_LT(c.max_rel_r, 1e-4);
  EXPECT_LT(c.max_rel_x, 1e-4);
}

TEST(SoftAdjoint, OneImplicitStep) {
  const Check c = checkGradients(makeSetup(SoftIntegrator::ImplicitEuler, 1), "implicit 1");
  EXPECT_LT(c.max_rel_r, 1e-4);
  EXPECT_LT(c.max_rel_x, 1e-4);
}

TEST(SoftAdjoint, FiftyStepExplicitRolloutWithCheckpoints) {
  const Check c = checkGradients(makeSetup(SoftIntegrator::SymplecticEuler, 50), "explicit 50");
  EXPECT_LT(c.max_rel_r, 1e-4);
  EXPECT_LT(c.max_rel_x, 1e-4);
}

TEST(SoftAdjoint, FiftyStepImplicitRolloutWithCheckpoints) {
  const Check c = checkGradients(makeSetup(SoftIntegrator::ImplicitEuler, 50), "implicit 50");
  EXPECT_LT(c.max_rel_r, 1e-4);
  EXPECT_LT(c.max_rel_x, 1e-4);
}

TEST(SoftAdjoint, FiftyStepExplicitRolloutWithEmbeddedContactSamples) {
  Scenario S = makeSetup(SoftIntegrator::SymplecticEuler, 50);
  S.embedding = faceSamples(S.body, 5, 4, 4);
  S.ground_z = 3e-4;  // the true bottom face is at z = 0 (the particles' centres at kDx/2)
  const Check c = checkGradients(S, "explicit 50 embedded");
  EXPECT_LT(c.max_rel_r, 1e-4);
  EXPECT_LT(c.max_rel_x, 1e-4);
}

TEST(SoftAdjoint, TwentyStepImplicitRolloutWithEmbeddedContactSamples) {
  Scenario S = makeSetup(SoftIntegrator::ImplicitEuler, 20);
  S.embedding = faceSamples(S.body, 5, 4, 4);
  S.ground_z = 3e-4;
  const Check c = checkGradients(S, "implicit 20 embedded");
  EXPECT_LT(c.max_rel_r, 1e-4);
  EXPECT_LT(c.max_rel_x, 1e-4);
}

TEST(SoftAdjoint, BadInput) {
  Scenario S = makeSetup(SoftIntegrator::SymplecticEuler, 3);
  const std::size_t n = S.body.X.size();
  std::vector<double> r(n, 0.5);
  std::vector<Eigen::Vector3d> v0(n, Eigen::Vector3d::Zero());
  try {
    runCase(S, r, S.body.X, v0, false, 1.0);  // far above the explicit limit
    FAIL() << "an unstable explicit dt was accepted";
  } catch (const TopoError& e) {
    EXPECT_NE(std::string(e.what()).find("stableTimeStep"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("ImplicitEuler"), std::string::npos) << e.what();
  }
}
