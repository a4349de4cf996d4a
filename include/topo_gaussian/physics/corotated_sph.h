// Corotated SPH elasticity (Becker, Ihmsen & Teschner 2009) as used by the TopoGaussian paper
// (appendix "Soft body dynamics"): cubic spline kernel, rest neighbourhoods fixed at construction,
// per-particle rotation R_i from the polar decomposition of A_pq,i, deformation gradient
// F_i = I + ∇u_i with u_ji = R_iᵀ(x_j − x_i) − (X_j − X_i), and a St. Venant–Kirchhoff (Green
// strain) or corotated linear (Cauchy strain) energy E = Σ_i V_i ψ(F_i), plus a zero-energy-mode
// (hourglass) penalty.
//
// Notation: X rest positions, x current positions, X_ji = X_j − X_i, x_ji = x_j − x_i,
// W_ij = W(X_ji, h), ĝ_ij = L_i ∇W(X_ji, h) the corrected kernel gradient.
// Structure of arrays; neighbourhoods in CSR form (NeighborList). No ROS / PCL / OpenCV.
#pragma once

#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

#include "topo_gaussian/physics/neighbor_list.h"
#include "topo_gaussian/physics/volume_cloud.h"

namespace topo_gaussian {

enum class SphEnergyModel {
  StVK,             ///< ψ = μ ε:ε + λ/2 tr(ε)², ε = ½(FᵀF − I)   (Green strain)
  CorotatedLinear,  ///< ψ = μ ε:ε + λ/2 tr(ε)², ε = ½(F + Fᵀ) − I (Cauchy strain)
};

/// Where R_i comes from.
enum class SphRotationSource {
  /// Paper / Becker 2009: polar decomposition of A_pq,i = Σ_j m_j W_ij x_ji X_jiᵀ. Exact for rigid
  /// motions; for a pure stretch S it gives R_i = I only where Σ_j m_j W_ij X_ji X_jiᵀ commutes with
  /// S (interior and face particles of an axis-aligned box, not edges/corners).
  ShapeMatchingApq,
  /// Polar decomposition of the corrected deformation gradient F̃_i = Σ_j V_j x_ji ĝ_ijᵀ: then
  /// F_i = R_iᵀF̃_i is the symmetric stretch on every particle for every affine deformation.
  CorrectedGradient,
};

struct LameParameters {
  double mu = 0.0;      ///< shear modulus μ [Pa]
  double lambda = 0.0;  ///< first Lamé parameter λ [Pa]
};

/// μ = E / (2(1+ν)), λ = E ν / ((1+ν)(1−2ν)). Throws TopoError for E ≤ 0, ν ∉ (−1, 0.5) or
/// non-finite values.
LameParameters lameFromYoung(double youngs_modulus, double poisson_ratio);

/// Strain energy density ψ(F) of a model (per unit rest volume).
double sphStrainEnergyDensity(SphEnergyModel model, const Eigen::Matrix3d& F, double mu, double lambda);
/// First Piola–Kirchhoff stress P = ∂ψ/∂F.
Eigen::Matrix3d sphFirstPiola(SphEnergyModel model, const Eigen::Matrix3d& F, double mu, double lambda);

struct CorotatedSphOptions {
  /// Smoothing length h [m]; ≤ 0 picks smoothing_factor × spacing.
  double smoothing_length = 0.0;
  double smoothing_factor = 1.5;
  /// Lattice spacing [m] (fromCloud: the volume's); ≤ 0 derives it with spacingFromVolumes (∛ median V_i).
  double spacing = 0.0;
  /// Mass density ρ0 [kg/m³]: m_i = ρ0 V_i (used for A_pq and the SPH rest density).
  double density = 1000.0;
  SphEnergyModel model = SphEnergyModel::StVK;
  SphRotationSource rotation = SphRotationSource::ShapeMatchingApq;
  /// Hourglass weight α in E_hg = Σ_i Σ_j V_i V_j W_ij (α μ_i / h²) |F̃_i X_ji − x_ji|².
  /// Σ_j V_j W_ij ≈ 1 and the non-affine part of x_ji is O(h |∇u|), so α is roughly the stiffness
  /// of the zero-energy modes relative to μ. 0.1 suppresses them while changing affine (and nearly
  /// affine) response not at all: E_hg vanishes exactly for every affine deformation.
  double hourglass_alpha = 0.1;
  /// Consistency order of the kernel gradient ĝ_ij (F̃_i = Σ_j V_j x_ji ĝ_ijᵀ):
  /// 1 = corrected kernel gradient L_i ∇W_ij (exact for linear fields, the paper's choice);
  /// 2 = moving-least-squares gradient with a quadratic basis (exact for quadratic fields, so pure
  ///     bending is exact even where the neighbourhood is one-sided: the outer fibres of a beam).
  ///     Particles whose neighbourhood cannot support a quadratic fit (too few / degenerate
  ///     neighbours) fall back to order 1. F̃ stays linear in x, so forces and Hessians are unchanged.
  int gradient_order = 1;
};

class CorotatedSph {
 public:
  /// Per-particle material. Throws TopoError for size mismatches, non-finite / non-positive input,
  /// a particle with no neighbour within 2h, or a degenerate (coplanar) neighbourhood.
  CorotatedSph(const std::vector<Eigen::Vector3d>& X, const std::vector<double>& V, const std::vector<double>& mu,
               const std::vector<double>& lambda, const CorotatedSphOptions& options = CorotatedSphOptions());
  /// Uniform material.
  CorotatedSph(const std::vector<Eigen::Vector3d>& X, const std::vector<double>& V, LameParameters material,
               const CorotatedSphOptions& options = CorotatedSphOptions());
  /// From a volume cloud (its spacing is used unless options.spacing is set).
  static CorotatedSph fromCloud(const VolumeCloud& cloud, LameParameters material,
                                CorotatedSphOptions options = CorotatedSphOptions());

  // ------------------------------------------------------------ rest state
  std::size_t size() const { return X_.size(); }
  double smoothingLength() const { return h_; }
  const CorotatedSphOptions& options() const { return opt_; }
  const NeighborList& neighbors() const { return nbr_; }
  int neighborCount(std::size_t i) const { return nbr_.count(i); }
  const std::vector<Eigen::Vector3d>& restPositions() const { return X_; }
  const std::vector<double>& volumes() const { return V_; }
  const std::vector<double>& masses() const { return m_; }
  /// SPH rest density ρ_i = Σ_j m_j W(X_ij, h) (self included); below ρ0 near the boundary.
  const std::vector<double>& restDensity() const { return rho_; }
  /// Correction matrix L_i = (Σ_j V_j ∇W(X_ji) X_jiᵀ)⁻¹.
  const Eigen::Matrix3d& correction(std::size_t i) const { return L_[i]; }
  /// Per-particle shear modulus μ_i and first Lamé parameter λ_i [Pa].
  const std::vector<double>& shearModuli() const { return mu_; }
  const std::vector<double>& lameLambdas() const { return lambda_; }
  /// Per CSR entry e (i→j) of neighbors(): the kernel value W_ij and the corrected gradient ĝ_ij
  /// (order 1 or 2), so that F̃_i = Σ_j V_j x_ji ĝ_ijᵀ (used to assemble the rest stiffness).
  const std::vector<double>& kernelValues() const { return W_; }
  const std::vector<Eigen::Vector3d>& kernelGradients() const { return gh_; }
  /// Particles that asked for gradient_order 2 but fell back to order 1 (too few neighbours).
  std::size_t linearFallbacks() const { return linear_fallbacks_; }
  /// Rest constants of the force gather (see gather() in corotated_sph.cpp), for backends that
  /// reproduce it (cuda/soft_body_cuda.h): c_i = α μ_i V_i / h², Σ_j V_j ĝ_ij, Σ_j 2 c_i V_j W_ij X_ji,
  /// per CSR entry k→j the reverse gradient ĝ_jk and the hourglass weights (W_kj c_j X_jk,
  /// W_kj (c_k V_j + c_j V_k)), and C_i = Σ_j V_j W_ij X_ji X_jiᵀ (empty when hourglass_alpha = 0).
  const std::vector<double>& hourglassCoefficients() const { return c_; }
  const std::vector<Eigen::Vector3d>& gradientSums() const { return gsum_; }
  const std::vector<Eigen::Vector3d>& hourglassSums() const { return hgsum_; }
  const std::vector<Eigen::Vector3d>& reverseKernelGradients() const { return ghr_; }
  const std::vector<std::array<double, 4>>& hourglassWeights() const { return hgw_; }
  const std::vector<Eigen::Matrix3d>& restMoments() const { return moment_; }

  // ------------------------------------------------------------ deformed state
  /// Rotations R_i for positions x (per options.rotation).
  std::vector<Eigen::Matrix3d> computeRotations(const std::vector<Eigen::Vector3d>& x) const;
  /// Evaluates R, F, P, energies and forces at x. Throws TopoError for a size mismatch, a
  /// non-finite position or an inverted particle (det F_i ≤ 0).
  void update(const std::vector<Eigen::Vector3d>& x);
  /// As update() but without the forces (the gather, about a third of update()'s time): the state
  /// at x for hessianProduct(), materialDirectional() and the energies, where the forces at x are
  /// already known (adjoint sweeps). forces() throws until the next update().
  void updateState(const std::vector<Eigen::Vector3d>& x);
  /// As update() but with the rotations given (held fixed).
  void updateWithRotations(const std::vector<Eigen::Vector3d>& x, const std::vector<Eigen::Matrix3d>& R);
  /// Total energy (elastic + hourglass) at x with rotations R held fixed; does not touch the state.
  /// Forces are exactly −∂/∂x of this function (used by the finite-difference tests).
  double energyWithRotations(const std::vector<Eigen::Vector3d>& x, const std::vector<Eigen::Matrix3d>& R) const;

  // ------------------------------------------------------------ derivatives (at the last update())
  /// Σ_j V_j u_ji ĝ_ijᵀ for a per-particle field u (F̃ when u = x; linear in u).
  std::vector<Eigen::Matrix3d> gradientField(const std::vector<Eigen::Vector3d>& u) const;
  /// ∂/∂x_k of Σ_i G_i : F̃_i(x) for per-particle matrices G_i held fixed (no hourglass term): the
  /// force of any energy Σ_i φ_i(F̃_i) is −stressDivergence(∂φ_i/∂F̃_i).
  std::vector<Eigen::Vector3d> stressDivergence(const std::vector<Eigen::Matrix3d>& G) const;
  /// H·dx with H = ∂²E/∂x² at the last update() (so the force changes by −H·dx). Exact for StVK
  /// (rotation-invariant) and for CorotatedLinear with SphRotationSource::CorrectedGradient (the
  /// derivative of the polar rotation is included); with ShapeMatchingApq rotations it holds R
  /// fixed (the rotation's derivative is not available), an approximation.
  std::vector<Eigen::Vector3d> hessianProduct(const std::vector<Eigen::Vector3d>& dx) const;
  /// hessianProduct(dx) and, in the same pass (F̃ of dx swept once), materialDirectional(dx, d_mu,
  /// d_lambda): what an explicit adjoint step needs for one vector.
  std::vector<Eigen::Vector3d> hessianProduct(const std::vector<Eigen::Vector3d>& dx, std::vector<double>* d_mu,
                                              std::vector<double>* d_lambda) const;
  /// Mixed derivatives for adjoints: d_mu[i] = w · ∂²E/∂x∂μ_i, d_lambda[i] = w · ∂²E/∂x∂λ_i.
  void materialDirectional(const std::vector<Eigen::Vector3d>& w, std::vector<double>* d_mu,
                           std::vector<double>* d_lambda) const;
  /// ∂E/∂μ_i and ∂E/∂λ_i at the last update() (E is linear in the Lamé parameters).
  void materialEnergies(std::vector<double>* e_mu, std::vector<double>* e_lambda) const;
  /// Replace the per-particle Lamé parameters (neighbourhoods kept) and re-evaluate at the last x.
  void setMaterial(const std::vector<double>& mu, const std::vector<double>& lambda);
  /// Positions of the last update().
  const std::vector<Eigen::Vector3d>& positions() const { return x_; }

  double energy() const { return elastic_energy_ + hourglassEnergy(); }
  double elasticEnergy() const { return elastic_energy_; }
  /// Summed on the first request after an update() (one sweep of the neighbourhoods; the forces
  /// do not need it), then cached.
  double hourglassEnergy() const;
  /// f = −∂E/∂x with R held fixed (at the last update(); throws after updateState()).
  const std::vector<Eigen::Vector3d>& forces() const;
  const Eigen::Matrix3d& F(std::size_t i) const { return F_[i]; }  ///< unrotated F_i = I + ∇u_i
  const Eigen::Matrix3d& R(std::size_t i) const { return R_[i]; }
  const Eigen::Matrix3d& stress(std::size_t i) const { return P_[i]; }  ///< P_i = ∂ψ/∂F (unrotated)
  /// Corrected full deformation gradient F̃_i = Σ_j V_j x_ji ĝ_ijᵀ = R_i F_i.
  const Eigen::Matrix3d& deformationGradient(std::size_t i) const { return Ft_[i]; }

 private:
  struct Eval {
    std::vector<Eigen::Matrix3d> F, Ft, P, M;
    std::vector<double> e_el, e_hg, det;
  };
  /// Buffers reused by update() / updateWithRotations() from call to call (no per-step
  /// allocation). Never copied: a copied body starts with empty scratch.
  struct Scratch {
    Eval ev;
    std::vector<Eigen::Matrix3d> R;
    Scratch() = default;
    Scratch(const Scratch&) {}
    Scratch& operator=(const Scratch&) { return *this; }
    Scratch(Scratch&&) = default;
    Scratch& operator=(Scratch&&) = default;
  };
  /// What evaluate() computes besides F̃, R, F, P and the elastic energies: M_i for the forces'
  /// gather, the hourglass energy summed directly, or nothing more (the state alone).
  enum class EvalMode { Forces, Energy, State };
  bool quadraticGradient(std::size_t i);
  /// materialDirectional()'s entry i, given dF̃_i = F̃(w)_i.
  void materialRow(std::size_t i, const Eigen::Matrix3d& dFt, const std::vector<Eigen::Vector3d>& w, double* d_mu,
                   double* d_lambda) const;
  /// Per-particle constants of the force gather (c_, gsum_, hgsum_); rebuilt when μ changes.
  void prepareGatherConstants();
  void checkPositions(const std::vector<Eigen::Vector3d>& x) const;
  void computeFtilde(const std::vector<Eigen::Vector3d>& x, std::vector<Eigen::Matrix3d>* Ft) const;
  /// One pass over the particles: F̃_i, the rotation R_i (from F̃_i or A_pq,i when R_given is null,
  /// written to *R_out; else R_given is used), F_i, P_i, energies and what the mode asks for (see
  /// EvalMode). Does not check det F_i.
  void evaluate(const std::vector<Eigen::Vector3d>& x, const std::vector<Eigen::Matrix3d>* R_given,
                std::vector<Eigen::Matrix3d>* R_out, Eval* ev, EvalMode mode) const;
  /// Throws for the first particle with det F_i ≤ 0.
  void checkInversion(const std::vector<Eigen::Vector3d>& x, const Eval& ev) const;
  /// update() (Forces) and updateState() (State): evaluate at x, check, store.
  void evaluateAndStore(const std::vector<Eigen::Vector3d>& x, EvalMode mode);
  /// Moves the scratch evaluation (and rotations) into the state; with_forces: forces from ev.M.
  void store(const std::vector<Eigen::Vector3d>& x, bool with_forces);
  void gather(const std::vector<Eigen::Vector3d>& x, const std::vector<Eigen::Matrix3d>& Ft,
              const std::vector<Eigen::Matrix3d>& M, bool hourglass, std::vector<Eigen::Vector3d>* out,
              bool negate = false) const;

  CorotatedSphOptions opt_;
  double h_ = 0.0;
  std::vector<Eigen::Vector3d> X_;
  std::vector<double> V_, m_, rho_, mu_, lambda_;
  NeighborList nbr_;
  std::vector<double> W_;            ///< per CSR entry: W_ij
  std::vector<Eigen::Vector3d> gh_;  ///< per CSR entry: ĝ_ij = L_i ∇W(X_ji)
  std::vector<Eigen::Matrix3d> L_;
  std::size_t linear_fallbacks_ = 0;

  // Gather constants (see gather()): c_i = α μ_i V_i / h², gsum_i = Σ_j V_j ĝ_ij,
  // hgsum_i = Σ_j 2 c_i V_j W_ij X_ji.
  // ghr_: per CSR entry (k→j) the reverse entry's gradient ĝ_jk (rest constant), so that the
  // gather streams it instead of looking it up in row j.
  std::vector<double> c_;
  std::vector<Eigen::Vector3d> gsum_, hgsum_, ghr_;
  /// Per CSR entry (k→j): the gather's hourglass weights (W_kj c_j X_jk, W_kj (c_k V_j + c_j V_k)).
  std::vector<std::array<double, 4>> hgw_;
  std::vector<Eigen::Matrix3d> moment_;  ///< C_i = Σ_j V_j W_ij X_ji X_jiᵀ (with the hourglass term)
  mutable Scratch scratch_;              ///< mutable: hourglassEnergy() sums into scratch_.ev.e_hg

  std::vector<Eigen::Matrix3d> R_, F_, Ft_, P_;
  std::vector<Eigen::Vector3d> f_, x_;
  double elastic_energy_ = 0.0;
  bool forces_valid_ = true;
  mutable double hourglass_energy_ = 0.0;  ///< valid when hourglass_valid_ (see hourglassEnergy())
  mutable bool hourglass_valid_ = true;
};

}  // namespace topo_gaussian
