// Corotated SPH elasticity; see corotated_sph.h for the model.
//
// Derivation used by the force code (R_i held fixed, the usual corotated SPH treatment of Becker
// et al. 2009: the rotation is treated as a constant of the step, so f = −∂E/∂x|_R):
//
//   F̃_i = Σ_j V_j x_ji ĝ_ijᵀ, and, because the correction makes Σ_j V_j X_ji ĝ_ijᵀ = I,
//   F_i = I + Σ_j V_j (R_iᵀ x_ji − X_ji) ĝ_ijᵀ = R_iᵀ F̃_i          (paper's F, computed as R_iᵀF̃_i)
//   dE_i = V_i P_i : dF_i = Σ_j V_j dx_jiᵀ (V_i R_i P_i) ĝ_ij
//
// Hourglass term (independent of R): e_ij = F̃_i X_ji − x_ji, c_i = α μ_i V_i / h²,
//   E_hg,i = c_i Σ_j V_j W_ij |e_ij|²
//   dE_hg,i = Σ_j V_j dx_jiᵀ (c_i H_i) ĝ_ij − Σ_j q_ijᵀ dx_ji,
//   H_i = Σ_j 2 V_j W_ij e_ij X_jiᵀ,  q_ij = 2 c_i V_j W_ij e_ij.
// With M_i = V_i R_i P_i + c_i H_i the gradient at particle k is a gather over its own row
// (neighbourhoods are symmetric):
//   ∂E/∂x_k = Σ_{j∈N(k)} [ V_k M_j ĝ_jk − V_j M_k ĝ_kj + q_kj − q_jk ],
// so every particle writes only its own force: deterministic under OpenMP.
#include "topo_gaussian/physics/corotated_sph.h"

#include <Eigen/Dense>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <sstream>

#include "topo_gaussian/physics/error.h"
#include "topo_gaussian/physics/sph_kernel.h"

namespace topo_gaussian {

namespace {

std::string vecStr(const Eigen::Vector3d& v) {
  std::ostringstream s;
  s << "(" << v.x() << ", " << v.y() << ", " << v.z() << ")";
  return s.str();
}

bool finite3(const Eigen::Vector3d& v) { return std::isfinite(v.x()) && std::isfinite(v.y()) && std::isfinite(v.z()); }

/// Rotation factor of the polar decomposition A = R S, with the determinant fixed so that R is a
/// proper rotation (det R = +1) also for reflected / degenerate A.
Eigen::Matrix3d polarRotation(const Eigen::Matrix3d& A) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(A, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d U = svd.matrixU();
  const Eigen::Matrix3d& Vm = svd.matrixV();
  if ((U * Vm.transpose()).determinant() < 0.0) U.col(2) = -U.col(2);  // smallest singular value
  return U * Vm.transpose();
}

}  // namespace

LameParameters lameFromYoung(double E, double nu) {
  if (!std::isfinite(E) || !std::isfinite(nu) || E <= 0.0 || nu <= -1.0 || nu >= 0.5) {
    std::ostringstream s;
    s << "E = " << E << " Pa, nu = " << nu << " is not a valid isotropic material";
    throw TopoError("lameFromYoung", s.str(), "use E > 0 and a Poisson ratio in (-1, 0.5)");
  }
  LameParameters p;
  p.mu = E / (2.0 * (1.0 + nu));
  p.lambda = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
  return p;
}

double sphStrainEnergyDensity(SphEnergyModel model, const Eigen::Matrix3d& F, double mu, double lambda) {
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d eps =
      model == SphEnergyModel::StVK ? Eigen::Matrix3d(0.5 * (F.transpose() * F - I)) : Eigen::Matrix3d(0.5 * (F + F.transpose()) - I);
  const double tr = eps.trace();
  return mu * eps.squaredNorm() + 0.5 * lambda * tr * tr;
}

Eigen::Matrix3d sphFirstPiola(SphEnergyModel model, const Eigen::Matrix3d& F, double mu, double lambda) {
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  if (model == SphEnergyModel::StVK) {
    const Eigen::Matrix3d eps = 0.5 * (F.transpose() * F - I);
    return F * (2.0 * mu * eps + lambda * eps.trace() * I);
  }
  const Eigen::Matrix3d eps = 0.5 * (F + F.transpose()) - I;
  return 2.0 * mu * eps + lambda * eps.trace() * I;
}

// ------------------------------------------------------------------ construction

CorotatedSph::CorotatedSph(const std::vector<Eigen::Vector3d>& X, const std::vector<double>& V,
                           LameParameters material, const CorotatedSphOptions& options)
    : CorotatedSph(X, V, std::vector<double>(X.size(), material.mu), std::vector<double>(X.size(), material.lambda),
                   options) {}

CorotatedSph CorotatedSph::fromCloud(const VolumeCloud& cloud, LameParameters material, CorotatedSphOptions options) {
  cloud.validate("soft-body volume cloud");
  if (options.spacing <= 0.0) options.spacing = cloud.spacing;
  return CorotatedSph(cloud.X, cloud.V, material, options);
}

CorotatedSph::CorotatedSph(const std::vector<Eigen::Vector3d>& X, const std::vector<double>& V,
                           const std::vector<double>& mu, const std::vector<double>& lambda,
                           const CorotatedSphOptions& options)
    : opt_(options), X_(X), V_(V), mu_(mu), lambda_(lambda) {
  const std::size_t n = X.size();
  const std::string what = "corotated SPH";
  if (n == 0) throw TopoError(what, "no particles", "pass a non-empty volume cloud");
  if (V.size() != n || mu.size() != n || lambda.size() != n) {
    std::ostringstream s;
    s << "sizes disagree: " << n << " positions, " << V.size() << " volumes, " << mu.size() << " mu, "
      << lambda.size() << " lambda";
    throw TopoError(what, s.str(), "give one volume and one material per particle");
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (!finite3(X[i]) || !std::isfinite(V[i]) || V[i] <= 0.0 || !std::isfinite(mu[i]) || mu[i] <= 0.0 ||
        !std::isfinite(lambda[i])) {
      std::ostringstream s;
      s << "particle " << i << " has a non-finite or invalid value (X = " << vecStr(X[i]) << ", V = " << V[i]
        << ", mu = " << mu[i] << ", lambda = " << lambda[i] << ")";
      throw TopoError(what, s.str(), "positions and lambda must be finite, volumes and mu positive");
    }
  }
  if (!std::isfinite(opt_.density) || opt_.density <= 0.0)
    throw TopoError(what, "density " + std::to_string(opt_.density) + " is not positive", "use a density > 0 kg/m^3");
  if (!std::isfinite(opt_.hourglass_alpha) || opt_.hourglass_alpha < 0.0)
    throw TopoError(what, "hourglass_alpha must be finite and >= 0", "use e.g. 0.1");

  // Smoothing length.
  if (opt_.smoothing_length > 0.0) {
    h_ = opt_.smoothing_length;
  } else {
    double s = opt_.spacing;
    if (!(s > 0.0)) {
      double mean = 0.0;
      for (double v : V) mean += v;
      s = std::cbrt(mean / static_cast<double>(n));
    }
    h_ = opt_.smoothing_factor * s;
  }
  if (!std::isfinite(h_) || h_ <= 0.0)
    throw TopoError(what, "smoothing length " + std::to_string(h_) + " is not positive",
                    "set options.smoothing_length or options.spacing > 0");

  m_.resize(n);
  for (std::size_t i = 0; i < n; ++i) m_[i] = opt_.density * V_[i];

  // Fixed rest neighbourhoods: all j ≠ i with |X_ji| < 2h.
  nbr_ = buildNeighborList(X_, cubicSplineSupport(h_), false);
  for (std::size_t i = 0; i < n; ++i) {
    if (nbr_.count(i) == 0) {
      std::ostringstream s;
      s << "particle " << i << " at " << vecStr(X_[i]) << " has no neighbour within the kernel support 2h = "
        << 2.0 * h_ << " m";
      throw TopoError(what, s.str(),
                      "increase the smoothing length (options.smoothing_length / smoothing_factor) or remove the "
                      "isolated particle");
    }
  }
  const std::size_t nnz = nbr_.indices.size();
  rev_.assign(nnz, -1);
  W_.resize(nnz);
  gh_.resize(nnz);
  L_.resize(n);
  rho_.resize(n);

  if (opt_.gradient_order != 1 && opt_.gradient_order != 2)
    throw TopoError(what, "gradient_order " + std::to_string(opt_.gradient_order) + " is not supported",
                    "use 1 (corrected kernel gradient) or 2 (quadratic moving least squares)");
  std::vector<int> bad(n, 0), fallback(n, 0);
#pragma omp parallel for schedule(static)
  for (long long ii = 0; ii < static_cast<long long>(n); ++ii) {
    const std::size_t i = static_cast<std::size_t>(ii);
    double rho = m_[i] * cubicSplineW(0.0, h_);
    Eigen::Matrix3d K = Eigen::Matrix3d::Zero();
    for (int e = nbr_.offsets[i]; e < nbr_.offsets[i + 1]; ++e) {
      const int j = nbr_.indices[e];
      const Eigen::Vector3d Xji = X_[j] - X_[i];
      W_[e] = cubicSplineW(Xji, h_);
      rho += m_[j] * W_[e];
      gh_[e] = cubicSplineGradW(Xji, h_);
      K += V_[j] * gh_[e] * Xji.transpose();
      // Reverse entry: row j is sorted, binary search for i.
      const int* b = nbr_.begin(j);
      const int* en = nbr_.end(j);
      const int* p = std::lower_bound(b, en, static_cast<int>(i));
      rev_[e] = (p != en && *p == static_cast<int>(i)) ? static_cast<int>(p - nbr_.indices.data()) : -1;
    }
    rho_[i] = rho;
    // Kernel-gradient correction: L_i = (Σ_j V_j ∇W_ij ⊗ X_ji)⁻¹ makes Σ_j V_j (G X_ji) ĝ_ijᵀ = G for
    // every matrix G, i.e. the SPH gradient of any linear field is exact, also at the boundary
    // where the neighbourhood is truncated. Without it a uniform stretch would not give the exact
    // F (the patch test fails at the boundary, and even inside by the kernel's discretisation error).
    Eigen::JacobiSVD<Eigen::Matrix3d> svd(K);
    const Eigen::Vector3d sv = svd.singularValues();
    if (!(sv(2) > 1e-8 * sv(0))) {
      bad[i] = 1;
      continue;
    }
    L_[i] = K.inverse();
    for (int e = nbr_.offsets[i]; e < nbr_.offsets[i + 1]; ++e) gh_[e] = L_[i] * gh_[e];
    if (opt_.gradient_order >= 2 && !quadraticGradient(i)) fallback[i] = 1;
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (bad[i]) {
      std::ostringstream s;
      s << "particle " << i << " at " << vecStr(X_[i]) << " has a degenerate neighbourhood (" << nbr_.count(i)
        << " neighbours, all collinear or coplanar), so the kernel-gradient correction is singular";
      throw TopoError(what, s.str(), "increase the smoothing length so that every particle has neighbours in 3-D");
    }
  }
  linear_fallbacks_ = 0;
  for (std::size_t i = 0; i < n; ++i) linear_fallbacks_ += fallback[i];
  for (std::size_t e = 0; e < nnz; ++e)
    if (rev_[e] < 0) throw TopoError(what, "neighbour list is not symmetric (internal error)", "report this as a bug");

  // Rest state.
  R_.assign(n, Eigen::Matrix3d::Identity());
  F_.assign(n, Eigen::Matrix3d::Identity());
  Ft_.assign(n, Eigen::Matrix3d::Identity());
  P_.assign(n, Eigen::Matrix3d::Zero());
  f_.assign(n, Eigen::Vector3d::Zero());
  x_ = X_;
}

// Quadratic moving least squares: fit x_ji ≈ G X_ji + Q q(X_ji) with weights V_j W_ij, where q holds
// the six quadratic monomials (scaled by 1/h for conditioning). G = Σ_j V_j x_ji ĝ_ijᵀ with
// ĝ_ij = W_ij [M_i⁻¹ p(X_ji)]_{0..2}, M_i = Σ_j V_j W_ij p pᵀ, p = (X_ji, q(X_ji)). Reproduces every
// quadratic field exactly. Returns false (ĝ left at order 1) when M_i is ill-conditioned.
bool CorotatedSph::quadraticGradient(std::size_t i) {
  using Vec9 = Eigen::Matrix<double, 9, 1>;
  using Mat9 = Eigen::Matrix<double, 9, 9>;
  const double ih = 1.0 / h_;
  auto basis = [&](const Eigen::Vector3d& d) {
    Vec9 p;
    p << d.x(), d.y(), d.z(), ih * d.x() * d.x(), ih * d.y() * d.y(), ih * d.z() * d.z(), ih * d.x() * d.y(),
        ih * d.x() * d.z(), ih * d.y() * d.z();
    return p;
  };
  Mat9 M = Mat9::Zero();
  int used = 0;
  for (int e = nbr_.offsets[i]; e < nbr_.offsets[i + 1]; ++e) {
    const Eigen::Vector3d d = X_[nbr_.indices[e]] - X_[i];
    const double w = V_[nbr_.indices[e]] * W_[e];
    if (w <= 0.0) continue;
    const Vec9 p = basis(d);
    M.noalias() += w * p * p.transpose();
    ++used;
  }
  if (used < 12) return false;
  Eigen::SelfAdjointEigenSolver<Mat9> es(M);
  const Eigen::VectorXd ev = es.eigenvalues();
  if (!(ev(0) > 1e-6 * ev(8))) return false;
  const Mat9 Minv = es.eigenvectors() * ev.cwiseInverse().asDiagonal() * es.eigenvectors().transpose();
  for (int e = nbr_.offsets[i]; e < nbr_.offsets[i + 1]; ++e) {
    const Eigen::Vector3d d = X_[nbr_.indices[e]] - X_[i];
    gh_[e] = W_[e] * (Minv * basis(d)).head<3>();
  }
  return true;
}

// ------------------------------------------------------------------ evaluation

void CorotatedSph::checkPositions(const std::vector<Eigen::Vector3d>& x) const {
  if (x.size() != X_.size()) {
    throw TopoError("corotated SPH positions",
                    std::to_string(x.size()) + " positions for " + std::to_string(X_.size()) + " particles",
                    "pass one position per particle");
  }
  for (std::size_t i = 0; i < x.size(); ++i)
    if (!finite3(x[i]))
      throw TopoError("corotated SPH positions", "particle " + std::to_string(i) + " has a non-finite position",
                      "check the time step (the simulation may have diverged)");
}

void CorotatedSph::computeFtilde(const std::vector<Eigen::Vector3d>& x, std::vector<Eigen::Matrix3d>* Ft) const {
  const std::size_t n = X_.size();
  Ft->resize(n);
#pragma omp parallel for schedule(static)
  for (long long ii = 0; ii < static_cast<long long>(n); ++ii) {
    const std::size_t i = static_cast<std::size_t>(ii);
    Eigen::Matrix3d G = Eigen::Matrix3d::Zero();
    for (int e = nbr_.offsets[i]; e < nbr_.offsets[i + 1]; ++e) {
      const int j = nbr_.indices[e];
      G += V_[j] * (x[j] - x[i]) * gh_[e].transpose();
    }
    (*Ft)[i] = G;
  }
}

void CorotatedSph::rotationsFrom(const std::vector<Eigen::Vector3d>& x, const std::vector<Eigen::Matrix3d>& Ft,
                                 std::vector<Eigen::Matrix3d>* R) const {
  const std::size_t n = X_.size();
  R->resize(n);
#pragma omp parallel for schedule(static)
  for (long long ii = 0; ii < static_cast<long long>(n); ++ii) {
    const std::size_t i = static_cast<std::size_t>(ii);
    if (opt_.rotation == SphRotationSource::CorrectedGradient) {
      (*R)[i] = polarRotation(Ft[i]);
      continue;
    }
    // A_pq,i = Σ_j m_j W_ij (x_j − x_i)(X_j − X_i)ᵀ
    Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
    for (int e = nbr_.offsets[i]; e < nbr_.offsets[i + 1]; ++e) {
      const int j = nbr_.indices[e];
      A += (m_[j] * W_[e]) * (x[j] - x[i]) * (X_[j] - X_[i]).transpose();
    }
    (*R)[i] = polarRotation(A);
  }
}

std::vector<Eigen::Matrix3d> CorotatedSph::computeRotations(const std::vector<Eigen::Vector3d>& x) const {
  checkPositions(x);
  std::vector<Eigen::Matrix3d> Ft, R;
  computeFtilde(x, &Ft);
  rotationsFrom(x, Ft, &R);
  return R;
}

void CorotatedSph::evaluate(const std::vector<Eigen::Vector3d>& x, const std::vector<Eigen::Matrix3d>& R, Eval* ev,
                            bool need_M, bool ft_ready) const {
  const std::size_t n = X_.size();
  if (R.size() != n)
    throw TopoError("corotated SPH rotations", std::to_string(R.size()) + " rotations for " + std::to_string(n) +
                                                   " particles", "pass one rotation per particle");
  if (!ft_ready) computeFtilde(x, &ev->Ft);
  ev->F.resize(n);
  ev->P.resize(n);
  ev->e_el.resize(n);
  ev->e_hg.resize(n);
  if (need_M) ev->M.resize(n);
  std::vector<double> det(n);
  const double alpha = opt_.hourglass_alpha;
  const double inv_h2 = 1.0 / (h_ * h_);
#pragma omp parallel for schedule(static)
  for (long long ii = 0; ii < static_cast<long long>(n); ++ii) {
    const std::size_t i = static_cast<std::size_t>(ii);
    const Eigen::Matrix3d& Ft = ev->Ft[i];
    // F_i = I + Σ_j V_j u_ji ĝ_ijᵀ with u_ji = R_iᵀ x_ji − X_ji, which equals R_iᵀ F̃_i exactly
    // because Σ_j V_j X_ji ĝ_ijᵀ = I (correction); computed in the latter form so that the
    // forces are the exact derivative of the energy.
    const Eigen::Matrix3d F = R[i].transpose() * Ft;
    ev->F[i] = F;
    det[i] = F.determinant();
    const Eigen::Matrix3d P = sphFirstPiola(opt_.model, F, mu_[i], lambda_[i]);
    ev->P[i] = P;
    ev->e_el[i] = V_[i] * sphStrainEnergyDensity(opt_.model, F, mu_[i], lambda_[i]);
    double ehg = 0.0;
    Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
    const double c = alpha * mu_[i] * V_[i] * inv_h2;
    if (c > 0.0) {
      for (int e = nbr_.offsets[i]; e < nbr_.offsets[i + 1]; ++e) {
        const int j = nbr_.indices[e];
        const Eigen::Vector3d Xji = X_[j] - X_[i];
        const Eigen::Vector3d err = Ft * Xji - (x[j] - x[i]);
        const double w = V_[j] * W_[e];
        ehg += w * err.squaredNorm();
        if (need_M) H += (2.0 * w) * err * Xji.transpose();
      }
    }
    ev->e_hg[i] = c * ehg;
    if (need_M) ev->M[i] = V_[i] * R[i] * P + c * H;
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (!(det[i] > 0.0)) {
      std::ostringstream s;
      s << "particle " << i << " at " << vecStr(x[i]) << " (rest " << vecStr(X_[i]) << ") is inverted: det F = "
        << det[i] << " <= 0";
      throw TopoError("corotated SPH", s.str(),
                      "reduce the time step or stiffen the material; an inverted rest-to-current map is not a valid "
                      "deformation");
    }
  }
}

void CorotatedSph::gatherForces(const std::vector<Eigen::Vector3d>& x, const Eval& ev,
                                std::vector<Eigen::Vector3d>* f) const {
  gather(x, ev.Ft, ev.M, true, f);
  for (auto& v : *f) v = -v;
}

// out_k = Σ_{j∈N(k)} [ V_k M_j ĝ_jk − V_j M_k ĝ_kj ] (+ hourglass q_kj − q_jk with e_ij = F̃_i X_ji − x_ji):
// the gradient of Σ_i M_i : F̃_i(x) (+ E_hg) for M held fixed; linear in (x, F̃, M) jointly, so
// the same gather with (dx, dF̃, dM) gives the Hessian product.
void CorotatedSph::gather(const std::vector<Eigen::Vector3d>& x, const std::vector<Eigen::Matrix3d>& Ft,
                          const std::vector<Eigen::Matrix3d>& M, bool hourglass,
                          std::vector<Eigen::Vector3d>* out) const {
  const std::size_t n = X_.size();
  out->resize(n);
  const double alpha = hourglass ? opt_.hourglass_alpha : 0.0;
  const double inv_h2 = 1.0 / (h_ * h_);
#pragma omp parallel for schedule(static)
  for (long long kk = 0; kk < static_cast<long long>(n); ++kk) {
    const std::size_t k = static_cast<std::size_t>(kk);
    const double ck = alpha * mu_[k] * V_[k] * inv_h2;
    Eigen::Vector3d g = Eigen::Vector3d::Zero();
    for (int e = nbr_.offsets[k]; e < nbr_.offsets[k + 1]; ++e) {
      const int j = nbr_.indices[e];
      const int r = rev_[e];  // entry (j → k)
      g += V_[k] * (M[j] * gh_[r]) - V_[j] * (M[k] * gh_[e]);
      const double cj = alpha * mu_[j] * V_[j] * inv_h2;
      if (ck > 0.0 || cj > 0.0) {
        const Eigen::Vector3d Xjk = X_[j] - X_[k];
        const Eigen::Vector3d xjk = x[j] - x[k];
        const double wk = W_[e];  // W_kj = W_jk
        const Eigen::Vector3d q_kj = (2.0 * ck * V_[j] * wk) * (Ft[k] * Xjk - xjk);
        const Eigen::Vector3d q_jk = (2.0 * cj * V_[k] * wk) * (Ft[j] * (-Xjk) + xjk);
        g += q_kj - q_jk;
      }
    }
    (*out)[k] = g;
  }
}

std::vector<Eigen::Matrix3d> CorotatedSph::gradientField(const std::vector<Eigen::Vector3d>& u) const {
  checkPositions(u);
  std::vector<Eigen::Matrix3d> G;
  computeFtilde(u, &G);
  return G;
}

std::vector<Eigen::Vector3d> CorotatedSph::stressDivergence(const std::vector<Eigen::Matrix3d>& G) const {
  if (G.size() != X_.size())
    throw TopoError("corotated SPH stress divergence", std::to_string(G.size()) + " matrices for " +
                                                           std::to_string(X_.size()) + " particles",
                    "pass one matrix per particle");
  std::vector<Eigen::Vector3d> out;
  gather(x_, Ft_, G, false, &out);
  return out;
}

namespace {

/// Differential of P̂(F̃) = ∂ψ(R(F̃)ᵀF̃)/∂F̃ along dF̃ (see hessianProduct()).
Eigen::Matrix3d piolaDifferential(SphEnergyModel model, bool exact_rotation, const Eigen::Matrix3d& Ft,
                                  const Eigen::Matrix3d& R, const Eigen::Matrix3d& dFt, double mu, double lambda) {
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  if (model == SphEnergyModel::StVK) {
    const Eigen::Matrix3d E = 0.5 * (Ft.transpose() * Ft - I);
    const Eigen::Matrix3d dE = 0.5 * (dFt.transpose() * Ft + Ft.transpose() * dFt);
    return dFt * (2.0 * mu * E + lambda * E.trace() * I) + Ft * (2.0 * mu * dE + lambda * dE.trace() * I);
  }
  // Corotated linear: P̂ = 2μ(F̃ − R) + λ tr(S − I) R with S = RᵀF̃.
  const Eigen::Matrix3d S = R.transpose() * Ft;
  const Eigen::Matrix3d Y = R.transpose() * dFt;
  Eigen::Matrix3d dR = Eigen::Matrix3d::Zero();
  if (exact_rotation) {
    // F̃ = RS ⇒ Y − Yᵀ = WS + SW with W = RᵀdR = [ω]×, i.e. ((tr S)I − S) ω = axial(Y − Yᵀ).
    const Eigen::Vector3d a(Y(2, 1) - Y(1, 2), Y(0, 2) - Y(2, 0), Y(1, 0) - Y(0, 1));
    const Eigen::Vector3d w = (S.trace() * I - 0.5 * (S + S.transpose())).inverse() * a;
    Eigen::Matrix3d Wx;
    Wx << 0, -w.z(), w.y(), w.z(), 0, -w.x(), -w.y(), w.x(), 0;
    dR = R * Wx;
  }
  const double trSm = S.trace() - 3.0;
  return 2.0 * mu * (dFt - dR) + lambda * Y.trace() * R + lambda * trSm * dR;
}

}  // namespace

std::vector<Eigen::Vector3d> CorotatedSph::hessianProduct(const std::vector<Eigen::Vector3d>& dx) const {
  checkPositions(dx);
  const std::size_t n = X_.size();
  std::vector<Eigen::Matrix3d> dFt, dM(n);
  computeFtilde(dx, &dFt);
  const bool exact = opt_.rotation == SphRotationSource::CorrectedGradient;
  const double inv_h2 = 1.0 / (h_ * h_);
#pragma omp parallel for schedule(static)
  for (long long ii = 0; ii < static_cast<long long>(n); ++ii) {
    const std::size_t i = static_cast<std::size_t>(ii);
    Eigen::Matrix3d m = V_[i] * piolaDifferential(opt_.model, exact, Ft_[i], R_[i], dFt[i], mu_[i], lambda_[i]);
    const double c = opt_.hourglass_alpha * mu_[i] * V_[i] * inv_h2;
    if (c > 0.0) {
      Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
      for (int e = nbr_.offsets[i]; e < nbr_.offsets[i + 1]; ++e) {
        const int j = nbr_.indices[e];
        const Eigen::Vector3d Xji = X_[j] - X_[i];
        H += (2.0 * V_[j] * W_[e]) * (dFt[i] * Xji - (dx[j] - dx[i])) * Xji.transpose();
      }
      m += c * H;
    }
    dM[i] = m;
  }
  std::vector<Eigen::Vector3d> out;
  gather(dx, dFt, dM, true, &out);
  return out;
}

void CorotatedSph::materialDirectional(const std::vector<Eigen::Vector3d>& w, std::vector<double>* d_mu,
                                       std::vector<double>* d_lambda) const {
  checkPositions(w);
  const std::size_t n = X_.size();
  std::vector<Eigen::Matrix3d> dFt;
  computeFtilde(w, &dFt);
  d_mu->assign(n, 0.0);
  d_lambda->assign(n, 0.0);
  const double inv_h2 = 1.0 / (h_ * h_);
#pragma omp parallel for schedule(static)
  for (long long ii = 0; ii < static_cast<long long>(n); ++ii) {
    const std::size_t i = static_cast<std::size_t>(ii);
    // ∂E_i/∂μ_i and ∂E_i/∂λ_i as functions of x; their derivative along w. M̂ = R P(F) per unit modulus.
    const Eigen::Matrix3d Pmu = R_[i] * sphFirstPiola(opt_.model, F_[i], 1.0, 0.0);
    const Eigen::Matrix3d Plam = R_[i] * sphFirstPiola(opt_.model, F_[i], 0.0, 1.0);
    double hg = 0.0;
    const double c = opt_.hourglass_alpha * V_[i] * inv_h2;
    if (c > 0.0) {
      for (int e = nbr_.offsets[i]; e < nbr_.offsets[i + 1]; ++e) {
        const int j = nbr_.indices[e];
        const Eigen::Vector3d Xji = X_[j] - X_[i];
        const Eigen::Vector3d err = Ft_[i] * Xji - (x_[j] - x_[i]);
        const Eigen::Vector3d derr = dFt[i] * Xji - (w[j] - w[i]);
        hg += 2.0 * V_[j] * W_[e] * err.dot(derr);
      }
    }
    (*d_mu)[i] = V_[i] * (Pmu.array() * dFt[i].array()).sum() + c * hg;
    (*d_lambda)[i] = V_[i] * (Plam.array() * dFt[i].array()).sum();
  }
}

void CorotatedSph::materialEnergies(std::vector<double>* e_mu, std::vector<double>* e_lambda) const {
  const std::size_t n = X_.size();
  e_mu->assign(n, 0.0);
  e_lambda->assign(n, 0.0);
  const double inv_h2 = 1.0 / (h_ * h_);
  for (std::size_t i = 0; i < n; ++i) {
    (*e_mu)[i] = V_[i] * sphStrainEnergyDensity(opt_.model, F_[i], 1.0, 0.0);
    (*e_lambda)[i] = V_[i] * sphStrainEnergyDensity(opt_.model, F_[i], 0.0, 1.0);
    const double c = opt_.hourglass_alpha * V_[i] * inv_h2;
    if (c > 0.0)
      for (int e = nbr_.offsets[i]; e < nbr_.offsets[i + 1]; ++e) {
        const int j = nbr_.indices[e];
        const Eigen::Vector3d err = Ft_[i] * (X_[j] - X_[i]) - (x_[j] - x_[i]);
        (*e_mu)[i] += c * V_[j] * W_[e] * err.squaredNorm();
      }
  }
}

void CorotatedSph::setMaterial(const std::vector<double>& mu, const std::vector<double>& lambda) {
  if (mu.size() != X_.size() || lambda.size() != X_.size())
    throw TopoError("corotated SPH material", std::to_string(mu.size()) + " mu and " + std::to_string(lambda.size()) +
                                                  " lambda values for " + std::to_string(X_.size()) + " particles",
                    "give one material per particle");
  for (std::size_t i = 0; i < mu.size(); ++i)
    if (!std::isfinite(mu[i]) || mu[i] <= 0.0 || !std::isfinite(lambda[i]))
      throw TopoError("corotated SPH material",
                      "particle " + std::to_string(i) + " has mu = " + std::to_string(mu[i]) +
                          ", lambda = " + std::to_string(lambda[i]),
                      "mu must be positive and lambda finite");
  mu_ = mu;
  lambda_ = lambda;
  update(x_);
}

void CorotatedSph::store(const std::vector<Eigen::Vector3d>& x, std::vector<Eigen::Matrix3d> R, Eval&& ev) {
  gatherForces(x, ev, &f_);
  x_ = x;
  R_ = std::move(R);
  F_ = std::move(ev.F);
  Ft_ = std::move(ev.Ft);
  P_ = std::move(ev.P);
  double eel = 0.0, ehg = 0.0;  // serial sums: deterministic
  for (std::size_t i = 0; i < X_.size(); ++i) {
    eel += ev.e_el[i];
    ehg += ev.e_hg[i];
  }
  elastic_energy_ = eel;
  hourglass_energy_ = ehg;
}

void CorotatedSph::update(const std::vector<Eigen::Vector3d>& x) {
  checkPositions(x);
  Eval ev;
  std::vector<Eigen::Matrix3d> R;
  computeFtilde(x, &ev.Ft);
  rotationsFrom(x, ev.Ft, &R);
  evaluate(x, R, &ev, true, true);
  store(x, std::move(R), std::move(ev));
}

void CorotatedSph::updateWithRotations(const std::vector<Eigen::Vector3d>& x, const std::vector<Eigen::Matrix3d>& R) {
  checkPositions(x);
  Eval ev;
  evaluate(x, R, &ev, true);
  store(x, R, std::move(ev));
}

double CorotatedSph::energyWithRotations(const std::vector<Eigen::Vector3d>& x,
                                         const std::vector<Eigen::Matrix3d>& R) const {
  checkPositions(x);
  Eval ev;
  evaluate(x, R, &ev, false);
  double e = 0.0;
  for (std::size_t i = 0; i < X_.size(); ++i) e += ev.e_el[i] + ev.e_hg[i];
  return e;
}

}  // namespace topo_gaussian
