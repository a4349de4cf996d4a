// MLS embedding of contact samples in the particles; see contact_embedding.h.
#include "topo_gaussian/physics/contact_embedding.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <sstream>
#include <tuple>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/physics/neighbor_list.h"

namespace topo_gaussian {

namespace {

bool finite3(const Eigen::Vector3d& v) { return v.allFinite(); }

std::string point(const Eigen::Vector3d& p) {
  std::ostringstream s;
  s << "(" << p.x() << ", " << p.y() << ", " << p.z() << ") m";
  return s.str();
}

/// Smallest over largest eigenvalue of M below which a linear fit is taken as ill-posed (fewer than
/// 4 particles, or all of them on one plane or line).
constexpr double kMinConditioning = 1e-6;

}  // namespace

ContactEmbedding::ContactEmbedding(const std::vector<Eigen::Vector3d>& X, const std::vector<Eigen::Vector3d>& Y,
                                   const std::vector<double>& weights, double h, const ContactEmbeddingOptions& opt)
    : Y_(Y), w_(weights), n_particles_(X.size()) {
  const std::string what = "contact embedding";
  if (X.empty()) throw TopoError(what, "the body has no particles", "embed the samples in a non-empty volume");
  if (weights.size() != Y.size())
    throw TopoError(what, std::to_string(weights.size()) + " weights for " + std::to_string(Y.size()) + " samples",
                    "give one weight per contact sample");
  if (!(h > 0.0) || !std::isfinite(h))
    throw TopoError(what, "the particle spacing " + std::to_string(h) + " is not a positive length",
                    "pass the lattice spacing of the volume [m]");
  if (!(opt.radius_spacings > 1.0) || !(opt.max_radius_spacings >= opt.radius_spacings) ||
      !std::isfinite(opt.max_radius_spacings))
    throw TopoError(what, "the support radius must be > 1 spacing and max_radius_spacings >= radius_spacings",
                    "use e.g. radius_spacings 2, max_radius_spacings 3.5");
  for (const auto& p : X)
    if (!finite3(p)) throw TopoError(what, "a particle position is not finite", "pass finite rest positions");
  for (std::size_t k = 0; k < Y.size(); ++k) {
    if (!finite3(Y[k]))
      throw TopoError(what, "contact sample " + std::to_string(k) + " is not finite", "pass finite sample positions");
    if (!(weights[k] >= 0.0) || !std::isfinite(weights[k]))
      throw TopoError(what, "contact sample " + std::to_string(k) + " has weight " + std::to_string(weights[k]),
                      "give finite weights >= 0 (area over the particle's cross-section h^2)");
  }
  const std::size_t K = Y.size();
  const double r0 = opt.radius_spacings * h;
  const SpatialGrid grid(X, r0);
  std::unique_ptr<SpatialGrid> wide;  // for the few samples that need a larger support
  std::vector<std::vector<int>> rows_i(K);
  std::vector<std::vector<double>> rows_phi(K);
  std::vector<char> failed(K, 0);

  // One sample's weights at support radius r from a grid whose cells are >= r.
  auto fit = [&](std::size_t k, double r, const SpatialGrid& g, std::vector<int>* ids, std::vector<double>* phi) {
    ids->clear();
    phi->clear();
    std::vector<double> wq;
    std::vector<Eigen::Vector4d> ps;
    const Eigen::Vector3d& y = Y[k];
    Eigen::Matrix4d M = Eigen::Matrix4d::Zero();
    g.query(y, [&](int j, const Eigen::Vector3d& xj) {
      const Eigen::Vector3d d = xj - y;
      const double q2 = d.squaredNorm() / (r * r);
      if (q2 >= 1.0) return;
      const double w = (1.0 - q2) * (1.0 - q2) * (1.0 - q2);
      Eigen::Vector4d p;
      p << 1.0, d / h;
      M.noalias() += w * p * p.transpose();
      ids->push_back(j);
      wq.push_back(w);
      ps.push_back(p);
    });
    if (ids->size() < 4) return false;
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d> es(M, Eigen::EigenvaluesOnly);
    const Eigen::Vector4d ev = es.eigenvalues();
    if (!(ev(0) > kMinConditioning * ev(3))) return false;
    const Eigen::Vector4d a = M.ldlt().solve(Eigen::Vector4d::UnitX());
    phi->resize(ids->size());
    for (std::size_t q = 0; q < ids->size(); ++q) (*phi)[q] = wq[q] * ps[q].dot(a);
    return true;
  };

#pragma omp parallel for schedule(dynamic, 64)
  for (long long kk = 0; kk < static_cast<long long>(K); ++kk) {
    const std::size_t k = static_cast<std::size_t>(kk);
    if (!fit(k, r0, grid, &rows_i[k], &rows_phi[k])) failed[k] = 1;
  }
  for (std::size_t k = 0; k < K; ++k) {
    if (!failed[k]) continue;
    if (!wide) wide = std::make_unique<SpatialGrid>(X, opt.max_radius_spacings * h);
    bool ok = false;
    for (double r = 1.25 * r0; !ok; r = std::min(1.25 * r, opt.max_radius_spacings * h)) {
      ok = fit(k, r, *wide, &rows_i[k], &rows_phi[k]);
      if (r >= opt.max_radius_spacings * h) break;
    }
    if (!ok) {
      double dmin = 1e300;
      for (const auto& p : X) dmin = std::min(dmin, (p - Y[k]).norm());
      std::ostringstream s;
      s << "contact sample " << k << " at " << point(Y[k]) << " has no well-posed linear fit (4 particles not on one "
        << "plane) within " << opt.max_radius_spacings << " spacings (" << opt.max_radius_spacings * h
        << " m); its nearest particle is " << dmin << " m away";
      throw TopoError(what, s.str(),
                      "give contact samples on this volume's surface, in the particles' frame and units (e.g. fill "
                      "the surface again with `topo fill`), or a finer particle spacing for thin parts");
    }
  }
  off_.assign(1, 0);
  off_.reserve(K + 1);
  for (std::size_t k = 0; k < K; ++k) {
    idx_.insert(idx_.end(), rows_i[k].begin(), rows_i[k].end());
    phi_.insert(phi_.end(), rows_phi[k].begin(), rows_phi[k].end());
    off_.push_back(static_cast<int>(idx_.size()));
  }
  // Anchors (nearest particle in the support) and the band of nearSamples.
  anchor_.resize(K);
  double e_max = 0.0;
  for (std::size_t k = 0; k < K; ++k) {
    double best = 1e300;
    for (int q = off_[k]; q < off_[k + 1]; ++q) {
      const double d = (X[idx_[q]] - Y[k]).squaredNorm();
      if (d < best) {
        best = d;
        anchor_[k] = idx_[q];
      }
    }
    e_max = std::max(e_max, std::sqrt(best));
  }
  band_ = 3.0 * std::max(e_max, h);
}

void ContactEmbedding::gather(const std::vector<Eigen::Vector3d>& x, std::vector<Eigen::Vector3d>* y) const {
  if (x.size() != n_particles_)
    throw TopoError("contact embedding",
                    std::to_string(x.size()) + " particles for an embedding in " + std::to_string(n_particles_),
                    "pass the state of the body the samples were embedded in");
  y->resize(size());
#pragma omp parallel for schedule(static) if (size() > 4096)
  for (long long kk = 0; kk < static_cast<long long>(size()); ++kk) {
    Eigen::Vector3d s = Eigen::Vector3d::Zero();
    for (int q = off_[kk]; q < off_[kk + 1]; ++q) s += phi_[q] * x[idx_[q]];
    (*y)[kk] = s;
  }
}

void mergeContactSamples(double cell, std::vector<Eigen::Vector3d>* X, std::vector<Eigen::Vector3d>* normal,
                         std::vector<double>* area) {
  if (!(cell > 0.0) || !std::isfinite(cell))
    throw TopoError("contact sample merge", "the cell " + std::to_string(cell) + " is not a positive length",
                    "pass a positive cell edge [m], e.g. half the particle spacing");
  if (normal->size() != X->size() || area->size() != X->size())
    throw TopoError("contact sample merge", "positions, normals and areas differ in number",
                    "give one normal and one area per sample");
  struct Acc {
    Eigen::Vector3d m = Eigen::Vector3d::Zero(), n = Eigen::Vector3d::Zero();
    double a = 0.0;
    std::vector<std::size_t> members;
  };
  std::map<std::tuple<long, long, long, int>, Acc> cells;
  for (std::size_t k = 0; k < X->size(); ++k) {
    const Eigen::Vector3d& p = (*X)[k];
    const Eigen::Vector3d& n = (*normal)[k];
    Eigen::Index axis;
    n.cwiseAbs().maxCoeff(&axis);
    const int dir = 2 * static_cast<int>(axis) + (n(axis) < 0.0 ? 1 : 0);
    const auto key = std::make_tuple(std::lround(std::floor(p.x() / cell)), std::lround(std::floor(p.y() / cell)),
                                     std::lround(std::floor(p.z() / cell)), dir);
    Acc& c = cells[key];
    const double a = (*area)[k];
    c.m += a * p;
    c.n += a * n;
    c.a += a;
    c.members.push_back(k);
  }
  std::vector<Eigen::Vector3d> Xo, No;
  std::vector<double> Ao;
  for (const auto& [key, c] : cells) {
    if (!(c.a > 0.0)) continue;
    // The member nearest to the area-weighted mean: on the surface (the mean of a curved patch is not).
    const Eigen::Vector3d mean = c.m / c.a;
    std::size_t best = c.members[0];
    for (std::size_t k : c.members)
      if (((*X)[k] - mean).squaredNorm() < ((*X)[best] - mean).squaredNorm()) best = k;
    Xo.push_back((*X)[best]);
    No.push_back(c.n.norm() > 0.0 ? Eigen::Vector3d(c.n.normalized()) : (*normal)[best]);
    Ao.push_back(c.a);
  }
  *X = std::move(Xo);
  *normal = std::move(No);
  *area = std::move(Ao);
}

}  // namespace topo_gaussian
