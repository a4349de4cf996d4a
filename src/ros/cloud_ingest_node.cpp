#include "topo_gaussian/ros/cloud_ingest_node.h"

#include <sys/stat.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <exception>
#include <limits>
#include <new>
#include <sstream>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/number_text.h"
#include "topo_gaussian/ros/ascii_text.h"
#include "topo_gaussian/ros/conversions.h"
#include "topo_gaussian/ros/param_reader.h"
#include "topo_gaussian/ros/rig_simulator_node.h"  // toSurfaceCloud
#include "topo_gaussian/ros/service_guard.h"

namespace topo_gaussian::topo_ros {

CloudIngestParams loadCloudIngestParams(const ::ros::NodeHandle& pnh) {
  const ParamReader reader(pnh, "cloud_ingest");
  CloudIngestParams p;
  auto& clean = p.options.clean;
  auto& fill = p.options.fill;
  auto bad = [&](const std::string& name, const std::string& problem, const std::string& fix) {
    throw TopoError(reader.displayName(name), problem, fix);
  };
  // Types are checked by the reader; the ranges here, with the node's own advice.
  p.surface_file = reader.text("surface_file", "");
  p.frame_id = reader.text("frame_id", p.frame_id);
  if (p.frame_id.empty()) bad("frame_id", "is empty", "name the object's body frame, e.g. object");
  p.up_axis = reader.text("up_axis", p.up_axis);
  upAxisVector(p.up_axis, reader.displayName("up_axis"));  // x y z -x -y -z, or a TopoError naming it
  p.options.up_axis = p.up_axis;

  fill.spacing_m = reader.number("spacing_m", fill.spacing_m, "m");
  if (fill.spacing_m < 0.0)
    bad("spacing_m", "is " + numberText(fill.spacing_m, 6) + " m, a negative spacing",
        "give a positive lattice spacing in metres, or 0 to use ~fill_count");
  const long count = reader.integer("fill_count", long(fill.target_count));
  if (count < 8)
    bad("fill_count", "is " + std::to_string(count) + ": too few particles",
        "ask for at least 8 particles (default 50000)");
  fill.target_count = std::size_t(count);
  clean.scale = reader.number("scale", clean.scale);
  if (!(clean.scale > 0.0))
    bad("scale", "is " + numberText(clean.scale, 6) + ", not a positive factor",
        "use 1 for metres, 0.001 for millimetres");
  clean.recenter = reader.flag("recenter", clean.recenter);
  clean.opacity_threshold = reader.number("opacity_threshold", clean.opacity_threshold);
  if (clean.opacity_threshold < 0.0 || clean.opacity_threshold >= 1.0)
    bad("opacity_threshold", "is " + numberText(clean.opacity_threshold, 6) + ", outside [0, 1)",
        "use the default 0.02, or 0 to keep every Gaussian");
  const long k = reader.integer("outlier_neighbours", clean.outlier_neighbours);
  if (k < 0 || k > 1000)
    bad("outlier_neighbours", "is " + std::to_string(k) + ", outside [0, 1000]",
        "use 16, or 0 to turn outlier removal off");
  clean.outlier_neighbours = int(k);
  const long closing = reader.integer("closing_cells", fill.density.closing_cells);
  if (closing < -1 || closing > 64)
    bad("closing_cells", "is " + std::to_string(closing) + ", outside [-1, 64]",
        "use -1 (automatic), 0 (off) or a few cells, e.g. 2");
  fill.density.closing_cells = int(closing);
  const long grid = reader.integer("grid_resolution", fill.grid_resolution);
  if (grid < 0 || grid > 4096)
    bad("grid_resolution", "is " + std::to_string(grid) + ", outside [0, 4096]",
        "use 0 (the lattice spacing) or e.g. 100 cells");
  fill.grid_resolution = int(grid);
  fill.max_open_fraction = reader.number("max_open_fraction", fill.max_open_fraction);
  if (fill.max_open_fraction < 0.0 || fill.max_open_fraction > 1.0)
    bad("max_open_fraction", "is " + numberText(fill.max_open_fraction, 6) + ", outside [0, 1]",
        "use the default 0.02");
  geometry::validateFillOptions(fill, pnh.getNamespace() + " parameters");  // the library's own checks too
  // Depth views (`depth_points`, ~finish_views).
  p.target_frame = reader.text("target_frame", p.target_frame);
  if (p.target_frame.empty())
    bad("target_frame", "is empty", "name the fixed frame the views are fused in, e.g. world or base_link");
  p.fusion.voxel_m = reader.number("voxel_m", p.fusion.voxel_m, "m", Range::atLeast(0.0));
  p.min_coverage = reader.number("min_coverage", p.min_coverage, "", Range::between(0.0, 1.0));
  p.tf_timeout_s = reader.number("tf_timeout_s", p.tf_timeout_s, "s", Range::between(0.0, 10.0));
  p.max_views = reader.integer("max_views", p.max_views, "", Range::between(1.0, 10000.0));
  return p;
}

Eigen::Vector3d upAxisVector(const std::string& axis, const std::string& name) {
  const std::string a = axis.size() == 2 && axis[0] == '+' ? axis.substr(1) : axis;
  const double sign = !a.empty() && a[0] == '-' ? -1.0 : 1.0;
  const std::string letter = sign < 0 ? a.substr(1) : a;
  if (letter == "x") return Eigen::Vector3d(sign, 0, 0);
  if (letter == "y") return Eigen::Vector3d(0, sign, 0);
  if (letter == "z") return Eigen::Vector3d(0, 0, sign);
  throw TopoError(name, "is '" + axis + "', not an axis",
                  "use one of x y z -x -y -z: the object's up direction in its file or cloud frame (default z)");
}

void checkSurfaceFile(const std::string& path, const std::string& what) {
  struct stat st {};
  if (path.empty() || ::stat(path.c_str(), &st) != 0) return;  // missing: the reader says so
  if (S_ISREG(st.st_mode)) return;
  const char* kind = S_ISFIFO(st.st_mode)   ? "a FIFO (named pipe)"
                     : S_ISDIR(st.st_mode)  ? "a directory"
                     : S_ISCHR(st.st_mode)  ? "a character device"
                     : S_ISBLK(st.st_mode)  ? "a block device"
                     : S_ISSOCK(st.st_mode) ? "a socket"
                                            : "not a regular file";
  throw TopoError(what,
                  "'" + path + "' is " + std::string(kind) + ", not a regular file (reading it could block the node)",
                  "give the path of a surface file: .ply .pcd .obj .off .stl");
}

geometry::IngestOptions requestOptions(const topo_gaussian::FillInterior::Request& req,
                                       const geometry::IngestOptions& defaults, const std::string& service) {
  geometry::IngestOptions o = defaults;
  if (!std::isfinite(req.spacing_m) || req.spacing_m < 0.0)
    throw TopoError(service, "spacing_m " + numberText(req.spacing_m, 6) + " is negative or not finite",
                    "give a positive spacing in metres, or 0 to use target_count");
  if (req.spacing_m > 0.0) {
    o.fill.spacing_m = req.spacing_m;
  } else if (req.target_count > 0) {
    o.fill.spacing_m = 0.0;
    o.fill.target_count = req.target_count;
  }
  if (!std::isfinite(req.scale) || req.scale < 0.0)
    throw TopoError(service, "scale " + numberText(req.scale, 6) + " is negative or not finite",
                    "use 1 for metres, 0.001 for millimetres, 0 for the node's ~scale");
  if (req.scale > 0.0) o.clean.scale = req.scale;
  if (req.recenter) o.clean.recenter = true;
  if (req.closing_cells < -1 || req.closing_cells > 64)
    throw TopoError(service, "closing_cells " + std::to_string(req.closing_cells) + " is outside [-1, 64]",
                    "use 0 (node default), -1 (automatic) or a few cells, e.g. 2");
  if (req.closing_cells != 0) o.fill.density.closing_cells = req.closing_cells;
  geometry::validateFillOptions(o.fill, service + " request");
  return o;
}

std::string describe(const geometry::IngestResult& r) {
  std::ostringstream s;
  s.precision(6);
  s << "filled " << r.input << " (" << geometry::toString(r.kind) << ", " << r.clean.points_in
    << " points): " << r.cloud.size() << " particles (" << r.cloud.surfaceCount() << " on the surface), volume "
    << r.cloud.totalVolume() << " m^3, spacing " << r.cloud.spacing << " m, " << r.cloud.contact.size()
    << " contact samples on the true surface (spacing " << r.cloud.contact.spacing << " m), " << r.seconds
    << " s, method " << r.fill.method;
  // Every repair and suspicion of the run (merged duplicate points, welded or re-oriented faces,
  // overlapping shells, an open mesh filled by the density method), as topo fill prints them.
  for (std::size_t i = 0; i < r.warnings.size(); ++i)
    s << (i ? "; " : "; warning" + std::string(r.warnings.size() > 1 ? "s" : "") + ": ") << r.warnings[i];
  return s.str();
}

CloudIngestNode::CloudIngestNode(const ::ros::NodeHandle& nh, const ::ros::NodeHandle& pnh)
    : nh_(nh), pnh_(pnh), fill_nh_(nh), params_(loadCloudIngestParams(pnh)), tf_listener_(tf_buffer_) {
  fill_nh_.setCallbackQueue(&fill_queue_);
  volume_pub_ = nh_.advertise<sensor_msgs::PointCloud2>("volume", 1, /*latch=*/true);
  contact_pub_ = nh_.advertise<sensor_msgs::PointCloud2>("contact_samples", 1, /*latch=*/true);
  surface_sub_ = fill_nh_.subscribe("surface_cloud", 1, &CloudIngestNode::onSurfaceCloud, this);
  fill_srv_ = pnh_.advertiseService("fill_interior", &CloudIngestNode::onFillInterior, this);
  status_pub_ = pnh_.advertise<std_msgs::String>("views_status", 1, /*latch=*/true);
  fused_pub_ = pnh_.advertise<sensor_msgs::PointCloud2>("fused_surface", 1, /*latch=*/true);
  depth_sub_ = fill_nh_.subscribe("depth_points", 4, &CloudIngestNode::onDepthPoints, this);
  finish_srv_ = pnh_.advertiseService("finish_views", &CloudIngestNode::onFinishViews, this);
  clear_srv_ = pnh_.advertiseService("clear_views", &CloudIngestNode::onClearViews, this);
  ROS_INFO("cloud_ingest: publishing %s and %s (latched, frame %s), listening on %s, service %s",
           volume_pub_.getTopic().c_str(), contact_pub_.getTopic().c_str(), params_.frame_id.c_str(),
           surface_sub_.getTopic().c_str(), fill_srv_.getService().c_str());
  ROS_INFO("cloud_ingest: depth views on %s are fused in frame %s; %s fills them, %s forgets them",
           depth_sub_.getTopic().c_str(), params_.target_frame.c_str(), finish_srv_.getService().c_str(),
           clear_srv_.getService().c_str());
  fill_spinner_ = std::make_unique<::ros::AsyncSpinner>(1, &fill_queue_);
  fill_spinner_->start();
  if (params_.surface_file.empty()) {
    ROS_INFO("cloud_ingest: no ~surface_file; waiting for clouds on %s or calls to %s", surface_sub_.getTopic().c_str(),
             fill_srv_.getService().c_str());
  } else {
    startup_timer_ = fill_nh_.createWallTimer(
        ::ros::WallDuration(0.001), [this](const ::ros::WallTimerEvent&) { fillStartupFile(); }, /*oneshot=*/true);
  }
}

CloudIngestNode::~CloudIngestNode() {
  startup_timer_.stop();
  surface_sub_.shutdown();
  depth_sub_.shutdown();
  fill_queue_.disable();
  fill_spinner_->stop();  // waits for a fill in progress
  fill_queue_.clear();
}

void CloudIngestNode::fillStartupFile() {
  std::string why;
  try {
    checkSurfaceFile(params_.surface_file, pnh_.resolveName("surface_file"));
    const geometry::IngestResult r = geometry::ingestFile(params_.surface_file, params_.options);
    publish(r.cloud, params_.frame_id, ::ros::Time::now());
    ROS_INFO("cloud_ingest: %s", asciiText(describe(r)).c_str());
    return;
  } catch (const std::bad_alloc&) {
    why = params_.surface_file + ": out of memory; raise ~spacing_m or lower ~fill_count";
  } catch (const std::exception& e) {
    why = e.what();
  } catch (...) {
    why = params_.surface_file + ": unknown exception";
  }
  ROS_ERROR("cloud_ingest: ~surface_file not filled: %s. The node keeps running: publish a cloud on %s or call %s",
            asciiText(why).c_str(), surface_sub_.getTopic().c_str(), fill_srv_.getService().c_str());
}

void CloudIngestNode::onSurfaceCloud(const sensor_msgs::PointCloud2ConstPtr& msg) {
  const std::string topic = surface_sub_.getTopic();
  try {
    const geometry::IngestResult r = geometry::ingestSurface(toSurfaceData(*msg, topic), params_.options);
    const std::string frame = msg->header.frame_id.empty() ? params_.frame_id : msg->header.frame_id;
    const ::ros::Time stamp = msg->header.stamp.isZero() ? ::ros::Time::now() : msg->header.stamp;
    publish(r.cloud, frame, stamp);
    ROS_INFO("cloud_ingest: %s", asciiText(describe(r)).c_str());
  } catch (const std::bad_alloc&) {
    ROS_ERROR(
        "cloud_ingest: cloud on %s (%u x %u points) not filled (last good volume stays published): out of memory; "
        "raise ~spacing_m, lower ~fill_count, or publish fewer points",
        topic.c_str(), msg->width, msg->height);
  } catch (const std::exception& e) {  // TopoError: bad input, named with the fix
    ROS_ERROR("cloud_ingest: cloud on %s not filled (last good volume stays published): %s", topic.c_str(),
              asciiText(e.what()).c_str());
  } catch (...) {
    ROS_ERROR("cloud_ingest: cloud on %s not filled (last good volume stays published): unknown exception",
              topic.c_str());
  }
}

bool CloudIngestNode::onFillInterior(topo_gaussian::FillInterior::Request& req,
                                     topo_gaussian::FillInterior::Response& res) {
  const std::string service = fill_srv_.getService();
  res.success = false;
  return guardService("cloud_ingest", service, res, [&] {
    const geometry::IngestOptions options = requestOptions(req, params_.options, service);
    geometry::IngestResult r;
    std::string frame = params_.frame_id;
    ::ros::Time stamp = ::ros::Time::now();
    if (!req.surface_file.empty()) {
      checkSurfaceFile(req.surface_file, service + " surface_file");
      r = geometry::ingestFile(req.surface_file, options);
    } else {
      if (std::size_t(req.surface.width) * req.surface.height == 0)
        throw TopoError(service, "the request has neither a surface_file nor surface points",
                        "set surface_file to a .ply/.pcd/.obj/.off/.stl file, or fill surface with x y z points");
      r = geometry::ingestSurface(toSurfaceData(req.surface, service + " request surface"), options);
      if (!req.surface.header.frame_id.empty()) frame = req.surface.header.frame_id;
      if (!req.surface.header.stamp.isZero()) stamp = req.surface.header.stamp;
    }
    res.volume = toPointCloud2(r.cloud, frame, stamp);
    res.count = std::uint32_t(r.cloud.size());
    res.total_volume_m3 = r.cloud.totalVolume();
    res.spacing_m = r.cloud.spacing;
    res.method = r.fill.method;
    res.message = describe(r);
    res.success = true;
    if (req.publish) publish(r.cloud, frame, stamp);
    ROS_INFO("cloud_ingest: %s: %s%s", service.c_str(), asciiText(res.message).c_str(),
             req.publish ? " (published)" : "");
  });  // errors travel in the response, never as a failed call
}

namespace {

Eigen::Isometry3d toIsometry(const geometry_msgs::Transform& t) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::Quaterniond(t.rotation.w, t.rotation.x, t.rotation.y, t.rotation.z).normalized().toRotationMatrix();
  T.translation() = Eigen::Vector3d(t.translation.x, t.translation.y, t.translation.z);
  return T;
}

/// Pointers to the views of a snapshot (which keeps them alive while they are fused).
std::vector<const geometry::DepthView*> pointers(const std::vector<std::shared_ptr<const geometry::DepthView>>& views) {
  std::vector<const geometry::DepthView*> out;
  out.reserve(views.size());
  for (const auto& v : views) out.push_back(v.get());
  return out;
}

}  // namespace

std::size_t CloudIngestNode::viewCount() const {
  std::lock_guard<std::mutex> lock(views_mutex_);
  return views_.size();
}

std::vector<std::shared_ptr<const geometry::DepthView>> CloudIngestNode::views(::ros::Time* newest) const {
  std::lock_guard<std::mutex> lock(views_mutex_);
  if (newest) *newest = newest_view_;
  return views_;
}

void CloudIngestNode::onDepthPoints(const sensor_msgs::PointCloud2ConstPtr& msg) {
  const std::string topic = depth_sub_.getTopic();
  const std::string frame = msg->header.frame_id;
  try {
    if (frame.empty()) {
      ROS_WARN("cloud_ingest: cloud on %s skipped: it has no header.frame_id, so its sensor pose is unknown. Fix: set "
               "the depth camera's frame (e.g. camera_depth_optical_frame) and publish its tf to %s",
               topic.c_str(), params_.target_frame.c_str());
      return;
    }
    if (viewCount() >= std::size_t(params_.max_views)) {
      ROS_WARN_THROTTLE(5.0,
                        "cloud_ingest: cloud on %s skipped: %zu views kept, ~max_views is %ld. Fix: call %s (fill) or "
                        "%s (start again), or raise ~max_views; publish one cloud per viewpoint",
                        topic.c_str(), viewCount(), params_.max_views, finish_srv_.getService().c_str(),
                        clear_srv_.getService().c_str());
      return;
    }
    geometry_msgs::TransformStamped tf;
    try {
      tf = tf_buffer_.lookupTransform(params_.target_frame, frame, msg->header.stamp,
                                      ::ros::Duration(params_.tf_timeout_s));
    } catch (const tf2::TransformException& e) {
      ROS_WARN("cloud_ingest: cloud on %s skipped (the views kept are unchanged): no transform %s <- %s at stamp "
               "%.3f within %.2f s: %s. Fix: publish the tf from %s to the camera frame %s (robot_state_publisher, "
               "a static_transform_publisher, or the arm's driver) at the clouds' stamps",
               topic.c_str(), params_.target_frame.c_str(), frame.c_str(), msg->header.stamp.toSec(),
               params_.tf_timeout_s, asciiText(e.what()).c_str(), params_.target_frame.c_str(), frame.c_str());
      return;
    }
    auto view = std::make_shared<geometry::DepthView>();
    view->world_from_sensor = toIsometry(tf.transform);
    for (const auto& p : toSurfaceData(*msg, topic).points)
      if (p.allFinite()) view->points.push_back(p);
    if (view->points.empty()) {
      ROS_WARN("cloud_ingest: cloud on %s (frame %s) skipped: no finite point (the camera saw nothing in range)",
               topic.c_str(), frame.c_str());
      return;
    }
    std::size_t count = 0;
    {
      std::lock_guard<std::mutex> lock(views_mutex_);
      view->name = "view " + std::to_string(views_.size() + 1) + " (frame " + frame + ")";
      views_.push_back(view);
      newest_view_ = std::max(newest_view_, msg->header.stamp);
      count = views_.size();
    }
    ::ros::Time stamp;
    const auto kept = views(&stamp);
    const geometry::FusedViews fused = geometry::fuseViews(pointers(kept), params_.fusion, topic);
    const std::string text = view->name + " added (" + std::to_string(view->points.size()) + " points), " +
                             std::to_string(count) + " views fused into " + std::to_string(fused.voxels) +
                             " points (voxel " + numberText(fused.voxel_m, 3) + " m): " +
                             fused.coverage.summary(params_.target_frame) +
                             (fused.coverage.fraction >= params_.min_coverage
                                  ? ". Enough to fill: call " + finish_srv_.getService()
                                  : ". ~min_coverage is " + numberText(100.0 * params_.min_coverage, 3) +
                                        " %: add views where the holes are");
    std_msgs::String status;
    status.data = asciiText(text);
    status_pub_.publish(status);
    fused_pub_.publish(toSurfaceCloud(fused.surface.points, fused.surface.normals, params_.target_frame, stamp));
    ROS_INFO("cloud_ingest: %s", status.data.c_str());
  } catch (const std::exception& e) {  // TopoError: a cloud without z, absurd coordinates, ...
    ROS_WARN("cloud_ingest: cloud on %s (frame %s) not used: %s", topic.c_str(), frame.c_str(),
             asciiText(e.what()).c_str());
  }
}

bool CloudIngestNode::onFinishViews(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
  const std::string service = finish_srv_.getService();
  res.success = false;
  return guardService("cloud_ingest", service, res, [&] {
    ::ros::Time stamp;
    const auto kept = views(&stamp);
    if (kept.empty())
      throw TopoError(service, "no depth view has been added",
                      "publish depth clouds on " + depth_sub_.getTopic() + " with their tf to " + params_.target_frame +
                          " first");
    const geometry::FusedViews fused = geometry::fuseViews(pointers(kept), params_.fusion, depth_sub_.getTopic());
    geometry::requireCoverage(fused.coverage, params_.min_coverage,
                              service + " (" + std::to_string(kept.size()) + " views kept; ~min_coverage)",
                              params_.target_frame);
    const geometry::IngestResult r = geometry::ingestSurface(fused.surface, params_.options);
    publish(r.cloud, params_.target_frame, stamp.isZero() ? ::ros::Time::now() : stamp);
    res.message = describe(r) + "; " + fused.coverage.summary(params_.target_frame);
    res.success = true;
    ROS_INFO("cloud_ingest: %s: %s (published)", service.c_str(), asciiText(res.message).c_str());
  });  // a refusal travels in the response; the views stay for more
}

bool CloudIngestNode::onClearViews(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
  std::size_t n = 0;
  {
    std::lock_guard<std::mutex> lock(views_mutex_);
    n = views_.size();
    views_.clear();
    newest_view_ = ::ros::Time();
  }
  std_msgs::String status;
  status.data = "no views (cleared " + std::to_string(n) + ")";
  status_pub_.publish(status);
  res.success = true;
  res.message = "cleared " + std::to_string(n) + " view(s); the published volume stays";
  ROS_INFO("cloud_ingest: %s: %s", clear_srv_.getService().c_str(), res.message.c_str());
  return true;
}

void CloudIngestNode::publish(
const VolumeCloud& cloud, const std::string& frame, const ::ros::Time& stamp) {
  // The contact samples first: a subscriber pairs them with the volume of the same stamp.
  contact_pub_.publish(toContactCloud(cloud.contact, frame, stamp));
  volume_pub_.publish(toPointCloud2(cloud, frame, stamp));
  ++published_;
}

}  // namespace topo_gaussian::topo_ros
