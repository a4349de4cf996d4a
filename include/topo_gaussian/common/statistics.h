// Robust summaries of samples used across modules (frame intervals, residuals, spacings).
// Header-only, standard library only.
#pragma once

#include <algorithm>
#include <vector>

namespace topo_gaussian {

/// The median of v (the mean of the two middle values for an even count); 0 for an empty v.
inline double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const std::size_t m = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(m), v.end());
  double med = v[m];
  if (v.size() % 2 == 0) med = 0.5 * (med + *std::max_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(m)));
  return med;
}

}  // namespace topo_gaussian
