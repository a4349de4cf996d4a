#include "topo_gaussian/inference/truth_comparison.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/inference/region_uncertainty.h"

namespace topo_gaussian::inference {
namespace {
bool endsWith(const std::string& s, const std::string& e) {
  return s.size() >= e.size() && s.compare(s.size() - e.size(), e.size(), e) == 0;
}
}  // namespace

double featureScaleFloor(const std::string& name_in, double object_size_m) {
  // an element of a list feature, NAME[k] (the finger's bend_profile_deg[k]), takes NAME's floor
  std::string name = name_in;
  const std::size_t open = name.rfind('[');
  if (open != std::string::npos && name.back() == ']' && open + 2 < name.size() &&
      name.find_first_not_of("0123456789", open + 1) == name.size() - 1)
    name.erase(open);
  if (endsWith(name, "_deg")) return 10.0;
  if (endsWith(name, "_m") && std::isfinite(object_size_m)) return object_size_m;
  return 1e-12;
}

FeatureComparison compareFeature(const std::string& name, double recovered, double truth, double object_size_m,
                                 double tolerance) {
  FeatureComparison c;
  const double floor = featureScaleFloor(name, object_size_m);
  c.scale = std::isfinite(truth) ? std::max(std::abs(truth), floor) : floor;
  c.of_the_scale = std::isfinite(truth) && c.scale > std::abs(truth);
  c.relative_error = std::isfinite(recovered) && std::isfinite(truth) ? (recovered - truth) / c.scale
                                                                      : std::numeric_limits<double>::quiet_NaN();
  c.within = std::isfinite(c.relative_error) && std::abs(c.relative_error) <= tolerance;
  return c;
}

double objectSizeM(const std::vector<Eigen::Vector3d>& x) {
  if (x.empty()) return std::numeric_limits<double>::quiet_NaN();
  Eigen::Vector3d lo = x.front(), hi = x.front();
  for (const auto& p : x) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  return (hi - lo).norm();
}

std::vector<double> nearestLabels(const std::vector<Eigen::Vector3d>& query,
                                  const std::vector<Eigen::Vector3d>& reference, const std::vector<double>& labels) {
  if (reference.empty())
    throw TopoError("true interior", "has no particles", "give the truth's interior cloud (x, y, z, solid)");
  if (labels.size() != reference.size())
    throw TopoError("true interior",
                    "has " + std::to_string(labels.size()) + " labels for " + std::to_string(reference.size()) +
                        " particles",
                    "give one solid label per particle");
  std::vector<double> out(query.size());
  for (std::size_t i = 0; i < query.size(); ++i) {
    std::size_t best = 0;
    double d = std::numeric_limits<double>::infinity();
    for (std::size_t j = 0; j < reference.size(); ++j) {
      const double e = (reference[j] - query[i]).squaredNorm();
      if (e < d) d = e, best = j;
    }
    out[i] = labels[best];
  }
  return out;
}

InteriorIou interiorIou(const std::vector<Eigen::Vector3d>& x_recovered, const std::vector<double>& solid_recovered,
                        const std::vector<double>& V_recovered, const std::vector<Eigen::Vector3d>& x_truth,
                        const std::vector<double>& solid_truth) {
  const std::vector<double> V = V_recovered.empty() ? std::vector<double>(x_recovered.size(), 1.0) : V_recovered;
  const std::vector<double> truth = nearestLabels(x_recovered, x_truth, solid_truth);
  std::vector<double> hollow_r(solid_recovered.size()), hollow_t(truth.size());
  for (std::size_t i = 0; i < solid_recovered.size(); ++i) hollow_r[i] = 1.0 - solid_recovered[i];
  for (std::size_t i = 0; i < truth.size(); ++i) hollow_t[i] = 1.0 - truth[i];
  InteriorIou iou;
  iou.solid = volumeIou(V, solid_recovered, truth);
  iou.cavity = volumeIou(V, hollow_r, hollow_t);
  return iou;
}

}  // namespace topo_gaussian::inference
