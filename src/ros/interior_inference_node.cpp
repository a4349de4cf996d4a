#include "topo_gaussian/ros/interior_inference_node.h"

#include <geometry_msgs/TransformStamped.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <regex>
#include <sstream>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/cuda/backend.h"
#include "topo_gaussian/inference/interior_problem.h"
#include "topo_gaussian/io/run_folder.h"
#include "topo_gaussian/physics/mass_properties.h"
#include "topo_gaussian/physics/run_limits.h"
#include "topo_gaussian/io/task_dir.h"
#include "topo_gaussian/ros/ascii_text.h"
#include "topo_gaussian/ros/body_pose_msg.h"
#include "topo_gaussian/ros/inertia_msg.h"
#include "topo_gaussian/ros/conversions.h"
#include "topo_gaussian/ros/interior_markers.h"
#include "topo_gaussian/ros/motion_features_msg.h"
#include "topo_gaussian/ros/param_reader.h"
#include "topo_gaussian/ros/service_guard.h"
#include "topo_gaussian/workflow/experiment_loop.h"
#include "topo_gaussian/workflow/inference_run.h"
#include "topo_gaussian/workflow/interior_export.h"

namespace topo_gaussian::topo_ros {
namespace {

std::string defaultOutputDir() {
  if (const char* h = std::getenv("ROS_HOME")) return std::string(h) + "/topo_gaussian";
  if (const char* h = std::getenv("HOME")) return std::string(h) + "/.ros/topo_gaussian";
  return "/tmp/topo_gaussian";
}

void fillFeatures(const std::vector<inference::Feature>& fs, std::vector<std::string>* names,
                  std::vector<double>* values, std::vector<double>* targets, std::vector<std::string>* units) {
  for (const auto& f : fs) {
    names->push_back(f.name);
    values->push_back(f.value);
    if (targets) targets->push_back(f.has_target ? f.target : std::numeric_limits<double>::quiet_NaN());
    if (units) units->push_back(f.unit);
  }
}

}  // namespace

InteriorInferenceParams loadInteriorInferenceParams(const ::ros::NodeHandle& pnh) {
  InteriorInferenceParams p;
  const ParamReader r(pnh, "interior_inference");
  p.task_dir = r.text("task_dir", io::defaultTaskDir());
  p.default_task = r.text("default_task", p.default_task);
  p.output_dir = r.text("output_dir", defaultOutputDir());
  p.world_frame = r.text("world_frame", p.world_frame);
  p.object_frame = r.text("object_frame", p.object_frame);
  p.replay_rate_hz = r.number("replay_rate_hz", p.replay_rate_hz, "Hz", Range::between(0, 1000));
  p.replay_speed = r.number("replay_speed", p.replay_speed, "", Range{0, 100, true, false});
  p.export_on_finish = r.flag("export_on_finish", p.export_on_finish);
  p.max_features_age_s = r.number("max_features_age_s", p.max_features_age_s, "s", Range::atLeast(0));
  p.volume_wait_s = r.number("volume_wait_s", p.volume_wait_s, "s", Range::between(0, 3600));
  p.restore_latest = r.flag("restore_latest", p.restore_latest);
  p.backend = r.text("backend", p.backend);
  p.cut_away = r.flag("cut_away", p.cut_away);
  p.cut_normal = r.numbers("cut_normal", p.cut_normal, 3, "", "[1, 0, 0] (the +x half is cut away)");
  if (std::sqrt(p.cut_normal[0] * p.cut_normal[0] + p.cut_normal[1] * p.cut_normal[1] +
                p.cut_normal[2] * p.cut_normal[2]) == 0)
    throw TopoError(r.displayName("cut_normal"), "is zero",
                    "give the direction of the half to cut away, e.g. [1, 0, 0]");
  p.colour_by = r.text("colour_by", p.colour_by);
  if (p.colour_by != "indicator" && p.colour_by != "confidence")
    throw TopoError(r.displayName("colour_by"), "is '" + p.colour_by + "'",
                    "use indicator (solid red, hollow blue) or confidence (faded to grey where uncertain)");
  {
    std::string line;
    resolveBackend(parseComputeBackend(p.backend, "~backend"), "~backend", &line);
    ROS_INFO("interior_inference: %s", line.c_str());
  }
  if (p.world_frame.empty() || p.object_frame.empty() || p.world_frame == p.object_frame)
    throw TopoError("~world_frame/~object_frame", "must be two different, non-empty frame names",
                    "e.g. world and object_simulated");
  if (p.output_dir.empty()) throw TopoError("~output_dir", "is empty", "give a writable directory");
  inference::TaskConfig::load(p.default_task, p.task_dir);  // throws for an unknown ~default_task
  return p;
}

InteriorInferenceNode::InteriorInferenceNode(const ::ros::NodeHandle& nh, const ::ros::NodeHandle& pnh)
    : nh_(nh), pnh_(pnh), params_(loadInteriorInferenceParams(pnh)) {
  interior_pub_ = nh_.advertise<sensor_msgs::PointCloud2>("interior", 1, true);
  markers_pub_ = nh_.advertise<visualization_msgs::MarkerArray>("interior_markers", 1, true);
  deformed_pub_ = nh_.advertise<sensor_msgs::PointCloud2>("interior_deformed", 1);
  inertia_pub_ = nh_.advertise<geometry_msgs::InertiaStamped>("inertia", 1, true);
  identified_inertia_pub_ = nh_.advertise<topo_gaussian::IdentifiedInertia>("inertia_identified", 1, true);
  volume_sub_ = nh_.subscribe("volume", 1, &InteriorInferenceNode::onVolume, this);
  contact_sub_ = nh_.subscribe("contact_samples", 1, &InteriorInferenceNode::onContactSamples, this);
  features_sub_ = nh_.subscribe("motion_features", 1, &InteriorInferenceNode::onFeatures, this);
  infer_srv_ = pnh_.advertiseService("infer", &InteriorInferenceNode::onInfer, this);
  simulate_srv_ = pnh_.advertiseService("simulate", &InteriorInferenceNode::onSimulate, this);
  export_srv_ = pnh_.advertiseService("export", &InteriorInferenceNode::onExport, this);
  if (params_.replay_rate_hz > 0)
    replay_timer_ =
        nh_.createWallTimer(::ros::WallDuration(1.0 / params_.replay_rate_hz), &InteriorInferenceNode::onReplay, this);
  server_ = std::make_unique<actionlib::SimpleActionServer<topo_gaussian::InferInteriorAction>>(
      nh_, "infer_interior", [this](const topo_gaussian::InferInteriorGoalConstPtr& g) { execute(g); }, false);
  server_->start();
  if (params_.restore_latest) restoreLatest();
  ROS_INFO("interior_inference: action %s/infer_interior, services %s %s %s; waiting for %s and %s; results in %s",
           nh_.getNamespace() == "/" ? "" : nh_.getNamespace().c_str(), infer_srv_.getService().c_str(),
           simulate_srv_.getService().c_str(), export_srv_.getService().c_str(), volume_sub_.getTopic().c_str(),
           features_sub_.getTopic().c_str(), params_.output_dir.c_str());
}

void InteriorInferenceNode::onVolume(const sensor_msgs::PointCloud2ConstPtr& msg) {
  try {
    std::string derived;  // an older message without the spacing field: derived, and said so
    auto cloud = std::make_shared<VolumeCloud>(fromPointCloud2(*msg, volume_sub_.getTopic(), &derived));
    if (!derived.empty()) ROS_WARN("interior_inference: %s", asciiText(derived).c_str());
    cloud->validate(volume_sub_.getTopic());
    std::lock_guard<std::mutex> lock(state_mutex_);
    if (contact_ && contact_stamp_ == msg->header.stamp) cloud->contact = *contact_;
    volume_ = cloud;
    volume_frame_ = msg->header.frame_id;
    volume_stamp_ = msg->header.stamp;
    ROS_INFO(
        "interior_inference: volume of %zu particles (spacing %.4g m, %.4g m^3) in frame '%s', %zu contact "
        "samples%s",
        cloud->size(), cloud->spacing, cloud->totalVolume(), msg->header.frame_id.c_str(), cloud->contact.size(),
        cloud->contact.empty() ? " (none yet: contact uses the surface particles until they arrive)" : "");
  } catch (const std::exception& e) {
    ROS_ERROR("interior_inference: ignored a volume: %s", asciiText(e.what()).c_str());
  }
}

void InteriorInferenceNode::onContactSamples(const sensor_msgs::PointCloud2ConstPtr& msg) {
  try {
    std::string derived;
    auto samples = std::make_shared<ContactSamples>(fromContactCloud(*msg, contact_sub_.getTopic(), &derived));
    if (!derived.empty()) ROS_WARN("interior_inference: %s", asciiText(derived).c_str());
    std::lock_guard<std::mutex> lock(state_mutex_);
    contact_ = samples;
    contact_stamp_ = msg->header.stamp;
    if (volume_ && volume_stamp_ == msg->header.stamp && volume_->contact.size() != samples->size()) {
      auto cloud = std::make_shared<VolumeCloud>(*volume_);  // a run in progress keeps its own copy
      cloud->contact = *samples;
      cloud->validate(contact_sub_.getTopic());
      volume_ = cloud;
      ROS_INFO("interior_inference: %zu contact samples on the true surface attached to the volume", samples->size());
    }
  } catch (const std::exception& e) {
    ROS_ERROR("interior_inference: ignored contact samples: %s", asciiText(e.what()).c_str());
  }
}

void InteriorInferenceNode::onFeatures(const topo_gaussian::MotionFeaturesConstPtr& msg) {
  std::lock_guard<std::mutex> lock(state_mutex_);
  const bool first = !features_;
  features_ = std::make_shared<topo_gaussian::MotionFeatures>(*msg);
  features_received_ = ::ros::Time::now();
  const bool first_of_experiment = !features_by_experiment_.count(msg->experiment);
  features_by_experiment_[msg->experiment] = {features_, features_received_};
  if (first_of_experiment && !msg->experiment.empty())
    ROS_INFO("interior_inference: motion features of experiment '%s' from %s (kind %s)", msg->experiment.c_str(),
             msg->source.c_str(), msg->kind.c_str());
  if (first)
    ROS_INFO("interior_inference: motion features from %s (kind %s): period %.4g s, max tilt %.4g deg, bend %.4g deg",
             msg->source.c_str(), msg->kind.c_str(), msg->period_s, msg->max_tilt_deg, msg->bending_angle_deg);
}

inference::TaskConfig InteriorInferenceNode::configFor(const std::string& task,
                                                       const std::vector<std::string>& experiments,
                                                       const std::string& representation,
                                                       const std::vector<std::string>& overrides,
                                                       const std::string& origin) const {
  if (task.empty() && experiments.empty())
    throw TopoError(
        origin + " task", "is empty", "name a task (" + [] {
          std::string s;
          for (const auto& n : inference::TaskConfig::taskNames()) s += (s.empty() ? "" : ", ") + n;
          return s;
        }() + ") or a task YAML file");
  inference::TaskConfig config =
      inference::TaskConfig::loadWithExperiments(task, experiments, params_.task_dir, overrides);
  if (!representation.empty()) config.set("representation", representation, origin + " representation");
  config.set("backend", params_.backend, "~backend");
  for (const auto& o : overrides) config.setAssignment(o, origin + " overrides");
  return config;
}

void fillNextExperiment(const inference::IdentifiabilityAnalysis& analysis, double uncertain_fraction,
                        int experiments, topo_gaussian::InferInteriorResult* result) {
  result->uncertain_fraction = uncertain_fraction;
  result->next_experiment_tilt_deg = NAN;
  if (analysis.has_suggestion) {
    const inference::ExperimentSuggestion& s = analysis.suggestion;
    const workflow::SuggestedExperiment suggested = workflow::suggestionOverrides(s);
    result->next_experiment = s.sentence;
    result->next_experiment_kind = suggested.kind;
    result->next_experiment_task = suggested.task;
    // set-up parameters go to the rig; the object's shared ones (materials, representation) it has and
    // the node keeps with the object; the observed ones are the design's predictions, not observations:
    // the periods are timed by the rig, the rest tilt only steers the tracker
    for (const std::string& o : suggested.overrides) {
      const std::string key = o.substr(0, o.find('='));
      const inference::ParamSpec* spec = s.config.spec(key);
      if (inference::TaskConfig::isShared(key)) continue;
      if (!spec || !spec->is_target)
        result->next_experiment_overrides.push_back(o);
      else if (key.size() > 9 && key.compare(key.size() - 9, 9, "_period_s") == 0)
        result->next_experiment_instruments.push_back(key);
    }
    // a hang: the camera along world x sees the roll only while the pitch is small (a pitched body's
    // silhouette turns by atan2(sin roll, cos pitch cos roll)), so both angles are read on the hung body
    if (s.config.has("target_pitch_deg"))
      for (const char* angle : {"target_roll_deg", "target_pitch_deg"})
        result->next_experiment_instruments.push_back(angle);
    if (s.config.has("target_roll_deg"))
      result->next_experiment_tilt_deg = s.config.number("target_roll_deg");
  }
  const workflow::LoopDecision d = workflow::decideNextStep(analysis, uncertain_fraction, experiments);
  result->loop_continues = d.continues();
  result->loop_decision = workflow::verdictName(d.verdict);
  result->loop_reason = d.reason;
}

InferenceOutcome InteriorInferenceNode::run(const InferenceRequest& rq, const Feedback& feedback) {
  workflow::InferenceRunRequest run;
  run.config = configFor(rq.task, rq.experiments, rq.representation, rq.overrides, "goal");
  if (rq.max_evaluations < 0)
    throw TopoError("goal max_iterations (the task's max_evaluations)", "is negative",
                    "use 0 for the task's default or a positive count of objective evaluations");
  if (rq.max_evaluations > 0) run.config.setNumber("max_evaluations", rq.max_evaluations);
  // An object named in the goal: its earlier experiments (with the targets they were run with) join the
  // goal's; only the goal's own experiments take motion features.
  std::vector<std::string> own;
  if (!rq.object_id.empty()) {
    const inference::TaskConfig goal_config = run.config;
    std::lock_guard<std::mutex> lock(state_mutex_);
    const bool earlier = !objects_.experimentNames(rq.object_id).empty();  // else the goal runs as it is
    run.config = objects_.withEarlier(rq.object_id, goal_config, rq.overrides);
    if (earlier && goal_config.hasExperiments())
      for (const auto& e : goal_config.experiments()) own.push_back(e.name);
    else if (earlier)
      own.push_back(run.config.experiments().back().name);
    ROS_INFO("interior_inference: object '%s': %zu experiment(s) with the earlier ones", rq.object_id.c_str(),
             run.config.hasExperiments() ? run.config.experiments().size() : std::size_t(1));
  }
  const auto is_own = [&](const std::string& name) {
    return own.empty() || std::find(own.begin(), own.end(), name) != own.end();
  };
  // The volume: the goal's, else the latest on `volume` (waiting a little for the first one after
  // launch), else the task's default shape (the library's choice).
  const bool goal_volume = std::size_t(rq.volume.width) * rq.volume.height > 0;
  const bool has_default_shape = !inference::defaultShapeForTask(run.config.task()).empty();
  if (goal_volume) {
    std::string derived;
    run.volume = std::make_shared<VolumeCloud>(fromPointCloud2(rq.volume, "goal volume", &derived));
    if (!derived.empty()) ROS_WARN("interior_inference: %s", asciiText(derived).c_str());
  } else {
    const ::ros::WallTime until =
        ::ros::WallTime::now() + ::ros::WallDuration(has_default_shape ? 0.0 : params_.volume_wait_s);
    for (;;) {
      {
        std::lock_guard<std::mutex> lock(state_mutex_);
        run.volume = volume_;
      }
      if (run.volume || !::ros::ok() || ::ros::WallTime::now() >= until) break;
      ::ros::WallDuration(0.1).sleep();
    }
    if (!run.volume && !has_default_shape)
      throw TopoError("goal",
                      "has no volume cloud and none was received on " + volume_sub_.getTopic() + " (waited " +
                          std::to_string(params_.volume_wait_s) + " s)",
                      "start cloud_ingest with a surface (e.g. roslaunch topo_gaussian cloud_ingest.launch "
                      "surface_file:=...) or put a cloud in the goal's volume");
  }
  // The observed motion: the goal's features, else the latest on `motion_features` (not too old).
  if (!rq.ignore_motion_features) {
    if (!rq.features.kind.empty()) {
      auto window = std::make_shared<motion::MotionFeatures>(fromMotionFeaturesMsg(rq.features));
      if (own.empty()) {
        run.observed = window;
      } else {  // the goal's features are its own experiment's, not the object's first
        window->experiment = own.front();
        run.observed_experiments.push_back(window);
      }
    } else {
      std::lock_guard<std::mutex> lock(state_mutex_);
      const auto fresh = [&](const ::ros::Time& received) {
        const double age = (::ros::Time::now() - received).toSec();
        if (params_.max_features_age_s > 0 && age > params_.max_features_age_s)
          throw TopoError("motion features on " + features_sub_.getTopic(),
                          "are " + std::to_string(age) + " s old, more than ~max_features_age_s = " +
                              std::to_string(params_.max_features_age_s) + " s (is the camera still publishing?)",
                          "check the camera and motion_tracker, or give the targets in the goal");
      };
      if (run.config.hasExperiments()) {
        // Each experiment's latest tagged window; an untagged one counts for the first experiment (of an
        // object's, the goal's first own one: the earlier ones keep the targets they were run with).
        const std::string first = own.empty() ? run.config.experiments().front().name : own.front();
        for (const auto& e : run.config.experiments()) {
          if (!is_own(e.name)) continue;
          auto it = features_by_experiment_.find(e.name);
          if (it == features_by_experiment_.end() && e.name == first) it = features_by_experiment_.find("");
          if (it == features_by_experiment_.end()) continue;
          fresh(it->second.second);
          auto window = std::make_shared<motion::MotionFeatures>(fromMotionFeaturesMsg(*it->second.first));
          window->experiment = e.name;
          run.observed_experiments.push_back(window);
        }
      } else if (features_) {
        fresh(features_received_);
        run.observed = std::make_shared<motion::MotionFeatures>(fromMotionFeaturesMsg(*features_));
      }
    }
  }
  run.targets = rq.targets;
  if (own.size() == 1)  // an object's goal: its plain targets are its own experiment's
    for (std::string& t : run.targets)
      if (t.find(inference::kExperimentKeySeparator) == std::string::npos ||
          t.find(inference::kExperimentKeySeparator) > t.find('='))
        t = own.front() + inference::kExperimentKeySeparator + t;
  run.targets_origin = "goal targets";
  run.parameters_origin = "goal overrides";
  if (!run.observed && run.observed_experiments.empty())
    run.missing_targets_hint = " (and no motion features were received on " + features_sub_.getTopic() +
                               "): give the targets in the goal, or run motion_tracker so that motion_features arrive";
  if (rq.output_dir.empty())
    run.output_parent = params_.output_dir;
  else
    run.output_dir = rq.output_dir;
  run.export_files = params_.export_on_finish;

  std::mutex eval_mutex;
  inference::ProblemEvaluation last;
  bool stopped = false;
  run.progress = [&](const inference::IterationInfo& it) {
    topo_gaussian::InferInteriorFeedback fb;
    fb.iteration = it.iteration;
    fb.loss = it.loss;
    fb.best_loss = it.best_loss;
    fb.gradient_norm = it.gradient_norm;
    fb.elapsed_s = it.elapsed_s;
    {
      std::lock_guard<std::mutex> lock(eval_mutex);
      fillFeatures(last.task.features, &fb.feature_names, &fb.feature_values, nullptr, nullptr);
      for (const auto& xe : last.experiments) {
        fb.experiment_names.push_back(xe.name);
        fb.experiment_losses.push_back(xe.eval.loss);
      }
    }
    const bool go = feedback ? feedback(fb) : true;
    if (!go) stopped = true;
    return go && ::ros::ok();
  };
  // Polled inside the simulations' time loops: a cancelled goal stops within a few ms of work (the
  // ~infer service has no cancel: no goal is active then; shutdown stops both).
  run.should_stop = [this] { return !::ros::ok() || (server_->isActive() && server_->isPreemptRequested()); };
  run.on_evaluation = [&](const inference::ProblemEvaluation& ev) {
    std::lock_guard<std::mutex> lock(eval_mutex);
    last = ev;
  };
  ROS_INFO("interior_inference: task %s (%s), representation %s, at most %d evaluations", run.config.task().c_str(),
           run.config.source().c_str(), run.config.text("representation").c_str(),
           run.config.integer("max_evaluations"));
  const workflow::InferenceRunOutcome done = workflow::runInference(run);
  if (!rq.object_id.empty() && !done.cancelled && !stopped) {
    std::lock_guard<std::mutex> lock(state_mutex_);
    objects_.remember(rq.object_id, done.config);
  }

  InferenceOutcome out;
  out.result = done.result;
  if (done.volume) out.uncertain_fraction = workflow::uncertainFraction(done.result, *done.volume);
  out.experiments = done.config.hasExperiments() ? static_cast<int>(done.config.experiments().size()) : 1;
  out.preempted = done.cancelled || stopped;
  out.output_dir = done.output_dir;
  out.files = done.files;
  out.message = (out.preempted ? "Preempted: best design so far. " : "") + done.message;
  {
    std::lock_guard<std::mutex> lock(state_mutex_);
    has_result_ = true;
    result_cloud_ = done.volume;
    result_ = done.result;
    result_task_ = done.config.task();
    result_dir_ = done.output_dir;
    result_report_ = done.report_json;
    result_signals_ = done.signals;
    result_continuous_ = done.config.boolean("continuous_material");
    ++result_generation_;  // a restore still simulating an older result stops and does not show it
  }
  const auto& res = done.result;
  std::lock_guard<std::mutex> publishing(publish_mutex_);
  out.interior = show(*done.volume, done.config, res.r, res.density, res.final, res.geometry, res.solid_confidence);
  if (!out.preempted) {  // the identified mass properties for a robot (a cancelled search's best is not identified)
    inertia_pub_.publish(toInertiaStamped(res.final.task.mass, params_.object_frame, ::ros::Time(0)));
    identified_inertia_pub_.publish(
        toIdentifiedInertia(res.final.task.mass, res.identifiability, params_.object_frame, ::ros::Time(0)));
  }
  return out;
}

inference::ProblemEvaluation InteriorInferenceNode::simulateAndShow(const VolumeCloud& cloud,
                                                                    const inference::TaskConfig& config,
                                                                    const std::vector<double>& r, bool show_it) {
  const inference::InteriorProblem problem(config, cloud);
  const inference::ProblemEvaluation ev = problem.evaluateIndicator(r, nullptr);
  if (show_it) {
    std::vector<double> density;
    problem.task().density().apply(r, &density, nullptr);
    std::lock_guard<std::mutex> publishing(publish_mutex_);
    show(cloud, config, r, density, ev, problem.task().geometry());
  }
  return ev;
}

sensor_msgs::PointCloud2 InteriorInferenceNode::show(const VolumeCloud& cloud, const inference::TaskConfig& config,
                                                     const std::vector<double>& r, const std::vector<double>& density,
                                                     const inference::ProblemEvaluation& ev,
                                                     const inference::TaskGeometry& geometry,
                                                     const std::vector<double>& confidence) {
  // Stamp 0: latched messages stay usable for a late subscriber (rviz transforms them with the latest
  // tf, not with a stamp older than its tf buffer).
  const ::ros::Time stamp(0);
  auto interior = boost::make_shared<sensor_msgs::PointCloud2>(toInteriorCloud(
      cloud, r, density, inference::particleStiffness(config, r), params_.object_frame, stamp, confidence));
  InteriorMarkerInput mi;
  mi.cloud = &cloud;
  mi.r = &r;
  mi.mass = ev.task.mass;
  mi.geometry = geometry;
  mi.features = ev.task.features;
  mi.object_frame = params_.object_frame;
  mi.world_frame = params_.world_frame;
  mi.cut_away = params_.cut_away;
  mi.cut_normal = Eigen::Vector3d(params_.cut_normal[0], params_.cut_normal[1], params_.cut_normal[2]);
  mi.colour_by = params_.colour_by;
  mi.confidence = &confidence;
  mi.experiments = ev.experiments.empty() ? 1 : static_cast<int>(ev.experiments.size());
  std::vector<inference::BodyPose> motion = ev.task.motion;
  if (motion.empty())
    motion.push_back(inference::BodyPose{});  // no rigid motion: the object frame sits at the world origin
  mi.object_in_world = Eigen::Translation3d(motion.front().translation) * motion.front().rotation;
  auto markers = boost::make_shared<visualization_msgs::MarkerArray>(makeInteriorMarkers(mi, stamp));
  {
    std::lock_guard<std::mutex> lock(state_mutex_);
    replay_ = std::move(motion);
    replay_start_ = ::ros::WallTime::now();
    shape_t_.clear();
    shapes_.clear();
    bool shapes_fit = ev.task.shapes.size() >= 2 && ev.task.shape_time_s.size() == ev.task.shapes.size();
    for (const auto& sh : ev.task.shapes) shapes_fit = shapes_fit && sh.size() == cloud.size();
    if (shapes_fit) {  // a soft result: its simulated shapes move on `interior_deformed`
      shape_t_ = ev.task.shape_time_s;
      shapes_ = ev.task.shapes;
      shape_cloud_ = cloud;
      shape_r_ = r;
      shape_density_ = density;
      shape_stiffness_ = inference::particleStiffness(config, r);
      shape_confidence_ = confidence;
    }
  }
  interior_pub_.publish(interior);
  markers_pub_.publish(markers);
  // Once more after a second of tf replay: a viewer that got the first copy before it had heard of
  // ~object_frame (rviz drops such messages) gets a second chance; the latched copy stays the same.
  republish_timer_ = nh_.createWallTimer(
      ::ros::WallDuration(1.0),
      [this, interior, markers](const ::ros::WallTimerEvent&) {
        interior_pub_.publish(interior);
        markers_pub_.publish(markers);
      },
      true);
  return *interior;
}

void InteriorInferenceNode::onReplay(const ::ros::WallTimerEvent&) {
  inference::BodyPose p;
  {
    std::lock_guard<std::mutex> lock(state_mutex_);
    if (!shapes_.empty() && deformed_pub_.getNumSubscribers() > 0) {
      // rest → deformed over the shapes' span, hold 0.5 s, back, hold 0.5 s (replay_speed scales it)
      const double span = std::max(1e-6, shape_t_.back() - shape_t_.front()), period = 2 * span + 1.0;
      double u = std::fmod((::ros::WallTime::now() - replay_start_).toSec() * params_.replay_speed, period);
      double t = u < span ? u : (u < span + 0.5 ? span : (u < 2 * span + 0.5 ? 2 * span + 0.5 - u : 0.0));
      t += shape_t_.front();
      std::size_t k = 0;
      while (k + 2 < shape_t_.size() && shape_t_[k + 1] < t) ++k;
      const double w = std::clamp((t - shape_t_[k]) / std::max(1e-12, shape_t_[k + 1] - shape_t_[k]), 0.0, 1.0);
      VolumeCloud moved = shape_cloud_;
      for (std::size_t i = 0; i < moved.X.size(); ++i) moved.X[i] = (1 - w) * shapes_[k][i] + w * shapes_[k + 1][i];
      deformed_pub_.publish(toInteriorCloud(moved, shape_r_, shape_density_, shape_stiffness_, params_.object_frame,
                                            ::ros::Time(0), shape_confidence_));
    }
    if (replay_.empty()) return;
    const double span = replay_.back().t - replay_.front().t;
    double t = (::ros::WallTime::now() - replay_start_).toSec() * params_.replay_speed;
    t = span > 0 ? replay_.front().t + std::fmod(t, span) : replay_.front().t;
    p = inference::poseAt(replay_, t);
  }
  tf_.sendTransform(toTransformStamped(p, params_.world_frame, params_.object_frame, ::ros::Time::now()));
}

std::vector<std::string> unfinishedRunFolders(const std::string& parent, const std::string& newer_than) {
  namespace fs = std::filesystem;
  static const std::regex kRunName(R"(.+_[0-9]{8}_[0-9]{6}(_[0-9]+)?)");
  std::error_code ec;
  fs::file_time_type since = fs::file_time_type::min();
  if (!newer_than.empty()) {
    const fs::path report = fs::path(newer_than) / "report.json";
    since = fs::exists(report, ec) ? fs::last_write_time(report, ec) : fs::last_write_time(newer_than, ec);
    if (ec) since = fs::file_time_type::min();
  }
  std::vector<std::pair<fs::file_time_type, std::string>> found;
  for (const auto& e : fs::directory_iterator(parent, ec)) {
    std::error_code dec;
    if (!e.is_directory(dec) || !std::regex_match(e.path().filename().string(), kRunName)) continue;
    if (fs::exists(e.path() / "report.json", dec)) continue;  // a run: findLatestRun judges it
    const auto t = fs::last_write_time(e.path(), dec);
    if (dec || t < since) continue;
    std::vector<std::string> files;
    for (const auto& f : fs::directory_iterator(e.path(), dec)) files.push_back(f.path().filename().string());
    std::sort(files.begin(), files.end());
    std::string have;
    for (const auto& f : files) have += (have.empty() ? "" : " ") + f;
    found.emplace_back(t, e.path().string() +
                              ": no report.json, so the run did not finish (the node stopped, "
                              "crashed or was killed while it ran); it holds " +
                              (files.empty() ? std::string("no files") : have) + "; delete it or run the goal again");
  }
  std::sort(found.begin(), found.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  std::vector<std::string> out;
  for (auto& f : found) out.push_back(std::move(f.second));
  return out;
}

void InteriorInferenceNode::restoreLatest() {
  // The newest complete run under ~output_dir (volume.ply, interior.ply and a report.json naming a
  // task known here, not interrupted); newer ones that do not load are skipped, each with the reason.
  const workflow::RestorableRun found = workflow::findRestorableRun(params_.output_dir, params_.task_dir);
  const io::LatestRun& latest = found.latest;
  for (const auto& why : unfinishedRunFolders(params_.output_dir, latest.found ? latest.run.dir : ""))
    ROS_WARN("interior_inference: restore skipped %s", asciiText(why).c_str());
  for (const auto& why : latest.skipped) ROS_WARN("interior_inference: restore skipped %s", asciiText(why).c_str());
  if (!latest.found) {
    if (!latest.skipped.empty())
      ROS_WARN("interior_inference: no complete run under %s to restore", params_.output_dir.c_str());
    return;
  }
  const io::RunFiles& run = latest.run;
  auto cloud = std::make_shared<const VolumeCloud>(run.volume);
  const inference::TaskConfig& config = found.config;
  std::uint64_t generation = 0;
  {
    std::lock_guard<std::mutex> lock(state_mutex_);
    has_result_ = true;
    result_cloud_ = cloud;
    result_ = inference::InferenceResult{};
    result_.task = config.task();
    result_.r = run.interior.r;
    result_.density = run.interior.density;
    result_task_ = config.task();
    result_dir_ = run.dir;
    result_report_ = run.report_json;
    result_continuous_ = run.interior.continuous;
    generation = ++result_generation_;
  }
  try {  // the restored run's identified mass properties, as its report holds them
    const io::IdentifiedMass id = io::identifiedMassFromReport(run.report_json, run.dir + "/report.json");
    std::lock_guard<std::mutex> publishing(publish_mutex_);
    inertia_pub_.publish(toInertiaStamped(id.mass, params_.object_frame, ::ros::Time(0)));
    identified_inertia_pub_.publish(toIdentifiedInertia(id, params_.object_frame, ::ros::Time(0)));
  } catch (const TopoError& e) {
    ROS_WARN("interior_inference: the restored run's mass properties are not published: %s", asciiText(e.what()).c_str());
  }
  // Shown and simulated off the main thread: the action server and the services serve at once, however
  // long the simulation of the restored design takes (a fine volume's takes minutes).
  restore_thread_ = std::thread([this, cloud, config, r = run.interior.r, dir = run.dir, generation] {
    showRestored(cloud, config, r, dir, generation);
  });
}

void InteriorInferenceNode::showRestored(const std::shared_ptr<const VolumeCloud>& cloud,
                                         const inference::TaskConfig& config, const std::vector<double>& r,
                                         const std::string& dir, std::uint64_t generation) {
  const auto current = [this, generation] {
    std::lock_guard<std::mutex> lock(state_mutex_);
    return result_generation_ == generation;
  };
  try {
    inference::InteriorProblem problem(config, *cloud);
    // A newer result (a goal that finished meanwhile) or shutdown stops the simulation of this one.
    problem.setShouldStop([this, current] { return restore_stop_ || !::ros::ok() || !current(); });
    std::vector<double> density, masses;
    problem.task().density().apply(r, &density, nullptr);
    problem.task().masses(r, &masses, nullptr);
    inference::ProblemEvaluation at_rest;  // the interior and its mass properties first, the motion follows
    at_rest.task.mass = computeMassProperties(cloud->X, masses, cubeCellVariance(cloud->spacing));
    {
      std::lock_guard<std::mutex> publishing(publish_mutex_);
      if (!current()) return;
      show(*cloud, config, r, density, at_rest, problem.task().geometry());
    }
    ROS_INFO("interior_inference: restored the latest result from %s (task %s, %zu particles): published on %s; "
             "simulating its motion in the background",
             dir.c_str(), config.task().c_str(), cloud->size(), interior_pub_.getTopic().c_str());
    // Its features with the task's default parameters (the goal's overrides are not in the files).
    const inference::ProblemEvaluation ev = problem.evaluateIndicator(r, nullptr);
    std::lock_guard<std::mutex> publishing(publish_mutex_);
    if (!current()) return;
    show(*cloud, config, r, density, ev, problem.task().geometry());
    ROS_INFO("interior_inference: simulated the restored result from %s: its features are on interior_markers",
             dir.c_str());
  } catch (const SimulationCancelled&) {
    ROS_INFO("interior_inference: stopped simulating the restored result from %s (%s)", dir.c_str(),
             current() ? "the node stops" : "a newer result replaced it");
  } catch (const std::exception& e) {
    ROS_WARN("interior_inference: could not simulate the restored result from %s (its interior stays published, "
             "without its motion): %s",
             dir.c_str(), asciiText(e.what()).c_str());
  }
}

InteriorInferenceNode::~InteriorInferenceNode() {
  restore_stop_ = true;
  if (restore_thread_.joinable()) restore_thread_.join();
}

void InteriorInferenceNode::execute(const topo_gaussian::InferInteriorGoalConstPtr& goal) {
  topo_gaussian::InferInteriorResult result;
  std::unique_lock<std::mutex> running(run_mutex_, std::try_to_lock);
  if (!running.owns_lock()) {
    result.message = "another inference (a ~infer call) is running: wait for it to finish, then send the goal again";
    ROS_WARN("interior_inference: goal aborted: %s", asciiText(result.message).c_str());
    server_->setAborted(result, result.message);
    return;
  }
  InferenceRequest rq;
  rq.task = goal->task;
  rq.experiments = goal->experiments;
  rq.representation = goal->representation;
  rq.overrides = goal->overrides;
  rq.targets = goal->targets;
  rq.volume = goal->volume;
  rq.features = goal->features;
  rq.ignore_motion_features = goal->ignore_motion_features;
  rq.max_evaluations = goal->max_iterations;
  rq.output_dir = goal->output_dir;
  rq.object_id = goal->object_id;
  try {
    const InferenceOutcome out = run(rq, [&](const topo_gaussian::InferInteriorFeedback& fb) {
      server_->publishFeedback(fb);
      return !server_->isPreemptRequested();
    });
    const auto& res = out.result;
    result.converged = res.converged;
    result.preempted = out.preempted;
    result.message = out.message;
    result.interior = out.interior;
    fillFeatures(res.final.task.features, &result.feature_names, &result.achieved, &result.target, &result.units);
    result.initial_loss = res.initial.loss;
    result.final_loss = res.final.loss;
    result.iterations = res.optimizer.iterations;
    result.solid_fraction = res.final.solid_fraction;
    const MassProperties& mass = res.final.task.mass;
    result.mass_kg = mass.mass;
    result.center_of_mass = {mass.com.x(), mass.com.y(), mass.com.z()};
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) result.inertia.push_back(mass.inertia(a, b));
    const inference::IdentifiabilityAnalysis& id = res.identifiability;
    result.identifiability = id.summary;
    for (const auto& m : id.moments) (m.determined ? result.determined_moments : result.free_moments).push_back(m.name);
    if (id.available)
      for (const auto& m : id.moments) result.moment_std.push_back(m.std);
    fillNextExperiment(id, out.uncertain_fraction, out.experiments, &result);
    for (const auto& xe : res.final.experiments) {
      result.experiment_names.push_back(xe.name);
      result.experiment_losses.push_back(xe.eval.loss);
      result.experiment_weights.push_back(xe.weight);
    }
    result.output_dir = out.output_dir;
    result.files = out.files;
    ROS_INFO("interior_inference: %s", asciiText(out.message).c_str());
    if (out.preempted)
      server_->setPreempted(result, result.message);
    else
      server_->setSucceeded(result, result.message);
  } catch (const std::exception& e) {
    result.message = e.what();
    ROS_ERROR("interior_inference: goal aborted: %s", asciiText(e.what()).c_str());
    server_->setAborted(result, result.message);
  }
}

bool InteriorInferenceNode::onInfer(topo_gaussian::Infer::Request& req, topo_gaussian::Infer::Response& res) {
  std::unique_lock<std::mutex> running(run_mutex_, std::try_to_lock);
  if (!running.owns_lock()) {
    res.success = false;
    res.message = "an inference (an infer_interior goal) is running: wait for it or cancel it, then call again";
    return true;
  }
  InferenceRequest rq;
  rq.task = req.task;
  rq.experiments = req.experiments;
  rq.representation = req.representation;
  rq.overrides = req.overrides;
  rq.targets = req.targets;
  rq.ignore_motion_features = req.ignore_motion_features;
  rq.max_evaluations = req.max_iterations;
  rq.output_dir = req.output_dir;
  return guardService("interior_inference", infer_srv_.getService(), res, [&] {
    const InferenceOutcome out = run(rq, [](const topo_gaussian::InferInteriorFeedback& fb) {
      ROS_INFO("interior_inference: ~infer iteration %d  loss %.6e  |grad| %.3e  best %.6e  %.2f s", fb.iteration,
               fb.loss, fb.gradient_norm, fb.best_loss, fb.elapsed_s);
      return true;
    });
    res.success = true;
    res.converged = out.result.converged;
    res.message = out.message;
    fillFeatures(out.result.final.task.features, &res.feature_names, &res.achieved, &res.target, nullptr);
    res.final_loss = out.result.final.loss;
    res.iterations = out.result.optimizer.iterations;
    res.solid_fraction = out.result.final.solid_fraction;
    for (const auto& xe : out.result.final.experiments) {
      res.experiment_names.push_back(xe.name);
      res.experiment_losses.push_back(xe.eval.loss);
    }
    res.output_dir = out.output_dir;
    res.files = out.files;
    ROS_INFO("interior_inference: ~infer: %s", asciiText(out.message).c_str());
  });
}

bool InteriorInferenceNode::onSimulate(topo_gaussian::SimulateInterior::Request& req,
                                       topo_gaussian::SimulateInterior::Response& res) {
  return guardService("interior_inference", simulate_srv_.getService(), res, [&] {
    std::shared_ptr<const VolumeCloud> cloud;
    std::vector<double> r;
    std::string task;
    {
      std::lock_guard<std::mutex> lock(state_mutex_);
      task = !req.task.empty() ? req.task : (has_result_ ? result_task_ : params_.default_task);
      if (std::size_t(req.interior.width) * req.interior.height == 0) {
        if (!has_result_)
          throw TopoError("~simulate interior", "is empty and no inference has run yet",
                          "give a design in interior (fields x y z solid) or run an inference first");
        cloud = result_cloud_;
        r = result_.r;
      } else {
        cloud = result_cloud_ ? result_cloud_ : volume_;
      }
    }
    if (r.empty()) {
      const InteriorPoints pts = fromInteriorCloud(req.interior, "~simulate interior");
      if (!cloud)
        throw TopoError("~simulate interior",
                        "cannot be matched to a volume: nothing was received on " + volume_sub_.getTopic(),
                        "start cloud_ingest (the design's points must be the volume's particles)");
      if (pts.r.size() != cloud->size())
        throw TopoError("~simulate interior",
                        "has " + std::to_string(pts.r.size()) + " points but the volume has " +
                            std::to_string(cloud->size()) + " particles",
                        "give one solid value per particle of the latest volume, in its order");
      const double tol = 0.25 * (cloud->spacing > 0 ? cloud->spacing : 1e-3);
      for (std::size_t i = 0; i < pts.X.size(); ++i)
        if ((pts.X[i] - cloud->X[i]).norm() > tol)
          throw TopoError("~simulate interior",
                          "point " + std::to_string(i) + " is not at particle " + std::to_string(i) + " of the volume",
                          "give the particles in the volume's order (as the `interior` topic publishes them)");
      r = pts.r;
    }
    inference::TaskConfig config = configFor(task, {}, "", req.overrides, "~simulate");
    for (const auto& t : req.targets) config.setAssignment(t, "~simulate targets");
    const inference::ProblemEvaluation ev = simulateAndShow(*cloud, config, r, req.replay);
    fillFeatures(ev.task.features, &res.feature_names, &res.values, nullptr, &res.units);
    res.loss = ev.loss;
    res.mass_kg = ev.task.mass.mass;
    res.center_of_mass.x = ev.task.mass.com.x();
    res.center_of_mass.y = ev.task.mass.com.y();
    res.center_of_mass.z = ev.task.mass.com.z();
    res.success = true;
    std::ostringstream os;
    os << "simulated " << config.task() << ": " << featuresText(ev.task.features);
    res.message = os.str();
    for (auto& c : res.message)
      if (c == '\n') c = ';';
    ROS_INFO("interior_inference: ~simulate: %s", asciiText(res.message).c_str());
  });
}

bool InteriorInferenceNode::onExport(topo_gaussian::ExportInterior::Request& req,
                                     topo_gaussian::ExportInterior::Response& res) {
  return guardService("interior_inference", export_srv_.getService(), res, [&] {
    std::shared_ptr<const VolumeCloud> cloud;
    workflow::ExportOptions eo;
    std::vector<double> r, density;
    {
      std::lock_guard<std::mutex> lock(state_mutex_);
      if (!has_result_)
        throw TopoError("~export", "has nothing to export: no inference has finished yet",
                        "send an infer_interior goal (or call ~infer) first");
      cloud = result_cloud_;
      r = result_.r;
      density = result_.density;
      eo.output_dir = req.output_dir.empty() ? result_dir_ : req.output_dir;
      eo.report_json = result_report_;
      eo.signals = result_signals_;
      eo.continuous = result_continuous_;
      eo.title = result_.task + " interior";
    }
    if (!req.stl_unit.empty() && req.stl_unit != "mm" && req.stl_unit != "m")
      throw TopoError("~export stl_unit", "is '" + req.stl_unit + "'", "use mm or m (empty = mm)");
    if (req.stl_unit == "m") {
      eo.stl_unit = "m";
      eo.stl_scale = 1.0;
    }
    if (req.iso < 0 || req.iso >= 1)
      throw TopoError("~export iso", "must be in (0, 1)", "use 0.5 (or 0 for the default)");
    if (req.iso > 0) eo.iso = req.iso;
    const workflow::ExportSummary s = workflow::exportInterior(*cloud, r, density, eo);
    res.success = true;
    res.output_dir = s.output_dir;
    for (const auto& f : s.files) res.files.push_back(s.output_dir + "/" + f);
    res.watertight = s.interface.check.watertight();
    res.volume_difference = s.interface.volume_difference;
    std::ostringstream os;
    os << "wrote " << s.files.size() << " files to " << s.output_dir << "; STL "
       << (res.watertight ? "watertight" : "NOT watertight") << ", volume " << std::showpos
       << 100 * s.interface.volume_difference << std::noshowpos << " % vs the solid particles' volume";
    for (const auto& n : s.notes) os << "; " << n;
    res.message = os.str();
    ROS_INFO("interior_inference: ~export: %s", asciiText(res.message).c_str());
  });
}

}  // namespace topo_gaussian::topo_ros
