// Soft-body simulator; see soft_body.h for the model and the integrator.
#include "topo_gaussian/physics/soft_body.h"

#include <Eigen/Dense>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <sstream>
#include <utility>

#include "topo_gaussian/common/error.h"

namespace topo_gaussian {

namespace {

bool finite3(const Eigen::Vector3d& v) { return std::isfinite(v.x()) && std::isfinite(v.y()) && std::isfinite(v.z()); }

/// Particle count from which step()'s per-particle loops run threaded.
constexpr long long kParallelUpdateMin = 8192;

}  // namespace

SoftBodySimulator::SoftBodySimulator(CorotatedSph sph, const SoftBodyOptions& options)
    : sph_(std::move(sph)), opt_(options) {
  static std::atomic<std::uint64_t> serials{0};
  serial_ = ++serials;
  const std::size_t n = sph_.size();
  if (n == 0) throw TopoError("SoftBodySimulator", "the particle set is empty", "pass a non-empty CorotatedSph");
  if (!finite3(opt_.gravity))
    throw TopoError("SoftBodySimulator options", "gravity is not finite", "give a finite gravity vector");
  if (!std::isfinite(opt_.damping) || opt_.damping < 0.0)
    throw TopoError("SoftBodySimulator options", "damping must be finite and >= 0", "use damping >= 0 [1/s]");
  if (!std::isfinite(opt_.cfl) || opt_.cfl <= 0.0)
    throw TopoError("SoftBodySimulator options", "cfl must be finite and > 0", "use e.g. cfl = 0.5");
  m_ = sph_.masses();
  x_ = sph_.restPositions();
  v_.assign(n, Eigen::Vector3d::Zero());
  clamped_.assign(n, 0);

  updateStability();
  refreshForces("initial state");
}

void SoftBodySimulator::updateStability() {
  const std::size_t n = sph_.size();
  double vmin = sph_.volumes()[0];
  c_max_ = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const double V = sph_.volumes()[i];
    vmin = std::min(vmin, V);
    const double rho = m_[i] / V;
    const double c = std::sqrt((sph_.lameLambdas()[i] + 2.0 * sph_.shearModuli()[i]) / rho);
    c_max_ = std::max(c_max_, c);
  }
  dx_ = std::cbrt(vmin);
  // The typical spacing (median volume): a fill's partial boundary cells (down to half a cell) must not
  // soften the automatic contact stiffness k = k_max · spacing.
  dx_typical_ = spacingFromVolumes(sph_.volumes());
  if (!(c_max_ > 0.0) || !std::isfinite(c_max_))
    throw TopoError("SoftBodySimulator", "the wave speed sqrt((lambda + 2 mu)/rho) is not positive and finite",
                    "check the material parameters and the density");
  // Second-order (quadratic MLS) gradients weigh the near neighbours more strongly: the highest
  // frequency of a lattice beam is 2.37× that of first-order gradients (power iteration, Δx = 4 mm),
  // so the step is scaled by 1/2.37 to keep the same margin.
  const double order_factor = sph_.options().gradient_order >= 2 ? 1.0 / 2.37 : 1.0;
  dt_stable_ = opt_.cfl * order_factor * dx_ / c_max_;
}

void SoftBodySimulator::setMasses(const std::vector<double>& m) {
  if (m.size() != size())
    throw TopoError("SoftBodySimulator::setMasses",
                    std::to_string(m.size()) + " masses for " + std::to_string(size()) + " particles",
                    "pass one mass per particle");
  for (std::size_t i = 0; i < m.size(); ++i)
    if (!std::isfinite(m[i]) || m[i] <= 0.0)
      throw TopoError("SoftBodySimulator::setMasses",
                      "mass " + std::to_string(i) + " = " + std::to_string(m[i]) + " is not positive",
                      "use a mass floor for hollow particles");
  m_ = m;
  invalidateRestFactor();
  updateStability();
}

void SoftBodySimulator::setMaterial(const std::vector<double>& mu, const std::vector<double>& lambda) {
  sph_.setMaterial(mu, lambda);
  invalidateRestFactor();
  updateStability();
  refreshForces("setMaterial");
}

void SoftBodySimulator::setActuation(const PneumaticActuation& a) {
  a.validate(size());
  act_ = a;
  ext_stiffness_.reset();  // the chamber's weights are part of the external body
  refreshForces("setActuation");
}

void SoftBodySimulator::setContact(const SoftContact& c) {
  if (!c.mask().empty() && c.mask().size() != size())
    throw TopoError("SoftBodySimulator::setContact",
                    "the contact mask has " + std::to_string(c.mask().size()) + " entries for " +
                        std::to_string(size()) + " particles",
                    "pass one entry per particle or an empty mask");
  if (c.embedded() && c.embedding()->particleCount() != size())
    throw TopoError("SoftBodySimulator::setContact",
                    "the contact samples are embedded in " + std::to_string(c.embedding()->particleCount()) +
                        " particles but the body has " + std::to_string(size()),
                    "embed the samples in this body's rest positions (restPositions())");
  contact_ = c;
  if (!(contact_.options().stiffness > 0.0)) {
    double kmax = 0.0;
    for (std::size_t i = 0; i < size(); ++i) kmax = std::max(kmax, sph_.lameLambdas()[i] + 2.0 * sph_.shearModuli()[i]);
    contact_.setStiffness(kmax * dx_typical_);
  }
  refreshForces("setContact");
}

void SoftBodySimulator::setTime(double t) {
  if (!std::isfinite(t)) throw TopoError("SoftBodySimulator::setTime", "time is not finite", "pass a finite time [s]");
  time_ = t;
  refreshForces("setTime");
}

void SoftBodySimulator::setGravity(const Eigen::Vector3d& g) {
  if (!finite3(g)) throw TopoError("SoftBodySimulator::setGravity", "gravity is not finite", "give a finite vector");
  opt_.gravity = g;
}

void SoftBodySimulator::setDamping(double c) {
  if (!std::isfinite(c) || c < 0.0)
    throw TopoError("SoftBodySimulator::setDamping", "damping must be finite and >= 0", "use damping >= 0 [1/s]");
  opt_.damping = c;
}

std::size_t SoftBodySimulator::clampedCount() const {
  return static_cast<std::size_t>(std::count(clamped_.begin(), clamped_.end(), std::uint8_t(1)));
}

void SoftBodySimulator::setClamped(const std::vector<std::uint8_t>& mask) {
  if (mask.size() != size()) {
    std::ostringstream s;
    s << "the clamp mask has " << mask.size() << " entries but the body has " << size() << " particles";
    throw TopoError("SoftBodySimulator::setClamped", s.str(), "pass one entry (0 free / 1 clamped) per particle");
  }
  clamped_.resize(mask.size());
  for (std::size_t i = 0; i < mask.size(); ++i) clamped_[i] = mask[i] ? 1 : 0;
  invalidateRestFactor();
  enforceClamp();
  refreshForces("setClamped");
}

void SoftBodySimulator::enforceClamp() {
  const auto& X = sph_.restPositions();
  for (std::size_t i = 0; i < size(); ++i)
    if (clamped_[i]) {
      x_[i] = X[i];
      v_[i].setZero();
    }
}

void SoftBodySimulator::setPositions(const std::vector<Eigen::Vector3d>& x) {
  if (x.size() != size()) {
    std::ostringstream s;
    s << x.size() << " positions for " << size() << " particles";
    throw TopoError("SoftBodySimulator::setPositions", s.str(), "pass one position per particle");
  }
  x_ = x;
  enforceClamp();
  refreshForces("setPositions");
}

void SoftBodySimulator::setVelocities(const std::vector<Eigen::Vector3d>& v) {
  if (v.size() != size()) {
    std::ostringstream s;
    s << v.size() << " velocities for " << size() << " particles";
    throw TopoError("SoftBodySimulator::setVelocities", s.str(), "pass one velocity per particle");
  }
  for (std::size_t i = 0; i < v.size(); ++i)
    if (!finite3(v[i]))
      throw TopoError("SoftBodySimulator::setVelocities", "velocity " + std::to_string(i) + " is not finite",
                      "pass finite velocities");
  v_ = v;
  enforceClamp();
}

void SoftBodySimulator::refreshForces(const std::string& where, const std::vector<Eigen::Vector3d>* known_forces) {
  ++state_version_;
  try {
    if (known_forces)
      sph_.updateState(x_);
    else
      sph_.update(x_);
  } catch (const TopoError& e) {
    throw TopoError("SoftBodySimulator (" + where + ")", e.what(),
                    "reduce the time step (e.g. 0.5 x stableTimeStep()), add damping, or check the loads");
  }
  if (known_forces) {
    f_cons_ = *known_forces;
    return;
  }
  f_cons_ = sph_.forces();
  act_.addForces(sph_, pressureNow(), &f_cons_);
  if (!contact_.empty()) contact_.addNormalForces(x_, &f_cons_);
}

void SoftBodySimulator::evaluateAt(const std::vector<Eigen::Vector3d>& x, double t) {
  x_ = x;
  time_ = t;
  enforceClamp();
  refreshForces("evaluateAt t = " + std::to_string(t) + " s");
}

void SoftBodySimulator::evaluateStateAt(const std::vector<Eigen::Vector3d>& x, double t,
                                        const std::vector<Eigen::Vector3d>& f_cons) {
  if (f_cons.size() != size())
    throw TopoError("SoftBodySimulator::evaluateStateAt",
                    std::to_string(f_cons.size()) + " forces for " + std::to_string(size()) + " particles",
                    "pass the conservative forces of the forward pass at x");
  x_ = x;
  time_ = t;
  enforceClamp();
  refreshForces("evaluateStateAt t = " + std::to_string(t) + " s", &f_cons);
}

std::vector<Eigen::Vector3d> SoftBodySimulator::stiffnessProduct(const std::vector<Eigen::Vector3d>& dx) const {
  return stiffnessProduct(dx, nullptr, nullptr);
}

std::vector<Eigen::Vector3d> SoftBodySimulator::stiffnessProduct(const std::vector<Eigen::Vector3d>& dx_in,
                                                                 std::vector<double>* d_mu,
                                                                 std::vector<double>* d_lambda) const {
  std::vector<Eigen::Vector3d> dx = dx_in;
  for (std::size_t i = 0; i < size(); ++i)
    if (clamped_[i]) dx[i].setZero();
  std::vector<Eigen::Vector3d> out = sph_.hessianProduct(dx, d_mu, d_lambda);
  act_.addHessianProduct(sph_, pressureNow(), dx, &out);
  if (!contact_.empty()) contact_.addHessianProduct(x_, dx, &out);
  for (std::size_t i = 0; i < size(); ++i)
    if (clamped_[i]) out[i].setZero();
  return out;
}

void SoftBodySimulator::systemProduct(const Eigen::VectorXd& p, double inertia, Eigen::VectorXd* out) const {
  const std::size_t n = size();
  if (opt_.stiffness_external && contact_.empty() && !ext_failed_) {
    try {
      if (!ext_stiffness_) {
        ext_stiffness_ = opt_.stiffness_external(*this);
        ext_version_ = -1;
      }
      // the state it was given, and the loads the host reads at product time (solveStatic and
      // stepImplicit set the pressure and the clock without re-evaluating until Newton's first value)
      if (ext_version_ != state_version_ || ext_time_ != time_ || ext_pressure_ != act_.pressure_pa ||
          ext_ramp_ != act_.ramp_s) {
        ext_stiffness_->setState(x_, time_, act_.pressure_pa, act_.ramp_s);
        ext_version_ = state_version_;
        ext_time_ = time_;
        ext_pressure_ = act_.pressure_pa;
        ext_ramp_ = act_.ramp_s;
      }
      Eigen::VectorXd q = p;
      for (std::size_t i = 0; i < n; ++i)
        if (clamped_[i]) q.segment<3>(3 * i).setZero();
      ext_stiffness_->product(q, out);
      for (std::size_t i = 0; i < n; ++i)
        out->segment<3>(3 * i) = clamped_[i]
                                     ? Eigen::Vector3d::Zero()
                                     : Eigen::Vector3d(out->segment<3>(3 * i) + inertia * m_[i] * q.segment<3>(3 * i));
      return;
    } catch (const TopoError& e) {
      ext_stiffness_.reset();
      ext_version_ = -1;
      if (opt_.cholesky_external_required) throw ExternalFactorRefused(e.what());
      ext_failed_ = true;  // the host from now on, said once
      preconditioner_note_ += (preconditioner_note_.empty() ? "" : "; ") +
                              std::string("the stiffness products on the host, not the GPU: ") + e.what();
    }
  }
  std::vector<Eigen::Vector3d> dx(n);
  for (std::size_t i = 0; i < n; ++i) dx[i] = p.segment<3>(3 * i);
  const auto h = stiffnessProduct(dx);
  out->resize(3 * n);
  for (std::size_t i = 0; i < n; ++i)
    out->segment<3>(3 * i) = clamped_[i] ? Eigen::Vector3d::Zero() : Eigen::Vector3d(h[i] + inertia * m_[i] * dx[i]);
}

Eigen::VectorXd SoftBodySimulator::systemDiagonal(double inertia) const {
  const std::size_t n = size();
  std::vector<Eigen::Vector3d> cd(n, Eigen::Vector3d::Zero());
  if (!contact_.empty()) contact_.addHessianDiagonal(x_, &cd);
  const double h2 = sph_.smoothingLength() * sph_.smoothingLength();
  Eigen::VectorXd d(3 * n);
  for (std::size_t i = 0; i < n; ++i) {
    const double el = (sph_.lameLambdas()[i] + 2.0 * sph_.shearModuli()[i]) * sph_.volumes()[i] / h2;
    for (int k = 0; k < 3; ++k) d(3 * i + k) = clamped_[i] ? 1.0 : inertia * m_[i] + el + cd[i](k);
  }
  return d;
}

namespace {
LinearOperator preconditionerOf(std::shared_ptr<const RestStiffnessPreconditioner> f) {
  return [f](const Eigen::VectorXd& r, Eigen::VectorXd* z) { f->apply(r, z); };
}
}  // namespace

LinearOperator SoftBodySimulator::systemPreconditioner(double inertia) const {
  if (size() > opt_.cholesky_max_particles) {
    if (preconditioner_note_.empty())  // once: this runs at every Newton step
      preconditioner_note_ = "Jacobi preconditioner: " + std::to_string(size()) +
                             " particles are above SoftBodyOptions::cholesky_max_particles (" +
                             std::to_string(opt_.cholesky_max_particles) + ")";
    return jacobiPreconditioner(systemDiagonal(inertia));
  }
  // A kept factor of another design that has cost more in this design's solves than its own would:
  // this design's own factor below (rest_factor_reuse.h, the rule during a use).
  if (rest_factor_inertia_ == inertia && rest_factor_ && opt_.rest_factor_reuse &&
      opt_.rest_factor_reuse->renewDuringUse(serial_))
    rest_factor_inertia_ = -1.0;
  if (rest_factor_inertia_ != inertia) {
    Eigen::VectorXd shift(3 * size());
    for (std::size_t i = 0; i < size(); ++i) shift.segment<3>(3 * i).setConstant(inertia * m_[i]);
    rest_factor_inertia_ = inertia;
    rest_factor_.reset();  // its memory back before the next factor is sized
    preconditioner_note_.clear();
    const double max_bytes =
        opt_.cholesky_max_factor_bytes > 0.0 ? opt_.cholesky_max_factor_bytes : 0.5 * availableMemoryBytes();
    try {
      if (opt_.rest_factor_reuse) rest_factor_ = opt_.rest_factor_reuse->find(serial_, sph_, clamped_, inertia);
      if (!rest_factor_) {
        rest_factor_ = std::make_shared<const RestStiffnessPreconditioner>(
            sph_, shift, clamped_, max_bytes, opt_.cholesky_external, opt_.cholesky_external_required);
        // kept for the next design unless it is the host's fallback for a refused external factor
        if (opt_.rest_factor_reuse && rest_factor_->externalNote().empty())
          opt_.rest_factor_reuse->store(serial_, rest_factor_, sph_, clamped_, inertia);
      }
      if (!rest_factor_->externalNote().empty())
        preconditioner_note_ =
            "the rest stiffness's Cholesky factor on the host, not the GPU: " + rest_factor_->externalNote();
    } catch (const ExternalFactorRefused&) {
      rest_factor_inertia_ = -1.0;  // no factor: the next call tries again (and fails) rather than use Jacobi
      throw;
    } catch (const TopoError& e) {
      // unsupported at rest (held by contact only) or above the memory limit: Jacobi
      preconditioner_note_ = std::string("Jacobi preconditioner: ") + e.what();
    } catch (...) {  // e.g. bad_alloc while assembling: nothing is cached
      rest_factor_inertia_ = -1.0;
      throw;
    }
  }
  if (!rest_factor_) return jacobiPreconditioner(systemDiagonal(inertia));
  return preconditionerOf(rest_factor_);
}

std::vector<Eigen::Vector3d> SoftBodySimulator::frictionForces(const std::vector<Eigen::Vector3d>& v) const {
  std::vector<Eigen::Vector3d> f(size(), Eigen::Vector3d::Zero());
  if (contact_.empty() || contact_.options().friction <= 0.0) return f;
  contact_.addFrictionForces(x_, v, &f);
  return f;
}

double SoftBodySimulator::forceScale() const {
  double s = 0.0;
  for (std::size_t i = 0; i < size(); ++i) s = std::max(s, m_[i] * opt_.gravity.norm());
  const double p = std::abs(act_.pressure_pa);
  if (p > 0.0 && !act_.chamber.empty())
    for (std::size_t i = 0; i < size(); ++i)
      s = std::max(s, p * act_.chamber[i] * std::pow(sph_.volumes()[i], 2.0 / 3.0));
  if (!(s > 0.0)) {  // no load at all: use the elastic force of a 1e-3 strain
    for (std::size_t i = 0; i < size(); ++i)
      s = std::max(s, 1e-3 * sph_.shearModuli()[i] * std::pow(sph_.volumes()[i], 2.0 / 3.0));
  }
  return s;
}

double SoftBodySimulator::roundoffForce(double inertia) const {
  // Positions of size |x|∞ carry an absolute rounding error ε|x|∞; the stiffest row (Jacobi diagonal:
  // (λ+2μ)V/h² + inertia·m, the force per unit displacement of one particle) turns it into a force.
  // The gradient sums ~N(i) such terms (with cancellation), so the floor is a multiple of that: the
  // residuals at which Newton stalled measured 3–30× ε|x|∞ max D_ii (cantilevers 0.2 m / E 1e7 /
  // 2.5 mm and 0.5 m / E 1e8 / 4 mm), hence the factor 64.
  double xmax = 0.0;
  for (const auto& p : x_) xmax = std::max(xmax, p.cwiseAbs().maxCoeff());
  const Eigen::VectorXd d = systemDiagonal(inertia);
  double dmax = 0.0;
  for (std::size_t i = 0; i < size(); ++i)
    if (!clamped_[i]) dmax = std::max(dmax, d.segment<3>(3 * i).maxCoeff());
  return 64.0 * std::numeric_limits<double>::epsilon() * xmax * dmax;
}

double SoftBodySimulator::firstNaturalFrequency(double tolerance, int max_iterations) const {
  requireConservative("SoftBodySimulator::firstNaturalFrequency");
  const std::size_t n = size();
  const LinearOperator precondition = systemPreconditioner(0.0);
  Eigen::VectorXd phi(3 * n), b(3 * n), next;
  // Start: the gravity direction (or z) everywhere — the static deflection shape after one solve.
  const Eigen::Vector3d d =
      opt_.gravity.norm() > 0 ? Eigen::Vector3d(opt_.gravity.normalized()) : Eigen::Vector3d::UnitZ();
  for (std::size_t i = 0; i < n; ++i) phi.segment<3>(3 * i) = clamped_[i] ? Eigen::Vector3d::Zero() : d;
  auto apply = [&](const Eigen::VectorXd& p, Eigen::VectorXd* out) { systemProduct(p, 0.0, out); };
  double omega2 = 0.0;
  for (int it = 0; it < max_iterations; ++it) {
    for (std::size_t i = 0; i < n; ++i) b.segment<3>(3 * i) = m_[i] * phi.segment<3>(3 * i);
    const CgResult cg = conjugateGradient(apply, precondition, b, 1e-10, 20000, &next);
    if (cg.negative_curvature || !(cg.relative_residual < 1e-6))
      throw TopoError(
          "SoftBodySimulator::firstNaturalFrequency",
          "the stiffness is singular or indefinite (relative residual " + std::to_string(cg.relative_residual) + ")",
          "clamp the body (an unsupported body has rigid modes at zero frequency)");
    // Rayleigh quotient of the new iterate: ω² = φᵀKφ / φᵀMφ with Kφ_new = Mφ.
    double num = 0.0, den = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      num += next.segment<3>(3 * i).dot(m_[i] * phi.segment<3>(3 * i));
      den += m_[i] * next.segment<3>(3 * i).squaredNorm();
    }
    const double w2 = num / den;
    phi = next / std::sqrt(den);
    if (it > 0 && std::abs(w2 - omega2) <= tolerance * w2) return std::sqrt(w2) / (2.0 * M_PI);
    omega2 = w2;
  }
  throw TopoError("SoftBodySimulator::firstNaturalFrequency",
                  "inverse iteration did not settle in " + std::to_string(max_iterations) + " iterations",
                  "raise max_iterations (two close lowest modes converge slowly)");
}

double SoftBodySimulator::maxAngularFrequency(int iterations) const {
  const std::size_t n = size();
  std::vector<Eigen::Vector3d> p(n);
  for (std::size_t i = 0; i < n; ++i)
    p[i] = clamped_[i] ? Eigen::Vector3d::Zero()
                       : Eigen::Vector3d(std::sin(1.0 + 3.0 * i), std::cos(7.0 * i), std::sin(5.0 * i + 2.0));
  double lam = 0.0;
  for (int it = 0; it < iterations; ++it) {
    auto q = stiffnessProduct(p);
    double nrm = 0.0, ray = 0.0, pp = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      ray += p[i].dot(q[i]);
      pp += m_[i] * p[i].squaredNorm();
      q[i] /= m_[i];
      nrm += q[i].squaredNorm();
    }
    lam = ray / pp;
    nrm = std::sqrt(nrm);
    if (!(nrm > 0.0)) break;
    for (std::size_t i = 0; i < n; ++i) p[i] = q[i] / nrm;
  }
  return std::sqrt(std::max(lam, 0.0));
}

void SoftBodySimulator::requireConservative(const std::string& where) const {
  if (sph_.options().model == SphEnergyModel::CorotatedLinear &&
      sph_.options().rotation != SphRotationSource::CorrectedGradient)
    throw TopoError(where,
                    "corotated linear elasticity with shape-matching rotations is not the gradient of an energy, so "
                    "Newton's line search and the adjoint have no exact objective",
                    "use CorotatedSphOptions::rotation = CorrectedGradient (or the StVK model)");
}

double SoftBodySimulator::staticPotential() const {
  double psi = sph_.energy() + act_.energy(sph_, pressureNow()) + contact_.energy(x_);
  for (std::size_t i = 0; i < size(); ++i)
    if (!clamped_[i]) psi -= m_[i] * opt_.gravity.dot(x_[i]);
  return psi;
}

SolveReport SoftBodySimulator::newtonSolve(const std::string& where, double dt, const std::vector<Eigen::Vector3d>& x0,
                                           const std::vector<Eigen::Vector3d>& v0, const NewtonOptions& newton) {
  requireConservative(where);
  const std::size_t n = size();
  const bool dynamic = dt > 0.0;
  const double c = opt_.damping;
  const double inertia = dynamic ? 1.0 / (dt * dt) + c / dt : 0.0;
  std::vector<Eigen::Vector3d> xt(n), ffr;
  if (dynamic) {
    for (std::size_t i = 0; i < n; ++i) xt[i] = x0[i];
    ffr = frictionForces(v0);  // lagged friction (current state is x0)
  }
  const Eigen::Vector3d g = opt_.gravity;
  auto unpack = [&](const Eigen::VectorXd& z) {
    std::vector<Eigen::Vector3d> x(n);
    for (std::size_t i = 0; i < n; ++i)
      x[i] = clamped_[i] ? sph_.restPositions()[i] : Eigen::Vector3d(z.segment<3>(3 * i));
    return x;
  };
  std::vector<Eigen::Vector3d> cur;
  NewtonObjective obj;
  obj.value = [&](const Eigen::VectorXd& z) {
    pollStop(opt_.should_stop);
    cur = unpack(z);
    x_ = cur;
    refreshForces(where);
    double psi = staticPotential();
    for (std::size_t i = 0; dynamic && i < n; ++i) {
      if (clamped_[i]) continue;
      const Eigen::Vector3d a = x_[i] - x0[i] - dt * v0[i], b = x_[i] - x0[i];
      psi += 0.5 * m_[i] * (a.squaredNorm() / (dt * dt) + (c / dt) * b.squaredNorm());
      psi -= ffr[i].dot(x_[i]);
    }
    return psi;
  };
  obj.gradient = [&](const Eigen::VectorXd&, Eigen::VectorXd* out) {
    out->setZero(3 * n);
    for (std::size_t i = 0; i < n; ++i) {
      if (clamped_[i]) continue;
      Eigen::Vector3d r = -f_cons_[i] - m_[i] * g;
      if (dynamic) r += m_[i] * ((x_[i] - x0[i] - dt * v0[i]) / (dt * dt) + (c / dt) * (x_[i] - x0[i])) - ffr[i];
      out->segment<3>(3 * i) = r;
    }
  };
  obj.hessian = [&](const Eigen::VectorXd&, const Eigen::VectorXd& p, Eigen::VectorXd* out) {
    systemProduct(p, inertia, out);
  };
  obj.preconditioner = [&](const Eigen::VectorXd&) { return systemPreconditioner(inertia); };
  Eigen::VectorXd z(3 * n);
  for (std::size_t i = 0; i < n; ++i) z.segment<3>(3 * i) = dynamic ? Eigen::Vector3d(x0[i] + dt * v0[i]) : x_[i];
  double scale = forceScale();
  SolveReport rep;
  rep.pressure_pa = pressureNow();
  rep.newton = minimizeNewton(obj, scale, newton, &z, roundoffForce(inertia));
  obj.value(z);
  return rep;
}

SolveReport SoftBodySimulator::stepImplicit(double dt, const NewtonOptions& newton) {
  if (!std::isfinite(dt) || dt <= 0.0)
    throw TopoError("SoftBodySimulator::stepImplicit", "time step dt = " + std::to_string(dt) + " s is not positive",
                    "use dt > 0");
  pollStop(opt_.should_stop);
  const long k = steps_ + 1;
  const std::vector<Eigen::Vector3d> x0 = x_, v0 = v_;
  const double t0 = time_;
  time_ = t0 + dt;
  const std::string where = "implicit step " + std::to_string(k) + ", t = " + std::to_string(time_) + " s";
  SolveReport rep;
  try {
    rep = newtonSolve(where, dt, x0, v0, newton);
  } catch (const TopoError&) {
    x_ = x0;
    time_ = t0;
    refreshForces("restore after a failed implicit step");
    throw;
  }
  if (!rep.newton.converged) {
    x_ = x0;
    time_ = t0;
    refreshForces("restore after a failed implicit step");
    std::ostringstream s;
    s << "Newton did not converge in " << where << ": " << rep.newton.message << ", residual " << rep.newton.residual
      << " after " << rep.newton.iterations << " iterations (" << rep.newton.cg_iterations << " CG iterations)";
    throw TopoError("SoftBodySimulator::stepImplicit", s.str(),
                    "reduce dt, ramp the pressure more slowly (PneumaticActuation::ramp_s), or raise "
                    "NewtonOptions::max_iterations");
  }
  for (std::size_t i = 0; i < size(); ++i)
    v_[i] = clamped_[i] ? Eigen::Vector3d::Zero() : Eigen::Vector3d((x_[i] - x0[i]) / dt);
  steps_ = k;
  return rep;
}

SolveReport SoftBodySimulator::solveStatic(const NewtonOptions& newton, int load_steps) {
  if (load_steps < 1)
    throw TopoError("SoftBodySimulator::solveStatic", "load_steps must be >= 1", "e.g. solveStatic(options, 4)");
  requireConservative("static solve");
  const Eigen::Vector3d g_full = opt_.gravity;
  const PneumaticActuation a_full = act_;
  auto restoreLoads = [&] {
    opt_.gravity = g_full;
    act_ = a_full;
  };
  // Load fraction f goes 0 → 1 in increments of 1/load_steps; an increment whose Newton solve fails
  // (line search stuck, too many iterations) is retried from the last equilibrium with half the
  // increment, down to 1/(8 · load_steps) (adaptive load stepping). Beyond a limit point (an
  // inflating soft chamber can have no equilibrium above some pressure) every retry fails, so the
  // number of halvings is kept small.
  const double df_min = 1.0 / (8.0 * load_steps);
  double f = 0.0, df = 1.0 / load_steps;
  std::vector<Eigen::Vector3d> x_ok = x_;
  SolveReport rep;
  int increments = 0, bisections = 0;
  std::string last_failure;
  while (f < 1.0) {
    const double f_try = std::min(1.0, f + df);
    opt_.gravity = f_try * g_full;
    act_.pressure_pa = f_try * a_full.pressure_pa;
    act_.ramp_s = 0.0;
    std::ostringstream where;
    where << "static solve, load " << f_try * 100.0 << " %";
    bool ok = false;
    try {
      rep = newtonSolve(where.str(), 0.0, x_, v_, newton);
      ok = rep.newton.converged;
      if (!ok) {
        std::ostringstream o;
        o << where.str() << ": " << rep.newton.message << ", residual " << rep.newton.residual << " after "
          << rep.newton.iterations << " iterations";
        last_failure = o.str();
      }
    } catch (const ExternalFactorRefused&) {  // the GPU that was required failed: not a load to halve
      x_ = x_ok;
      restoreLoads();
      refreshForces("restore after a refused external solve");
      throw;
    } catch (const TopoError& e) {
      last_failure = e.what();
    }
    if (ok) {
      f = f_try;
      x_ok = x_;
      ++increments;
      continue;
    }
    x_ = x_ok;  // back to the last equilibrium
    df *= 0.5;
    ++bisections;
    if (df < df_min) {
      restoreLoads();
      refreshForces("restore after a failed static solve");
      std::ostringstream o;
      o << "Newton did not converge even with load increments of " << df * 2.0 * 100.0 << " % (reached " << f * 100.0
        << " % of the load after " << increments << " increments and " << bisections
        << " halvings); last failure: " << last_failure;
      throw TopoError("SoftBodySimulator::solveStatic", o.str(),
                      "see the last failure for what to change; otherwise lower the pressure or the load, stiffen "
                      "the material, or check that the body is clamped or supported");
    }
  }
  restoreLoads();
  refreshForces("static solve");
  for (auto& v : v_) v.setZero();
  rep.load_increments = increments;
  return rep;
}

SolveReport SoftBodySimulator::solveStaticFrom(const std::vector<Eigen::Vector3d>& guess, const NewtonOptions& newton,
                                               int load_steps, int guess_iterations) {
  requireConservative("static solve");
  bool usable = guess.size() == size() && guess_iterations > 0;
  for (std::size_t i = 0; usable && i < guess.size(); ++i) usable = guess[i].allFinite();
  if (!usable) return solveStatic(newton, load_steps);
  const std::vector<Eigen::Vector3d> x_start = x_;
  const PneumaticActuation a_full = act_;
  auto restore = [&](const char* where) {
    act_ = a_full;
    x_ = x_start;
    refreshForces(where);
  };
  auto atEquilibrium = [&] {  // the full load kept, at rest
    act_ = a_full;
    refreshForces("static solve");
    for (auto& v : v_) v.setZero();
  };
  act_.ramp_s = 0.0;  // the full pressure now, as solveStatic's last increment
  SolveReport rep;
  bool ok = false;
  try {
    // A start that is the equilibrium at the full load already (the rest shape of a design without a
    // chamber, which Newton from the last design's bent shape may not reach in guess_iterations) is
    // kept: Newton with no iteration only checks the residual.
    NewtonOptions check = newton;
    check.max_iterations = 0;
    SolveReport at_start = newtonSolve("static solve, the start at the full load", 0.0, x_, v_, check);
    if (at_start.newton.converged) {
      atEquilibrium();
      return at_start;
    }
    x_ = guess;
    enforceClamp();
    NewtonOptions limited = newton;
    limited.max_iterations = std::min(newton.max_iterations, guess_iterations);
    rep = newtonSolve("static solve from the given start", 0.0, x_, v_, limited);
    ok = rep.newton.converged;
  } catch (const ExternalFactorRefused&) {  // the GPU that was required failed: not a guess to drop
    restore("restore after a refused external solve");
    throw;
  } catch (const TopoError&) {  // e.g. the guess is inverted for this design: from the start instead
  } catch (...) {               // cancelled (SimulationCancelled) or out of memory: the state as given
    restore("restore after a static solve from a guess");
    throw;
  }
  if (ok) {
    atEquilibrium();
    rep.load_increments = 1;
    rep.from_guess = true;
    rep.guess_iterations = rep.newton.iterations;
    return rep;
  }
  const int spent = rep.newton.iterations;  // 0 when the guess itself was refused
  restore("restore after a static solve from a guess");
  SolveReport fallback = solveStatic(newton, load_steps);
  fallback.guess_iterations = spent;
  return fallback;
}

void SoftBodySimulator::step(double dt) {
  if (!std::isfinite(dt) || dt <= 0.0) {
    std::ostringstream s;
    s << "time step dt = " << dt << " s is not positive";
    throw TopoError("SoftBodySimulator::step", s.str(), "use 0 < dt <= stableTimeStep()");
  }
  pollStop(opt_.should_stop);
  if (dt > dt_stable_) {
    std::ostringstream s;
    s << "time step dt = " << dt << " s exceeds the explicit stability estimate stableTimeStep() = " << dt_stable_
      << " s (cfl " << opt_.cfl << " x spacing " << dx_ << " m / wave speed " << c_max_ << " m/s)";
    throw TopoError("SoftBodySimulator::step", s.str(),
                    "use dt <= " + std::to_string(dt_stable_) +
                        " s (e.g. 0.5 x stableTimeStep()), or advance(duration), which substeps");
  }
  const long k = steps_ + 1;
  const std::size_t n = size();
  const Eigen::Vector3d g = opt_.gravity;
  const double c = opt_.damping;
  const bool friction = !contact_.empty() && contact_.options().friction > 0.0;
  const long long nn = static_cast<long long>(n);
  // Per-particle updates, each element computed exactly as serially (deterministic); threaded only
  // for large bodies, where they are worth a parallel region.
  const bool par = nn >= kParallelUpdateMin;
  // Returns false if a velocity became non-finite. With drift, x_i += dt v_i follows each particle's
  // kick in the same loop (the first half kick and the drift in one pass over the particles).
  auto kick = [&](double h, bool drift) {
    const auto& f = f_cons_;
    std::vector<Eigen::Vector3d> ffr;
    if (friction) ffr = frictionForces(v_);
    bool finite = true;
#pragma omp parallel for schedule(static) reduction(&& : finite) if (par)
    for (long long ii = 0; ii < nn; ++ii) {
      const std::size_t i = static_cast<std::size_t>(ii);
      if (!clamped_[i]) {
        v_[i] += h * ((friction ? Eigen::Vector3d(f[i] + ffr[i]) : f[i]) / m_[i] + g - c * v_[i]);
        if (drift) x_[i] += dt * v_[i];
      }
      finite = finite && finite3(v_[i]);
    }
    return finite;
  };
  kick(0.5 * dt, true);
  const double t0 = time_;
  time_ = t0 + dt;
  try {
    refreshForces("step " + std::to_string(k) + ", t = " + std::to_string(time_) + " s");
  } catch (...) {
    time_ = t0;
    throw;
  }
  if (!kick(0.5 * dt, false)) {
    for (std::size_t i = 0; i < n; ++i)
      if (!finite3(v_[i])) {
        std::ostringstream s;
        s << "velocity of particle " << i << " became non-finite at step " << k;
        throw TopoError("SoftBodySimulator::step", s.str(), "reduce the time step or check the material and loads");
      }
  }
  steps_ = k;
}

void SoftBodySimulator::advance(double duration, double safety) {
  if (!std::isfinite(duration) || duration < 0.0 || !(safety > 0.0) || safety > 1.0)
    throw TopoError("SoftBodySimulator::advance", "duration must be >= 0 and safety in (0, 1]",
                    "e.g. advance(0.1, 0.5)");
  if (duration == 0.0) return;
  checkStepBudget("soft-body simulation (advance)", safety * dt_stable_, duration, static_cast<double>(size()),
                  "a coarser particle spacing, a softer material or a shorter duration (the stable step is " +
                      std::to_string(dt_stable_) + " s)");
  const long n = static_cast<long>(std::ceil(duration / (safety * dt_stable_)));
  const double dt = duration / static_cast<double>(n);
  for (long s = 0; s < n; ++s) step(dt);
}

double SoftBodySimulator::kineticEnergy() const {
  double e = 0.0;
  for (std::size_t i = 0; i < size(); ++i) e += 0.5 * m_[i] * v_[i].squaredNorm();
  return e;
}

double SoftBodySimulator::gravitationalEnergy() const {
  double e = 0.0;
  for (std::size_t i = 0; i < size(); ++i) e -= m_[i] * opt_.gravity.dot(x_[i]);
  return e;
}

double SoftBodySimulator::residual() const {
  const auto& f = f_cons_;
  double rmax = 0.0, scale = 0.0;
  for (std::size_t i = 0; i < size(); ++i) {
    scale = std::max(scale, m_[i] * opt_.gravity.norm());
    if (clamped_[i]) continue;
    scale = std::max(scale, f[i].norm());
    rmax = std::max(rmax, (f[i] + m_[i] * opt_.gravity).norm());
  }
  return scale > 0.0 ? rmax / scale : 0.0;
}

RelaxResult SoftBodySimulator::relaxToEquilibrium(double tolerance, int max_steps) {
  if (!(tolerance > 0.0) || max_steps <= 0)
    throw TopoError("SoftBodySimulator::relaxToEquilibrium", "tolerance must be > 0 and max_steps > 0",
                    "e.g. relaxToEquilibrium(1e-6, 200000)");
  // FIRE (Bitzek et al. 2006) with the FIRE 2.0 half-step backtrack on uphill motion.
  const double dt_max = dt_stable_, dt_min = 0.02 * dt_stable_;
  const double alpha0 = 0.1, f_inc = 1.1, f_dec = 0.5, f_alpha = 0.99;
  const int n_min = 5;
  double dt = 0.5 * dt_max, alpha = alpha0;
  int n_pos = 0;
  const std::size_t n = size();
  const Eigen::Vector3d g = opt_.gravity;
  std::vector<Eigen::Vector3d> F(n);
  for (auto& v : v_) v.setZero();
  RelaxResult res;
  for (int it = 0; it <= max_steps; ++it) {
    pollStop(opt_.should_stop);
    res.residual = residual();
    res.iterations = it;
    if (res.residual <= tolerance) {
      res.converged = true;
      break;
    }
    if (it == max_steps) break;
    const auto& f = f_cons_;
    double P = 0.0, vv = 0.0, ff = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      F[i] = clamped_[i] ? Eigen::Vector3d::Zero() : Eigen::Vector3d(f[i] + m_[i] * g);
      P += F[i].dot(v_[i]);
      vv += v_[i].squaredNorm();
      ff += F[i].squaredNorm();
    }
    if (P > 0.0) {
      const double mix = ff > 0.0 ? alpha * std::sqrt(vv / ff) : 0.0;
      for (std::size_t i = 0; i < n; ++i) v_[i] = (1.0 - alpha) * v_[i] + mix * F[i];
      if (++n_pos > n_min) {
        dt = std::min(dt * f_inc, dt_max);
        alpha *= f_alpha;
      }
    } else {
      for (std::size_t i = 0; i < n; ++i) {
        x_[i] -= 0.5 * dt * v_[i];
        v_[i].setZero();
      }
      dt = std::max(dt * f_dec, dt_min);
      alpha = alpha0;
      n_pos = 0;
    }
    for (std::size_t i = 0; i < n; ++i) {
      if (clamped_[i]) continue;
      v_[i] += dt * F[i] / m_[i];
      x_[i] += dt * v_[i];
    }
    refreshForces("relaxToEquilibrium iteration " + std::to_string(it + 1));
  }
  for (auto& v : v_) v.setZero();
  res.x = x_;
  if (!res.converged) {
    std::ostringstream s;
    s << "did not converge: residual " << res.residual << " > tolerance " << tolerance << " after " << max_steps
      << " iterations";
    throw TopoError("SoftBodySimulator::relaxToEquilibrium", s.str(),
                    "raise max_steps or the tolerance, or check that the body is clamped (an unsupported body "
                    "under gravity has no equilibrium)");
  }
  return res;
}

}  // namespace topo_gaussian
