#include "topo_gaussian/ros/motion_targets.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "topo_gaussian/inference/oscillation.h"

namespace topo_gaussian::topo_ros {

namespace {

/// The tracker's signal resampled at its median frame interval (linear interpolation over gaps).
bool uniformSignal(const std::vector<double>& t, const std::vector<double>& y, std::vector<double>* out, double* dt) {
  if (t.size() != y.size() || t.size() < 8) return false;
  std::vector<double> d;
  for (std::size_t i = 1; i < t.size(); ++i) d.push_back(t[i] - t[i - 1]);
  std::nth_element(d.begin(), d.begin() + std::ptrdiff_t(d.size() / 2), d.end());
  *dt = d[d.size() / 2];
  if (!(*dt > 0)) return false;
  out->clear();
  std::size_t j = 0;
  for (double s = t.front(); s <= t.back() + 1e-9 * *dt; s += *dt) {
    while (j + 2 < t.size() && t[j + 1] < s) ++j;
    const double w = t[j + 1] > t[j] ? std::clamp((s - t[j]) / (t[j + 1] - t[j]), 0.0, 1.0) : 0.0;
    out->push_back((1 - w) * y[j] + w * y[j + 1]);
  }
  return out->size() >= 8;
}

}  // namespace

MotionTargets targetsFromMotion(const inference::TaskConfig& config, const topo_gaussian::MotionFeatures& f) {
  const std::string& task = config.task();
  MotionTargets out;
  const std::string from = "motion features (" + (f.source.empty() ? std::string("unknown source") : f.source) + ", kind " +
                           (f.kind.empty() ? std::string("?") : f.kind) + ")";
  if (task == "tumbler") {
    if (!f.oscillation_found || !(f.period_s > 0)) {
      out.note = from + " hold no oscillation" + (f.message.empty() ? "" : ": " + f.message);
      return out;
    }
    // Released at rest at initial_tilt_deg, the doll's largest tilt is at least the release tilt: an
    // observed maximum at or below it (within 1 %: tracking error) says the swing never went past the
    // release, so the target is the release tilt itself (anything below is unreachable).
    const double release = config.has("initial_tilt_deg") ? std::abs(config.number("initial_tilt_deg")) : 0.0;
    std::ostringstream os;
    double period = f.period_s, tilt = f.amplitude_confidence > 0 ? f.max_tilt_deg : 0.0;
    std::vector<double> y;
    double dt = 0;
    if (uniformSignal(f.time_s, f.angle_deg, &y, &dt)) {
      // A window that starts at the release (the first sample a turning point, the first step small
      // against the range, far from the centre) is measured as the task measures its simulation.
      double lo = y[0], hi = y[0], peak = 0;
      for (double v : y) lo = std::min(lo, v), hi = std::max(hi, v), peak = std::max(peak, std::abs(v));
      const bool at_rest = std::abs(y[1] - y[0]) < 0.05 * (hi - lo) && std::abs(y[0]) >= 0.5 * peak;
      const int cycles = config.has("measured_cycles") ? config.integer("measured_cycles") : 2;
      const inference::OscillationFeatures<double> o =
          at_rest ? inference::analyseOscillation(y, 0.0, dt, cycles, true) : inference::OscillationFeatures<double>{};
      if (o.valid && o.period > 0) {
        period = o.period;
        tilt = o.max_abs;
        os << "the window starts at a release: the task's analysis of the observed signal (" << y.size()
           << " samples, first " << cycles << " cycles) gives period " << o.period << " s, max tilt " << o.max_abs
           << " deg (the tracker's own over the window: " << f.period_s << " s, " << f.max_tilt_deg << " deg)";
      } else {
        os << "the window starts mid-swing: the tracker's period and max tilt over the window are used";
      }
    }
    out.targets.emplace_back("period_s", period);
    if (tilt > 1.01 * release) {
      out.targets.emplace_back("max_tilt_deg", tilt);
    } else if (release > 0) {
      out.targets.emplace_back("max_tilt_deg", release);
      os << "; the max tilt " << tilt << " deg does not exceed the release tilt, so its target is the release tilt "
         << release << " deg";
    } else {
      os << "; the tilt was not measured, only the period is used";
    }
    out.note = os.str();
  } else if (task == "hanging" || task == "balance" || task == "stand") {
    if (f.equilibrium_confidence > 0) out.targets.emplace_back("target_roll_deg", f.equilibrium_deg);
    else out.note = from + " hold no measured equilibrium angle";
  } else if (task == "finger") {
    if (f.bending_confidence > 0) out.targets.emplace_back("bend_angle_deg", f.bending_angle_deg);
    else out.note = from + " hold no measured bending angle";
  } else {
    out.note = "task " + task + " does not take its targets from motion features: give them in the goal's targets";
  }
  return out;
}

}  // namespace topo_gaussian::topo_ros
