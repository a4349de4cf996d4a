// Rest stiffness of corotated SPH, assembled as a sparse matrix, and the preconditioner built from
// its sparse Cholesky factor.
//
// At the rest state (F̃_i = I, R_i = I, zero stress) both energy models linearise to linear
// elasticity, ψ = μ ε:ε + λ/2 tr(ε)² with ε = sym(∇u), and the hourglass term is quadratic anyway,
// so K0 = ∂²E/∂x² at rest is exactly
//   elastic:   K_kl += V_i [ μ_i (c_k·c_l) I + μ_i c_l c_kᵀ + λ_i c_k c_lᵀ ]
//   hourglass: K_kl += 2 (α μ_i V_i / h²) Σ_j w_ij a_jk a_jl I
// for k, l ∈ {i} ∪ N(i), with F̃_i = Σ_k x_k c_kᵀ (c_j = V_j ĝ_ij, c_i = −Σ_j c_j), w_ij = V_j W_ij
// and F̃_i X_ji − x_ji = Σ_k a_jk x_k. K0 couples particles up to two neighbourhoods apart.
//
// Why: the slender, stiff-walled finger with a soft pressurised chamber makes Jacobi-PCG take
// thousands of iterations per Newton step (bending modes, material contrast, λ ≫ μ). K0 is the
// same discrete operator at rest, so with its Cholesky factor as the preconditioner CG only has
// to resolve what changed since the rest state (rotations, large strain, the pressure term,
// contact): tens of iterations instead of thousands. Its cost is one sparse factorisation per
// material: CHOLMOD's supernodal Cholesky (with BLAS) when the build found SuiteSparse, else
// Eigen's SimplicialLDLT (AMD ordering), same result, several times slower. Memory grows with the
// fill: the symbolic analysis predicts the factor's size before any value is computed, and a
// preconditioner whose K0 and factor would exceed the caller's byte limit is refused, K0 already
// before it is assembled (SoftBodyOptions::cholesky_max_factor_bytes; the simulator then falls back
// to Jacobi and says why in preconditionerNote()).
#pragma once

#include <Eigen/Core>
#include <Eigen/Sparse>
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/physics/corotated_sph.h"

namespace topo_gaussian {

/// K0 (3N × 3N, symmetric, both triangles stored) for the sph's current Lamé parameters.
Eigen::SparseMatrix<double> restStiffness(const CorotatedSph& sph);

/// A Cholesky factorisation computed outside this library: the GPU's dense one under backend cuda
/// (cuda/dense_cholesky_cuda.h), which the physics cannot call itself (module layering).
class CholeskySolver {
 public:
  virtual ~CholeskySolver() = default;
  /// Factorises the symmetric matrix whose lower triangle (row ≥ column, compressed columns) is given;
  /// false when it is not positive definite (as the host's factor would find). Throws TopoError when it
  /// cannot try (too little memory, naming how many particles fit; no device; a device error).
  virtual bool factorize(const Eigen::SparseMatrix<double>& lower) = 0;
  /// z = A⁻¹ r.
  virtual void solve(const Eigen::VectorXd& r, Eigen::VectorXd* z) const = 0;
  /// Where it runs, for notes: e.g. "dense Cholesky (cuSOLVER) on NVIDIA H100 80GB HBM3".
  virtual std::string name() const = 0;
  /// Memory its factor takes where it runs [bytes].
  virtual double bytes() const = 0;
  /// Seconds solve() spent on other work than applying the factor (e.g. inverting it in place once).
  virtual double extraSeconds() const { return 0.0; }
};
using CholeskySolverFactory = std::function<std::unique_ptr<CholeskySolver>()>;

/// The external factorisation was required (RestStiffnessPreconditioner's external_required) and could
/// not be made: its TopoError's text. The simulator stops on it instead of falling back.
class ExternalFactorRefused : public TopoError {
 public:
  using TopoError::TopoError;
};

class RestStiffnessPreconditioner {
 public:
  /// Factorises K0 + diag(shift) with the rows and columns of fixed particles (fixed[i] != 0)
  /// replaced by the identity. shift: 3N entries ≥ 0 (e.g. inertia m_i/dt²) or empty. Throws
  /// TopoError when the factorisation fails (K0 singular: a body with no support and no shift).
  /// max_factor_bytes > 0: throws TopoError when the preconditioner would take more memory than
  /// that: before assembling, when K0 alone would (estimated from the mean neighbour count: K0
  /// couples about 8 × one neighbourhood); before factorising, when K0 (12 bytes an entry) and the
  /// factor the symbolic analysis predicts (8 bytes an entry) would.
  /// external (optional): factorise there instead (the GPU); when it throws, the host factorises
  /// as without it and externalNote() says why (external_required: ExternalFactorRefused with its text
  /// instead). A matrix it finds not positive definite is refused as the host's factor refuses one.
  RestStiffnessPreconditioner(const CorotatedSph& sph, const Eigen::VectorXd& shift,
                              const std::vector<std::uint8_t>& fixed, double max_factor_bytes = 0.0,
                              const CholeskySolverFactory& external = nullptr, bool external_required = false);
  ~RestStiffnessPreconditioner();
  /// z = (K0 + diag(shift))⁻¹ r.
  void apply(const Eigen::VectorXd& r, Eigen::VectorXd* z) const;
  std::size_t nonZeros() const { return nnz_; }
  double factorSeconds() const { return seconds_; }
  /// How often apply() ran, and its seconds in all without the external solver's other work
  /// (extraSeconds(): rest_factor_reuse.h weighs them against a new factor).
  long applications() const { return applications_.load(); }
  double applySeconds() const { return 1e-9 * static_cast<double>(apply_ns_.load()) - extraSeconds(); }
  /// The external solver's seconds on other work than applications (its in-place inverse); 0 on the host.
  double extraSeconds() const { return external_ ? external_->extraSeconds() : 0.0; }
  /// True once an apply() threw: the factor is not to be used again (a kept factor is dropped).
  bool failed() const { return failed_.load(); }
  /// The factor's numerical values [bytes], as the symbolic analysis predicted them.
  double factorBytes() const { return factor_bytes_; }
  /// Peak memory of assembling K0's lower triangle [bytes], estimated before it is assembled: 21
  /// bytes (12 in K0, the rest in the rows being built) for each of 4.5 entries a particle pair within
  /// two neighbourhoods, taken as min(N, 8 × (mean neighbours + 1)) pairs a particle.
  static double assemblyBytesEstimate(const CorotatedSph& sph);
  /// The factor and the assembled K0 [bytes] in host memory: what max_factor_bytes bounds (an external
  /// factor is not counted: it lives where it runs).
  double memoryBytes() const { return factor_bytes_ + matrix_bytes_; }
  /// Where the factor is: "host: cholmod-supernodal" or the external solver's name().
  std::string where() const;
  /// Why the external factorisation was refused (the host's was used instead); empty otherwise.
  const std::string& externalNote() const { return external_note_; }
  /// "cholmod-supernodal" or "eigen-simplicial-ldlt".
  static std::string backend();
  /// True when the symbolic analysis (ordering) was taken over from a destroyed preconditioner of
  /// the same sparsity pattern (one is kept process-wide), so only the numeric factorisation ran.
  bool reusedAnalysis() const { return reused_analysis_; }

  struct Factor;   ///< the factorisation (backend-specific)
  struct Pattern;  ///< a sparsity pattern (the key of the symbolic analysis)

 private:
  std::unique_ptr<Factor> factor_;
  std::unique_ptr<Pattern> pattern_;
  std::unique_ptr<CholeskySolver> external_;
  std::string external_note_;
  bool reused_analysis_ = false;
  std::size_t nnz_ = 0;
  double seconds_ = 0.0;
  double factor_bytes_ = 0.0;
  double matrix_bytes_ = 0.0;
  mutable std::atomic<long> applications_{0};
  mutable std::atomic<bool> failed_{false};
  mutable std::atomic<long long> apply_ns_{0};
};

/// Physical memory available to this process now [bytes] (Linux MemAvailable; 0 when unknown).
double availableMemoryBytes();

}  // namespace topo_gaussian
