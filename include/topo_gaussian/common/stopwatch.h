// Wall-clock timing for reports and progress lines: seconds since a steady_clock time point.
// Header-only, standard library only.
#pragma once

#include <chrono>

namespace topo_gaussian {

using Clock = std::chrono::steady_clock;

/// Seconds elapsed since t.
inline double secondsSince(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

}  // namespace topo_gaussian
