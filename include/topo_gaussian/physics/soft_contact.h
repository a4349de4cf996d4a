// Penalty contact of soft-body particles with rigid obstacles (paper §"Collision model"): the
// ground (a half-space) and a rigid clamp (an axis-aligned solid box). For each contact particle i
// and obstacle with signed distance φ(x) (positive outside the obstacle) and margin δ:
//
//   E_c = ½ k Σ_i min(φ(x_i) − δ, 0)²                        (conservative, exact Hessian k n nᵀ)
//   f_friction,i = −μ f_n,i v_t,i / √(|v_t,i|² + ε²)          (smoothed Coulomb, f_n = k·penetration)
//
// Friction depends on the velocity, so it is not part of the potential: explicit steps evaluate it
// at the current state, implicit steps lag it (evaluated at the start of the step). Its derivatives
// are local to the particle (exact, used by the adjoints). The box's normal is piecewise constant
// (the face of least penetration), so its Hessian is exact away from edges.
//
// Embedded contact samples (contact_embedding.h): with an embedding, the contact points
// are not particles but samples k on the object's true surface, y_k = Σ_i φ_ki x_i, each with a
// weight ω_k (area over h²):
//
//   E_c = ½ k Σ_k ω_k min(φ(y_k) − δ, 0)²,          f_i = Σ_k φ_ki f_k   (f_k = −∂E_c/∂y_k)
//   ∂²E_c/∂x_i∂x_j = Σ_k φ_ki φ_kj k ω_k n_k n_kᵀ,  friction f_k(y_k, v_k) with v_k = Σ_i φ_ki v_i
//
// and every derivative (Hessian products, its diagonal, the friction adjoint) goes through the same
// weights and their transposes (serially, over the samples near an obstacle: ContactEmbedding::
// nearBand()). Without an embedding the particles (optionally masked) are the
// contact points with ω = 1, exactly as before.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <vector>

#include "topo_gaussian/physics/contact_embedding.h"

namespace topo_gaussian {

struct ContactObstacle {
  enum class Kind { HalfSpace, Box } kind = Kind::HalfSpace;
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();                           ///< HalfSpace: outward unit normal
  double offset = 0.0;                                                         ///< HalfSpace: φ(x) = n·x − offset
  Eigen::Vector3d lo = Eigen::Vector3d::Zero(), hi = Eigen::Vector3d::Zero();  ///< Box corners

  static ContactObstacle ground(double height = 0.0);
  static ContactObstacle box(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi);
  /// Signed distance and its gradient (unit normal).
  double distance(const Eigen::Vector3d& x, Eigen::Vector3d* n) const;
};

struct SoftContactOptions {
  double stiffness = 0.0;       ///< k [N/m] per particle; ≤ 0 = automatic (set by the simulator)
  double friction = 0.5;        ///< Coulomb coefficient μ
  double slip_velocity = 1e-3;  ///< ε [m/s]: friction regularisation (stick below ~ε)
  double margin = 0.0;          ///< δ [m]: contact starts at φ = δ (e.g. half the spacing)
};

class SoftContact {
 public:
  SoftContact() = default;
  SoftContact(std::vector<ContactObstacle> obstacles, const SoftContactOptions& options,
              std::vector<std::uint8_t> mask = {});
  /// Contact on embedded samples (see above) instead of the particles. Throws TopoError for a null
  /// or empty embedding.
  SoftContact(std::vector<ContactObstacle> obstacles, const SoftContactOptions& options,
              std::shared_ptr<const ContactEmbedding> embedding);
  bool empty() const { return obstacles_.empty(); }
  /// True when the contact points are embedded samples.
  bool embedded() const { return static_cast<bool>(emb_); }
  /// The embedding (null without one).
  const std::shared_ptr<const ContactEmbedding>& embedding() const { return emb_; }
  /// Positions of the contact points for particle positions x: the embedded samples y_k, or the
  /// candidate particles (mask) without an embedding.
  std::vector<Eigen::Vector3d> contactPositions(const std::vector<Eigen::Vector3d>& x) const;
  const SoftContactOptions& options() const { return opt_; }
  void setStiffness(double k) { opt_.stiffness = k; }
  const std::vector<ContactObstacle>& obstacles() const { return obstacles_; }
  /// Which particles may touch (empty = all).
  const std::vector<std::uint8_t>& mask() const { return mask_; }

  double energy(const std::vector<Eigen::Vector3d>& x) const;
  /// f += normal (conservative) forces −∂E_c/∂x.
  void addNormalForces(const std::vector<Eigen::Vector3d>& x, std::vector<Eigen::Vector3d>* f) const;
  /// f += friction forces for velocities v.
  void addFrictionForces(const std::vector<Eigen::Vector3d>& x, const std::vector<Eigen::Vector3d>& v,
                         std::vector<Eigen::Vector3d>* f) const;
  /// out += (∂²E_c/∂x²) dx.
  void addHessianProduct(const std::vector<Eigen::Vector3d>& x, const std::vector<Eigen::Vector3d>& dx,
                         std::vector<Eigen::Vector3d>* out) const;
  /// diag += the diagonal of ∂²E_c/∂x² (3 per particle).
  void addHessianDiagonal(const std::vector<Eigen::Vector3d>& x, std::vector<Eigen::Vector3d>* diag) const;
  /// Adjoint of the friction force: given a (per particle), x̄ += (∂f_fr/∂x)ᵀa, v̄ += (∂f_fr/∂v)ᵀa.
  void frictionAdjoint(const std::vector<Eigen::Vector3d>& x, const std::vector<Eigen::Vector3d>& v,
                       const std::vector<Eigen::Vector3d>& a, std::vector<Eigen::Vector3d>* x_bar,
                       std::vector<Eigen::Vector3d>* v_bar) const;
  /// Contact points (particles, or embedded samples) in contact at x.
  std::size_t activeCount(const std::vector<Eigen::Vector3d>& x) const;

 private:
  bool candidate(std::size_t i) const { return mask_.empty() || mask_[i]; }
  void validate() const;
  /// Without an embedding: calls f(i, n, fn) for every active contact of a candidate particle
  /// (fn = k · penetration > 0), in parallel.
  template <class F>
  void forEachContact(const std::vector<Eigen::Vector3d>& x, F&& f) const;
  /// With an embedding: calls f(k, n, fn, k ω_k) for every active contact of sample k at y_k(x).
  template <class F>
  void forEachSampleContact(const std::vector<Eigen::Vector3d>& x, F&& f) const;
  std::vector<ContactObstacle> obstacles_;
  SoftContactOptions opt_;
  std::vector<std::uint8_t> mask_;
  std::shared_ptr<const ContactEmbedding> emb_;
};

}  // namespace topo_gaussian
