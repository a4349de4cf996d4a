// Penalty contact for soft bodies; see soft_contact.h.
#include "topo_gaussian/physics/soft_contact.h"

#include <Eigen/Dense>
#include <cmath>

#include "topo_gaussian/common/error.h"

namespace topo_gaussian {

ContactObstacle ContactObstacle::ground(double height) {
  ContactObstacle o;
  o.kind = Kind::HalfSpace;
  o.normal = Eigen::Vector3d::UnitZ();
  o.offset = height;
  return o;
}

ContactObstacle ContactObstacle::box(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  ContactObstacle o;
  o.kind = Kind::Box;
  o.lo = lo;
  o.hi = hi;
  return o;
}

double ContactObstacle::distance(const Eigen::Vector3d& x, Eigen::Vector3d* n) const {
  if (kind == Kind::HalfSpace) {
    *n = normal;
    return normal.dot(x) - offset;
  }
  // Box: inside → minus the distance to the nearest face (its normal); outside → Euclidean.
  const Eigen::Vector3d c = 0.5 * (lo + hi), half = 0.5 * (hi - lo);
  const Eigen::Vector3d d = (x - c).cwiseAbs() - half;
  if (d.maxCoeff() <= 0.0) {
    Eigen::Index a;
    const double m = d.maxCoeff(&a);
    n->setZero();
    (*n)(a) = x(a) >= c(a) ? 1.0 : -1.0;
    return m;
  }
  const Eigen::Vector3d outside = d.cwiseMax(0.0);
  const double dist = outside.norm();
  Eigen::Vector3d g;
  for (int k = 0; k < 3; ++k) g(k) = (x(k) >= c(k) ? 1.0 : -1.0) * outside(k);
  *n = g / dist;
  return dist;
}

SoftContact::SoftContact(std::vector<ContactObstacle> obstacles, const SoftContactOptions& options,
                         std::vector<std::uint8_t> mask)
    : obstacles_(std::move(obstacles)), opt_(options), mask_(std::move(mask)) {
  for (const auto& o : obstacles_) {
    if (o.kind == ContactObstacle::Kind::HalfSpace && std::abs(o.normal.norm() - 1.0) > 1e-9)
      throw TopoError("soft contact", "a half-space normal is not a unit vector", "normalise the normal");
    if (o.kind == ContactObstacle::Kind::Box && !(o.hi.array() > o.lo.array()).all())
      throw TopoError("soft contact", "a box obstacle has hi <= lo", "give lo < hi in every axis");
  }
  if (!std::isfinite(opt_.friction) || opt_.friction < 0.0 || !(opt_.slip_velocity > 0.0) ||
      !std::isfinite(opt_.margin))
    throw TopoError("soft contact", "friction must be >= 0, slip_velocity > 0 and the margin finite",
                    "e.g. friction 0.5, slip_velocity 1e-3 m/s");
}

double SoftContact::energy(const std::vector<Eigen::Vector3d>& x) const {
  double e = 0.0;
  Eigen::Vector3d n;
  for (std::size_t i = 0; i < x.size(); ++i) {
    if (!candidate(i)) continue;
    for (const auto& o : obstacles_) {
      const double g = o.distance(x[i], &n) - opt_.margin;
      if (g < 0.0) e += 0.5 * opt_.stiffness * g * g;
    }
  }
  return e;
}

// Calls f(i, n, fn) for every active contact of a candidate particle (fn = k · penetration > 0).
template <class F>
void SoftContact::forEachContact(const std::vector<Eigen::Vector3d>& x, F&& f) const {
#pragma omp parallel for schedule(static)
  for (long long ii = 0; ii < static_cast<long long>(x.size()); ++ii) {
    const std::size_t i = static_cast<std::size_t>(ii);
    if (!candidate(i)) continue;
    Eigen::Vector3d n;
    for (const auto& o : obstacles_) {
      const double g = o.distance(x[i], &n) - opt_.margin;
      if (g < 0.0) f(i, n, -opt_.stiffness * g);
    }
  }
}

void SoftContact::addNormalForces(const std::vector<Eigen::Vector3d>& x, std::vector<Eigen::Vector3d>* f) const {
  forEachContact(x, [&](std::size_t i, const Eigen::Vector3d& n, double fn) { (*f)[i] += fn * n; });
}

void SoftContact::addFrictionForces(const std::vector<Eigen::Vector3d>& x, const std::vector<Eigen::Vector3d>& v,
                                    std::vector<Eigen::Vector3d>* f) const {
  const double mu = opt_.friction, eps2 = opt_.slip_velocity * opt_.slip_velocity;
  if (mu <= 0.0) return;
  forEachContact(x, [&](std::size_t i, const Eigen::Vector3d& n, double fn) {
    const Eigen::Vector3d vt = v[i] - n * n.dot(v[i]);
    (*f)[i] -= (mu * fn / std::sqrt(vt.squaredNorm() + eps2)) * vt;
  });
}

void SoftContact::addHessianProduct(const std::vector<Eigen::Vector3d>& x, const std::vector<Eigen::Vector3d>& dx,
                                    std::vector<Eigen::Vector3d>* out) const {
  forEachContact(
      x, [&](std::size_t i, const Eigen::Vector3d& n, double) { (*out)[i] += opt_.stiffness * n * n.dot(dx[i]); });
}

void SoftContact::addHessianDiagonal(const std::vector<Eigen::Vector3d>& x, std::vector<Eigen::Vector3d>* diag) const {
  forEachContact(
      x, [&](std::size_t i, const Eigen::Vector3d& n, double) { (*diag)[i] += opt_.stiffness * n.cwiseProduct(n); });
}

void SoftContact::frictionAdjoint(const std::vector<Eigen::Vector3d>& x, const std::vector<Eigen::Vector3d>& v,
                                  const std::vector<Eigen::Vector3d>& a, std::vector<Eigen::Vector3d>* x_bar,
                                  std::vector<Eigen::Vector3d>* v_bar) const {
  const double k = opt_.stiffness, mu = opt_.friction, eps2 = opt_.slip_velocity * opt_.slip_velocity;
  if (mu <= 0.0) return;
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  forEachContact(x, [&](std::size_t i, const Eigen::Vector3d& n, double fn) {
    const Eigen::Matrix3d T = I - n * n.transpose();
    const Eigen::Vector3d vt = T * v[i];
    const double s = std::sqrt(vt.squaredNorm() + eps2);
    const Eigen::Vector3d t = vt / s;
    // f = −μ fn t(v_t); ∂f/∂v = −μ fn (I/s − vt vtᵀ/s³) T; ∂f/∂x = −μ t (∂fn/∂x)ᵀ = −μ t (−k n)ᵀ.
    const Eigen::Matrix3d dfdv = -mu * fn * ((I / s - vt * vt.transpose() / (s * s * s)) * T);
    (*v_bar)[i] += dfdv.transpose() * a[i];
    (*x_bar)[i] += (mu * k * t.dot(a[i])) * n;
  });
}

std::size_t SoftContact::activeCount(const std::vector<Eigen::Vector3d>& x) const {
  std::size_t c = 0;
  Eigen::Vector3d n;
  for (std::size_t i = 0; i < x.size(); ++i) {
    if (!candidate(i)) continue;
    for (const auto& o : obstacles_)
      if (o.distance(x[i], &n) - opt_.margin < 0.0) {
        ++c;
        break;
      }
  }
  return c;
}

}  // namespace topo_gaussian
