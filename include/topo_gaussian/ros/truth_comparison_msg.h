// A result's interior cloud against a rig twin's (topo_gaussian/RigGroundTruth) as messages: the
// library's truth comparison (inference/truth_comparison.h) on the clouds' x y z and solid fields.
#pragma once

#include <sensor_msgs/PointCloud2.h>

#include <Eigen/Core>
#include <vector>

#include "topo_gaussian/inference/truth_comparison.h"

namespace topo_gaussian::topo_ros {

using inference::compareFeature;
using inference::FeatureComparison;
using inference::InteriorIou;

/// x y z and solid (1 where the field `solid` ≥ 0.5, else 0) of an interior cloud.
void readInteriorLabels(const sensor_msgs::PointCloud2& cloud, std::vector<Eigen::Vector3d>* x,
                        std::vector<double>* solid);

/// The extent of an interior cloud's points [m] (NaN when empty): the natural scale of its lengths.
double objectSizeM(const sensor_msgs::PointCloud2& cloud);

/// IoU of the recovered cavity and solid against the true ones, on the recovered particles.
InteriorIou interiorIou(const sensor_msgs::PointCloud2& recovered, const sensor_msgs::PointCloud2& truth);

}  // namespace topo_gaussian::topo_ros
