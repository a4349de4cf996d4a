#include "topo_gaussian/topology/materials.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "topo_gaussian/common/error.h"

namespace topo_gaussian {

namespace {

// r outside [0, 1] (never produced by the sigmoid) is clamped so r^p stays defined.
inline double clamp01(double r) { return std::min(1.0, std::max(0.0, r)); }

}  // namespace

void MaterialInterpolation::validate(const char* what) const {
  const std::string w = what ? what : "material";
  const auto fail = [&](const std::string& field, double v, const std::string& problem, const std::string& fix) {
    throw TopoError(w + " " + field, std::to_string(v) + " " + problem, fix);
  };
  if (!std::isfinite(value_r0)) fail("value_r0", value_r0, "is not finite", "give the material-A value (r = 0)");
  if (!std::isfinite(value_r1)) fail("value_r1", value_r1, "is not finite", "give the material-B value (r = 1)");
  if (value_r0 < 0.0) fail("value_r0", value_r0, "is negative", "material properties (density, stiffness) must be ≥ 0");
  if (value_r1 < 0.0) fail("value_r1", value_r1, "is negative", "material properties (density, stiffness) must be ≥ 0");
  if (!std::isfinite(power) || power < 1.0)
    fail("power", power, "is below 1 (or not finite)", "use power ≥ 1 (1 = linear, 3 = SIMP)");
  if (!std::isfinite(floor) || !(floor > 0.0))
    fail("floor", floor, "is not positive", "use a small positive floor, e.g. 1e-3 of the larger value");
}

double MaterialInterpolation::value(double r) const {
  const double p = continuous ? 1.0 : power;
  const double q = value_r0 + std::pow(clamp01(r), p) * (value_r1 - value_r0);
  return std::max(floor, q);
}

double MaterialInterpolation::derivative(double r) const {
  const double p = continuous ? 1.0 : power;
  if (r < 0.0 || r > 1.0) return 0.0;  // value() is clamped there
  const double rc = r;
  const double q = value_r0 + std::pow(rc, p) * (value_r1 - value_r0);
  if (q < floor) return 0.0;  // the floor is active
  if (p == 1.0) return value_r1 - value_r0;
  return p * std::pow(rc, p - 1.0) * (value_r1 - value_r0);
}

void MaterialInterpolation::apply(const std::vector<double>& r, std::vector<double>* q, std::vector<double>* dq) const {
  q->resize(r.size());
  if (dq) dq->resize(r.size());
  const std::ptrdiff_t n = static_cast<std::ptrdiff_t>(r.size());
#pragma omp parallel for schedule(static) if (n > 8192)
  for (std::ptrdiff_t i = 0; i < n; ++i) {
    (*q)[i] = value(r[i]);
    if (dq) (*dq)[i] = derivative(r[i]);
  }
}

}  // namespace topo_gaussian
