// Truth comparison: a recovered result against a known truth (a rig twin's interior, a peer's
// answer), as the demo and the benches judge it.
//
// Features: the relative error e = (y − y_true) / s on the feature's natural scale
//   s = max(|y_true|, floor),  floor = 10 deg for angles (names ending in _deg), the object's size for
//   lengths (names ending in _m), 1e-12 otherwise; an element NAME[k] of a list feature as NAME,
// so a feature near zero (a rest tilt, a centre-of-mass offset) is not judged on its own tiny size.
// Interiors: each recovered particle takes the true label of its nearest true particle (the two
// clouds may have different spacings), then the volume IoU of the cavity and of the solid
// (region_uncertainty.h's volumeIou).
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

namespace topo_gaussian::inference {

struct FeatureComparison {
  double relative_error = 0.0;  ///< (recovered − truth) / scale; NaN when either is not finite
  double scale = 0.0;           ///< max(|truth|, the feature's floor)
  bool of_the_scale = false;    ///< the floor was used (the truth is smaller than the feature's natural scale)
  bool within = false;          ///< |relative_error| ≤ tolerance
};

/// The floor of a feature's scale from its name (see the header comment); `object_size_m` NaN: lengths
/// use no floor.
double featureScaleFloor(const std::string& name, double object_size_m);

FeatureComparison compareFeature(const std::string& name, double recovered, double truth, double object_size_m,
                                 double tolerance);

/// Extent (bounding-box diagonal) of a point set [m]; NaN when empty.
double objectSizeM(const std::vector<Eigen::Vector3d>& x);

/// Per query point, the label of the nearest reference point (ties: the first). Throws TopoError for an
/// empty reference or labels of another size.
std::vector<double> nearestLabels(const std::vector<Eigen::Vector3d>& query,
                                  const std::vector<Eigen::Vector3d>& reference, const std::vector<double>& labels);

struct InteriorIou {
  double cavity = 0.0;  ///< IoU of the hollow (solid < 0.5) regions
  double solid = 0.0;   ///< IoU of the solid regions
};

/// IoU of a recovered interior (positions, solid labels 0/1, volumes V; empty V: equal volumes) against a
/// true one, on the recovered particles (see the header comment).
InteriorIou interiorIou(const std::vector<Eigen::Vector3d>& x_recovered, const std::vector<double>& solid_recovered,
                        const std::vector<double>& V_recovered, const std::vector<Eigen::Vector3d>& x_truth,
                        const std::vector<double>& solid_truth);

}  // namespace topo_gaussian::inference
