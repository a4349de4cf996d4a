// The rest stiffness's Cholesky factor kept from one design to the next (an inference's evaluations),
// and when to factorise again.
//
//   P = K0(θ_f) + diag(s_f)   (rest_stiffness.h), kept for the simulators of designs θ after θ_f
//
// An inference evaluates design after design of one body: the same particles, neighbours, clamp and
// shift pattern, other Lamé parameters and masses. The factor of an earlier design is still a
// preconditioner of the new design's linear systems: PCG converges to the same tolerance, with more
// iterations the further the materials moved (the Newton iterates and the answer agree within the
// solver's tolerances; the preconditioner is not part of the model). Factorising anew costs t_f (the
// finger's 27 636 unknowns: under a second with the GPU's dense cuSOLVER, seconds on the host with CHOLMOD);
// applying a stale factor more often costs t_a a time. The rule, evaluated when a new simulator
// (a use) asks for the factor:
//
//   refactorise when  (a_last − a_first) · t_a  >  t_f
//
// a_first: the applications in the factor's first use (the design it was made for), a_last: in the
// use just finished, t_a: the mean seconds of an application in that last use, t_f: what a new factor
// costs, its factorisation's seconds and the solver's other one-off work (the GPU's in-place inverse).
// And during a use (renewDuringUse(), before each linear solve of a simulator holding the kept factor):
//
//   refactorise now  when  (a_use − s_use · a_first / s_first) · t_a  >  t_f
//
// a_use, s_use: the applications and the linear solves of this use so far, a_first / s_first: the
// applications a solve took in the factor's first use. A design far from the factor's (an optimiser's
// long step) pays for its own factor within the use instead of at the next one: with the finger's
// warm_start a use's Newton iterations vary 0–8, so applications a solve, not a use, is what compares.
// A factor held by another live simulator is not shared (the solvers are not re-entrant): that
// simulator keeps it, the new one gets its own. A factor whose application failed is dropped.
//
// A new factor is a large part of a soft evaluation (~40 % for the finger on the GPU). Measured to pay
// on the GPU only (rest_factor_reuse is set by the soft tasks there; the host keeps a factor per
// design: README "Preconditioner").
#pragma once

#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "topo_gaussian/physics/rest_stiffness.h"

namespace topo_gaussian {

class RestFactorReuse {
 public:
  /// factor_seconds ≥ 0: take t_f as this instead of measuring it (tests: 0 renews at any extra
  /// application, a large value never).
  /// renew_during_use: also the rule during a use (renewDuringUse(); false: only between uses).
  explicit RestFactorReuse(double factor_seconds = -1.0, bool renew_during_use = true)
      : factor_seconds_(factor_seconds), renew_during_use_(renew_during_use) {}
  /// One instance for the process's GPU factors: the soft tasks of one inference (several experiments
  /// of one body) share its kept factor, and a factor for another body frees it first, so no more GPU
  /// memory is held than one factor (as without keeping it).
  static std::shared_ptr<RestFactorReuse> gpuShared();
  /// The kept factor for the simulator `user` (its serial number, unique in the process) of this body (the sph's
  /// rest positions and smoothing length, the fixed mask) and shift value `inertia`, when the rule keeps
  /// it; null when the caller must factorise (and store() what it made). A user that asks again gets
  /// the same factor without a new use being counted.
  std::shared_ptr<const RestStiffnessPreconditioner> find(std::uint64_t user, const CorotatedSph& sph,
                                                          const std::vector<std::uint8_t>& fixed, double inertia);
  /// Keeps `factor` (made for `user`'s body) as the one to reuse; its first use is `user`'s.
  void store(std::uint64_t user, std::shared_ptr<const RestStiffnessPreconditioner> factor, const CorotatedSph& sph,
             const std::vector<std::uint8_t>& fixed, double inertia);
  /// Before each further linear solve of `user` with the kept factor (the simulator's first one goes
  /// through find() or store()): counts the solve and returns true when the rule during a use says
  /// to refactorise now; the kept factor is then dropped (the caller lets go of it and factorises its
  /// own design, which it store()s). False for a user whose factor is not the kept one.
  bool renewDuringUse(std::uint64_t user);
  /// The rule above (between uses, and during one with first_use the applications expected of the
  /// solves so far): true when a factor whose first use took `first_use` applications and whose last
  /// took `last_use`, at `seconds_per_application` each, should be made anew (it took `factor_seconds`).
  static bool refactorise(double first_use, double last_use, double seconds_per_application, double factor_seconds);

  struct Counts {
    long factors = 0;             ///< factors stored
    long reuses = 0;              ///< uses served by a kept factor
    long renewed_during_use = 0;  ///< factors dropped within a use (renewDuringUse())
  };
  Counts counts() const;
  /// Drops the kept factor (its memory is freed when no simulator holds it).
  void clear();
  /// Why the kept factor was last refused by find() or dropped by renewDuringUse() (empty once find()
  /// has served a kept factor since).
  std::string lastRefusal() const;

 private:
  /// t_f: what a new factor costs (factor_seconds, else the kept one's factorisation and other one-off
  /// work); with m_ held and a factor kept.
  double newFactorSeconds() const;
  /// t_a: the mean seconds of the kept factor's `applications` since the current use began; with m_ held.
  double secondsPerApplicationInUse(long applications) const;

  mutable std::mutex m_;
  std::shared_ptr<const RestStiffnessPreconditioner> factor_;
  std::vector<Eigen::Vector3d> X_;
  std::vector<std::uint8_t> fixed_;
  double h_ = 0.0, inertia_ = -1.0;
  std::uint64_t user_ = 0;  ///< the simulator of the current use
  double factor_seconds_ = -1.0;
  long applications_at_use_ = 0, first_use_ = -1, uses_ = 0;
  long solves_in_use_ = 0, first_solves_ = 0;  ///< linear solves of the current / the first use
  bool renew_during_use_ = true;
  double seconds_at_use_ = 0.0;
  Counts counts_;
  std::string refusal_;
};

}  // namespace topo_gaussian
