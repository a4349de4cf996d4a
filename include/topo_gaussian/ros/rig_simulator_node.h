// RigSimulatorNode: the ROS face of the rig twin (workflow::RigTwin + vision::renderSplats), a
// digital twin of a lab rig that stands in for the camera, so every launch file and integration
// test runs with no hardware.
//   in : tf world_frame → camera_frame (the camera pose, e.g. a static_transform_publisher in the
//        launch file; after ~camera_pose_timeout_s without it: ~default_camera_pose, warned once)
//   out: `image` (sensor_msgs/Image bgr8, frame camera_frame) and `camera_info` (same stamp) at ~fps,
//        as a camera driver publishes them; tf world_frame → object_frame (the true pose) per frame;
//        `surface_cloud` (PointCloud2 latched: x y z normal_x normal_y normal_z, a scan of the object's
//        surface at ~scan_spacing_m in object_frame; cloud_ingest fills it);
//        ~ground_truth (RigGroundTruth latched: the true interior and its features, for tests only);
//        ~true_interior (PointCloud2 latched, the true interior in ~truth_view_frame, a static frame
//        beside the object, so rviz shows the true and the recovered interior side by side);
//        ~true_interior_markers (MarkerArray latched: the same, drawn like interior_markers, with the
//        viewer's half cut away so its cavity shows);
//        `experiment` (std_msgs/String latched: the experiment on camera, with ~experiments).
//   srv: ~perform_experiment (PerformExperiment: a new experiment NAME of a task with set-up overrides,
//        e.g. what an infer_interior result suggests; the twin sets it up with the same interior, adds it
//        to the experiments it plays and puts it on camera now; its `instruments` come back as readings:
//        features of the task (periods to ~timer_resolution_s, as a lab times a swing with a stopwatch or
//        an encoder) and the hung pose's target_roll_deg / target_pitch_deg (an inclinometer, to
//        ~inclinometer_resolution_deg: the camera along x sees only the roll). Refused,
//        with the reason and the experiments kept: a name taken, an unknown task or key, a hanging point
//        farther than two particle spacings from the object, the finger twin.)
//        `scale_kg` (std_msgs/Float64 latched: the object on the rig's scale, its true mass rounded to
//        ~scale_resolution_kg, 1 g; a lab weighs the object once and so does the twin: the inference
//        takes it as a mass_kg target, since rigid motion alone never fixes the mass).
// ~object finger: the pneumatic finger twin (workflow/finger_twin.h) instead of a moving rigid body:
//   in : `pressure_command` (std_msgs/Float64 [Pa], ~pressure_profile command: the regulator's set
//        point; outside [0, ~pressure_max_pa] or not finite: ignored with a throttled error naming it;
//        none for ~pressure_timeout_s: a throttled warning, the last pressure is held)
//   out: the bending finger rendered on `image`/`camera_info`; `pressure_pa` (std_msgs/Float64, the
//        chamber pressure, as a regulator's sensor) and ~true_bend_deg (std_msgs/Float64, the twin's
//        bend at that pressure, for tests) per frame; ~ground_truth, ~true_interior(_markers),
//        `surface_cloud` as above (features at ~pressure_max_pa); tf world_frame → object_frame static.
// The node owns handles and parameters; the library renders and simulates.
#pragma once

#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/PointCloud2.h>
#include <std_msgs/Float64.h>
#include <std_msgs/String.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <tf2_ros/transform_broadcaster.h>
#include <tf2_ros/transform_listener.h>
#include <visualization_msgs/MarkerArray.h>

#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

#include "topo_gaussian/PerformExperiment.h"
#include "topo_gaussian/RigGroundTruth.h"
#include "topo_gaussian/vision/splat_renderer.h"
#include "topo_gaussian/workflow/finger_twin.h"
#include "topo_gaussian/workflow/rig_twin.h"

namespace topo_gaussian::topo_ros {

struct RigSimulatorParams {
  /// ~object (tumbler), ~spacing_m (0.0025), ~task (the object's task), ~task_dir, ~set ["KEY=VALUE"],
  /// ~interior_quadric (10 numbers; unset = the default cavity), ~loop_cycles (8), ~undamped (true),
  /// ~surface_file ("": the default shape with its surface on the true boundary; a file: filled as
  /// cloud_ingest fills it, so the twin simulates the cloud the inference will see),
  /// ~scan_spacing_m (0.001: point spacing of `surface_cloud`)
  workflow::RigTwinOptions twin;
  /// ~experiments ["NAME=TASK", ...]: several experiments of the one object, played in turn for
  /// ~experiment_s each (the same interior); `~set` entries "NAME.KEY=VALUE" go to one experiment, the
  /// others to every experiment whose task has the key. Empty: one experiment, `twin`.
  std::vector<std::string> experiment_names;
  std::vector<workflow::RigTwinOptions> experiment_twins;
  double experiment_s = 20.0;                   ///< ~experiment_s [s]: how long each experiment plays before the next
  int width = 640, height = 480;                ///< ~width, ~height [px]
  double fps = 30.0;                            ///< ~fps [frames/s]
  double horizontal_fov_deg = 8.0;              ///< ~horizontal_fov_deg: gives fx = fy when ~fx/~fy are 0
  double fx = 0, fy = 0, cx = 0, cy = 0;        ///< ~fx ~fy ~cx ~cy [px]; 0 = from the FOV / image centre
  double noise_sigma = 2.0;                     ///< ~noise_sigma: Gaussian pixel noise [grey levels]
  double scale_resolution_kg = 0.001;           ///< ~scale_resolution_kg: the scale's display step [kg]
  double timer_resolution_s = 0.001;            ///< ~timer_resolution_s: the timed features' step [s]
  double inclinometer_resolution_deg = 0.1;     ///< ~inclinometer_resolution_deg: its step [deg]
  int seed = 1;                                 ///< ~seed: noise of frame k uses seed + k
  std::string world_frame = "world";            ///< ~world_frame
  std::string camera_frame = "camera_optical";  ///< ~camera_frame (optical: x right, y down, z forward)
  std::string object_frame = "object_true";     ///< ~object_frame: the true body frame
  double camera_pose_timeout_s = 2.0;           ///< ~camera_pose_timeout_s
  /// ~default_camera_pose [x y z qx qy qz qw]: camera_frame in world_frame; 1.5 m in front of the
  /// object along −x (its rocking axis), looking horizontally at 4 cm height.
  std::vector<double> default_camera_pose = {-1.5, 0.0, 0.04, -0.5, 0.5, -0.5, 0.5};
  std::vector<double> object_bgr = {40, 40, 150};        ///< ~object_bgr: a dark red doll
  std::vector<double> background_bgr = {235, 235, 235};  ///< ~background_bgr: a light backdrop
  std::vector<double> light_direction = {-1, 0, 1};      ///< ~light_direction (world, towards the light)
  double splat_radius_m = 0.0;                           ///< ~splat_radius_m: 0 = 0.8 × spacing
  /// ~truth_view_frame, ~truth_view_offset_m [x y z]: where rviz shows the true interior beside the
  /// recovered one (a static frame in world_frame; `~true_interior` is published in it).
  std::string truth_view_frame = "object_true_view";
  std::vector<double> truth_view_offset_m = {0.0, 0.15, 0.05};
  /// ~object finger: ~spacing_m (0.002), ~task (finger), ~set, ~interior_quadric (the chamber; unset =
  /// FingerTwin::defaultChamberQuadric()), ~pressure_max_pa (0 = the task's pressure_pa),
  /// ~pressure_levels (6). Camera defaults for the finger: ~default_camera_pose a side view 0.5 m away
  /// on −y, ~horizontal_fov_deg 16.
  bool finger = false;
  workflow::FingerTwinOptions finger_twin;
  /// ~pressure_profile: step (0 Pa for ~pressure_rest_s, then ~pressure_max_pa until the end of each
  /// ~pressure_period_s), ramp (0 → max linearly over the period minus the rest, after the rest), or
  /// command (follow `pressure_command`).
  std::string pressure_profile = "step";
  double pressure_period_s = 8.0;   ///< ~pressure_period_s [s]
  double pressure_rest_s = 2.0;     ///< ~pressure_rest_s [s]: at 0 Pa at the start of each period
  double pressure_timeout_s = 5.0;  ///< ~pressure_timeout_s [s]: warn when no command came for this long
};

/// One experiment's twin: `base` with `task` and those of `assignments` ("KEY=VALUE" for every task that has
/// KEY, "NAME.KEY=VALUE" for this one) that apply. Throws TopoError starting with `what` for a name that is
/// empty, taken or has '.' or '=', an unknown task or a bad assignment.
workflow::RigTwinOptions experimentTwinOptions(const workflow::RigTwinOptions& base, const std::string& name,
                                               const std::string& task, const std::vector<std::string>& assignments,
                                               const std::vector<std::string>& taken, const std::string& what);

/// The chamber pressure of the step/ramp profiles at time t [Pa] (command: NaN).
double profilePressurePa(const RigSimulatorParams& params, double max_pressure_pa, double t_s);

/// Reads and validates the private parameters (the ~set entries against the task, ~object against
/// the shapes); throws TopoError naming the parameter, its value and the fix.
RigSimulatorParams loadRigSimulatorParams(const ::ros::NodeHandle& pnh);

/// The pinhole camera of the parameters (intrinsics resolved, pose left at the origin).
vision::SplatCamera cameraFor(const RigSimulatorParams& params);
/// CameraInfo of that camera: K, P, R = identity, D zeros (plumb_bob).
sensor_msgs::CameraInfo cameraInfoFor(const vision::SplatCamera& camera, const std::string& frame_id,
                                      const ::ros::Time& stamp);
/// Points with normals (float32 x y z normal_x normal_y normal_z) as an unorganised PointCloud2.
/// Throws TopoError when the sizes differ.
sensor_msgs::PointCloud2 toSurfaceCloud(const std::vector<Eigen::Vector3d>& points,
                                        const std::vector<Eigen::Vector3d>& normals, const std::string& frame_id,
                                        const ::ros::Time& stamp);
/// The twin's ground truth (features, solid fraction, mass properties, loop length, interior in
/// object_frame). With several experiments (names, one twin each, the same interior) the features are
/// named "EXPERIMENT.feature" and the interior and loop are the first twin's.
topo_gaussian::RigGroundTruth toGroundTruthMsg(const std::vector<const workflow::RigTwin*>& twins,
                                               const std::vector<std::string>& names, const std::string& object_frame,
                                               const ::ros::Time& stamp);

/// The finger twin's ground truth: features at the highest pressure, chamber as the interior.
topo_gaussian::RigGroundTruth toGroundTruthMsg(const workflow::FingerTwin& twin, double loop_s,
                                               const std::string& object_frame, const ::ros::Time& stamp);

class RigSimulatorNode {
 public:
  /// Loads the parameters and builds the twin (both throw TopoError: bad parameters, a failed
  /// simulation), publishes the latched topics and starts the camera timer.
  RigSimulatorNode(const ::ros::NodeHandle& nh, const ::ros::NodeHandle& pnh);

  const workflow::RigTwin& twin() const { return *twins_.front(); }  ///< not with ~object finger
  std::size_t framesPublished() const { return frames_; }

 private:
  void onTimer(const ::ros::TimerEvent& event);
  void setUpFinger(const ::ros::Time& now);
  /// Camera intrinsics, shading and the splats of the body-frame surface.
  void setUpCamera(const std::vector<Eigen::Vector3d>& surface, const std::vector<Eigen::Vector3d>& normals,
                   double spacing_m);
  /// ~true_interior and ~true_interior_markers (latched, in ~truth_view_frame).
  void publishTrueInterior(const VolumeCloud& cloud, const std::vector<double>& r, const std::vector<double>& density,
                           const inference::TaskConfig& config, const MassProperties& mass);
  /// Renders the posed surface and publishes image and camera_info.
  void publishFrame(const ::ros::Time& now, const vision::Splats& world);
  void onPressureCommand(const std_msgs::Float64& msg);
  bool onPerformExperiment(topo_gaussian::PerformExperiment::Request& req,
                           topo_gaussian::PerformExperiment::Response& res);
  /// Sets up the requested experiment's twin (throws TopoError: the reason it cannot be performed).
  std::unique_ptr<workflow::RigTwin> performedTwin(const topo_gaussian::PerformExperiment::Request& req) const;
  void publishGroundTruth(const ::ros::Time& stamp);
  /// What the rig's instrument reads of an experiment (see ~perform_experiment) and its step (*resolution, in
  /// its unit; 0 = exact); throws TopoError naming it.
  double instrumentReading(const workflow::RigTwin& twin, const std::string& name, double* resolution) const;
  /// The finger's pressure now (profile or command) and its rendered surface.
  double fingerPressurePa(const ::ros::Time& now);
  /// The camera pose from tf, or the default after the timeout; false while still waiting.
  bool cameraPose(const ::ros::Time& now, vision::SplatCamera* camera);

  ::ros::NodeHandle nh_, pnh_;
  RigSimulatorParams params_;
  std::vector<std::unique_ptr<workflow::RigTwin>> twins_;  ///< one per experiment
  std::vector<std::string> names_;                         ///< the experiments' names ("" for one)
  int playing_ = -1;                                       ///< the experiment on camera
  double slot_start_s_ = 0.0;  ///< when it came on camera (seconds since start_)
  ::ros::ServiceServer perform_srv_;
  ::ros::Publisher experiment_pub_, true_interior_pub_, true_markers_pub_;
  tf2_ros::StaticTransformBroadcaster static_broadcaster_;
  vision::SplatCamera camera_;
  vision::SplatShading shading_;
  vision::Splats body_;  ///< the surface in the body frame (posed per frame)
  ::ros::Publisher image_pub_, info_pub_, surface_pub_, truth_pub_, scale_pub_;
  ::ros::Timer timer_;
  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_listener_;
  tf2_ros::TransformBroadcaster tf_broadcaster_;
  std::unique_ptr<workflow::FingerTwin> finger_;
  ::ros::Subscriber pressure_sub_;
  ::ros::Publisher pressure_pub_, true_bend_pub_;
  double commanded_pa_ = 0.0;
  ::ros::Time last_command_;
  ::ros::Time start_;
  bool pose_from_tf_ = false, fallback_warned_ = false;
  std::size_t frames_ = 0;
  double render_s_ = 0.0;
};

}  // namespace topo_gaussian::topo_ros
