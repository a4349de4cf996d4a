// Limits every simulation checks before it starts, and the cancel check its time loop polls.
//
// Step budget: a simulation of duration T with substep h takes T/h integration steps of P particles
// (or contact points); a step of 1e-12 s would never finish. Before the first step the simulator
// estimates steps and particle-steps and refuses with the numbers over kMaxSimulationSteps or
// kMaxParticleSteps; a rigid simulation's contact work (substeps × points in contact) is checked again
// whenever the contact step shrinks (kMaxContactPointSteps). Memory budget: the states a simulation keeps (a rigid trajectory stores one
// state per output sample) are estimated in bytes before anything is allocated and refused over
// kMaxSimulationBytes. Cancel: a StopCheck returning true makes the time loop throw
// SimulationCancelled within a few ms of work (rigid: every 64 substeps; soft: every step and every
// Newton/relaxation iteration); the optimiser turns it into "cancelled, best design so far".
#pragma once

#include <functional>
#include <stdexcept>
#include <string>

namespace topo_gaussian {

/// Returns true when the caller wants the work stopped (a cancelled goal, Ctrl-C). Polled from the
/// thread that runs the simulation, never from inside a parallel region.
using StopCheck = std::function<bool()>;

/// Integration steps (substeps) of one simulation.
constexpr double kMaxSimulationSteps = 1e8;
/// Steps × particles (or contact points) of one simulation: about 1e4 s of CPU at 100 ns each.
constexpr double kMaxParticleSteps = 1e11;
/// Contact-point evaluations of one rigid simulation (substeps × points in contact): minutes of CPU at
/// the 100–400 ns each of the contact in dual numbers (a tumbler landing on a box's face, one core); an
/// inference runs dozens of such simulations.
constexpr double kMaxContactPointSteps = 1e9;
/// Bytes of the states one simulation keeps (1 GiB).
constexpr double kMaxSimulationBytes = 1024.0 * 1024.0 * 1024.0;

/// Thrown by a simulation whose StopCheck returned true. Not a TopoError: it is not bad input.
class SimulationCancelled : public std::runtime_error {
 public:
  SimulationCancelled() : std::runtime_error("cancelled") {}
};

/// Throws SimulationCancelled when stop is set and returns true.
inline void pollStop(const StopCheck& stop) {
  if (stop && stop()) throw SimulationCancelled();
}

/// Refuses a simulation of `steps` steps of `particles` particles over duration_s with step step_s:
/// "<what>: 1e-12 s steps over 2 s = 2e12 steps; the limit is 1e8. Fix: use <step_parameter> >= 2e-8 s
/// (or a shorter duration)". particles ≤ 0 skips the particle-step check.
void checkStepBudget(const std::string& what, double step_s, double duration_s, double particles,
                     const std::string& step_parameter);

/// Refuses the rest of a rigid simulation (from t_s to duration_s) whose contact work, substeps of step_s
/// × `points` points in contact at once, is over kMaxContactPointSteps: a flat face of finely sampled
/// surface landing on the ground needs a substep that shrinks with the points' number, so the work grows
/// as its 1.5th power. Checked whenever the substep is chosen (before the first step, then once per
/// output sample): a run is refused as soon as it comes to such a contact, not after hours. The message
/// names the points, the substep, the work and the limit; the fix, the contact-sample spacing that fits
/// (spacing_m() is called only then: the present spacing of the contact points).
void checkContactWork(const std::string& what, double t_s, double duration_s, double step_s, double points,
                      const std::function<double()>& spacing_m);

/// Refuses a simulation that would keep `bytes` of state over kMaxSimulationBytes, naming the
/// estimate (states × bytes each) and `fix` (e.g. "use dt_s >= 1e-5 s or a shorter duration_s").
void checkMemoryBudget(const std::string& what, double states, double bytes_per_state, const std::string& fix);

}  // namespace topo_gaussian
