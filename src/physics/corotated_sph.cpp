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

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/physics/sph_kernel.h"

namespace topo_gaussian {

namespace {

std::string vecStr(const Eigen::Vector3d& v) {
  std::ostringstream s;
  s << "(" << v.x() << ", " << v.y() << ", " << v.z() << ")";
  return s.str();
}

bool finite3(const Eigen::Vector3d& v) { return std::isfinite(v.x()) && std::isfinite(v.y()) && std::isfinite(v.z()); }

/// Rotation factor of the polar decomposition A = R S from the SVD, with the determinant fixed so
/// that R is a proper rotation (det R = +1) also for reflected / degenerate A.
Eigen::Matrix3d polarRotationSvd(const Eigen::Matrix3d& A) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(A, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d U = svd.matrixU();
  const Eigen::Matrix3d& Vm = svd.matrixV();
  if ((U * Vm.transpose()).determinant() < 0.0) U.col(2) = -U.col(2);  // smallest singular value
  return U * Vm.transpose();
}

/// Cofactor matrix: X⁻ᵀ = cof(X) / det X.
inline Eigen::Matrix3d cofactor3(const Eigen::Matrix3d& X) {
  Eigen::Matrix3d C;
  C(0, 0) = X(1, 1) * X(2, 2) - X(1, 2) * X(2, 1);
  C(0, 1) = X(1, 2) * X(2, 0) - X(1, 0) * X(2, 2);
  C(0, 2) = X(1, 0) * X(2, 1) - X(1, 1) * X(2, 0);
  C(1, 0) = X(0, 2) * X(2, 1) - X(0, 1) * X(2, 2);
  C(1, 1) = X(0, 0) * X(2, 2) - X(0, 2) * X(2, 0);
  C(1, 2) = X(0, 1) * X(2, 0) - X(0, 0) * X(2, 1);
  C(2, 0) = X(0, 1) * X(1, 2) - X(0, 2) * X(1, 1);
  C(2, 1) = X(0, 2) * X(1, 0) - X(0, 0) * X(1, 2);
  C(2, 2) = X(0, 0) * X(1, 1) - X(0, 1) * X(1, 0);
  return C;
}

/// State of polarRotation's Newton iteration for one matrix (see there).
struct PolarNewton {
  Eigen::Matrix3d X;
  double step2 = 1.0;  // ‖X_k − X_{k−1}‖_F²
  int it = 0;
  int state = 0;  // 0 iterating, 1 converged (X), 2 use the SVD
  explicit PolarNewton(const Eigen::Matrix3d& A) {
    const double na2 = A.squaredNorm();
    if (na2 > 0.0 && std::isfinite(na2))
      X = std::sqrt(3.0 / na2) * A;  // rms singular value 1
    else
      state = 2;
  }
  /// One Newton step; returns true while more are needed.
  bool step() {
    const Eigen::Matrix3d C = cofactor3(X);
    const double det = X(0, 0) * C(0, 0) + X(0, 1) * C(0, 1) + X(0, 2) * C(0, 2);
    if (it == 0 ? !(det >= 1e-3) : !(det > 0.0)) {
      state = 2;
      return false;
    }
    // X_{k+1} = ½(ζ X + ζ⁻¹ X⁻ᵀ), X⁻ᵀ = C / det.
    double a = 0.5, b = 0.5 / det;
    if (it == 0 ? det < 0.9 : step2 > 1e-4) {
      const double z = std::sqrt(std::sqrt(C.squaredNorm() / (det * det * X.squaredNorm())));
      a *= z;
      b /= z;
    }
    const Eigen::Matrix3d Xn = a * X + b * C;
    step2 = (Xn - X).squaredNorm();
    X = Xn;
    if (step2 < 1e-16) {
      state = 1;
      return false;
    }
    if (++it >= 40) {
      state = 2;
      return false;
    }
    return true;
  }
};

/// Rotation factor of the polar decomposition A = R S (R proper, S symmetric positive definite),
/// replacing a 3×3 Jacobi SVD per particle (~10× faster). Newton iteration X ← ½(ζX + ζ⁻¹X⁻ᵀ)
/// (Higham 1986) on X_0 = A √3/‖A‖_F: it keeps the singular vectors and drives every singular
/// value to 1, i.e. converges quadratically to U Vᵀ of A = U Σ Vᵀ, the SVD's factor. Frobenius
/// scaling ζ = (‖X⁻¹‖_F/‖X‖_F)^½ while far from convergence (first step only when det X_0 < 0.9,
/// i.e. the singular values are spread; later steps while the last step was > 1e-2). Used when
/// det X_0 ≥ 1e-3 (A proper and σ_max/σ_min ≲ 5e3); reflected, near-singular or non-finite A (and
/// the never-seen case of no convergence in 40 steps) go to the SVD, which also gives the proper
/// rotation for det A < 0 by flipping the direction of the smallest singular value, as before.
/// Stops once a step changes X by < 1e-8 (Frobenius): the returned iterate is then ~½(1e-8)²
/// from U Vᵀ, i.e. converged to round-off (random A with κ ≤ 1e4: max |R − R_svd| ≈ 2e-14).
Eigen::Matrix3d polarRotation(const Eigen::Matrix3d& A) {
  PolarNewton p(A);
  if (p.state == 0)
    while (p.step()) {
    }
  return p.state == 1 ? p.X : polarRotationSvd(A);
}

/// polarRotation of two matrices, iterated side by side (independent dependency chains overlap);
/// each result is bit-identical to polarRotation's.
void polarRotation2(const Eigen::Matrix3d& A0, const Eigen::Matrix3d& A1, Eigen::Matrix3d* R0, Eigen::Matrix3d* R1) {
  PolarNewton p(A0), q(A1);
  bool a = p.state == 0, b = q.state == 0;
  while (a && b) {
    a = p.step();
    b = q.step();
  }
  while (a) a = p.step();
  while (b) b = q.step();
  *R0 = p.state == 1 ? p.X : polarRotationSvd(A0);
  *R1 = q.state == 1 ? q.X : polarRotationSvd(A1);
}

/// sphFirstPiola and sphStrainEnergyDensity in one go (same arithmetic as those two).
inline void piolaAndEnergy(SphEnergyModel model, const Eigen::Matrix3d& F, double mu, double lambda, Eigen::Matrix3d* P,
                           double* psi) {
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  if (model == SphEnergyModel::StVK) {
    const Eigen::Matrix3d eps = 0.5 * (F.transpose() * F - I);
    const double tr = eps.trace();
    *psi = mu * eps.squaredNorm() + 0.5 * lambda * tr * tr;
    *P = F * (2.0 * mu * eps + lambda * tr * I);
    return;
  }
  const Eigen::Matrix3d eps = 0.5 * (F + F.transpose()) - I;
  const double tr = eps.trace();
  *psi = mu * eps.squaredNorm() + 0.5 * lambda * tr * tr;
  *P = 2.0 * mu * eps + lambda * tr * I;
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
  const Eigen::Matrix3d eps = model == SphEnergyModel::StVK ? Eigen::Matrix3d(0.5 * (F.transpose() * F - I))
                                                            : Eigen::Matrix3d(0.5 * (F + F.transpose()) - I);
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

CorotatedSph::CorotatedSph(const std::vector<Eigen::Vector3d>& X, const std::vector<double>& V, LameParameters material,
                           const CorotatedSphOptions& options)
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
    s << "sizes disagree: " << n << " positions, " << V.size() << " volumes, " << mu.size() << " mu, " << lambda.size()
      << " lambda";
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
    // The volume's spacing (fromCloud passes it on); particles given without one: the one fallback.
    const double s = opt_.spacing > 0.0 ? opt_.spacing : spacingFromVolumes(V);
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
      s << "particle " << i << " at " << vecStr(X_[i])
        << " has no neighbour within the kernel support 2h = " << 2.0 * h_ << " m";
      throw TopoError(what, s.str(),
                      "increase the smoothing length (options.smoothing_length / smoothing_factor) or remove the "
                      "isolated particle");
    }
  }
  const std::size_t nnz = nbr_.indices.size();
  std::vector<int> rev(nnz, -1);  // per CSR entry (i→j): position of entry (j→i) in row j
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
      rev[e] = (p != en && *p == static_cast<int>(i)) ? static_cast<int>(p - nbr_.indices.data()) : -1;
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
    if (rev[e] < 0) throw TopoError(what, "neighbour list is not symmetric (internal error)", "report this as a bug");
  // The gather reads ĝ_jk (entry j→k) while sweeping row k: stored in row-k order it streams.
  ghr_.resize(nnz);
  for (std::size_t e = 0; e < nnz; ++e) ghr_[e] = gh_[rev[e]];

  // Rest state.
  R_.assign(n, Eigen::Matrix3d::Identity());
  F_.assign(n, Eigen::Matrix3d::Identity());
  Ft_.assign(n, Eigen::Matrix3d::Identity());
  P_.assign(n, Eigen::Matrix3d::Zero());
  f_.assign(n, Eigen::Vector3d::Zero());
  x_ = X_;
  // C_i = Σ_j V_j W_ij X_ji X_jiᵀ: the hourglass matrix H_i = 2(F̃_i C_i − D_i) (see evaluate()).
  if (opt_.hourglass_alpha > 0.0) {
    moment_.resize(n);
#pragma omp parallel for schedule(static)
    for (long long ii = 0; ii < static_cast<long long>(n); ++ii) {
      const std::size_t i = static_cast<std::size_t>(ii);
      Eigen::Matrix3d C = Eigen::Matrix3d::Zero();
      for (int e = nbr_.offsets[i]; e < nbr_.offsets[i + 1]; ++e) {
        const int j = nbr_.indices[e];
        const Eigen::Vector3d Xji = X_[j] - X_[i];
        C += (V_[j] * W_[e]) * Xji * Xji.transpose();
      }
      moment_[i] = C;
    }
  }
  prepareGatherConstants();
}

void CorotatedSph::prepareGatherConstants() {
  const std::size_t n = X_.size();
  const double inv_h2 = 1.0 / (h_ * h_);
  c_.resize(n);
  gsum_.resize(n);
  hgsum_.resize(n);
  for (std::size_t i = 0; i < n; ++i) c_[i] = opt_.hourglass_alpha * mu_[i] * V_[i] * inv_h2;
#pragma omp parallel for schedule(static)
  for (long long ii = 0; ii < static_cast<long long>(n); ++ii) {
    const std::size_t i = static_cast<std::size_t>(ii);
    Eigen::Vector3d gs = Eigen::Vector3d::Zero(), hs = Eigen::Vector3d::Zero();
    for (int e = nbr_.offsets[i]; e < nbr_.offsets[i + 1]; ++e) {
      const int j = nbr_.indices[e];
      gs += V_[j] * gh_[e];
      hs += (2.0 * c_[i] * V_[j] * W_[e]) * (X_[j] - X_[i]);
    }
    gsum_[i] = gs;
    hgsum_[i] = hs;
  }
  // Per CSR entry k→j, the gather's hourglass weights (rest constants for the material):
  // (W_kj c_j X_jk, W_kj (c_k V_j + c_j V_k)), streamed in row order.
  hgw_.resize(nbr_.indices.size());
#pragma omp parallel for schedule(static)
  for (long long kk = 0; kk < static_cast<long long>(n); ++kk) {
    const std::size_t k = static_cast<std::size_t>(kk);
    for (int e = nbr_.offsets[k]; e < nbr_.offsets[k + 1]; ++e) {
      const int j = nbr_.indices[e];
      const double w = W_[e], wc = w * c_[j];
      hgw_[e] = {wc * (X_[j].x() - X_[k].x()), wc * (X_[j].y() - X_[k].y()), wc * (X_[j].z() - X_[k].z()),
                 w * (c_[k] * V_[j] + c_[j] * V_[k])};
    }
  }
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
  bool finite = true;
  const long long n = static_cast<long long>(x.size());
#pragma omp parallel for schedule(static) reduction(&& : finite) if (n >= 8192)
  for (long long i = 0; i < n; ++i) finite = finite && finite3(x[static_cast<std::size_t>(i)]);
  if (finite) return;
  for (std::size_t i = 0; i < x.size(); ++i)  // report the first one
    if (!finite3(x[i]))
      throw TopoError("corotated SPH positions", "particle " + std::to_string(i) + " has a non-finite position",
                      "check the time step (the simulation may have diverged)");
}

namespace {

// The per-row kernels below accumulate in explicit registers (components 0-1 of a 3-vector as one
// Eigen::Array2d SIMD pair, component 2 as a scalar): Eigen's outer-product expressions
// (G += s * a * bᵀ) go through a stack temporary whose partial stores stall the following loads.
// Every component sees the same operations in the same order as plain scalar code (no
// reassociation), and every particle's sums run in its fixed row order: results do not depend on
// the thread count.

using Pair = Eigen::Array2d;
/// Components 0 and 1 of a 3-vector as one SIMD pair (unaligned load).
inline Pair head2(const Eigen::Vector3d& v) { return Eigen::Map<const Pair>(v.data()); }
inline Pair head2(const double* v) { return Eigen::Map<const Pair>(v); }

/// One sweep of row i for both linear sums of the evaluation: G = Σ_e V_j d_e ĝ_eᵀ (F̃_i for u = x)
/// and D = Σ_e V_j W_e d_e X_jiᵀ, d_e = u_j − u_i. D gives the hourglass matrix without a second
/// sweep, H_i = Σ_e 2 V_j W_e (G X_ji − d_e) X_jiᵀ = 2(G C_i − D) with the rest moment
/// C_i = Σ_e V_j W_e X_ji X_jiᵀ, and the paper's A_pq,i = Σ_e m_j W_e x_ji X_jiᵀ = ρ D.
/// kD = false: G alone (X, W, Xi and D unused). Rows 0-1 of each column as a pair, row 2 scalar.
template <bool kD>
inline void rowGradientMoment(const int* idx, int e0, int e1, const Eigen::Vector3d* x, const Eigen::Vector3d* X,
                              const double* V, const Eigen::Vector3d* gh, const double* W, const Eigen::Vector3d& xi,
                              const Eigen::Vector3d& Xi, Eigen::Matrix3d* G, Eigen::Matrix3d* D) {
  Pair c0 = Pair::Zero(), c1 = Pair::Zero(), c2 = Pair::Zero();  // G rows 0-1, by column
  Pair p0 = Pair::Zero(), p1 = Pair::Zero(), p2 = Pair::Zero();  // D rows 0-1, by column
  double g20 = 0, g21 = 0, g22 = 0, d20 = 0, d21 = 0, d22 = 0;
  const Pair xi01 = head2(xi);
  for (int e = e0; e < e1; ++e) {
    const int j = idx[e];
    const double v = V[j];
    const Pair u01 = head2(x[j]) - xi01;
    const double u2 = x[j].z() - xi.z();
    const Pair d01 = v * u01;
    const double d2 = v * u2;
    const double* g = gh[e].data();
    c0 += d01 * g[0];
    c1 += d01 * g[1];
    c2 += d01 * g[2];
    g20 += d2 * g[0];
    g21 += d2 * g[1];
    g22 += d2 * g[2];
    if (!kD) continue;
    const double w = W[e];
    const Pair b01 = w * d01;
    const double b2 = w * d2;
    const double X0 = X[j].x() - Xi.x(), X1 = X[j].y() - Xi.y(), X2 = X[j].z() - Xi.z();
    p0 += b01 * X0;
    p1 += b01 * X1;
    p2 += b01 * X2;
    d20 += b2 * X0;
    d21 += b2 * X1;
    d22 += b2 * X2;
  }
  *G << c0(0), c1(0), c2(0), c0(1), c1(1), c2(1), g20, g21, g22;
  if (kD) *D << p0(0), p1(0), p2(0), p0(1), p1(1), p2(1), d20, d21, d22;
}

/// Σ_e V_j (x_j − x_i) ĝ_eᵀ over the entries [e0, e1) of row i (F̃_i for u = x).
inline Eigen::Matrix3d rowGradient(const int* idx, int e0, int e1, const Eigen::Vector3d* x, const double* V,
                                   const Eigen::Vector3d* gh, const Eigen::Vector3d& xi) {
  Eigen::Matrix3d G;
  rowGradientMoment<false>(idx, e0, e1, x, nullptr, V, gh, nullptr, xi, xi, &G, nullptr);
  return G;
}

/// Hourglass sums of row i: Σ_e w_e |e_e|² and (kH) H = Σ_e 2 w_e e_e X_jiᵀ, e_e = F̃ X_ji − x_ji,
/// w_e = V_j W_e.
template <bool kH>
double rowHourglass(const int* idx, int e0, int e1, const Eigen::Vector3d* x, const Eigen::Vector3d* X, const double* V,
                    const double* W, const Eigen::Matrix3d& Ft, const Eigen::Vector3d& xi, const Eigen::Vector3d& Xi,
                    Eigen::Matrix3d* H) {
  const Pair f0 = head2(Ft.col(0).data()), f1 = head2(Ft.col(1).data()), f2 = head2(Ft.col(2).data());
  const double f20 = Ft(2, 0), f21 = Ft(2, 1), f22 = Ft(2, 2);
  const Pair xi01 = head2(xi);
  double ehg = 0.0;
  Pair h0 = Pair::Zero(), h1 = Pair::Zero(), h2 = Pair::Zero();
  double h20 = 0, h21 = 0, h22 = 0;
  for (int e = e0; e < e1; ++e) {
    const int j = idx[e];
    const double X0 = X[j].x() - Xi.x(), X1 = X[j].y() - Xi.y(), X2 = X[j].z() - Xi.z();
    const Pair r01 = f0 * X0 + f1 * X1 + f2 * X2 - (head2(x[j]) - xi01);
    const double r2 = f20 * X0 + f21 * X1 + f22 * X2 - (x[j].z() - xi.z());
    const double w = V[j] * W[e];
    ehg += w * (r01(0) * r01(0) + r01(1) * r01(1) + r2 * r2);
    if (kH) {
      const Pair s01 = (2.0 * w) * r01;
      const double s2 = 2.0 * w * r2;
      h0 += s01 * X0;
      h1 += s01 * X1;
      h2 += s01 * X2;
      h20 += s2 * X0;
      h21 += s2 * X1;
      h22 += s2 * X2;
    }
  }
  if (kH) *H << h0(0), h1(0), h2(0), h0(1), h1(1), h2(1), h20, h21, h22;
  return ehg;
}

}  // namespace

void CorotatedSph::computeFtilde(const std::vector<Eigen::Vector3d>& x, std::vector<Eigen::Matrix3d>* Ft) const {
  const std::size_t n = X_.size();
  Ft->resize(n);
#pragma omp parallel for schedule(static)
  for (long long ii = 0; ii < static_cast<long long>(n); ++ii) {
    const std::size_t i = static_cast<std::size_t>(ii);
    (*Ft)[i] =
        rowGradient(nbr_.indices.data(), nbr_.offsets[i], nbr_.offsets[i + 1], x.data(), V_.data(), gh_.data(), x[i]);
  }
}

std::vector<Eigen::Matrix3d> CorotatedSph::computeRotations(const std::vector<Eigen::Vector3d>& x) const {
  checkPositions(x);
  Eval ev;
  std::vector<Eigen::Matrix3d> R;
  evaluate(x, nullptr, &R, &ev, EvalMode::State);
  return R;
}

void CorotatedSph::evaluate(const std::vector<Eigen::Vector3d>& x, const std::vector<Eigen::Matrix3d>* R_given,
                            std::vector<Eigen::Matrix3d>* R_out, Eval* ev, EvalMode mode) const {
  const bool need_M = mode == EvalMode::Forces;
  const std::size_t n = X_.size();
  if (R_given && R_given->size() != n)
    throw TopoError("corotated SPH rotations",
                    std::to_string(R_given->size()) + " rotations for " + std::to_string(n) + " particles",
                    "pass one rotation per particle");
  if (!R_given) R_out->resize(n);
  ev->Ft.resize(n);
  ev->F.resize(n);
  ev->P.resize(n);
  ev->e_el.resize(n);
  ev->e_hg.resize(n);
  ev->det.resize(n);
  if (need_M) ev->M.resize(n);
  const bool shape_matching = !R_given && opt_.rotation == SphRotationSource::ShapeMatchingApq;
  const bool hourglass = opt_.hourglass_alpha > 0.0;
  // Particles in pairs: the two rotations' Newton iterations run side by side.
  const long long pairs = static_cast<long long>((n + 1) / 2);
#pragma omp parallel for schedule(static)
  for (long long pp = 0; pp < pairs; ++pp) {
    const std::size_t i0 = static_cast<std::size_t>(2 * pp);
    const int lanes = i0 + 1 < n ? 2 : 1;
    Eigen::Matrix3d Ft[2], H[2], A[2], R[2], D;
    double ehg[2] = {0.0, 0.0};
    bool polar[2] = {false, false};
    const int* idx = nbr_.indices.data();
    for (int l = 0; l < lanes; ++l) {
      const std::size_t i = i0 + l;
      const int e0 = nbr_.offsets[i], e1 = nbr_.offsets[i + 1];
      const Eigen::Vector3d xi = x[i], Xi = X_[i];
      const bool hg_row = hourglass && c_[i] > 0.0;
      // F̃_i = Σ_j V_j x_ji ĝ_ijᵀ (same arithmetic as computeFtilde), and in the same sweep, where
      // the forces' hourglass term or the paper's rotation needs it, D_i = Σ_j V_j W_ij x_ji X_jiᵀ:
      // H_i = Σ_j 2 V_j W_ij e_ij X_jiᵀ = 2(F̃_i C_i − D_i) with e_ij = F̃_i X_ji − x_ji, and
      // A_pq,i = ρ D_i (the polar factor is scale invariant).
      const bool need_D = (need_M && hg_row) || shape_matching;
      if (need_D) {
        rowGradientMoment<true>(idx, e0, e1, x.data(), X_.data(), V_.data(), gh_.data(), W_.data(), xi, Xi, &Ft[l], &D);
      } else {
        Ft[l] = rowGradient(idx, e0, e1, x.data(), V_.data(), gh_.data(), xi);
      }
      H[l].setZero();
      if (hg_row && need_M) H[l] = 2.0 * (Ft[l] * moment_[i] - D);
      // For the energy alone the hourglass energy Σ_j V_j W_ij |e_ij|² is summed directly (no
      // cancellation); update() and updateState() leave it to hourglassEnergy().
      if (hg_row && mode == EvalMode::Energy)
        ehg[l] = rowHourglass<false>(idx, e0, e1, x.data(), X_.data(), V_.data(), W_.data(), Ft[l], xi, Xi, nullptr);
      // Rotation: polar decomposition of F̃_i, or of the paper's A_pq,i.
      if (R_given) {
        R[l] = (*R_given)[i];
      } else {
        polar[l] = true;
        A[l] = shape_matching ? D : Ft[l];
      }
    }
    if (lanes == 2 && polar[0] && polar[1]) {
      polarRotation2(A[0], A[1], &R[0], &R[1]);
    } else {
      for (int l = 0; l < lanes; ++l)
        if (polar[l]) R[l] = polarRotation(A[l]);
    }
    for (int l = 0; l < lanes; ++l) {
      const std::size_t i = i0 + l;
      if (!R_given) (*R_out)[i] = R[l];
      ev->Ft[i] = Ft[l];
      ev->e_hg[i] = c_[i] * ehg[l];
      // F_i = I + Σ_j V_j u_ji ĝ_ijᵀ with u_ji = R_iᵀ x_ji − X_ji, which equals R_iᵀ F̃_i exactly
      // because Σ_j V_j X_ji ĝ_ijᵀ = I (correction); computed in the latter form so that the
      // forces are the exact derivative of the energy.
      const Eigen::Matrix3d F = R[l].transpose() * Ft[l];
      ev->F[i] = F;
      ev->det[i] = F.determinant();
      Eigen::Matrix3d P;
      double psi;
      piolaAndEnergy(opt_.model, F, mu_[i], lambda_[i], &P, &psi);
      ev->P[i] = P;
      ev->e_el[i] = V_[i] * psi;
      if (need_M) ev->M[i] = V_[i] * R[l] * P + c_[i] * H[l];
    }
  }
}

void CorotatedSph::checkInversion(const std::vector<Eigen::Vector3d>& x, const Eval& ev) const {
  for (std::size_t i = 0; i < X_.size(); ++i) {
    if (!(ev.det[i] > 0.0)) {
      std::ostringstream s;
      s << "particle " << i << " at " << vecStr(x[i]) << " (rest " << vecStr(X_[i])
        << ") is inverted: det F = " << ev.det[i] << " <= 0";
      throw TopoError("corotated SPH", s.str(),
                      "reduce the time step or stiffen the material; an inverted rest-to-current map is not a valid "
                      "deformation");
    }
  }
}

// out_k = Σ_{j∈N(k)} [ V_k M_j ĝ_jk − V_j M_k ĝ_kj ] (+ hourglass q_kj − q_jk with e_ij = F̃_i X_ji − x_ji):
// the gradient of Σ_i M_i : F̃_i(x) (+ E_hg) for M held fixed; linear in (x, F̃, M) jointly, so
// the same gather with (dx, dF̃, dM) gives the Hessian product.
// Evaluated as (one sweep of row k, the rest-state sums precomputed by prepareGatherConstants):
//   Σ_j V_j M_k ĝ_kj = M_k gsum_k,
//   Σ_j (q_kj − q_jk) = F̃_k hgsum_k + Σ_j [ 2 c_j V_k W_kj F̃_j X_jk − 2 W_kj (c_k V_j + c_j V_k) x_jk ],
// with q_kj = 2 c_k V_j W_kj (F̃_k X_jk − x_jk) and W_jk = W_kj.
void CorotatedSph::gather(const std::vector<Eigen::Vector3d>& x, const std::vector<Eigen::Matrix3d>& Ft,
                          const std::vector<Eigen::Matrix3d>& M, bool hourglass, std::vector<Eigen::Vector3d>* out,
                          bool negate) const {
  const std::size_t n = X_.size();
  out->resize(n);
  const bool hg = hourglass && opt_.hourglass_alpha > 0.0;
  const int* idx = nbr_.indices.data();
#pragma omp parallel for schedule(static)
  for (long long kk = 0; kk < static_cast<long long>(n); ++kk) {
    const std::size_t k = static_cast<std::size_t>(kk);
    const int e0 = nbr_.offsets[k], e1 = nbr_.offsets[k + 1];
    const double Vk = V_[k];
    double a2 = 0;  // Σ_j M_j ĝ_jk (component 2; 0-1 in a01)
    Eigen::Vector3d g;
    if (hg) {
      const Eigen::Vector3d xk = x[k];
      Pair a01 = Pair::Zero(), t01 = Pair::Zero(), u01 = Pair::Zero();  // components 0-1
      double t2 = 0, u2 = 0;
      const Pair xk01 = head2(xk);
      for (int e = e0; e < e1; ++e) {
        const int j = idx[e];
        const double* m = M[j].data();  // column-major
        const double* r = ghr_[e].data();
        a01 += head2(m) * r[0] + head2(m + 3) * r[1] + head2(m + 6) * r[2];
        a2 += m[2] * r[0] + m[5] * r[1] + m[8] * r[2];
        const double* y = hgw_[e].data();  // W_kj c_j X_jk, then W_kj (c_k V_j + c_j V_k)
        const double* f = Ft[j].data();
        t01 += head2(f) * y[0] + head2(f + 3) * y[1] + head2(f + 6) * y[2];
        t2 += f[2] * y[0] + f[5] * y[1] + f[8] * y[2];
        u01 += y[3] * (head2(x[j]) - xk01);
        u2 += y[3] * (x[j].z() - xk.z());
      }
      g = Vk * Eigen::Vector3d(a01(0), a01(1), a2) - M[k] * gsum_[k] + Ft[k] * hgsum_[k] +
          (2.0 * Vk) * Eigen::Vector3d(t01(0), t01(1), t2) - 2.0 * Eigen::Vector3d(u01(0), u01(1), u2);
    } else {
      Pair a01 = Pair::Zero();
      for (int e = e0; e < e1; ++e) {
        const double* m = M[idx[e]].data();
        const double* r = ghr_[e].data();
        a01 += head2(m) * r[0] + head2(m + 3) * r[1] + head2(m + 6) * r[2];
        a2 += m[2] * r[0] + m[5] * r[1] + m[8] * r[2];
      }
      g = Vk * Eigen::Vector3d(a01(0), a01(1), a2) - M[k] * gsum_[k];
    }
    (*out)[k] = negate ? Eigen::Vector3d(-g) : g;
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
    throw TopoError("corotated SPH stress divergence",
                    std::to_string(G.size()) + " matrices for " + std::to_string(X_.size()) + " particles",
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
  return hessianProduct(dx, nullptr, nullptr);
}

std::vector<Eigen::Vector3d> CorotatedSph::hessianProduct(const std::vector<Eigen::Vector3d>& dx,
                                                          std::vector<double>* d_mu,
                                                          std::vector<double>* d_lambda) const {
  checkPositions(dx);
  const std::size_t n = X_.size();
  const bool material = d_mu && d_lambda;
  if (material) {
    d_mu->assign(n, 0.0);
    d_lambda->assign(n, 0.0);
  }
  std::vector<Eigen::Matrix3d> dFt(n), dM(n);
  const bool exact = opt_.rotation == SphRotationSource::CorrectedGradient;
  const bool hourglass = opt_.hourglass_alpha > 0.0;
  const int* idx = nbr_.indices.data();
#pragma omp parallel for schedule(static)
  for (long long ii = 0; ii < static_cast<long long>(n); ++ii) {
    const std::size_t i = static_cast<std::size_t>(ii);
    const int e0 = nbr_.offsets[i], e1 = nbr_.offsets[i + 1];
    const double c = c_[i];
    Eigen::Matrix3d dH = Eigen::Matrix3d::Zero();
    if (hourglass && c > 0.0) {
      // dF̃_i and, in the same sweep, dD_i: dH_i = Σ_j 2 V_j W_ij (dF̃_i X_ji − dx_ji) X_jiᵀ = 2(dF̃_i C_i − dD_i).
      Eigen::Matrix3d dD;
      rowGradientMoment<true>(idx, e0, e1, dx.data(), X_.data(), V_.data(), gh_.data(), W_.data(), dx[i], X_[i],
                              &dFt[i], &dD);
      dH = (2.0 * c) * (dFt[i] * moment_[i] - dD);
    } else {
      dFt[i] = rowGradient(idx, e0, e1, dx.data(), V_.data(), gh_.data(), dx[i]);
    }
    dM[i] = V_[i] * piolaDifferential(opt_.model, exact, Ft_[i], R_[i], dFt[i], mu_[i], lambda_[i]) + dH;
    if (material) materialRow(i, dFt[i], dx, &(*d_mu)[i], &(*d_lambda)[i]);  // row i still in cache
  }
  std::vector<Eigen::Vector3d> out;
  gather(dx, dFt, dM, true, &out);
  return out;
}

void CorotatedSph::materialRow(std::size_t i, const Eigen::Matrix3d& dFt, const std::vector<Eigen::Vector3d>& w,
                               double* d_mu, double* d_lambda) const {
  // ∂E_i/∂μ_i and ∂E_i/∂λ_i as functions of x; their derivative along w. M̂ = R P(F) per unit modulus.
  const Eigen::Matrix3d Pmu = R_[i] * sphFirstPiola(opt_.model, F_[i], 1.0, 0.0);
  const Eigen::Matrix3d Plam = R_[i] * sphFirstPiola(opt_.model, F_[i], 0.0, 1.0);
  double hg = 0.0;
  const double c = opt_.hourglass_alpha * V_[i] / (h_ * h_);
  if (c > 0.0) {
    for (int e = nbr_.offsets[i]; e < nbr_.offsets[i + 1]; ++e) {
      const int j = nbr_.indices[e];
      const Eigen::Vector3d Xji = X_[j] - X_[i];
      const Eigen::Vector3d err = Ft_[i] * Xji - (x_[j] - x_[i]);
      const Eigen::Vector3d derr = dFt * Xji - (w[j] - w[i]);
      hg += 2.0 * V_[j] * W_[e] * err.dot(derr);
    }
  }
  *d_mu = V_[i] * (Pmu.array() * dFt.array()).sum() + c * hg;
  *d_lambda = V_[i] * (Plam.array() * dFt.array()).sum();
}

void CorotatedSph::materialDirectional(const std::vector<Eigen::Vector3d>& w, std::vector<double>* d_mu,
                                       std::vector<double>* d_lambda) const {
  checkPositions(w);
  const std::size_t n = X_.size();
  std::vector<Eigen::Matrix3d> dFt;
  computeFtilde(w, &dFt);
  d_mu->assign(n, 0.0);
  d_lambda->assign(n, 0.0);
#pragma omp parallel for schedule(static)
  for (long long ii = 0; ii < static_cast<long long>(n); ++ii) {
    const std::size_t i = static_cast<std::size_t>(ii);
    materialRow(i, dFt[i], w, &(*d_mu)[i], &(*d_lambda)[i]);
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
    throw TopoError("corotated SPH material",
                    std::to_string(mu.size()) + " mu and " + std::to_string(lambda.size()) + " lambda values for " +
                        std::to_string(X_.size()) + " particles",
                    "give one material per particle");
  for (std::size_t i = 0; i < mu.size(); ++i)
    if (!std::isfinite(mu[i]) || mu[i] <= 0.0 || !std::isfinite(lambda[i]))
      throw TopoError("corotated SPH material",
                      "particle " + std::to_string(i) + " has mu = " + std::to_string(mu[i]) +
                          ", lambda = " + std::to_string(lambda[i]),
                      "mu must be positive and lambda finite");
  mu_ = mu;
  lambda_ = lambda;
  prepareGatherConstants();
  update(x_);
}

void CorotatedSph::store(const std::vector<Eigen::Vector3d>& x, bool with_forces) {
  Eval& ev = scratch_.ev;
  if (with_forces) gather(x, ev.Ft, ev.M, true, &f_, true);  // f = −∂E/∂x
  forces_valid_ = with_forces;
  x_ = x;
  F_.swap(ev.F);  // the previous state's buffers become the next call's scratch
  Ft_.swap(ev.Ft);
  P_.swap(ev.P);
  double eel = 0.0;  // serial sum: deterministic
  for (std::size_t i = 0; i < X_.size(); ++i) eel += ev.e_el[i];
  elastic_energy_ = eel;
  hourglass_valid_ = opt_.hourglass_alpha <= 0.0;  // summed on request (hourglassEnergy())
  hourglass_energy_ = 0.0;
}

const std::vector<Eigen::Vector3d>& CorotatedSph::forces() const {
  if (!forces_valid_)
    throw TopoError("corotated SPH forces", "requested after updateState(), which does not compute them",
                    "call update(x) for the forces at x");
  return f_;
}

double CorotatedSph::hourglassEnergy() const {
  if (hourglass_valid_) return hourglass_energy_;
  // E_hg = Σ_i c_i Σ_j V_j W_ij |F̃_i X_ji − x_ji|² at the last update(), summed directly: the
  // forces' form 2(F̃_i C_i − D_i) would cancel to round-off of |x_ji|² here.
  const std::size_t n = X_.size();
  std::vector<double>& e = scratch_.ev.e_hg;
  e.resize(n);
  const int* idx = nbr_.indices.data();
#pragma omp parallel for schedule(static)
  for (long long ii = 0; ii < static_cast<long long>(n); ++ii) {
    const std::size_t i = static_cast<std::size_t>(ii);
    e[i] = c_[i] > 0.0 ? c_[i] * rowHourglass<false>(idx, nbr_.offsets[i], nbr_.offsets[i + 1], x_.data(), X_.data(),
                                                     V_.data(), W_.data(), Ft_[i], x_[i], X_[i], nullptr)
                       : 0.0;
  }
  double ehg = 0.0;  // serial sum: deterministic
  for (std::size_t i = 0; i < n; ++i) ehg += e[i];
  hourglass_energy_ = ehg;
  hourglass_valid_ = true;
  return ehg;
}

void CorotatedSph::update(const std::vector<Eigen::Vector3d>& x) { evaluateAndStore(x, EvalMode::Forces); }

void CorotatedSph::updateState(const std::vector<Eigen::Vector3d>& x) { evaluateAndStore(x, EvalMode::State); }

void CorotatedSph::evaluateAndStore(const std::vector<Eigen::Vector3d>& x, EvalMode mode) {
  checkPositions(x);
  evaluate(x, nullptr, &scratch_.R, &scratch_.ev, mode);
  checkInversion(x, scratch_.ev);
  R_.swap(scratch_.R);
  store(x, mode == EvalMode::Forces);
}

void CorotatedSph::updateWithRotations(const std::vector<Eigen::Vector3d>& x, const std::vector<Eigen::Matrix3d>& R) {
  checkPositions(x);
  evaluate(x, &R, nullptr, &scratch_.ev, EvalMode::Forces);
  checkInversion(x, scratch_.ev);
  R_ = R;
  store(x, true);
}

double CorotatedSph::energyWithRotations(const std::vector<Eigen::Vector3d>& x,
                                         const std::vector<Eigen::Matrix3d>& R) const {
  checkPositions(x);
  Eval ev;
  evaluate(x, &R, nullptr, &ev, EvalMode::Energy);
  checkInversion(x, ev);
  double e = 0.0;
  for (std::size_t i = 0; i < X_.size(); ++i) e += ev.e_el[i] + ev.e_hg[i];
  return e;
}

}  // namespace topo_gaussian
