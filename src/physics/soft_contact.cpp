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
  validate();
}

SoftContact::SoftContact(std::vector<ContactObstacle> obstacles, const SoftContactOptions& options,
                         std::shared_ptr<const ContactEmbedding> embedding)
    : obstacles_(std::move(obstacles)), opt_(options), emb_(std::move(embedding)) {
  if (!emb_ || emb_->empty())
    throw TopoError("soft contact", "the contact embedding is empty",
                    "embed the volume's contact samples (ContactEmbedding), or pass a particle mask instead");
  validate();
}

void SoftContact::validate() const {
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

std::vector<Eigen::Vector3d> SoftContact::contactPositions(const std::vector<Eigen::Vector3d>& x) const {
  std::vector<Eigen::Vector3d> p;
  if (emb_) {
    emb_->gather(x, &p);
    return p;
  }
  for (std::size_t i = 0; i < x.size(); ++i)
    if (candidate(i)) p.push_back(x[i]);
  return p;
}

double SoftContact::energy(const std::vector<Eigen::Vector3d>& x) const {
  std::vector<Eigen::Vector3d> y;
  if (emb_) emb_->gather(x, &y);
  const std::vector<Eigen::Vector3d>& p = emb_ ? y : x;
  double e = 0.0;
  Eigen::Vector3d n;
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (!candidate(i)) continue;
    const double k = stiffnessOf(i);
    for (const auto& o : obstacles_) {
      const double g = o.distance(p[i], &n) - opt_.margin;
      if (g < 0.0) e += 0.5 * k * g * g;
    }
  }
  return e;
}

// Calls f(i, n, fn, k_i) for every active contact of a contact point (fn = k_i · penetration > 0).
template <class F>
void SoftContact::forEachContact(const std::vector<Eigen::Vector3d>& p, F&& f) const {
#pragma omp parallel for schedule(static)
  for (long long ii = 0; ii < static_cast<long long>(p.size()); ++ii) {
    const std::size_t i = static_cast<std::size_t>(ii);
    if (!candidate(i)) continue;
    const double k = stiffnessOf(i);
    Eigen::Vector3d n;
    for (const auto& o : obstacles_) {
      const double g = o.distance(p[i], &n) - opt_.margin;
      if (g < 0.0) f(i, n, -k * g, k);
    }
  }
}

void SoftContact::addNormalForces(const std::vector<Eigen::Vector3d>& x, std::vector<Eigen::Vector3d>* f) const {
  if (!emb_) {
    forEachContact(x, [&](std::size_t i, const Eigen::Vector3d& n, double fn, double) { (*f)[i] += fn * n; });
    return;
  }
  std::vector<Eigen::Vector3d> y;
  emb_->gather(x, &y);
  std::vector<Eigen::Vector3d> fk(y.size(), Eigen::Vector3d::Zero());
  forEachContact(y, [&](std::size_t k, const Eigen::Vector3d& n, double fn, double) { fk[k] += fn * n; });
  emb_->scatter(fk, f);
}

void SoftContact::addFrictionForces(const std::vector<Eigen::Vector3d>& x, const std::vector<Eigen::Vector3d>& v,
                                    std::vector<Eigen::Vector3d>* f) const {
  const double mu = opt_.friction, eps2 = opt_.slip_velocity * opt_.slip_velocity;
  if (mu <= 0.0) return;
  auto friction = [&](const Eigen::Vector3d& n, double fn, const Eigen::Vector3d& vi) {
    const Eigen::Vector3d vt = vi - n * n.dot(vi);
    return Eigen::Vector3d(-(mu * fn / std::sqrt(vt.squaredNorm() + eps2)) * vt);
  };
  if (!emb_) {
    forEachContact(
        x, [&](std::size_t i, const Eigen::Vector3d& n, double fn, double) { (*f)[i] += friction(n, fn, v[i]); });
    return;
  }
  std::vector<Eigen::Vector3d> y, vk;
  emb_->gather(x, &y);
  emb_->gather(v, &vk);
  std::vector<Eigen::Vector3d> fk(y.size(), Eigen::Vector3d::Zero());
  forEachContact(y,
                 [&](std::size_t k, const Eigen::Vector3d& n, double fn, double) { fk[k] += friction(n, fn, vk[k]); });
  emb_->scatter(fk, f);
}

void SoftContact::addHessianProduct(const std::vector<Eigen::Vector3d>& x, const std::vector<Eigen::Vector3d>& dx,
                                    std::vector<Eigen::Vector3d>* out) const {
  if (!emb_) {
    forEachContact(
        x, [&](std::size_t i, const Eigen::Vector3d& n, double, double k) { (*out)[i] += k * n * n.dot(dx[i]); });
    return;
  }
  std::vector<Eigen::Vector3d> y, dy;
  emb_->gather(x, &y);
  emb_->gather(dx, &dy);
  std::vector<Eigen::Vector3d> hk(y.size(), Eigen::Vector3d::Zero());
  forEachContact(y, [&](std::size_t q, const Eigen::Vector3d& n, double, double k) { hk[q] += k * n * n.dot(dy[q]); });
  emb_->scatter(hk, out);
}

void SoftContact::addHessianDiagonal(const std::vector<Eigen::Vector3d>& x, std::vector<Eigen::Vector3d>* diag) const {
  if (!emb_) {
    forEachContact(
        x, [&](std::size_t i, const Eigen::Vector3d& n, double, double k) { (*diag)[i] += k * n.cwiseProduct(n); });
    return;
  }
  std::vector<Eigen::Vector3d> y;
  emb_->gather(x, &y);
  std::vector<Eigen::Vector3d> dk(y.size(), Eigen::Vector3d::Zero());
  forEachContact(y, [&](std::size_t q, const Eigen::Vector3d& n, double, double k) { dk[q] += k * n.cwiseProduct(n); });
  emb_->scatterSquared(dk, diag);
}

void SoftContact::frictionAdjoint(const std::vector<Eigen::Vector3d>& x, const std::vector<Eigen::Vector3d>& v,
                                  const std::vector<Eigen::Vector3d>& a, std::vector<Eigen::Vector3d>* x_bar,
                                  std::vector<Eigen::Vector3d>* v_bar) const {
  const double mu = opt_.friction, eps2 = opt_.slip_velocity * opt_.slip_velocity;
  if (mu <= 0.0) return;
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  // One contact: f = −μ fn t(v_t); ∂f/∂v = −μ fn (I/s − vt vtᵀ/s³) T; ∂f/∂x = −μ t (∂fn/∂x)ᵀ = −μ t (−k n)ᵀ.
  auto adjoint = [&](const Eigen::Vector3d& n, double fn, double k, const Eigen::Vector3d& vi,
                     const Eigen::Vector3d& ai, Eigen::Vector3d* xb, Eigen::Vector3d* vb) {
    const Eigen::Matrix3d T = I - n * n.transpose();
    const Eigen::Vector3d vt = T * vi;
    const double s = std::sqrt(vt.squaredNorm() + eps2);
    const Eigen::Vector3d t = vt / s;
    const Eigen::Matrix3d dfdv = -mu * fn * ((I / s - vt * vt.transpose() / (s * s * s)) * T);
    *vb += dfdv.transpose() * ai;
    *xb += (mu * k * t.dot(ai)) * n;
  };
  if (!emb_) {
    forEachContact(x, [&](std::size_t i, const Eigen::Vector3d& n, double fn, double k) {
      adjoint(n, fn, k, v[i], a[i], &(*x_bar)[i], &(*v_bar)[i]);
    });
    return;
  }
  // Through the embedding: a_k = Σ_i φ_ki a_i; ȳ_k, v̄_k as above; x̄_i += Σ_k φ_ki ȳ_k (same for v̄).
  std::vector<Eigen::Vector3d> y, vk, ak;
  emb_->gather(x, &y);
  emb_->gather(v, &vk);
  emb_->gather(a, &ak);
  std::vector<Eigen::Vector3d> yb(y.size(), Eigen::Vector3d::Zero()), vkb(y.size(), Eigen::Vector3d::Zero());
  forEachContact(y, [&](std::size_t q, const Eigen::Vector3d& n, double fn, double k) {
    adjoint(n, fn, k, vk[q], ak[q], &yb[q], &vkb[q]);
  });
  emb_->scatter(yb, x_bar);
  emb_->scatter(vkb, v_bar);
}

std::size_t SoftContact::activeCount(const std::vector<Eigen::Vector3d>& x) const {
  std::vector<Eigen::Vector3d> y;
  if (emb_) emb_->gather(x, &y);
  const std::vector<Eigen::Vector3d>& p = emb_ ? y : x;
  std::size_t c = 0;
  Eigen::Vector3d n;
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (!candidate(i)) continue;
    for (const auto& o : obstacles_)
      if (o.distance(p[i], &n) - opt_.margin < 0.0) {
        ++c;
        break;
      }
  }
  return c;
}

}  // namespace topo_gaussian
