#include "topo_gaussian/ros/truth_comparison_msg.h"

#include <sensor_msgs/point_cloud2_iterator.h>

namespace topo_gaussian::topo_ros {

void readInteriorLabels(const sensor_msgs::PointCloud2& cloud, std::vector<Eigen::Vector3d>* x,
                        std::vector<double>* solid) {
  if (cloud.width * cloud.height == 0) return;
  sensor_msgs::PointCloud2ConstIterator<float> px(cloud, "x"), ps(cloud, "solid");
  for (; px != px.end(); ++px, ++ps) {
    x->emplace_back(px[0], px[1], px[2]);
    solid->push_back(*ps >= 0.5f ? 1.0 : 0.0);
  }
}

double objectSizeM(const sensor_msgs::PointCloud2& cloud) {
  std::vector<Eigen::Vector3d> x;
  std::vector<double> solid;
  readInteriorLabels(cloud, &x, &solid);
  return inference::objectSizeM(x);
}

InteriorIou interiorIou(const sensor_msgs::PointCloud2& recovered, const sensor_msgs::PointCloud2& truth) {
  std::vector<Eigen::Vector3d> xr, xt;
  std::vector<double> sr, st;
  readInteriorLabels(recovered, &xr, &sr);
  readInteriorLabels(truth, &xt, &st);
  return inference::interiorIou(xr, sr, {}, xt, st);
}

}  // namespace topo_gaussian::topo_ros
