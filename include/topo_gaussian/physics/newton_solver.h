// Matrix-free Newton minimisation with preconditioned conjugate gradients and a backtracking
// (Armijo) line search, for the soft body's incremental potential (implicit Euler, paper appendix
// A.2) and its quasi-static equilibrium. Vectors are flat (3N); the caller supplies the objective,
// its gradient, Hessian-vector products and a preconditioner. Fixed (Dirichlet) degrees of
// freedom are handled by the caller zeroing them in the gradient and in Hessian products.
#pragma once

#include <Eigen/Core>
#include <functional>
#include <string>

namespace topo_gaussian {

struct CgResult {
  int iterations = 0;
  double relative_residual = 0.0;   ///< |b − Ax| / |b|
  bool negative_curvature = false;  ///< stopped at a direction with pᵀAp ≤ 0
  bool converged = false;
};

/// y = A x for a linear operator A (matrix-free).
using LinearOperator = std::function<void(const Eigen::VectorXd&, Eigen::VectorXd*)>;

/// Jacobi preconditioner z = r ./ diag (diag > 0).
LinearOperator jacobiPreconditioner(Eigen::VectorXd diag);

/// Solves A x = b by preconditioned CG from x = 0: apply(p, &Ap); precondition(r, &z) applies an
/// SPD approximation of A⁻¹. Stops at relative residual ≤ tol, max_iter, or negative curvature
/// (then x is the last iterate, or the preconditioned steepest-descent direction if that happens
/// at once).
CgResult conjugateGradient(const LinearOperator& apply, const LinearOperator& precondition, const Eigen::VectorXd& b,
                           double tol, int max_iter, Eigen::VectorXd* x);
/// As conjugateGradient(), from the initial guess in *x (of b's size; else from 0): r₀ = b − A x costs one
/// product; a guess with |r₀| ≥ |b| is dropped (CG from 0). The relative residual is still |b − Ax| / |b|,
/// so a guess close to the solution saves the iterations that reduce the residual to |r₀|. A guess that
/// meets tol already is returned without an iteration, so without a curvature test.
CgResult conjugateGradientFrom(const LinearOperator& apply, const LinearOperator& precondition,
                               const Eigen::VectorXd& b, double tol, int max_iter, Eigen::VectorXd* x);

struct NewtonOptions {
  /// Converged when |∇Ψ|∞ ≤ tolerance × force_scale (force_scale given by the caller: the largest
  /// external/inertial load on one particle [N], so the tolerance is relative to the load), or when
  /// |∇Ψ|∞ is at the gradient's round-off floor (see minimizeNewton), whichever is larger.
  double tolerance = 1e-8;
  int max_iterations = 50;
  /// Largest relative residual of an inner solve; each solve uses min(cg_tolerance, outer residual).
  double cg_tolerance = 0.1;
  int cg_max_iterations = 5000;
  int max_line_search = 30;  ///< halvings
  /// Stop (not converged, with the reason) when the residual has not halved in this many
  /// consecutive iterations: Newton on a smooth problem never stalls that long unless the inner
  /// solves are too inexact (ill-conditioning) or the gradient is noisy.
  int stall_iterations = 6;
};

struct NewtonResult {
  bool converged = false;
  int iterations = 0;
  int cg_iterations = 0;          ///< total
  double residual = 0.0;          ///< final |∇Ψ|∞ / force_scale
  double roundoff_floor = 0.0;    ///< the gradient's round-off floor / force_scale (0 = not given)
  bool at_roundoff = false;       ///< converged at the round-off floor (above options.tolerance)
  double last_cg_residual = 0.0;  ///< relative residual of the last inner solve
  std::string message;            ///< why it stopped; when not converged, also what to change
};

/// The objective Ψ: value(x) may throw TopoError (e.g. an inverted particle), which the line search
/// treats as +∞. gradient(x, &g) and hessian(x, p, &Hp) are evaluated at the most recent x passed to
/// value() (the caller caches the state there); preconditioner(x) returns the inner solves'
/// preconditioner at x (an SPD approximation of the inverse Hessian).
struct NewtonObjective {
  std::function<double(const Eigen::VectorXd&)> value;
  std::function<void(const Eigen::VectorXd&, Eigen::VectorXd*)> gradient;
  std::function<void(const Eigen::VectorXd&, const Eigen::VectorXd&, Eigen::VectorXd*)> hessian;
  std::function<LinearOperator(const Eigen::VectorXd&)> preconditioner;
};

/// Minimises Ψ from x (overwritten with the result). Never throws for non-convergence: the result
/// says so and why (the caller decides; the soft-body simulator turns it into a TopoError with the
/// step).
///
/// roundoff_force [N] ≥ 0: the size of |∇Ψ|∞ that rounding alone produces at the solution (the
/// caller's estimate, e.g. machine ε × |x|∞ × the largest stiffness diagonal × a safety factor).
/// A gradient evaluated in floating point cannot get below it: positions of size |x| carry an
/// absolute error ε|x|, which the stiffness turns into a force. Convergence is declared at
/// max(tolerance × force_scale, roundoff_force): a fixed relative tolerance is below the floor for
/// stiff, finely resolved or large bodies (E 1e8, 0.5 m, 12 000 particles: floor ≈ 3e-6 of the
/// per-particle load), where Newton would otherwise spin in line searches until max_iterations.
NewtonResult minimizeNewton(const NewtonObjective& f, double force_scale, const NewtonOptions& options,
                            Eigen::VectorXd* x, double roundoff_force = 0.0);

}  // namespace topo_gaussian
