#include "topo_gaussian/ros/interior_inference_node.h"

#include <geometry_msgs/TransformStamped.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <iomanip>
#include <limits>
#include <sstream>

#include "topo_gaussian/geometry/volume_io.h"
#include "topo_gaussian/inference/interior_export.h"
#include "topo_gaussian/inference/interior_problem.h"
#include "topo_gaussian/physics/default_shapes.h"
#include "topo_gaussian/common/error.h"
#include "topo_gaussian/ros/body_pose_msg.h"
#include "topo_gaussian/ros/conversions.h"
#include "topo_gaussian/ros/interior_markers.h"
#include "topo_gaussian/inference/motion_targets.h"
#include "topo_gaussian/ros/motion_features_msg.h"

#ifndef TOPO_DEFAULT_TASK_DIR
#define TOPO_DEFAULT_TASK_DIR ""
#endif

namespace topo_gaussian::topo_ros {
namespace {

namespace fs = std::filesystem;

std::string defaultOutputDir() {
  if (const char* h = std::getenv("ROS_HOME")) return std::string(h) + "/topo_gaussian";
  if (const char* h = std::getenv("HOME")) return std::string(h) + "/.ros/topo_gaussian";
  return "/tmp/topo_gaussian";
}

std::string timeTag() {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  localtime_r(&now, &tm);
  std::ostringstream os;
  os << std::put_time(&tm, "%Y%m%d_%H%M%S");
  return os.str();
}

void writeText(const std::string& path, const std::string& text) {
  std::ofstream out(path);
  if (!out) throw TopoError(path, "cannot be written", "check that ~output_dir is writable");
  out << text;
}

/// The series an export draws: the observed signal of the motion features, the simulated one.
std::vector<inference::SignalSeries> signalsOf(const topo_gaussian::MotionFeatures* observed,
                                               const inference::TaskEvaluation& simulated) {
  std::vector<inference::SignalSeries> out;
  if (observed && !observed->time_s.empty() && observed->time_s.size() == observed->angle_deg.size()) {
    inference::SignalSeries s;
    s.label = "observed " + (observed->kind.empty() ? std::string("angle") : observed->kind) + " [deg]";
    const auto& t = observed->time_s;
    const auto& y = observed->angle_deg;
    double t0 = t.front();
    // A simulation released at rest starts at a turning point; a camera window usually starts
    // mid-swing. Start the observed series at its first turning point on the release side, so the
    // two can be compared by eye and by their RMS difference.
    const auto& sim = simulated.signal;
    if (!sim.empty() && std::abs(sim.front()) > 0) {
      double peak = 0;
      for (double v : y) peak = std::max(peak, std::abs(v));
      for (std::size_t i = 1; i + 1 < y.size(); ++i) {
        const bool turning = (y[i] - y[i - 1]) * (y[i + 1] - y[i]) <= 0;
        if (turning && y[i] * sim.front() > 0 && std::abs(y[i]) >= 0.8 * peak) {
          t0 = t[i];
          s.label += ", aligned";
          break;
        }
      }
    }
    for (std::size_t i = 0; i < t.size(); ++i) {
      if (t[i] < t0) continue;
      s.t.push_back(t[i] - t0);
      s.value.push_back(y[i]);
    }
    out.push_back(std::move(s));
  }
  if (!simulated.signal.empty() && simulated.signal.size() == simulated.signal_time_s.size()) {
    inference::SignalSeries s;
    s.label = "simulated " + simulated.signal_name;
    s.t = simulated.signal_time_s;
    s.value = simulated.signal;
    out.push_back(std::move(s));
  }
  return out;
}

std::string signalCsv(const inference::TaskEvaluation& ev) {
  std::ostringstream os;
  os << std::setprecision(10) << "time_s," << (ev.signal_name.empty() ? "value" : ev.signal_name) << "\n";
  for (std::size_t i = 0; i < ev.signal.size() && i < ev.signal_time_s.size(); ++i)
    os << ev.signal_time_s[i] << "," << ev.signal[i] << "\n";
  return os.str();
}

void fillFeatures(const std::vector<inference::Feature>& fs, std::vector<std::string>* names, std::vector<double>* values,
                  std::vector<double>* targets, std::vector<std::string>* units) {
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
  pnh.param<std::string>("task_dir", p.task_dir, TOPO_DEFAULT_TASK_DIR);
  pnh.param<std::string>("default_task", p.default_task, p.default_task);
  pnh.param<std::string>("output_dir", p.output_dir, defaultOutputDir());
  pnh.param<std::string>("world_frame", p.world_frame, p.world_frame);
  pnh.param<std::string>("object_frame", p.object_frame, p.object_frame);
  pnh.param("replay_rate_hz", p.replay_rate_hz, p.replay_rate_hz);
  pnh.param("replay_speed", p.replay_speed, p.replay_speed);
  pnh.param("export_on_finish", p.export_on_finish, p.export_on_finish);
  pnh.param("max_features_age_s", p.max_features_age_s, p.max_features_age_s);
  pnh.param("volume_wait_s", p.volume_wait_s, p.volume_wait_s);
  pnh.param("restore_latest", p.restore_latest, p.restore_latest);
  if (!(p.volume_wait_s >= 0 && p.volume_wait_s <= 3600))
    throw TopoError("~volume_wait_s", "is " + std::to_string(p.volume_wait_s) + ", outside [0, 3600]", "use e.g. 15 [s]");
  if (!(p.replay_rate_hz >= 0 && p.replay_rate_hz <= 1000))
    throw TopoError("~replay_rate_hz", "is " + std::to_string(p.replay_rate_hz) + ", outside [0, 1000]",
                    "use e.g. 30 (0 turns the tf replay off)");
  if (!(p.replay_speed > 0 && p.replay_speed <= 100))
    throw TopoError("~replay_speed", "is " + std::to_string(p.replay_speed) + ", outside (0, 100]", "use 1 for real time");
  if (!(p.max_features_age_s >= 0))
    throw TopoError("~max_features_age_s", "is negative", "use 0 to accept motion features of any age");
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
  volume_sub_ = nh_.subscribe("volume", 1, &InteriorInferenceNode::onVolume, this);
  features_sub_ = nh_.subscribe("motion_features", 1, &InteriorInferenceNode::onFeatures, this);
  infer_srv_ = pnh_.advertiseService("infer", &InteriorInferenceNode::onInfer, this);
  simulate_srv_ = pnh_.advertiseService("simulate", &InteriorInferenceNode::onSimulate, this);
  export_srv_ = pnh_.advertiseService("export", &InteriorInferenceNode::onExport, this);
  if (params_.replay_rate_hz > 0)
    replay_timer_ = nh_.createWallTimer(::ros::WallDuration(1.0 / params_.replay_rate_hz), &InteriorInferenceNode::onReplay, this);
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
    auto cloud = std::make_shared<VolumeCloud>(fromPointCloud2(*msg, volume_sub_.getTopic()));
    cloud->validate(volume_sub_.getTopic());
    std::lock_guard<std::mutex> lock(state_mutex_);
    volume_ = cloud;
    volume_frame_ = msg->header.frame_id;
    ROS_INFO("interior_inference: volume of %zu particles (spacing %.4g m, %.4g m^3) in frame '%s'", cloud->size(),
             cloud->spacing, cloud->totalVolume(), msg->header.frame_id.c_str());
  } catch (const std::exception& e) {
    ROS_ERROR("interior_inference: ignored a volume: %s", e.what());
  }
}

void InteriorInferenceNode::onFeatures(const topo_gaussian::MotionFeaturesConstPtr& msg) {
  std::lock_guard<std::mutex> lock(state_mutex_);
  const bool first = !features_;
  features_ = std::make_shared<topo_gaussian::MotionFeatures>(*msg);
  features_received_ = ::ros::Time::now();
  if (first)
    ROS_INFO("interior_inference: motion features from %s (kind %s): period %.4g s, max tilt %.4g deg, bend %.4g deg",
             msg->source.c_str(), msg->kind.c_str(), msg->period_s, msg->max_tilt_deg, msg->bending_angle_deg);
}

inference::TaskConfig InteriorInferenceNode::configFor(const std::string& task, const std::string& representation,
                                                       const std::vector<std::string>& overrides,
                                                       const std::string& origin) const {
  if (task.empty())
    throw TopoError(origin + " task", "is empty", "name a task (" + [] {
      std::string s;
      for (const auto& n : inference::TaskConfig::taskNames()) s += (s.empty() ? "" : ", ") + n;
      return s;
    }() + ") or a task YAML file");
  inference::TaskConfig config = inference::TaskConfig::load(task, params_.task_dir);
  if (!representation.empty()) config.set("representation", representation, origin + " representation");
  for (const auto& o : overrides) config.setAssignment(o, origin + " overrides");
  return config;
}

InferenceOutcome InteriorInferenceNode::run(const InferenceRequest& rq, const Feedback& feedback) {
  inference::TaskConfig config = configFor(rq.task, rq.representation, rq.overrides, "goal");
  // The volume: the goal's, else the latest on `volume`, else a task's default shape.
  std::shared_ptr<VolumeCloud> cloud;
  std::shared_ptr<topo_gaussian::MotionFeatures> latest_features;
  ::ros::Time features_time;
  const bool goal_volume = std::size_t(rq.volume.width) * rq.volume.height > 0;
  if (!goal_volume && inference::defaultShapeForTask(config.task()).empty()) {
    // A goal sent right after launch may arrive before the first volume: wait a little for it.
    const ::ros::WallTime until = ::ros::WallTime::now() + ::ros::WallDuration(params_.volume_wait_s);
    while (::ros::ok() && ::ros::WallTime::now() < until) {
      {
        std::lock_guard<std::mutex> lock(state_mutex_);
        if (volume_) break;
      }
      ::ros::WallDuration(0.1).sleep();
    }
  }
  {
    std::lock_guard<std::mutex> lock(state_mutex_);
    cloud = volume_;
    latest_features = features_;
    features_time = features_received_;
  }
  if (goal_volume) {
    cloud = std::make_shared<VolumeCloud>(fromPointCloud2(rq.volume, "goal volume"));
    cloud->validate("goal volume");
  }
  std::vector<std::string> notes;
  if (!cloud) {
    const std::string shape = inference::defaultShapeForTask(config.task());
    if (!shape.empty()) {
      cloud = std::make_shared<VolumeCloud>(defaultShapeCloud(shape, config.number("default_spacing_m")));
      notes.push_back("no volume received: used the default " + shape + " shape (" + std::to_string(cloud->size()) +
                      " particles)");
    } else {
      throw TopoError("goal", "has no volume cloud and none was received on " + volume_sub_.getTopic() + " (waited " +
                                  std::to_string(params_.volume_wait_s) + " s)",
                      "start cloud_ingest with a surface (e.g. roslaunch topo_gaussian cloud_ingest.launch "
                      "surface_file:=...) or put a cloud in the goal's volume");
    }
  }
  // Targets: from motion features (the goal's or the latest), then the goal's own.
  const topo_gaussian::MotionFeatures* observed = nullptr;
  if (!rq.ignore_motion_features) {
    if (!rq.features.kind.empty()) {
      observed = &rq.features;
    } else if (latest_features) {
      const double age = (::ros::Time::now() - features_time).toSec();
      if (params_.max_features_age_s > 0 && age > params_.max_features_age_s)
        throw TopoError("motion features on " + features_sub_.getTopic(),
                        "are " + std::to_string(age) + " s old, more than ~max_features_age_s = " +
                            std::to_string(params_.max_features_age_s) + " s (is the camera still publishing?)",
                        "check the camera and motion_tracker, or give the targets in the goal");
      observed = latest_features.get();
    }
    if (observed) {
      const inference::MotionTargets mt = inference::targetsFromMotion(config, fromMotionFeaturesMsg(*observed));
      for (const auto& [name, value] : mt.targets) {
        config.setNumber(name, value);
        std::ostringstream os;
        os << name << " = " << value << " from motion features";
        notes.push_back(os.str());
      }
      if (!mt.note.empty()) notes.push_back(mt.note);
    }
  }
  for (const auto& t : rq.targets) {
    config.setAssignment(t, "goal targets");
    notes.push_back(t + " from the goal");
  }
  if (rq.max_iterations < 0)
    throw TopoError("goal max_iterations", "is negative", "use 0 for the task's default or a positive count");
  if (rq.max_iterations > 0) config.setNumber("max_iterations", rq.max_iterations);
  try {
    inference::makeTask(config, *cloud)->requireTargets();
  } catch (const TopoError& e) {
    throw TopoError("goal", std::string(e.what()) + (observed ? "" : " (and no motion features were received on " +
                                                                         features_sub_.getTopic() + ")"),
                    "give the targets in the goal, or run motion_tracker so that motion_features arrive");
  }
  // Output directory (created before the run, so a bad one fails early).
  InferenceOutcome out;
  out.output_dir = rq.output_dir.empty() ? params_.output_dir + "/" + config.task() + "_" + timeTag() : rq.output_dir;
  std::error_code ec;
  fs::create_directories(out.output_dir, ec);
  if (!fs::is_directory(out.output_dir))
    throw TopoError("output directory " + out.output_dir, "cannot be created" + (ec ? ": " + ec.message() : ""),
                    "give a writable output_dir in the goal or set ~output_dir");

  ROS_INFO("interior_inference: task %s (%s), representation %s, %zu particles, at most %d iterations; %s",
           config.task().c_str(), config.source().c_str(), config.text("representation").c_str(), cloud->size(),
           config.integer("max_iterations"), notes.empty() ? "" : notes.front().c_str());
  std::mutex eval_mutex;
  inference::ProblemEvaluation last;
  bool stopped = false;
  out.result = inference::runInference(
      config, *cloud,
      [&](const inference::IterationInfo& it) {
        topo_gaussian::InferInteriorFeedback fb;
        fb.iteration = it.iteration;
        fb.loss = it.loss;
        fb.best_loss = it.best_loss;
        fb.gradient_norm = it.gradient_norm;
        fb.elapsed_s = it.elapsed_s;
        {
          std::lock_guard<std::mutex> lock(eval_mutex);
          fillFeatures(last.task.features, &fb.feature_names, &fb.feature_values, nullptr, nullptr);
        }
        const bool go = feedback ? feedback(fb) : true;
        if (!go) stopped = true;
        return go && ::ros::ok();
      },
      [&](const inference::ProblemEvaluation& ev) {
        std::lock_guard<std::mutex> lock(eval_mutex);
        last = ev;
      });
  out.preempted = out.result.optimizer.cancelled || stopped;

  // Files: everything `topo export` writes (interior.ply, report.json with the interface, STL,
  // pictures), and signal.csv; on an export failure at least interior.ply and report.json.
  const auto& res = out.result;
  const std::vector<inference::SignalSeries> signals = signalsOf(observed, res.final.task);
  std::string report = inference::reportJson(res, config);
  const std::string dir = out.output_dir;
  bool exported = false;
  if (params_.export_on_finish) {
    try {
      inference::ExportOptions eo;
      eo.output_dir = dir;
      eo.report_json = report;
      eo.signals = signals;
      eo.continuous = config.boolean("continuous_material");
      eo.title = config.task() + " interior";
      const inference::ExportSummary s = inference::exportInterior(*cloud, res.r, res.density, eo);
      for (const auto& f : s.files) out.files.push_back(dir + "/" + f);
      exported = true;
    } catch (const std::exception& e) {
      notes.push_back(std::string("export failed (interior.ply and report.json written instead): ") + e.what());
    }
  }
  if (!exported) {
    inference::writeInteriorPly(dir + "/interior.ply", *cloud, res.r, res.density, config.boolean("continuous_material"));
    writeText(dir + "/report.json", report);
    out.files.push_back(dir + "/interior.ply");
    out.files.push_back(dir + "/report.json");
  }
  if (!res.final.task.signal.empty()) {
    writeText(dir + "/signal.csv", signalCsv(res.final.task));
    out.files.push_back(dir + "/signal.csv");
  }
  geometry::writeVolumePly(*cloud, dir + "/volume.ply");  // with interior.ply and report.json: the run can be reloaded
  out.files.push_back(dir + "/volume.ply");
  std::ostringstream msg;
  msg << (out.preempted ? "Preempted: best design so far. " : "") << res.message;
  for (const auto& n : notes) msg << " [" << n << "]";
  out.message = msg.str();
  {
    std::lock_guard<std::mutex> lock(state_mutex_);
    has_result_ = true;
    result_cloud_ = cloud;
    result_ = res;
    result_task_ = rq.task;
    result_dir_ = dir;
    result_report_ = report;
    result_signals_ = signals;
    result_continuous_ = config.boolean("continuous_material");
  }
  out.interior = show(*cloud, config, res.r, res.density, res.final, res.geometry);
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
    show(cloud, config, r, density, ev, problem.task().geometry());
  }
  return ev;
}

sensor_msgs::PointCloud2 InteriorInferenceNode::show(const VolumeCloud& cloud, const inference::TaskConfig& config,
                                                     const std::vector<double>& r, const std::vector<double>& density,
                                                     const inference::ProblemEvaluation& ev,
                                                     const inference::TaskGeometry& geometry) {
  // Stamp 0: latched messages stay usable for a late subscriber (rviz transforms them with the latest
  // tf, not with a stamp older than its tf buffer).
  const ::ros::Time stamp(0);
  auto interior = boost::make_shared<sensor_msgs::PointCloud2>(
      toInteriorCloud(cloud, r, density, inference::particleStiffness(config, r), params_.object_frame, stamp));
  InteriorMarkerInput mi;
  mi.cloud = &cloud;
  mi.r = &r;
  mi.mass = ev.task.mass;
  mi.geometry = geometry;
  mi.features = ev.task.features;
  mi.object_frame = params_.object_frame;
  mi.world_frame = params_.world_frame;
  std::vector<inference::BodyPose> motion = ev.task.motion;
  if (motion.empty()) motion.push_back(inference::BodyPose{});  // no rigid motion: the object frame sits at the world origin
  mi.object_in_world = Eigen::Translation3d(motion.front().translation) * motion.front().rotation;
  auto markers = boost::make_shared<visualization_msgs::MarkerArray>(makeInteriorMarkers(mi, stamp));
  {
    std::lock_guard<std::mutex> lock(state_mutex_);
    replay_ = std::move(motion);
    replay_start_ = ::ros::WallTime::now();
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
    if (replay_.empty()) return;
    const double span = replay_.back().t - replay_.front().t;
    double t = (::ros::WallTime::now() - replay_start_).toSec() * params_.replay_speed;
    t = span > 0 ? replay_.front().t + std::fmod(t, span) : replay_.front().t;
    p = inference::poseAt(replay_, t);
  }
  tf_.sendTransform(toTransformStamped(p, params_.world_frame, params_.object_frame, ::ros::Time::now()));
}

void InteriorInferenceNode::restoreLatest() {
  // The newest run directory under ~output_dir that holds volume.ply, interior.ply and report.json.
  std::error_code ec;
  fs::path best;
  fs::file_time_type best_time{};
  for (const auto& e : fs::directory_iterator(params_.output_dir, ec)) {
    const fs::path d = e.path();
    if (!fs::exists(d / "volume.ply") || !fs::exists(d / "interior.ply") || !fs::exists(d / "report.json")) continue;
    const auto t = fs::last_write_time(d / "report.json", ec);
    if (best.empty() || t > best_time) best = d, best_time = t;
  }
  if (best.empty()) return;
  try {
    auto cloud = std::make_shared<VolumeCloud>(geometry::readVolumePly((best / "volume.ply").string()));
    const inference::InteriorPly ply = inference::readInteriorPlyData((best / "interior.ply").string(), cloud->size());
    std::ifstream in(best / "report.json");
    const std::string report((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const std::string task = inference::jsonStringField(report, "task");
    const inference::TaskConfig config = inference::TaskConfig::load(task.empty() ? params_.default_task : task, params_.task_dir);
    {
      std::lock_guard<std::mutex> lock(state_mutex_);
      has_result_ = true;
      result_cloud_ = cloud;
      result_ = inference::InferenceResult{};
      result_.task = config.task();
      result_.r = ply.r;
      result_.density = ply.density;
      result_task_ = config.task();
      result_dir_ = best.string();
      result_report_ = report;
      result_continuous_ = ply.continuous;
    }
    // Its features with the task's default parameters (the goal's overrides are not in the files).
    simulateAndShow(*cloud, config, ply.r, true);
    ROS_INFO("interior_inference: restored the latest result from %s (task %s, %zu particles): published on %s",
             best.c_str(), config.task().c_str(), cloud->size(), interior_pub_.getTopic().c_str());
  } catch (const std::exception& e) {
    ROS_WARN("interior_inference: could not restore the latest result from %s: %s", best.c_str(), e.what());
  }
}

void InteriorInferenceNode::execute(const topo_gaussian::InferInteriorGoalConstPtr& goal) {
  topo_gaussian::InferInteriorResult result;
  std::unique_lock<std::mutex> running(run_mutex_, std::try_to_lock);
  if (!running.owns_lock()) {
    result.message = "another inference (a ~infer call) is running: wait for it to finish, then send the goal again";
    ROS_WARN("interior_inference: goal aborted: %s", result.message.c_str());
    server_->setAborted(result, result.message);
    return;
  }
  InferenceRequest rq;
  rq.task = goal->task;
  rq.representation = goal->representation;
  rq.overrides = goal->overrides;
  rq.targets = goal->targets;
  rq.volume = goal->volume;
  rq.features = goal->features;
  rq.ignore_motion_features = goal->ignore_motion_features;
  rq.max_iterations = goal->max_iterations;
  rq.output_dir = goal->output_dir;
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
    result.output_dir = out.output_dir;
    result.files = out.files;
    ROS_INFO("interior_inference: %s", out.message.c_str());
    if (out.preempted) server_->setPreempted(result, result.message);
    else server_->setSucceeded(result, result.message);
  } catch (const std::exception& e) {
    result.message = e.what();
    ROS_ERROR("interior_inference: goal aborted: %s", e.what());
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
  rq.representation = req.representation;
  rq.overrides = req.overrides;
  rq.targets = req.targets;
  rq.ignore_motion_features = req.ignore_motion_features;
  rq.max_iterations = req.max_iterations;
  rq.output_dir = req.output_dir;
  try {
    const InferenceOutcome out = run(rq, [](const topo_gaussian::InferInteriorFeedback& fb) {
      ROS_INFO("interior_inference: ~infer iteration %d  loss %.6e  |grad| %.3e  best %.6e  %.2f s", fb.iteration, fb.loss,
               fb.gradient_norm, fb.best_loss, fb.elapsed_s);
      return true;
    });
    res.success = true;
    res.converged = out.result.converged;
    res.message = out.message;
    fillFeatures(out.result.final.task.features, &res.feature_names, &res.achieved, &res.target, nullptr);
    res.final_loss = out.result.final.loss;
    res.iterations = out.result.optimizer.iterations;
    res.solid_fraction = out.result.final.solid_fraction;
    res.output_dir = out.output_dir;
    res.files = out.files;
    ROS_INFO("interior_inference: ~infer: %s", out.message.c_str());
  } catch (const std::exception& e) {
    res.success = false;
    res.message = e.what();
    ROS_ERROR("interior_inference: ~infer: %s", e.what());
  }
  return true;
}

bool InteriorInferenceNode::onSimulate(topo_gaussian::SimulateInterior::Request& req,
                                       topo_gaussian::SimulateInterior::Response& res) {
  try {
    std::shared_ptr<VolumeCloud> cloud;
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
        throw TopoError("~simulate interior", "cannot be matched to a volume: nothing was received on " +
                                                  volume_sub_.getTopic(),
                        "start cloud_ingest (the design's points must be the volume's particles)");
      if (pts.r.size() != cloud->size())
        throw TopoError("~simulate interior", "has " + std::to_string(pts.r.size()) + " points but the volume has " +
                                                  std::to_string(cloud->size()) + " particles",
                        "give one solid value per particle of the latest volume, in its order");
      const double tol = 0.25 * (cloud->spacing > 0 ? cloud->spacing : 1e-3);
      for (std::size_t i = 0; i < pts.X.size(); ++i)
        if ((pts.X[i] - cloud->X[i]).norm() > tol)
          throw TopoError("~simulate interior", "point " + std::to_string(i) + " is not at particle " + std::to_string(i) +
                                                    " of the volume",
                          "give the particles in the volume's order (as the `interior` topic publishes them)");
      r = pts.r;
    }
    inference::TaskConfig config = configFor(task, "", req.overrides, "~simulate");
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
    ROS_INFO("interior_inference: ~simulate: %s", res.message.c_str());
  } catch (const std::exception& e) {
    res.success = false;
    res.message = e.what();
    ROS_ERROR("interior_inference: ~simulate: %s", e.what());
  }
  return true;
}

bool InteriorInferenceNode::onExport(topo_gaussian::ExportInterior::Request& req,
                                     topo_gaussian::ExportInterior::Response& res) {
  try {
    std::shared_ptr<VolumeCloud> cloud;
    inference::ExportOptions eo;
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
    if (req.iso < 0 || req.iso >= 1) throw TopoError("~export iso", "must be in (0, 1)", "use 0.5 (or 0 for the default)");
    if (req.iso > 0) eo.iso = req.iso;
    const inference::ExportSummary s = inference::exportInterior(*cloud, r, density, eo);
    res.success = true;
    res.output_dir = s.output_dir;
    for (const auto& f : s.files) res.files.push_back(s.output_dir + "/" + f);
    res.watertight = s.interface.check.watertight();
    res.volume_difference = s.interface.volume_difference;
    std::ostringstream os;
    os << "wrote " << s.files.size() << " files to " << s.output_dir << "; STL " << (res.watertight ? "watertight" : "NOT watertight")
       << ", volume " << std::showpos << 100 * s.interface.volume_difference << std::noshowpos << " % vs the solid particles";
    for (const auto& n : s.notes) os << "; " << n;
    res.message = os.str();
    ROS_INFO("interior_inference: ~export: %s", res.message.c_str());
  } catch (const std::exception& e) {
    res.success = false;
    res.message = e.what();
    ROS_ERROR("interior_inference: ~export: %s", e.what());
  }
  return true;
}

}  // namespace topo_gaussian::topo_ros
