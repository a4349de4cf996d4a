// Soft-body simulator; see soft_body.h for the model and the integrator.
#include "topo_gaussian/physics/soft_body.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <utility>

#include "topo_gaussian/physics/error.h"

namespace topo_gaussian {

namespace {

bool finite3(const Eigen::Vector3d& v) { return std::isfinite(v.x()) && std::isfinite(v.y()) && std::isfinite(v.z()); }

}  // namespace

SoftBodySimulator::SoftBodySimulator(CorotatedSph sph, const SoftBodyOptions& options)
    : sph_(std::move(sph)), opt_(options) {
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
  if (!(c_max_ > 0.0) || !std::isfinite(c_max_))
    throw TopoError("SoftBodySimulator", "the wave speed sqrt((lambda + 2 mu)/rho) is not positive and finite",
                    "check the material parameters and the density");
  dt_stable_ = opt_.cfl * dx_ / c_max_;
  refreshForces("initial state");
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

void SoftBodySimulator::refreshForces(const std::string& where) {
  try {
    sph_.update(x_);
  } catch (const TopoError& e) {
    throw TopoError("SoftBodySimulator (" + where + ")", e.what(),
                    "reduce the time step (e.g. 0.5 x stableTimeStep()), add damping, or check the loads");
  }
}

void SoftBodySimulator::step(double dt) {
  if (!std::isfinite(dt) || dt <= 0.0) {
    std::ostringstream s;
    s << "time step dt = " << dt << " s is not positive";
    throw TopoError("SoftBodySimulator::step", s.str(), "use 0 < dt <= stableTimeStep()");
  }
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
  auto kick = [&](double h) {
    const auto& f = sph_.forces();
    for (std::size_t i = 0; i < n; ++i) {
      if (clamped_[i]) continue;
      v_[i] += h * (f[i] / m_[i] + g - c * v_[i]);
    }
  };
  kick(0.5 * dt);
  for (std::size_t i = 0; i < n; ++i)
    if (!clamped_[i]) x_[i] += dt * v_[i];
  refreshForces("step " + std::to_string(k) + ", t = " + std::to_string(time_ + dt) + " s");
  kick(0.5 * dt);
  for (std::size_t i = 0; i < n; ++i)
    if (!finite3(v_[i])) {
      std::ostringstream s;
      s << "velocity of particle " << i << " became non-finite at step " << k;
      throw TopoError("SoftBodySimulator::step", s.str(), "reduce the time step or check the material and loads");
    }
  steps_ = k;
  time_ += dt;
}

void SoftBodySimulator::advance(double duration, double safety) {
  if (!std::isfinite(duration) || duration < 0.0 || !(safety > 0.0) || safety > 1.0)
    throw TopoError("SoftBodySimulator::advance", "duration must be >= 0 and safety in (0, 1]",
                    "e.g. advance(0.1, 0.5)");
  if (duration == 0.0) return;
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
  const auto& f = sph_.forces();
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
    res.residual = residual();
    res.iterations = it;
    if (res.residual <= tolerance) {
      res.converged = true;
      break;
    }
    if (it == max_steps) break;
    const auto& f = sph_.forces();
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
