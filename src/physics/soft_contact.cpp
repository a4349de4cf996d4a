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
  double e = 0.0;
  if (emb_) {
    forEachSampleContact(x, [&](std::size_t, const Eigen::Vector3d&, double fn, double k) {
      if (k > 0.0) e += 0.5 * fn * fn / k;
    });
    return e;
  }
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

// Calls f(k, n, fn, k_k) for every active contact of an embedded sample (fn = k ω_k · penetration),
// in sample order, gathering only the samples whose anchor particle is within nearBand() of an
// obstacle (contact_embedding.h).
template <class F>
void SoftContact::forEachSampleContact(const std::vector<Eigen::Vector3d>& x, F&& f) const {
  const ContactEmbedding& E = *emb_;
  if (x.size() != E.particleCount())
    throw TopoError(
        "soft contact",
        std::to_string(x.size()) + " particles for contact samples embedded in " + std::to_string(E.particleCount()),
        "pass the state of the body the samples were embedded in");
  const double band = E.nearBand();
  Eigen::Vector3d n;
  for (std::size_t k = 0; k < E.size(); ++k) {
    const Eigen::Vector3d& xa = x[E.anchor(k)];
    bool near = false;
    for (const auto& o : obstacles_)
      if (o.distance(xa, &n) - opt_.margin < band) {
        near = true;
        break;
      }
    if (!near) continue;
    const Eigen::Vector3d y = E.at(k, x);
    const double kk = opt_.stiffness * E.weights()[k];
    for (const auto& o : obstacles_) {
      const double g = o.distance(y, &n) - opt_.margin;
      if (g < 0.0) f(k, n, -kk * g, kk);
    }
  }
}

void SoftContact::addNormalForces(const std::vector<Eigen::Vector3d>& x, std::vector<Eigen::Vector3d>* f) const {
  if (emb_) {
    forEachSampleContact(
        x, [&](std::size_t k, const Eigen::Vector3d& n, double fn, double) { emb_->addAt(k, fn * n, f); });
    return;
  }
  forEachContact(x, [&](std::size_t i, const Eigen::Vector3d& n, double fn) { (*f)[i] += fn * n; });
}

void SoftContact::addFrictionForces(const std::vector<Eigen::Vector3d>& x, const std::vector<Eigen::Vector3d>& v,
                                    std::vector<Eigen::Vector3d>* f) const {
  const double mu = opt_.friction, eps2 = opt_.slip_velocity * opt_.slip_velocity;
  if (mu <= 0.0) return;
  if (emb_) {
    forEachSampleContact(x, [&](std::size_t k, const Eigen::Vector3d& n, double fn, double) {
      const Eigen::Vector3d vk = emb_->at(k, v);
      const Eigen::Vector3d vt = vk - n * n.dot(vk);
      emb_->addAt(k, -(mu * fn / std::sqrt(vt.squaredNorm() + eps2)) * vt, f);
    });
    return;
  }
  forEachContact(x, [&](std::size_t i, const Eigen::Vector3d& n, double fn) {
    const Eigen::Vector3d vt = v[i] - n * n.dot(v[i]);
    (*f)[i] -= (mu * fn / std::sqrt(vt.squaredNorm() + eps2)) * vt;
  });
}

void SoftContact::addHessianProduct(const std::vector<Eigen::Vector3d>& x, const std::vector<Eigen::Vector3d>& dx,
                                    std::vector<Eigen::Vector3d>* out) const {
  if (emb_) {
    forEachSampleContact(x, [&](std::size_t k, const Eigen::Vector3d& n, double, double kk) {
      emb_->addAt(k, kk * n * n.dot(emb_->at(k, dx)), out);
    });
    return;
  }
  forEachContact(
      x, [&](std::size_t i, const Eigen::Vector3d& n, double) { (*out)[i] += opt_.stiffness * n * n.dot(dx[i]); });
}

void SoftContact::addHessianDiagonal(const std::vector<Eigen::Vector3d>& x, std::vector<Eigen::Vector3d>* diag) const {
  if (emb_) {
    forEachSampleContact(x, [&](std::size_t k, const Eigen::Vector3d& n, double, double kk) {
      emb_->addSquaredAt(k, kk * n.cwiseProduct(n), diag);
    });
    return;
  }
  forEachContact(
      x, [&](std::size_t i, const Eigen::Vector3d& n, double) { (*diag)[i] += opt_.stiffness * n.cwiseProduct(n); });
}

void SoftContact::frictionAdjoint(const std::vector<Eigen::Vector3d>& x, const std::vector<Eigen::Vector3d>& v,
                                  const std::vector<Eigen::Vector3d>& a, std::vector<Eigen::Vector3d>* x_bar,
                                  std::vector<Eigen::Vector3d>* v_bar) const {
  const double mu = opt_.friction, eps2 = opt_.slip_velocity * opt_.slip_velocity;
  if (mu <= 0.0) return;
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  // One contact point: f = −μ fn t(v_t); ∂f/∂v = −μ fn (I/s − vt vtᵀ/s³) T; ∂f/∂x = −μ t (∂fn/∂x)ᵀ = −μ t (−k n)ᵀ.
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
  if (emb_) {
    // Through the embedding: a_k = Σ_i φ_ki a_i, v_k likewise; x̄_i += φ_ki ȳ_k, v̄_i += φ_ki v̄_k.
    forEachSampleContact(x, [&](std::size_t k, const Eigen::Vector3d& n, double fn, double kk) {
      Eigen::Vector3d yb = Eigen::Vector3d::Zero(), vkb = Eigen::Vector3d::Zero();
      adjoint(n, fn, kk, emb_->at(k, v), emb_->at(k, a), &yb, &vkb);
      emb_->addAt(k, yb, x_bar);
      emb_->addAt(k, vkb, v_bar);
    });
    return;
  }
  forEachContact(x, [&](std::size_t i, const Eigen::Vector3d& n, double fn) {
    adjoint(n, fn, opt_.stiffness, v[i], a[i], &(*x_bar)[i], &(*v_bar)[i]);
  });
}

std::size_t SoftContact::activeCount(const std::vector<Eigen::Vector3d>& x) const {
  std::size_t c = 0;
  if (emb_) {
    long last = -1;
    forEachSampleContact(x, [&](std::size_t k, const Eigen::Vector3d&, double, double) {
      if (static_cast<long>(k) != last) ++c;
      last = static_cast<long>(k);
    });
    return c;
  }
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
