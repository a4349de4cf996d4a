// CloudIngestNode: the ROS face of the first stage (surface -> filled VolumeCloud).
//   in : ~surface_file (parameter, filled once at start), topic `surface_cloud` (PointCloud2),
//        service ~fill_interior (FillInterior.srv)
//   out: topic `volume` (PointCloud2, latched; fields x y z volume surface spacing) and `contact_samples`
//        (PointCloud2, latched, same stamp; x y z normal_x normal_y normal_z area: the true surface)
//   views: topic `depth_points` (PointCloud2 from a depth camera, one cloud per viewpoint) is taken
//        through tf at each cloud's stamp into ~target_frame and kept; each added view is fused with
//        the others (geometry::fuseViews) and its coverage logged and latched on `~views_status`
//        (std_msgs/String) with the fused surface on `~fused_surface`; service ~finish_views
//        (std_srvs/Trigger) fills the fused surface on the same path as a cloud, or refuses naming the
//        hole; ~clear_views (std_srvs/Trigger) forgets the views.
// The node owns the ROS handles and the parameters; geometry::ingestFile/ingestSurface do the work.
// Threads: clouds on `surface_cloud` and the ~surface_file at start are filled on the node's own
// callback queue and thread (one at a time, newest cloud wins), so ~fill_interior keeps answering
// on the caller's spinner while a long topic fill runs (a 5e6-point cloud takes ~25 s). Nothing a
// fill throws (TopoError, std::bad_alloc, any exception) stops the node: the error is logged and the
// last good volume stays latched on `volume`.
#pragma once

#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>
#include <std_msgs/String.h>
#include <std_srvs/Trigger.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <atomic>
#include <cstddef>
#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "topo_gaussian/FillInterior.h"
#include "topo_gaussian/geometry/ingest.h"
#include "topo_gaussian/geometry/view_fusion.h"

namespace topo_gaussian::topo_ros {

/// The node's private parameters, validated.
struct CloudIngestParams {
  std::string surface_file;         ///< ~surface_file: filled once at start when not empty
  std::string frame_id = "object";  ///< ~frame_id: frame of volumes from files (clouds keep their own)
  /// ~up_axis: the object's up direction in its input frame, one of x y z -x -y -z (default z);
  /// passed to geometry::IngestOptions::up_axis (the fill turns that axis to +z).
  std::string up_axis = "z";
  /// ~spacing_m, ~fill_count, ~scale, ~recenter, ~opacity_threshold, ~outlier_neighbours,
  /// ~closing_cells, ~grid_resolution, ~max_open_fraction; unset ones keep the library's defaults
  /// (IngestOptions{}), so the node and `topo fill` agree.
  geometry::IngestOptions options;
  /// Depth views (`depth_points`): ~target_frame (default world) the views are fused and filled in,
  /// ~voxel_m (fusion voxel, 0 = 1 % of the object's size), ~min_coverage (0.95: below it
  /// ~finish_views refuses), ~tf_timeout_s (0.5 s: how long a cloud waits for its transform),
  /// ~max_views (100: more clouds are skipped until ~finish_views or ~clear_views).
  std::string target_frame = "world";
  geometry::ViewFusionOptions fusion;
  double min_coverage = 0.95;
  double tf_timeout_s = 0.5;
  long max_views = 100;
};

/// Reads the private parameters from `pnh` (unset: the defaults of CloudIngestParams) and
/// validates them. Throws TopoError naming the parameter, its value and the fix.
CloudIngestParams loadCloudIngestParams(const ::ros::NodeHandle& pnh);

/// The axis names ~up_axis accepts, and the unit vector of one ("-y" → (0, -1, 0)). Throws TopoError
/// naming `name` for anything else.
Eigen::Vector3d upAxisVector(const std::string& axis, const std::string& name);

/// A surface path the node can read: refuses a FIFO, a directory or a device (reading a FIFO would
/// block the node) with TopoError naming `what` and the path. A missing path passes (the reader
/// names it with its own message).
void checkSurfaceFile(const std::string& path, const std::string& what);

/// The options for one ~fill_interior request: the request's non-zero fields over `defaults`.
/// Throws TopoError naming `service` for negative or non-finite values.
geometry::IngestOptions requestOptions(const topo_gaussian::FillInterior::Request& request,
                                       const geometry::IngestOptions& defaults, const std::string& service);

/// One-line summary of a successful fill, as logged and returned in the service message, ending with
/// the fill's warnings ("; warnings: ...") when it has any.
std::string describe(const geometry::IngestResult& result);

class CloudIngestNode {
 public:
  /// Loads parameters (throws TopoError on invalid ones), advertises `volume`, subscribes
  /// `surface_cloud` on the node's fill queue, offers ~fill_interior, starts the fill thread and
  /// queues the fill of ~surface_file when it is set. A failure of that first fill is logged with
  /// ROS_ERROR and the node keeps running.
  CloudIngestNode(const ::ros::NodeHandle& nh, const ::ros::NodeHandle& pnh);
  ~CloudIngestNode();

  const CloudIngestParams& params() const { return params_; }
  /// Volumes published on `volume` so far.
  std::size_t publishedCount() const { return published_; }
  /// Depth views kept so far.
  std::size_t viewCount() const;

 private:
  void onSurfaceCloud(const sensor_msgs::PointCloud2ConstPtr& msg);
  bool onFillInterior(topo_gaussian::FillInterior::Request& request, topo_gaussian::FillInterior::Response& response);
  void fillStartupFile();
  void onDepthPoints(const sensor_msgs::PointCloud2ConstPtr& msg);
  bool onFinishViews(std_srvs::Trigger::Request& request, std_srvs::Trigger::Response& response);
  bool onClearViews(std_srvs::Trigger::Request& request, std_srvs::Trigger::Response& response);
  /// The kept views (a snapshot) and the stamp of the newest.
  std::vector<std::shared_ptr<const geometry::DepthView>> views(::ros::Time* newest) const;
  /// Publishes contact_samples, then volume, both latched, with the same frame and stamp.
  void publish(const VolumeCloud& cloud, const std::string& frame, const ::ros::Time& stamp);

  ::ros::NodeHandle nh_, pnh_;
  ::ros::NodeHandle fill_nh_;  ///< nh_ on fill_queue_: `surface_cloud` and the startup fill
  ::ros::CallbackQueue fill_queue_;
  std::unique_ptr<::ros::AsyncSpinner> fill_spinner_;  ///< the one thread that serves fill_queue_
  const CloudIngestParams params_;                     ///< read-only after construction: no lock needed
  ::ros::Publisher volume_pub_;                        ///< publish() is thread-safe in roscpp
  ::ros::Publisher contact_pub_;                       ///< the volume's contact samples (same stamp)
  ::ros::Subscriber surface_sub_;
  ::ros::ServiceServer fill_srv_;
  ::ros::WallTimer startup_timer_;  ///< one shot on fill_queue_: fills ~surface_file
  // Depth views: received on fill_queue_, fused and filled by the services on the main queue.
  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_listener_;  ///< its own thread: a lookup may wait for it
  ::ros::Subscriber depth_sub_;
  ::ros::Publisher status_pub_;  ///< ~views_status (latched): the coverage after each change
  ::ros::Publisher fused_pub_;   ///< ~fused_surface (latched): x y z normal_x normal_y normal_z
  ::ros::ServiceServer finish_srv_, clear_srv_;
  mutable std::mutex views_mutex_;
  std::vector<std::shared_ptr<const geometry::DepthView>> views_;
  ::ros::Time newest_view_;
  std::atomic<std::size_t> published_{0};
};

}  // namespace topo_gaussian::topo_ros
