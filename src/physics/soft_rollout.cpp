// Differentiable soft-body rollout with checkpointing; see soft_rollout.h for the equations.
#include "topo_gaussian/physics/soft_rollout.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>

#include "topo_gaussian/common/error.h"

namespace topo_gaussian {

namespace {

using Vec3s = std::vector<Eigen::Vector3d>;

/// G.μ −= a·∂²E/∂x∂μ (likewise λ) and G.w −= a·∂²E_a/∂x∂w at the simulator's state: the material
/// part of every adjoint (explicit: a = dt w/m; implicit and static: a = λ). d_mu, d_lam: the SPH
/// part, CorotatedSph::materialDirectional(a) (or from SoftBodySimulator::stiffnessProduct(a, ...)).
void subtractMaterialTerms(const SoftBodySimulator& s, const Vec3s& a, const std::vector<double>& d_mu,
                           const std::vector<double>& d_lam, SoftDesignGradient* G) {
  for (std::size_t i = 0; i < a.size(); ++i) {
    G->mu[i] -= d_mu[i];
    G->lambda[i] -= d_lam[i];
  }
  if (s.actuation().chamber.empty()) return;
  const std::vector<double> dch = s.actuation().chamberDirectional(s.sph(), s.pressureNow(), a);
  for (std::size_t i = 0; i < a.size(); ++i) G->chamber[i] -= dch[i];
}

void subtractMaterialTerms(const SoftBodySimulator& s, const Vec3s& a, SoftDesignGradient* G) {
  std::vector<double> d_mu, d_lam;
  s.sph().materialDirectional(a, &d_mu, &d_lam);
  subtractMaterialTerms(s, a, d_mu, d_lam, G);
}

/// Solves (K + inertia·M) λ = b by PCG at the simulator's state; throws naming `what` on failure.
Vec3s adjointSolve(const SoftBodySimulator& s, double inertia, const Eigen::VectorXd& b, double tol, int max_iter,
                   const std::string& what, const Vec3s* guess = nullptr) {
  Eigen::VectorXd lam;
  if (guess && guess->size() == s.size()) {
    lam.resize(3 * guess->size());
    for (std::size_t i = 0; i < guess->size(); ++i) lam.segment<3>(3 * i) = (*guess)[i];
  }
  const CgResult cg =
      conjugateGradientFrom([&](const Eigen::VectorXd& p, Eigen::VectorXd* out) { s.systemProduct(p, inertia, out); },
                            s.systemPreconditioner(inertia), b, tol, max_iter, &lam);
  if (cg.negative_curvature || (!cg.converged && cg.relative_residual > 1e-6)) {
    std::ostringstream o;
    o << "the adjoint solve of " << what << " did not converge (relative residual " << cg.relative_residual
      << (cg.negative_curvature ? ", the Hessian is indefinite: an unstable state or an unsupported body" : "") << ")";
    throw TopoError("soft-body adjoint", o.str(), "reduce dt, clamp or support the body, or lower the load");
  }
  Vec3s L(s.size());
  for (std::size_t i = 0; i < L.size(); ++i) L[i] = lam.segment<3>(3 * i);
  return L;
}

double since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

SoftRollout::SoftRollout(SoftBodySimulator* sim, const SoftRolloutOptions& options) : sim_(sim), opt_(options) {
  if (!sim_) throw TopoError("SoftRollout", "no simulator", "pass a SoftBodySimulator");
  if (!std::isfinite(opt_.dt) || opt_.dt <= 0.0 || opt_.steps < 1) {
    std::ostringstream s;
    s << "dt = " << opt_.dt << " s, steps = " << opt_.steps;
    throw TopoError("SoftRollout options", s.str(), "use dt > 0 and steps >= 1");
  }
  if (opt_.integrator == SoftIntegrator::SymplecticEuler && opt_.dt > sim_->stableTimeStep()) {
    std::ostringstream s;
    s << "explicit time step dt = " << opt_.dt
      << " s exceeds the stability limit stableTimeStep() = " << sim_->stableTimeStep() << " s";
    throw TopoError("SoftRollout options", s.str(),
                    "use dt <= " + std::to_string(sim_->stableTimeStep()) +
                        " s, or SoftIntegrator::ImplicitEuler, which has no stability limit");
  }
  if (opt_.checkpoint_every <= 0) opt_.checkpoint_every = static_cast<int>(std::ceil(std::sqrt(double(opt_.steps))));
  // Step budget before the first step: steps × particles (the memory of a gradient run: run()).
  checkStepBudget("soft-body rollout", opt_.dt, opt_.dt * opt_.steps, static_cast<double>(sim_->size()), "dt_s");
}

void SoftRollout::stepForward(int k) {
  SoftBodySimulator& s = *sim_;
  pollStop(s.options().should_stop);
  const double dt = opt_.dt;
  if (opt_.integrator == SoftIntegrator::ImplicitEuler) {
    s.stepImplicit(dt, opt_.newton);
    return;
  }
  const std::size_t n = s.size();
  const Vec3s& f = s.conservativeForces();
  const Vec3s ffr = s.frictionForces(s.velocities());
  const Eigen::Vector3d g = s.options().gravity;
  const double c = s.options().damping;
  Vec3s x = s.positions(), v = s.velocities();
  for (std::size_t i = 0; i < n; ++i) {
    if (s.clamped()[i]) continue;
    v[i] += dt * ((f[i] + ffr[i]) / s.masses()[i] + g - c * v[i]);
    x[i] += dt * v[i];
  }
  const std::string where = "explicit step " + std::to_string(k + 1);
  for (std::size_t i = 0; i < n; ++i)
    if (!std::isfinite(v[i].squaredNorm()) || !std::isfinite(x[i].squaredNorm())) {
      std::ostringstream o;
      o << "particle " << i << " became non-finite at " << where;
      throw TopoError("SoftRollout", o.str(), "reduce dt or check the material and loads");
    }
  try {
    s.evaluateAt(x, s.time() + dt);
  } catch (const TopoError& e) {
    throw TopoError("SoftRollout (" + where + ")", e.what(), "reduce dt or use the implicit integrator");
  }
  s.setVelocities(v);
}

SoftRolloutResult SoftRollout::run(const SoftStepLoss& loss, bool with_gradient) {
  SoftBodySimulator& s = *sim_;
  const std::size_t n = s.size();
  const int N = opt_.steps, K = opt_.checkpoint_every;
  const double dt = opt_.dt, t0 = s.time();
  if (with_gradient)  // checkpoints + one recomputed segment with forces, 72 bytes per particle and state
    checkMemoryBudget("soft-body rollout", std::ceil(double(N) / K) + K + 1, 72.0 * double(n),
                      "use a larger dt_s, a shorter duration_s or a coarser particle spacing");
  SoftRolloutResult res;
  auto tf = std::chrono::steady_clock::now();
  std::vector<std::pair<Vec3s, Vec3s>> checkpoints;
  auto counts = [&](int k) { return !opt_.loss_at || opt_.loss_at(k); };
  if (counts(0)) res.loss = loss(0, t0, s.positions(), s.velocities(), nullptr, nullptr);
  for (int k = 0; k < N; ++k) {
    if (with_gradient && k % K == 0) checkpoints.emplace_back(s.positions(), s.velocities());
    stepForward(k);
    if (counts(k + 1)) res.loss += loss(k + 1, t0 + (k + 1) * dt, s.positions(), s.velocities(), nullptr, nullptr);
  }
  res.forward_s = since(tf);
  res.peak_states = checkpoints.size();
  constexpr std::size_t kState = 2 * sizeof(Eigen::Vector3d), kStateWithForces = 3 * sizeof(Eigen::Vector3d);
  res.peak_state_bytes = checkpoints.size() * n * kState;
  if (!with_gradient) return res;

  auto tb = std::chrono::steady_clock::now();
  const Vec3s x_end = s.positions(), v_end = s.velocities();
  const double t_end = s.time();
  const long steps_end = s.stepCount();
  SoftDesignGradient& G = res.gradient;
  G.mass.assign(n, 0.0);
  G.mu.assign(n, 0.0);
  G.lambda.assign(n, 0.0);
  G.chamber.assign(n, 0.0);
  Vec3s xb(n, Eigen::Vector3d::Zero()), vb(n, Eigen::Vector3d::Zero());
  if (counts(N)) loss(N, t_end, x_end, v_end, &xb, &vb);
  const Eigen::Vector3d g = s.options().gravity;
  const double c = s.options().damping;
  const auto& clamped = s.clamped();

  for (int seg = static_cast<int>(checkpoints.size()) - 1; seg >= 0; --seg) {
    const int k0 = seg * K, k1 = std::min(k0 + K, N);
    // Recompute the segment from its checkpoint.
    // Explicit steps also keep each state's conservative forces, so that the adjoint step below
    // needs the SPH state at x_k only (evaluateStateAt: no second force gather).
    const bool keep_forces = opt_.integrator == SoftIntegrator::SymplecticEuler;
    std::vector<std::pair<Vec3s, Vec3s>> states;
    std::vector<Vec3s> forces;
    states.reserve(k1 - k0 + 1);
    if (keep_forces) forces.reserve(k1 - k0 + 1);
    s.evaluateAt(checkpoints[seg].first, t0 + k0 * dt);
    s.setVelocities(checkpoints[seg].second);
    states.emplace_back(s.positions(), s.velocities());
    if (keep_forces) forces.push_back(s.conservativeForces());
    for (int k = k0; k < k1; ++k) {
      stepForward(k);
      states.emplace_back(s.positions(), s.velocities());
      if (keep_forces) forces.push_back(s.conservativeForces());
    }
    res.peak_states = std::max(res.peak_states, checkpoints.size() + states.size());
    const std::size_t segment_bytes = states.size() * (keep_forces ? kStateWithForces : kState);
    res.peak_state_bytes = std::max(res.peak_state_bytes, (checkpoints.size() * kState + segment_bytes) * n);
    for (int k = k1 - 1; k >= k0; --k) {
      pollStop(s.options().should_stop);
      const Vec3s& xk = states[k - k0].first;
      const Vec3s& vk = states[k - k0].second;
      Vec3s xbn(n, Eigen::Vector3d::Zero()), vbn(n, Eigen::Vector3d::Zero());
      if (opt_.integrator == SoftIntegrator::SymplecticEuler) {
        s.evaluateStateAt(xk, t0 + k * dt, forces[k - k0]);
        s.setVelocities(vk);
        const Vec3s& f = s.conservativeForces();
        const Vec3s ffr = s.frictionForces(vk);
        Vec3s a(n, Eigen::Vector3d::Zero());
        Vec3s w(n, Eigen::Vector3d::Zero());
        for (std::size_t i = 0; i < n; ++i) {
          if (clamped[i]) continue;
          w[i] = vb[i] + dt * xb[i];
          a[i] = dt * w[i] / s.masses()[i];
          G.mass[i] -= a[i].dot(f[i] + ffr[i]) / s.masses()[i];
        }
        std::vector<double> d_mu, d_lam;
        const Vec3s Ha = s.stiffnessProduct(a, &d_mu, &d_lam);
        for (std::size_t i = 0; i < n; ++i) {
          if (clamped[i]) continue;
          xbn[i] = xb[i] - Ha[i];
          vbn[i] = (1.0 - c * dt) * w[i];
        }
        if (!s.contact().empty()) s.contact().frictionAdjoint(xk, vk, a, &xbn, &vbn);
        subtractMaterialTerms(s, a, d_mu, d_lam, &G);
      } else {
        const Vec3s& x1 = states[k - k0 + 1].first;
        s.evaluateAt(x1, t0 + (k + 1) * dt);
        const double inertia = 1.0 / (dt * dt) + c / dt;
        Eigen::VectorXd b(3 * n);
        for (std::size_t i = 0; i < n; ++i)
          b.segment<3>(3 * i) = clamped[i] ? Eigen::Vector3d::Zero() : Eigen::Vector3d(xb[i] + vb[i] / dt);
        const Vec3s L = adjointSolve(s, inertia, b, opt_.adjoint_cg_tolerance, opt_.adjoint_cg_max_iterations,
                                     "implicit step " + std::to_string(k + 1));
        for (std::size_t i = 0; i < n; ++i) {
          if (clamped[i]) continue;
          const double m = s.masses()[i];
          xbn[i] = -vb[i] / dt + m * inertia * L[i];
          vbn[i] = m * L[i] / dt;
          const Eigen::Vector3d r = (x1[i] - xk[i] - dt * vk[i]) / (dt * dt) + c * (x1[i] - xk[i]) / dt - g;
          G.mass[i] -= L[i].dot(r);
        }
        if (!s.contact().empty()) s.contact().frictionAdjoint(xk, vk, L, &xbn, &vbn);
        subtractMaterialTerms(s, L, &G);
      }
      for (std::size_t i = 0; i < n; ++i)
        if (clamped[i]) {
          xbn[i].setZero();
          vbn[i].setZero();
        }
      if (counts(k)) loss(k, t0 + k * dt, xk, vk, &xbn, &vbn);
      xb.swap(xbn);
      vb.swap(vbn);
    }
  }
  for (std::size_t i = 0; i < n; ++i)
    if (clamped[i]) {
      xb[i].setZero();
      vb[i].setZero();
    }
  G.x0 = xb;
  G.v0 = vb;
  // Leave the simulator at the final state, as after a forward-only run.
  s.evaluateAt(x_end, t_end);
  s.setVelocities(v_end);
  (void)steps_end;
  res.backward_s = since(tb);
  return res;
}

SoftDesignGradient staticEquilibriumGradient(const SoftBodySimulator& s, const std::vector<Eigen::Vector3d>& dL_dx,
                                             double cg_tolerance, std::vector<Eigen::Vector3d>* adjoint) {
  const std::size_t n = s.size();
  if (dL_dx.size() != n)
    throw TopoError("staticEquilibriumGradient",
                    std::to_string(dL_dx.size()) + " loss gradients for " + std::to_string(n) + " particles",
                    "pass dL/dx for every particle");
  if (s.pressureNow() != s.actuation().pressure_pa)
    throw TopoError("staticEquilibriumGradient", "the pressure ramp is not complete at the simulator's time",
                    "set PneumaticActuation::ramp_s = 0 (static solves apply the full pressure)");
  const auto& clamped = s.clamped();
  Eigen::VectorXd b(3 * n);
  for (std::size_t i = 0; i < n; ++i) b.segment<3>(3 * i) = clamped[i] ? Eigen::Vector3d::Zero() : dL_dx[i];
  const Vec3s L = adjointSolve(s, 0.0, b, cg_tolerance, 50000, "the static equilibrium", adjoint);
  if (adjoint) *adjoint = L;
  SoftDesignGradient G;
  G.mass.assign(n, 0.0);
  G.mu.assign(n, 0.0);
  G.lambda.assign(n, 0.0);
  G.chamber.assign(n, 0.0);
  const Eigen::Vector3d g = s.options().gravity;
  for (std::size_t i = 0; i < n; ++i)
    if (!clamped[i]) G.mass[i] = L[i].dot(g);
  subtractMaterialTerms(s, L, &G);
  return G;
}

}  // namespace topo_gaussian
