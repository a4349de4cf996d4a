// InteriorInferenceNode: the ROS face of topo_inference (one inference = one action goal).
//   in : topics `volume` (PointCloud2, volume layout; its `contact_samples` of the same stamp, when
//        published, give the ground contact the true surface) and `motion_features` (MotionFeatures): the
//        latest of each is used when a goal carries none
//   out: action `infer_interior` (InferInterior.action: feedback every iteration, result with the
//        interior cloud, achieved vs target features and the files written; a cancel or a new goal
//        returns the best design so far; invalid goals abort with the reason)
//        topic `interior` (PointCloud2, latched; x y z solid density stiffness confidence rgb, frame ~object_frame)
//        topic `interior_markers` (MarkerArray, latched; see interior_markers.h)
//        tf ~world_frame → ~object_frame: the simulated motion of the latest result, replayed in a loop
//        services ~infer (Infer.srv, the blocking form of the action), ~simulate (SimulateInterior.srv),
//        ~export (ExportInterior.srv)
// Every run writes its run folder (io/run_folder.h) to ~output_dir/<task>_<time>[_N]/; a restarted
// node reloads the newest complete run (not interrupted, of a task known here) and publishes it again
// at once, simulating its motion off the main thread (~restore_latest); a `topo infer` folder under
// ~output_dir loads the same way.
// The node owns handles, parameters and the latest result; workflow::runInference (the run and its
// folder, the same call as `topo infer`), simulateInterior and exportInterior do the work. Callbacks may run
// concurrently (AsyncSpinner): one inference runs at a time, state is guarded by a mutex.
#pragma once

#include <actionlib/server/simple_action_server.h>
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_ros/transform_broadcaster.h>

#include <atomic>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "topo_gaussian/ExportInterior.h"
#include "topo_gaussian/Infer.h"
#include "topo_gaussian/InferInteriorAction.h"
#include "topo_gaussian/MotionFeatures.h"
#include "topo_gaussian/SimulateInterior.h"
#include "topo_gaussian/inference/pipeline.h"
#include "topo_gaussian/inference/task_config.h"
#include "topo_gaussian/io/run_files.h"
#include "topo_gaussian/workflow/object_experiments.h"

namespace topo_gaussian::topo_ros {

struct InteriorInferenceParams {
  std::string task_dir;                           ///< ~task_dir: where task names resolve (config/tasks)
  std::string default_task = "tumbler";           ///< ~default_task: for ~simulate before any goal
  std::string output_dir;                         ///< ~output_dir: runs write into OUTPUT_DIR/<task>_<time>
  std::string world_frame = "world";              ///< ~world_frame
  std::string object_frame = "object_simulated";  ///< ~object_frame: frame of `interior`, markers, replay
  double replay_rate_hz = 30.0;                   ///< ~replay_rate_hz: tf replay rate (0: no replay)
  double replay_speed = 1.0;                      ///< ~replay_speed: simulated seconds per wall second
  bool export_on_finish = true;                   ///< ~export_on_finish: STL + pictures after every run
  double max_features_age_s = 0.0;  ///< ~max_features_age_s: older motion features are refused (0: any age)
  double volume_wait_s = 15.0;      ///< ~volume_wait_s: a goal before any `volume` waits this long for one
  /// ~restore_latest: at start, reload the newest run under output_dir (volume.ply, interior.ply,
  /// report.json) and publish it, so a restarted node restores rviz and ~export / ~simulate
  bool restore_latest = true;
  /// ~backend: auto | cpu | cuda, where the particle kernels run (the task parameter `backend` of every
  /// goal unless the goal's overrides set it); auto logs whether a GPU is used, cuda without one is
  /// refused at start with the reason
  std::string backend = "auto";
  /// ~cut_away, ~cut_normal [x, y, z] (object frame), ~colour_by (indicator | confidence): how
  /// interior_markers draws the interior (ros/interior_markers.h): the viewer's half cut away so the
  /// hollow shows, cubes faded to grey where the interior is uncertain
  bool cut_away = true;
  std::vector<double> cut_normal{0.955, 0.296, 0.0};
  std::string colour_by = "indicator";
};

/// Reads and validates the private parameters; throws TopoError naming the parameter and the fix.
InteriorInferenceParams loadInteriorInferenceParams(const ::ros::NodeHandle& pnh);

/// Run folders under `parent` (named <stem>_<YYYYmmdd_HHMMSS>[_N], as io::createRunFolder makes
/// them) that have no report.json: runs that never finished (the node was killed or crashed while it
/// worked). io::findLatestRun passes over them silently; the restore names them. Only folders changed
/// after `newer_than` (a run folder, e.g. the one restored; empty: all) are listed, newest first,
/// each as "DIR: why".
std::vector<std::string> unfinishedRunFolders(const std::string& parent, const std::string& newer_than);

/// What one inference needs (the common part of an action goal and an ~infer request).
struct InferenceRequest {
  std::string task, representation;
  std::vector<std::string> experiments;  ///< "[NAME=]FILE": more experiments of the same object
  std::vector<std::string> overrides, targets;
  sensor_msgs::PointCloud2 volume;         ///< no points = the latest `volume`
  topo_gaussian::MotionFeatures features;  ///< empty kind = the latest `motion_features`
  bool ignore_motion_features = false;
  int max_evaluations = 0;  ///< the goal's max_iterations field: objective evaluations; 0 = the task's
  std::string output_dir;
  /// The goal's object_id: its earlier experiments join this goal's (workflow/object_experiments.h).
  std::string object_id;
};

/// What came out of one inference.
struct InferenceOutcome {
  inference::InferenceResult result;
  std::vector<std::string> files;
  std::string output_dir;
  std::string message;                ///< result message + notes (targets used, export)
  sensor_msgs::PointCloud2 interior;  ///< as published on `interior`
  bool preempted = false;
  double uncertain_fraction = NAN;    ///< workflow::uncertainFraction of the result
  int experiments = 1;                ///< of the object (its earlier ones and the goal's)
};

/// The next experiment of an inference as the action result carries it (next_experiment_kind … _tilt_deg:
/// the task, its set-up overrides without the observed targets, what to read beside the camera, the
/// predicted rest tilt) and the experiment loop's decision (workflow::decideNextStep) with the object's experiment count.
void fillNextExperiment(const inference::IdentifiabilityAnalysis& analysis, double uncertain_fraction,
                        int experiments, topo_gaussian::InferInteriorResult* result);

class InteriorInferenceNode {
 public:
  /// Loads parameters (throws TopoError on invalid ones), advertises, subscribes and starts the
  /// action server.
  InteriorInferenceNode(const ::ros::NodeHandle& nh, const ::ros::NodeHandle& pnh);
  /// Stops the restore's simulation (when still running) and waits for it.
  ~InteriorInferenceNode();

  const InteriorInferenceParams& params() const { return params_; }

  /// Runs one inference (throws TopoError for an invalid request: unknown task, no volume, no
  /// targets, bad overrides). feedback is called after every iteration with the iteration and the
  /// features of the design just evaluated; returning false stops with the best design so far.
  using Feedback = std::function<bool(const topo_gaussian::InferInteriorFeedback&)>;
  InferenceOutcome run(const InferenceRequest& request, const Feedback& feedback);

 private:
  void onVolume(const sensor_msgs::PointCloud2ConstPtr& msg);
  void onContactSamples(const sensor_msgs::PointCloud2ConstPtr& msg);
  void onFeatures(const topo_gaussian::MotionFeaturesConstPtr& msg);
  void execute(const topo_gaussian::InferInteriorGoalConstPtr& goal);
  bool onInfer(topo_gaussian::Infer::Request& req, topo_gaussian::Infer::Response& res);
  bool onSimulate(topo_gaussian::SimulateInterior::Request& req, topo_gaussian::SimulateInterior::Response& res);
  bool onExport(topo_gaussian::ExportInterior::Request& req, topo_gaussian::ExportInterior::Response& res);
  void onReplay(const ::ros::WallTimerEvent&);
  /// Finds the run to restore (workflow::findRestorableRun), makes it the latest result and starts
  /// showRestored on its own thread: the node serves goals and services meanwhile.
  void restoreLatest();
  /// Publishes a restored run's interior with its mass properties at once, then simulates it (the task's
  /// default parameters) and publishes it again with its motion; stops when a newer result arrives
  /// (result_generation_ moves on) or the node stops.
  void showRestored(const std::shared_ptr<const VolumeCloud>& cloud, const inference::TaskConfig& config,
                    const std::vector<double>& r, const std::string& dir, std::uint64_t generation);
  /// Publishes `interior` and `interior_markers` for a design (r and density per particle) and
  /// starts replaying its motion; returns the interior cloud it published.
  sensor_msgs::PointCloud2 show(const VolumeCloud& cloud, const inference::TaskConfig& config,
                                const std::vector<double>& r, const std::vector<double>& density,
                                const inference::ProblemEvaluation& ev, const inference::TaskGeometry& geometry,
                                const std::vector<double>& confidence = {});
  /// Simulates a design and shows it (one InteriorProblem for the features, density and geometry).
  inference::ProblemEvaluation simulateAndShow(const VolumeCloud& cloud, const inference::TaskConfig& config,
                                               const std::vector<double>& r, bool show_it);
  inference::TaskConfig configFor(const std::string& task, const std::vector<std::string>& experiments,
                                  const std::string& representation, const std::vector<std::string>& overrides,
                                  const std::string& origin) const;

  ::ros::NodeHandle nh_, pnh_;
  InteriorInferenceParams params_;
  ::ros::Publisher interior_pub_, markers_pub_, deformed_pub_;
  ::ros::Publisher inertia_pub_, identified_inertia_pub_;  ///< the result's mass properties, latched
  ::ros::Subscriber volume_sub_, features_sub_, contact_sub_;
  /// The latest contact samples and their stamp; attached to the volume of the same stamp.
  std::shared_ptr<const ContactSamples> contact_;
  ::ros::Time contact_stamp_, volume_stamp_;
  ::ros::ServiceServer infer_srv_, simulate_srv_, export_srv_;
  ::ros::WallTimer replay_timer_, republish_timer_;
  tf2_ros::TransformBroadcaster tf_;
  std::unique_ptr<actionlib::SimpleActionServer<topo_gaussian::InferInteriorAction>> server_;

  std::mutex run_mutex_;    ///< held while an inference runs
  /// Held while a result is shown: the restore's show and a goal's show do not interleave, and the
  /// restore checks result_generation_ under it.
  std::mutex publish_mutex_;
  std::thread restore_thread_;            ///< showRestored, when ~restore_latest found a run
  std::atomic<bool> restore_stop_{false};  ///< set by the destructor: the restore's simulation stops
  std::mutex state_mutex_;  ///< guards everything below
  std::shared_ptr<VolumeCloud> volume_;
  std::string volume_frame_;
  std::shared_ptr<topo_gaussian::MotionFeatures> features_;
  ::ros::Time features_received_;
  /// The latest window of each experiment (MotionFeatures.experiment, "" = untagged) and when it came.
  std::map<std::string, std::pair<std::shared_ptr<topo_gaussian::MotionFeatures>, ::ros::Time>> features_by_experiment_;
  /// Each goal's object_id: the experiments it was inferred from, with their targets.
  workflow::ObjectExperiments objects_;
  // the latest result (for ~export and ~simulate)
  bool has_result_ = false;
  std::shared_ptr<const VolumeCloud> result_cloud_;
  inference::InferenceResult result_;
  std::string result_task_, result_dir_, result_report_;
  std::vector<io::SignalSeries> result_signals_;
  bool result_continuous_ = false;
  std::uint64_t result_generation_ = 0;  ///< counts the results set (a goal's, the restore's)
  // the replayed motion
  std::vector<inference::BodyPose> replay_;
  ::ros::WallTime replay_start_;
  /// Soft results: the simulated shapes (TaskEvaluation::shapes) replayed on `interior_deformed`
  /// (rest → deformed, hold, back, hold), with the interior's fields of the cloud they belong to.
  std::vector<double> shape_t_;
  std::vector<std::vector<Eigen::Vector3d>> shapes_;
  VolumeCloud shape_cloud_;
  std::vector<double> shape_r_, shape_density_, shape_stiffness_, shape_confidence_;
};

}  // namespace topo_gaussian::topo_ros
