// CloudIngestNode: the ROS face of the first stage (surface -> filled VolumeCloud).
//   in : ~surface_file (parameter, filled once at start), topic `surface_cloud` (PointCloud2),
//        service ~fill_interior (FillInterior.srv)
//   out: topic `volume` (PointCloud2, latched; fields x y z volume surface)
// The node owns the ROS handles and the parameters; geometry::ingestFile/ingestSurface do the work.
// Callbacks run on the caller's spinner (ros::spin: one at a time), so fills never overlap.
#pragma once

#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>

#include <cstddef>
#include <string>

#include "topo_gaussian/FillInterior.h"
#include "topo_gaussian/geometry/ingest.h"

namespace topo_gaussian::topo_ros {

/// The node's private parameters, validated.
struct CloudIngestParams {
  std::string surface_file;         ///< ~surface_file: filled once at start when not empty
  std::string frame_id = "object";  ///< ~frame_id: frame of volumes from files (clouds keep their own)
  /// ~spacing_m, ~fill_count, ~scale, ~recenter, ~opacity_threshold, ~outlier_neighbours,
  /// ~closing_cells, ~grid_resolution, ~max_open_fraction; unset ones keep the library's defaults
  /// (IngestOptions{}), so the node and `topo fill` agree.
  geometry::IngestOptions options;
};

/// Reads the private parameters from `pnh` (unset: the defaults of CloudIngestParams) and
/// validates them. Throws TopoError naming the parameter, its value and the fix.
CloudIngestParams loadCloudIngestParams(const ::ros::NodeHandle& pnh);

/// The options for one ~fill_interior request: the request's non-zero fields over `defaults`.
/// Throws TopoError naming `service` for negative or non-finite values.
geometry::IngestOptions requestOptions(const topo_gaussian::FillInterior::Request& request,
                                       const geometry::IngestOptions& defaults, const std::string& service);

/// One-line summary of a successful fill, as logged and returned in the service message.
std::string describe(const geometry::IngestResult& result);

class CloudIngestNode {
 public:
  /// Loads parameters (throws TopoError on invalid ones), advertises `volume`, subscribes
  /// `surface_cloud`, offers ~fill_interior, then fills ~surface_file when it is set. A failure of
  /// that first fill is logged with ROS_ERROR and the node keeps running.
  CloudIngestNode(const ::ros::NodeHandle& nh, const ::ros::NodeHandle& pnh);

  const CloudIngestParams& params() const { return params_; }
  /// Volumes published on `volume` so far.
  std::size_t publishedCount() const { return published_; }

 private:
  void onSurfaceCloud(const sensor_msgs::PointCloud2ConstPtr& msg);
  bool onFillInterior(topo_gaussian::FillInterior::Request& request, topo_gaussian::FillInterior::Response& response);
  void fillStartupFile();
  void publish(const sensor_msgs::PointCloud2& volume);

  ::ros::NodeHandle nh_, pnh_;
  CloudIngestParams params_;
  ::ros::Publisher volume_pub_;
  ::ros::Subscriber surface_sub_;
  ::ros::ServiceServer fill_srv_;
  std::size_t published_ = 0;
};

}  // namespace topo_gaussian::topo_ros
