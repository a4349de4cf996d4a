// Newton–PCG minimisation; see newton_solver.h.
#include "topo_gaussian/physics/newton_solver.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "topo_gaussian/common/error.h"

namespace topo_gaussian {

LinearOperator jacobiPreconditioner(Eigen::VectorXd diag) {
  Eigen::VectorXd inv = diag.cwiseMax(1e-300).cwiseInverse();
  return [inv](const Eigen::VectorXd& r, Eigen::VectorXd* z) { *z = inv.cwiseProduct(r); };
}

CgResult conjugateGradient(const LinearOperator& apply, const LinearOperator& precondition, const Eigen::VectorXd& b,
                           double tol, int max_iter, Eigen::VectorXd* x) {
  x->setZero(b.size());
  return conjugateGradientFrom(apply, precondition, b, tol, max_iter, x);
}

CgResult conjugateGradientFrom(const LinearOperator& apply, const LinearOperator& precondition,
                               const Eigen::VectorXd& b, double tol, int max_iter, Eigen::VectorXd* x) {
  CgResult res;
  const Eigen::Index n = b.size();
  const double bn = b.norm();
  if (bn == 0.0) {
    x->setZero(n);
    res.converged = true;
    return res;
  }
  Eigen::VectorXd r = b, z, Ap(n);
  if (x->size() != n || !x->allFinite()) {
    x->setZero(n);
  } else if (!x->isZero(0.0)) {
    apply(*x, &Ap);
    r = b - Ap;
    if (!(r.norm() < bn)) {  // no better than 0
      x->setZero(n);
      r = b;
    } else if ((res.relative_residual = r.norm() / bn) <= tol) {
      res.converged = true;
      return res;
    }
  }
  precondition(r, &z);
  Eigen::VectorXd p = z;
  double rz = r.dot(z);
  for (int it = 0; it < max_iter; ++it) {
    apply(p, &Ap);
    const double pAp = p.dot(Ap);
    if (!(pAp > 0.0)) {
      res.negative_curvature = true;
      if (it == 0) *x += z;  // preconditioned steepest descent (from the guess, or from 0)
      break;
    }
    const double a = rz / pAp;
    *x += a * p;
    r -= a * Ap;
    res.iterations = it + 1;
    res.relative_residual = r.norm() / bn;
    if (res.relative_residual <= tol) {
      res.converged = true;
      return res;
    }
    precondition(r, &z);
    const double rz_new = r.dot(z);
    p = z + (rz_new / rz) * p;
    rz = rz_new;
  }
  res.relative_residual = (b -
                           [&] {
                             Eigen::VectorXd Ax(n);
                             apply(*x, &Ax);
                             return Ax;
                           }())
                              .norm() /
                          bn;
  return res;
}

namespace {

std::string sci(double v) {
  std::ostringstream s;
  s.precision(3);
  s << v;
  return s.str();
}

/// What to change, for a solve that stopped at `residual` (relative) with the last inner solve at
/// relative residual `cg_residual`.
std::string newtonAdvice(const NewtonResult& r, const NewtonOptions& opt) {
  std::ostringstream s;
  if (r.last_cg_residual > std::min(opt.cg_tolerance, std::max(1e-12, r.residual)) * 1.01)
    s << " The last linear solve reached only relative residual " << sci(r.last_cg_residual) << " in "
      << opt.cg_max_iterations
      << " CG iterations: the stiffness is ill-conditioned for the preconditioner (material contrast, a slender "
         "body, or a Cholesky factor refused by its limits: SoftBodySimulator::preconditionerNote()); raise "
         "cg_max_iterations, SoftBodyOptions::cholesky_max_particles or cholesky_max_factor_bytes.";
  if (r.roundoff_floor > 0.0 && r.residual < 100.0 * r.roundoff_floor)
    s << " The residual is within 100x of the gradient's round-off floor " << sci(r.roundoff_floor)
      << " (relative to the load): raise the tolerance (newton_tolerance) to about " << sci(10.0 * r.roundoff_floor)
      << ", or use a coarser spacing or centre the body at the origin.";
  if (s.str().empty())
    s << " The problem may have no nearby equilibrium (a load beyond a limit point, an unsupported body): lower or "
         "ramp the load, or check the supports.";
  return s.str();
}

}  // namespace

NewtonResult minimizeNewton(const NewtonObjective& f, double force_scale, const NewtonOptions& opt, Eigen::VectorXd* x,
                            double roundoff_force) {
  NewtonResult res;
  if (!(force_scale > 0.0) || !std::isfinite(force_scale))
    throw TopoError("Newton solver", "force scale " + std::to_string(force_scale) + " is not positive",
                    "pass the size of the loads [N]");
  if (!(roundoff_force >= 0.0) || !std::isfinite(roundoff_force))
    throw TopoError("Newton solver", "round-off force " + std::to_string(roundoff_force) + " is not >= 0",
                    "pass 0 or the gradient's round-off estimate [N]");
  res.roundoff_floor = roundoff_force / force_scale;
  const double tol = std::max(opt.tolerance, res.roundoff_floor);
  const Eigen::Index n = x->size();
  double psi = f.value(*x);
  if (!std::isfinite(psi)) {
    res.message = "the objective is not finite at the start";
    return res;
  }
  Eigen::VectorXd g(n), d(n), trial(n);
  double best = INFINITY;  // smallest residual so far, and the iteration it was reached
  int best_it = 0;
  auto stop = [&](const std::string& why) {
    res.message = why + "." + newtonAdvice(res, opt);
    return res;
  };
  for (int it = 0; it < opt.max_iterations; ++it) {
    f.gradient(*x, &g);
    res.residual = g.lpNorm<Eigen::Infinity>() / force_scale;
    res.iterations = it;
    if (!std::isfinite(res.residual)) {
      res.message = "the gradient became non-finite";
      return res;
    }
    if (res.residual <= tol) {
      res.converged = true;
      res.at_roundoff = res.residual > opt.tolerance;
      res.message = res.at_roundoff ? "converged to the round-off floor " + sci(res.roundoff_floor) +
                                          " (above the tolerance " + sci(opt.tolerance) + ")"
                                    : "converged";
      return res;
    }
    if (res.residual < 0.5 * best) {
      best = res.residual;
      best_it = it;
    } else if (it - best_it >= opt.stall_iterations) {
      std::ostringstream s;
      s << "stalled: the residual has not halved in " << it - best_it << " iterations (best " << sci(best) << ", now "
        << sci(res.residual) << ", tolerance " << sci(opt.tolerance) << ")";
      return stop(s.str());
    }
    const LinearOperator precondition = f.preconditioner(*x);
    // Forcing term (inexact Newton, Eisenstat–Walker flavour): the inner relative tolerance follows
    // the outer residual, η = min(cg_tolerance, residual), so early steps far from the solution
    // take few CG iterations and the last ones converge superlinearly.
    const double cg_tol = std::min(opt.cg_tolerance, std::max(1e-12, res.residual));
    const CgResult cg = conjugateGradient([&](const Eigen::VectorXd& p, Eigen::VectorXd* Hp) { f.hessian(*x, p, Hp); },
                                          precondition, -g, cg_tol, opt.cg_max_iterations, &d);
    res.cg_iterations += cg.iterations;
    res.last_cg_residual = cg.relative_residual;
    double slope = g.dot(d);
    if (!(slope < 0.0)) {  // not a descent direction: fall back to preconditioned steepest descent
      precondition(-g, &d);
      slope = g.dot(d);
    }
    double step = 1.0;
    bool accepted = false;
    for (int ls = 0; ls <= opt.max_line_search; ++ls) {
      trial = *x + step * d;
      double v;
      try {
        v = f.value(trial);
      } catch (const TopoError&) {
        v = INFINITY;
      }
      if (std::isfinite(v) && v <= psi + 1e-4 * step * slope) {
        psi = v;
        *x = trial;
        accepted = true;
        break;
      }
      // Near convergence Ψ stalls at round-off: accept a step that reduces the gradient instead.
      if (std::isfinite(v) && std::abs(v - psi) <= 1e-13 * std::max(1.0, std::abs(psi))) {
        Eigen::VectorXd gt(n);
        f.gradient(trial, &gt);
        if (gt.lpNorm<Eigen::Infinity>() < g.lpNorm<Eigen::Infinity>()) {
          psi = v;
          *x = trial;
          accepted = true;
          break;
        }
      }
      step *= 0.5;
    }
    if (!accepted) {
      f.value(*x);  // restore the cached state at x
      std::ostringstream s;
      s << "line search failed at Newton iteration " << it + 1 << " (residual " << sci(res.residual) << ", tolerance "
        << sci(opt.tolerance) << "): no step along the Newton direction lowers the objective";
      return stop(s.str());
    }
  }
  f.gradient(*x, &g);
  res.residual = g.lpNorm<Eigen::Infinity>() / force_scale;
  res.iterations = opt.max_iterations;
  res.converged = res.residual <= tol;
  res.at_roundoff = res.converged && res.residual > opt.tolerance;
  if (res.converged) {
    res.message = "converged";
    return res;
  }
  return stop("reached max_iterations (" + std::to_string(opt.max_iterations) + ")");
}

}  // namespace topo_gaussian
