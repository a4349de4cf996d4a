// Step and memory budgets of a simulation; see run_limits.h.
#include "topo_gaussian/physics/run_limits.h"

#include <cmath>
#include <functional>
#include <sstream>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/number_text.h"

namespace topo_gaussian {

void checkStepBudget(const std::string& what, double step_s, double duration_s, double particles,
                     const std::string& step_parameter) {
  if (!(step_s > 0.0) || !(duration_s > 0.0)) return;  // the simulator's own checks name these
  const double steps = std::ceil(duration_s / step_s - 1e-9);
  const double p = particles > 0.0 ? particles : 1.0;
  const bool too_many_steps = steps > kMaxSimulationSteps;
  const bool too_much_work = particles > 0.0 && steps * p > kMaxParticleSteps;
  if (!too_many_steps && !too_much_work) return;
  std::ostringstream problem, fix;
  problem << numberText(step_s, 3) << " s steps over " << numberText(duration_s, 4) << " s = " << numberText(steps, 3)
          << " steps";
  double min_step = 0.0;
  if (too_many_steps) {
    problem << "; the limit is " << numberText(kMaxSimulationSteps, 3) << " steps";
    min_step = duration_s / kMaxSimulationSteps;
  }
  if (too_much_work) {
    problem << (too_many_steps ? ", and " : "; ") << numberText(p, 4) << " particles x " << numberText(steps, 3)
            << " steps = " << numberText(steps * p, 3) << " particle-steps; the limit is "
            << numberText(kMaxParticleSteps, 3);
    min_step = std::max(min_step, duration_s * p / kMaxParticleSteps);
  }
  problem << " (it would not finish)";
  const std::size_t n = step_parameter.size();
  if (n > 2 && step_parameter.compare(n - 2, 2, "_s") == 0)
    fix << "use " << step_parameter << " >= " << numberText(min_step, 3) << " s, or a shorter duration";
  else
    fix << "use " << step_parameter << " (the steps must stay >= " << numberText(min_step, 3) << " s)";
  throw TopoError(what, problem.str(), fix.str());
}

void checkContactWork(const std::string& what, double t_s, double duration_s, double step_s, double points,
                      const std::function<double()>& spacing_m) {
  if (!(step_s > 0.0) || !(points > 0.0) || !(duration_s > t_s)) return;
  const double steps = std::ceil((duration_s - t_s) / step_s - 1e-9);
  const double work = steps * points;
  if (!(work > kMaxContactPointSteps)) return;
  std::ostringstream problem, fix;
  problem << "at t = " << numberText(t_s, 4) << " s " << numberText(points, 6)
          << " contact points touch or are about to touch the ground at once (a flat face landing): the contact "
             "needs substeps of "
          << numberText(step_s, 3) << " s, so the remaining " << numberText(duration_s - t_s, 4) << " s take "
          << numberText(steps, 3) << " substeps x " << numberText(points, 6) << " points = " << numberText(work, 3)
          << " point-steps; the limit is " << numberText(kMaxContactPointSteps, 3);
  // The work goes as n^1.5 (n points per face ∝ spacing^-2, the substep ∝ n^-1/2): as spacing^-3. The
  // spacing asked for aims at a quarter of the limit: the substep moves in steps of √2 (the contact count
  // is rounded to powers of two), so a spacing that just fits the model may not fit the run.
  const double factor = std::cbrt(4.0 * work / kMaxContactPointSteps);
  const double s = spacing_m ? spacing_m() : 0.0;
  fix << "use fewer contact points: contact samples about " << numberText(factor, 2) << " x farther apart (topo fill "
      << "--contact-spacing";
  if (s > 0.0) fix << " >= " << numberText(s * factor, 2) << " m; they are about " << numberText(s, 2) << " m apart now";
  fix << "), or a shorter duration_s";
  throw TopoError(what, problem.str(), fix.str());
}

void checkMemoryBudget(const std::string& what, double states, double bytes_per_state, const std::string& fix) {
  const double bytes = states * bytes_per_state;
  if (!(bytes > kMaxSimulationBytes)) return;
  std::ostringstream problem;
  problem << "would keep " << numberText(states, 3) << " states x " << numberText(bytes_per_state, 4)
          << " bytes = " << numberText(bytes / 1e9, 3) << " GB; the limit is "
          << numberText(kMaxSimulationBytes / 1e9, 3) << " GB";
  throw TopoError(what, problem.str(), fix);
}

}  // namespace topo_gaussian
