#include "topo_gaussian/ros/rig_simulator_node.h"

#include <cv_bridge/cv_bridge.h>
#include <geometry_msgs/TransformStamped.h>
#include <sensor_msgs/point_cloud2_iterator.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <sstream>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/number_text.h"
#include "topo_gaussian/inference/pipeline.h"
#include "topo_gaussian/inference/task_registry.h"
#include "topo_gaussian/io/task_dir.h"
#include "topo_gaussian/physics/default_shapes.h"
#include "topo_gaussian/ros/ascii_text.h"
#include "topo_gaussian/ros/body_pose_msg.h"
#include "topo_gaussian/ros/conversions.h"
#include "topo_gaussian/ros/interior_markers.h"
#include "topo_gaussian/ros/param_reader.h"

namespace topo_gaussian::topo_ros {
namespace {

constexpr double kPi = 3.14159265358979323846;

void requireRange(const std::string& name, double value, double lo, double hi, const std::string& fix) {
  if (!(value >= lo && value <= hi))
    throw TopoError("~" + name + " = " + numberText(value, 6),
                    "is outside [" + numberText(lo) + ", " + numberText(hi) + "]", fix);
}

void requireColour(const std::string& name, const std::vector<double>& bgr) {
  for (double c : bgr)
    if (!(c >= 0 && c <= 255))
      throw TopoError("~" + name + " " + listText(bgr), "must be three numbers 0..255 (B, G, R)", "e.g. [40, 40, 150]");
}

/// The task that brings `shape` and whose motion the pressure twin replays (TaskDefinition::
/// pressure_twin; the finger task for the finger), or nullptr.
const inference::TaskDefinition* pressureTwinTask(const std::string& shape) {
  for (const auto& t : inference::taskDefinitions())
    if (t.pressure_twin && t.default_shape == shape) return &t;
  return nullptr;
}

}  // namespace

namespace {
void loadFingerParams(const ParamReader& r, const inference::TaskDefinition& task, RigSimulatorParams* params);
void loadRigidTwinParams(const ParamReader& r, RigSimulatorParams* params);
void loadCameraParams(const ParamReader& r, RigSimulatorParams* params);
}  // namespace

workflow::RigTwinOptions experimentTwinOptions(const workflow::RigTwinOptions& base, const std::string& name,
                                               const std::string& task, const std::vector<std::string>& assignments,
                                               const std::vector<std::string>& taken, const std::string& what) {
  if (name.empty() || name.find('.') != std::string::npos || name.find('=') != std::string::npos ||
      std::find(taken.begin(), taken.end(), name) != taken.end())
    throw TopoError(what, "needs a new experiment name without '.' or '='" +
                              (taken.empty() ? std::string() : " (taken: " + listText(taken) + ")"),
                    "e.g. ['rock10=tumbler', 'rock25=tumbler']");
  workflow::RigTwinOptions x = base;
  x.task = task;
  x.overrides.clear();
  try {
    inference::TaskConfig c = inference::TaskConfig::load(task, base.task_dir);
    for (const auto& a : assignments) {
      const auto dot = a.find('.'), is = a.find('=');
      const bool named = dot != std::string::npos && dot < is;
      const std::string key = named ? a.substr(dot + 1) : a;
      if (named ? a.substr(0, dot) != name : !c.spec(key.substr(0, key.find('=')))) continue;
      c.setAssignment(key, "~set");
      x.overrides.push_back(key);
    }
  } catch (const TopoError& error) {
    throw TopoError(what + " " + name + " (~set): " + error.what());
  }
  return x;
}

RigSimulatorParams loadRigSimulatorParams(const ::ros::NodeHandle& pnh) {
  // Types are checked by the reader (a wrong type stops the node naming the parameter); the ranges
  // below keep the node's own advice.
  const ParamReader r(pnh, "rig_simulator");
  RigSimulatorParams p;
  workflow::RigTwinOptions& t = p.twin;
  t.shape = r.text("object", t.shape);
  try {
    defaultShape(t.shape);
  } catch (const TopoError& e) {
    throw TopoError(std::string("~object: ") + e.what());
  }
  // a shape that a pressure-twin task brings (the finger), with such a task or none named: the pneumatic
  // twin; with another task (e.g. hanging) the shape is a rigid body like any other
  const inference::TaskDefinition* pressure = pressureTwinTask(t.shape);
  if (pressure) {
    const std::string task = r.text("task", "");
    try {
      if (!task.empty()) {
        const inference::TaskDefinition& named = inference::taskDefinition(
            inference::TaskConfig::load(task, r.text("task_dir", io::defaultTaskDir())).task());
        if (!named.pressure_twin || named.default_shape != t.shape) pressure = nullptr;
      }
    } catch (const TopoError& e) {
      throw TopoError(std::string("~task: ") + e.what());
    }
  }
  if (pressure) {
    loadFingerParams(r, *pressure, &p);
  } else {
    loadRigidTwinParams(r, &p);
  }
  loadCameraParams(r, &p);
  return p;
}

namespace {

void loadFingerParams(const ParamReader& r, const inference::TaskDefinition& task, RigSimulatorParams* params) {
  RigSimulatorParams& p = *params;
  workflow::FingerTwinOptions& f = p.finger_twin;
  p.finger = true;
  f.spacing_m = r.number("spacing_m", f.spacing_m, "m");
  const DefaultShape shape = defaultShape(task.default_shape);
  requireRange("spacing_m", f.spacing_m, 5e-4, shape.thickness_m / 3.0,
               "use e.g. 0.002 (at most a third of the finger's thickness, " + numberText(shape.thickness_m) + " m)");
  f.task = r.text("task", task.name);
  f.task_dir = r.text("task_dir", io::defaultTaskDir());
  f.overrides = r.texts("set", f.overrides, "['youngs_modulus_solid=2e6']", "; \t");
  if (!r.texts("experiments", {}, "[]", "; \t").empty())
    throw TopoError("~experiments", "is not available for the finger twin",
                    "drive several pressures with ~pressure_profile instead; leave ~experiments unset");
  try {
    inference::TaskConfig c = inference::TaskConfig::load(f.task, f.task_dir);
    const inference::TaskDefinition& named = inference::taskDefinition(c.task());
    if (!named.pressure_twin || named.default_shape != task.default_shape)
      throw TopoError("~task '" + f.task + "'", "is the " + c.task() + " task",
                      "use the " + task.name + " task (or leave it unset)");
    for (const auto& a : f.overrides) c.setAssignment(a, "~set");
  } catch (const TopoError& e) {
    throw TopoError(std::string("~task/~set: ") + e.what());
  }
  const std::vector<double> theta =
      r.numbers("interior_quadric", {}, 10, "", "[0.01, 0.174, 1, 0, 0, 0, 0.004, 0, 0.08, -0.0005]");
  if (!theta.empty()) f.interior_quadric = Eigen::Map<const Eigen::VectorXd>(theta.data(), 10);
  f.max_pressure_pa = r.number("pressure_max_pa", f.max_pressure_pa, "Pa");
  requireRange("pressure_max_pa", f.max_pressure_pa, 0, 1e7, "a gauge pressure, e.g. 5e5, or 0 for the task's");
  f.pressure_levels = int(r.integer("pressure_levels", f.pressure_levels));
  requireRange("pressure_levels", f.pressure_levels, 2, 100, "about 6 (the shape is interpolated between them)");
  p.pressure_profile = r.text("pressure_profile", p.pressure_profile);
  if (p.pressure_profile != "step" && p.pressure_profile != "ramp" && p.pressure_profile != "command")
    throw TopoError("~pressure_profile '" + p.pressure_profile + "'", "is not a profile",
                    "use step, ramp or command (follow the pressure_command topic)");
  p.pressure_period_s = r.number("pressure_period_s", p.pressure_period_s, "s");
  requireRange("pressure_period_s", p.pressure_period_s, 0.1, 3600, "seconds per cycle, e.g. 8");
  p.pressure_rest_s = r.number("pressure_rest_s", p.pressure_rest_s, "s");
  requireRange("pressure_rest_s", p.pressure_rest_s, 0, p.pressure_period_s,
               "seconds at 0 Pa at the start of each cycle, less than ~pressure_period_s, e.g. 2");
  p.pressure_timeout_s = r.number("pressure_timeout_s", p.pressure_timeout_s, "s");
  requireRange("pressure_timeout_s", p.pressure_timeout_s, 0.1, 3600, "seconds, e.g. 5");
  // a side view of the finger's bending plane (x-z), 0.5 m away on −y: image right = +x, up = +z
  p.default_camera_pose = {0.05, -0.5, 0.0, -0.7071068, 0.0, 0.0, 0.7071068};
  p.horizontal_fov_deg = 16.0;
}

void loadRigidTwinParams(const ParamReader& r, RigSimulatorParams* params) {
  RigSimulatorParams& p = *params;
  workflow::RigTwinOptions& t = p.twin;
  t.spacing_m = r.number("spacing_m", t.spacing_m, "m");
  const DefaultShape shape = defaultShape(t.shape);
  requireRange("spacing_m", t.spacing_m, 1e-4, shape.thickness_m / 3.0,
               "use e.g. 0.0025 (at most a third of the " + t.shape + "'s thinnest dimension, " +
                   numberText(shape.thickness_m) + " m)");
  t.task = r.text("task", "");
  t.task_dir = r.text("task_dir", io::defaultTaskDir());
  // a list of "KEY=VALUE" strings, or one string (`_set:=...` on a command line) of assignments
  // separated by spaces or semicolons
  t.overrides = r.texts("set", t.overrides, "['initial_tilt_deg=8', 'density_solid=4000']", "; \t");
  const std::vector<std::string> experiments =
      r.texts("experiments", {}, "['rock10=tumbler', 'rock25=tumbler']", "; \t");
  p.experiment_s = r.number("experiment_s", p.experiment_s, "s");
  requireRange("experiment_s", p.experiment_s, 1.0, 3600.0, "seconds each experiment plays, e.g. 20");
  const std::string default_task = t.task.empty() ? workflow::RigTwin::defaultTaskFor(t.shape) : t.task;
  // The task and its overrides, checked here so the message names the parameter.
  if (experiments.empty()) {
    try {
      inference::TaskConfig c = inference::TaskConfig::load(default_task, t.task_dir);
      for (const auto& a : t.overrides) c.setAssignment(a, "~set");
    } catch (const TopoError& e) {
      throw TopoError(std::string("~task/~set: ") + e.what());
    }
  }
  for (const auto& e : experiments) {
    const auto eq = e.find('=');
    const std::string name = e.substr(0, eq), task = eq == std::string::npos ? default_task : e.substr(eq + 1);
    p.experiment_twins.push_back(
        experimentTwinOptions(t, name, task, t.overrides, p.experiment_names, "~experiments entry '" + e + "'"));
    p.experiment_names.push_back(name);
  }
  const std::vector<double> theta = r.numbers("interior_quadric", {}, 10, "", "[1, 1, 1, 0, 0, 0, 0, 0, -0.8, -0.09]");
  if (!theta.empty()) t.interior_quadric = Eigen::Map<const Eigen::VectorXd>(theta.data(), 10);
  t.loop_cycles = int(r.integer("loop_cycles", t.loop_cycles));
  requireRange("loop_cycles", t.loop_cycles, 2, 1000, "use about 8");
  t.undamped = r.flag("undamped", t.undamped);
  t.surface_file = r.text("surface_file", "");
  t.scan_spacing_m = r.number("scan_spacing_m", t.scan_spacing_m, "m");
  if (t.scan_spacing_m != 0)
    requireRange("scan_spacing_m", t.scan_spacing_m, 2e-4, shape.thickness_m / 3.0,
                 "use e.g. 0.001 (a finer scan fills closer to the true volume), or 0 for the surface particles");
}

void loadCameraParams(const ParamReader& r, RigSimulatorParams* params) {
  RigSimulatorParams& p = *params;

  p.width = int(r.integer("width", p.width, "px"));
  p.height = int(r.integer("height", p.height, "px"));
  requireRange("width", p.width, 16, 8192, "give the image width in pixels, e.g. 640");
  requireRange("height", p.height, 16, 8192, "give the image height in pixels, e.g. 480");
  p.fps = r.number("fps", p.fps, "frames/s");
  requireRange("fps", p.fps, 0.1, 240, "e.g. 30");
  p.horizontal_fov_deg = r.number("horizontal_fov_deg", p.horizontal_fov_deg, "deg");
  requireRange("horizontal_fov_deg", p.horizontal_fov_deg, 0.1, 170, "e.g. 8 for the default 1.5 m camera distance");
  const std::pair<const char*, double*> intrinsics[] = {{"fx", &p.fx}, {"fy", &p.fy}, {"cx", &p.cx}, {"cy", &p.cy}};
  for (const auto& [name, v] : intrinsics) {
    *v = r.number(name, *v, "px");
    requireRange(name, *v, 0, 1e6,
                 "give pixels, or 0 to derive it (fx, fy from ~horizontal_fov_deg; cx, cy the image centre)");
  }
  p.noise_sigma = r.number("noise_sigma", p.noise_sigma, "grey levels");
  requireRange("noise_sigma", p.noise_sigma, 0, 100, "grey levels of Gaussian pixel noise, e.g. 2 (0 = none)");
  p.scale_resolution_kg = r.number("scale_resolution_kg", p.scale_resolution_kg, "kg");
  requireRange("scale_resolution_kg", p.scale_resolution_kg, 1e-9, 10, "the scale's display step in kg, e.g. 0.001");
  p.timer_resolution_s = r.number("timer_resolution_s", p.timer_resolution_s, "s");
  requireRange("timer_resolution_s", p.timer_resolution_s, 1e-9, 10,
               "the step of the rig's timed features in seconds, e.g. 0.001");
  p.inclinometer_resolution_deg = r.number("inclinometer_resolution_deg", p.inclinometer_resolution_deg, "deg");
  requireRange("inclinometer_resolution_deg", p.inclinometer_resolution_deg, 1e-9, 10,
               "the step of the rig's inclinometer in degrees, e.g. 0.1");
  p.seed = int(r.integer("seed", p.seed));
  requireRange("seed", p.seed, 0, 2147483647, "any non-negative integer");
  p.world_frame = r.text("world_frame", p.world_frame);
  p.camera_frame = r.text("camera_frame", p.camera_frame);
  p.object_frame = r.text("object_frame", p.object_frame);
  if (p.world_frame.empty() || p.camera_frame.empty() || p.object_frame.empty() || p.world_frame == p.camera_frame ||
      p.world_frame == p.object_frame || p.camera_frame == p.object_frame)
    throw TopoError("~world_frame/~camera_frame/~object_frame ('" + p.world_frame + "', '" + p.camera_frame + "', '" +
                        p.object_frame + "')",
                    "must be three different, non-empty frame names", "e.g. world, camera_optical and object_true");
  p.camera_pose_timeout_s = r.number("camera_pose_timeout_s", p.camera_pose_timeout_s, "s");
  requireRange("camera_pose_timeout_s", p.camera_pose_timeout_s, 0, 3600,
               "seconds to wait for the tf camera pose, e.g. 2");
  p.default_camera_pose =
      r.numbers("default_camera_pose", p.default_camera_pose, 7, "", "[-1.5, 0, 0.04, -0.5, 0.5, -0.5, 0.5]");
  if (!(Eigen::Vector4d(p.default_camera_pose[3], p.default_camera_pose[4], p.default_camera_pose[5],
                        p.default_camera_pose[6])
            .norm() > 0))
    throw TopoError("~default_camera_pose " + listText(p.default_camera_pose), "has a zero quaternion",
                    "give [x, y, z, qx, qy, qz, qw] of the optical frame in the world");
  p.object_bgr = r.numbers("object_bgr", p.object_bgr, 3, "", "[40, 40, 150]");
  p.background_bgr = r.numbers("background_bgr", p.background_bgr, 3, "", "[235, 235, 235]");
  requireColour("object_bgr", p.object_bgr);
  requireColour("background_bgr", p.background_bgr);
  p.light_direction = r.numbers("light_direction", p.light_direction, 3, "", "[-1, 0, 1]");
  if (!(Eigen::Vector3d(p.light_direction[0], p.light_direction[1], p.light_direction[2]).norm() > 0))
    throw TopoError("~light_direction", "is zero",
                    "give the direction towards the light in the world, e.g. [-1, 0, 1]");
  p.truth_view_frame = r.text("truth_view_frame", p.truth_view_frame);
  p.truth_view_offset_m = r.numbers("truth_view_offset_m", p.truth_view_offset_m, 3, "m", "[0, 0.15, 0.05]");
  if (p.truth_view_frame.empty() || p.truth_view_frame == p.world_frame || p.truth_view_frame == p.object_frame)
    throw TopoError("~truth_view_frame '" + p.truth_view_frame + "'", "must be a new, non-empty frame name",
                    "e.g. object_true_view");
  p.splat_radius_m = r.number("splat_radius_m", p.splat_radius_m, "m");
  requireRange("splat_radius_m", p.splat_radius_m, 0, 0.1, "use 0 for 0.8 particle spacings");
}

}  // namespace

double profilePressurePa(const RigSimulatorParams& p, double max_pa, double t_s) {
  if (p.pressure_profile == "command") return NAN;
  const double tau = std::fmod(std::max(0.0, t_s), p.pressure_period_s);
  if (tau < p.pressure_rest_s) return 0.0;
  if (p.pressure_profile == "step") return max_pa;
  return max_pa * (tau - p.pressure_rest_s) / std::max(1e-9, p.pressure_period_s - p.pressure_rest_s);
}

vision::SplatCamera cameraFor(const RigSimulatorParams& p) {
  vision::SplatCamera c;
  c.width = p.width;
  c.height = p.height;
  c.fx = p.fx > 0 ? p.fx : 0.5 * p.width / std::tan(0.5 * p.horizontal_fov_deg * kPi / 180.0);
  c.fy = p.fy > 0 ? p.fy : c.fx;
  c.cx = p.cx > 0 ? p.cx : 0.5 * (p.width - 1);
  c.cy = p.cy > 0 ? p.cy : 0.5 * (p.height - 1);
  return c;
}

sensor_msgs::CameraInfo cameraInfoFor(const vision::SplatCamera& c, const std::string& frame_id,
                                      const ::ros::Time& stamp) {
  sensor_msgs::CameraInfo info;
  info.header.frame_id = frame_id;
  info.header.stamp = stamp;
  info.width = static_cast<std::uint32_t>(c.width);
  info.height = static_cast<std::uint32_t>(c.height);
  info.distortion_model = "plumb_bob";
  info.D.assign(5, 0.0);
  info.K = {c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1};
  info.R = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  info.P = {c.fx, 0, c.cx, 0, 0, c.fy, c.cy, 0, 0, 0, 1, 0};
  return info;
}

sensor_msgs::PointCloud2 toSurfaceCloud(const std::vector<Eigen::Vector3d>& points,
                                        const std::vector<Eigen::Vector3d>& normals, const std::string& frame_id,
                                        const ::ros::Time& stamp) {
  if (points.size() != normals.size())
    throw TopoError(
        "surface cloud",
        "has " + std::to_string(normals.size()) + " normals for " + std::to_string(points.size()) + " points",
        "give one normal per point");
  sensor_msgs::PointCloud2 msg;
  msg.header.frame_id = frame_id;
  msg.header.stamp = stamp;
  sensor_msgs::PointCloud2Modifier mod(msg);
  mod.setPointCloud2Fields(6, "x", 1, sensor_msgs::PointField::FLOAT32, "y", 1, sensor_msgs::PointField::FLOAT32, "z",
                           1, sensor_msgs::PointField::FLOAT32, "normal_x", 1, sensor_msgs::PointField::FLOAT32,
                           "normal_y", 1, sensor_msgs::PointField::FLOAT32, "normal_z", 1,
                           sensor_msgs::PointField::FLOAT32);
  mod.resize(points.size());
  sensor_msgs::PointCloud2Iterator<float> x(msg, "x"), n(msg, "normal_x");
  for (std::size_t i = 0; i < points.size(); ++i, ++x, ++n)
    for (int k = 0; k < 3; ++k) {
      x[k] = static_cast<float>(points[i][k]);
      n[k] = static_cast<float>(normals[i][k]);
    }
  return msg;
}

namespace {
/// The true interior, its solid fraction and mass properties into a ground truth (header set).
void setTrueInterior(const VolumeCloud& cloud, const std::vector<double>& r, const std::vector<double>& density,
                     const inference::TaskConfig& config, const MassProperties& mass,
                     topo_gaussian::RigGroundTruth* m) {
  double solid = 0, total = 0;
  for (std::size_t i = 0; i < r.size(); ++i) solid += r[i] * cloud.V[i], total += cloud.V[i];
  m->solid_fraction = total > 0 ? solid / total : 0.0;
  m->mass_kg = mass.mass;
  m->center_of_mass = {mass.com.x(), mass.com.y(), mass.com.z()};
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) m->inertia.push_back(mass.inertia(a, b));
  m->interior =
      toInteriorCloud(cloud, r, density, inference::particleStiffness(config, r), m->header.frame_id, m->header.stamp);
}
}  // namespace

topo_gaussian::RigGroundTruth toGroundTruthMsg(const std::vector<const workflow::RigTwin*>& twins,
                                               const std::vector<std::string>& names, const std::string& object_frame,
                                               const ::ros::Time& stamp) {
  if (twins.empty() || (twins.size() > 1 && names.size() != twins.size()))
    throw TopoError("ground truth", "needs one twin per experiment name", "give the names of the twins");
  const workflow::RigTwin& twin = *twins.front();
  topo_gaussian::RigGroundTruth m;
  m.header.frame_id = object_frame;
  m.header.stamp = stamp;
  m.object = twin.shape().name;
  m.task = twin.config().task();
  for (std::size_t k = 0; k < twins.size(); ++k) {
    const std::string prefix = twins.size() > 1 ? names[k] + "." : std::string();
    if (twins.size() > 1) m.experiments.push_back(names[k]);
    for (const auto& f : twins[k]->truth().task.features) {
      m.feature_names.push_back(prefix + f.name);
      m.feature_values.push_back(f.value);
      m.units.push_back(f.unit);
    }
  }
  m.loop_s = twin.loopSeconds();
  setTrueInterior(twin.cloud(), twin.indicator(), twin.density(), twin.config(), twin.truth().task.mass, &m);
  return m;
}

topo_gaussian::RigGroundTruth toGroundTruthMsg(const workflow::FingerTwin& twin, double loop_s,
                                               const std::string& object_frame, const ::ros::Time& stamp) {
  topo_gaussian::RigGroundTruth m;
  m.header.frame_id = object_frame;
  m.header.stamp = stamp;
  m.object = twin.shape().name;
  m.task = twin.config().task();
  for (const auto& f : twin.truth().task.features) {
    m.feature_names.push_back(f.name);
    m.feature_values.push_back(f.value);
    m.units.push_back(f.unit);
  }
  m.feature_names.push_back("chamber_volume_m3");
  m.feature_values.push_back(twin.chamberVolumeM3());
  m.units.push_back("m3");
  m.loop_s = loop_s;
  setTrueInterior(twin.cloud(), twin.indicator(), twin.density(), twin.config(), twin.truth().task.mass, &m);
  return m;
}

RigSimulatorNode::RigSimulatorNode(const ::ros::NodeHandle& nh, const ::ros::NodeHandle& pnh)
    : nh_(nh), pnh_(pnh), params_(loadRigSimulatorParams(pnh)), tf_listener_(tf_buffer_) {
  if (params_.finger) {
    setUpFinger(::ros::Time::now());
    return;
  }
  const workflow::RigTwinOptions& o = params_.twin;
  ROS_INFO("rig_simulator: simulating the %s twin (spacing %s m, task '%s') ...", o.shape.c_str(),
           numberText(o.spacing_m).c_str(),
           o.task.empty() ? workflow::RigTwin::defaultTaskFor(o.shape).c_str() : o.task.c_str());
  // TopoError: the simulation failed (main reports it). Several experiments: one twin each, all with
  // the first one's interior.
  if (params_.experiment_twins.empty()) {
    twins_.push_back(std::make_unique<workflow::RigTwin>(o));
    names_.push_back("");
  }
  for (std::size_t k = 0; k < params_.experiment_twins.size(); ++k) {
    workflow::RigTwinOptions x = params_.experiment_twins[k];
    if (k > 0) x.interior_quadric = twins_.front()->options().interior_quadric;
    twins_.push_back(std::make_unique<workflow::RigTwin>(x));
    names_.push_back(params_.experiment_names[k]);
    std::string fs;
    for (const auto& f : twins_.back()->truth().task.features)
      fs += (fs.empty() ? "" : ", ") + f.name + " " + numberText(f.value, 6) + " " + f.unit;
    ROS_INFO("rig_simulator: experiment %s (task %s): %s; loops every %.4f s", names_.back().c_str(), x.task.c_str(),
             asciiText(fs).c_str(), twins_.back()->loopSeconds());
  }
  const workflow::RigTwin& tw = *twins_.front();
  std::string features;
  for (const auto& f : tw.truth().task.features)
    features += (features.empty() ? "" : ", ") + f.name + " " + numberText(f.value, 6) + " " + f.unit;
  std::vector<double> theta(tw.options().interior_quadric.data(), tw.options().interior_quadric.data() + 10);
  ROS_INFO(
      "rig_simulator: %s twin, task %s: %zu particles (%zu on the surface), solid fraction %.3f, interior quadric "
      "%s%s; "
      "scan of %zu points on surface_cloud",
      tw.shape().name.c_str(), tw.config().task().c_str(), tw.cloud().size(), tw.surfacePoints().size(),
      tw.solidFraction(), listText(theta).c_str(), o.interior_quadric.size() ? "" : " (default cavity)",
      tw.scanPoints().size());
  ROS_INFO("rig_simulator: ground truth: %s", asciiText(features).c_str());
  ROS_INFO(
      "rig_simulator: motion loops every %.4f s (%d periods; seam %.3f deg / %.3f mm; amplitude decay %.3f %% per "
      "period%s); set up in %.2f s",
      tw.loopSeconds(), tw.loopCycles(), tw.seamRotationDeg(), 1e3 * tw.seamTranslationM(),
      100 * tw.amplitudeDecayPerCycle(), o.undamped ? ", contact damping off" : "", tw.simulationSeconds());

  setUpCamera(tw.surfacePoints(), tw.surfaceNormals(), tw.cloud().spacing);
  ROS_INFO(
      "rig_simulator: camera %dx%d at %.1f fps, fx %.1f fy %.1f cx %.1f cy %.1f px (%.2f deg horizontal FOV), noise "
      "%.1f; pose from tf %s -> %s (default %s after %.1f s)",
      camera_.width, camera_.height, params_.fps, camera_.fx, camera_.fy, camera_.cx, camera_.cy,
      2 * std::atan(0.5 * camera_.width / camera_.fx) * 180 / kPi, params_.noise_sigma, params_.world_frame.c_str(),
      params_.camera_frame.c_str(), listText(params_.default_camera_pose).c_str(), params_.camera_pose_timeout_s);

  image_pub_ = nh_.advertise<sensor_msgs::Image>("image", 2);
  info_pub_ = nh_.advertise<sensor_msgs::CameraInfo>("camera_info", 2);
  surface_pub_ = nh_.advertise<sensor_msgs::PointCloud2>("surface_cloud", 1, true);
  truth_pub_ = pnh_.advertise<topo_gaussian::RigGroundTruth>("ground_truth", 1, true);
  const ::ros::Time now = ::ros::Time::now();
  surface_pub_.publish(toSurfaceCloud(tw.scanPoints(), tw.scanNormals(), params_.object_frame, now));
  publishGroundTruth(now);
  experiment_pub_ = nh_.advertise<std_msgs::String>("experiment", 1, true);
  // The object on the rig's scale, as a lab weighs it once: its true mass to the scale's resolution.
  scale_pub_ = nh_.advertise<std_msgs::Float64>("scale_kg", 1, true);
  std_msgs::Float64 reading;
  reading.data = params_.scale_resolution_kg * std::round(tw.truth().task.mass.mass / params_.scale_resolution_kg);
  scale_pub_.publish(reading);
  ROS_INFO("rig_simulator: on the scale (scale_kg): %.6g kg (true mass %.6g kg, resolution %.3g kg)", reading.data,
           tw.truth().task.mass.mass, params_.scale_resolution_kg);
  // The true interior beside the object, for rviz (the recovered one is drawn at the object).
  geometry_msgs::TransformStamped view;
  view.header.stamp = now;
  view.header.frame_id = params_.world_frame;
  view.child_frame_id = params_.truth_view_frame;
  view.transform.translation.x = params_.truth_view_offset_m[0];
  view.transform.translation.y = params_.truth_view_offset_m[1];
  view.transform.translation.z = params_.truth_view_offset_m[2];
  view.transform.rotation.w = 1.0;
  static_broadcaster_.sendTransform(view);
  publishTrueInterior(tw.cloud(), tw.indicator(), tw.density(), tw.config(), tw.truth().task.mass);
  start_ = now;
  perform_srv_ = pnh_.advertiseService("perform_experiment", &RigSimulatorNode::onPerformExperiment, this);
  timer_ = nh_.createTimer(::ros::Duration(1.0 / params_.fps), &RigSimulatorNode::onTimer, this);
}

void RigSimulatorNode::publishGroundTruth(const ::ros::Time& stamp) {
  std::vector<const workflow::RigTwin*> twins;
  for (const auto& t : twins_) twins.push_back(t.get());
  truth_pub_.publish(toGroundTruthMsg(twins, names_, params_.object_frame, stamp));
}

std::unique_ptr<workflow::RigTwin> RigSimulatorNode::performedTwin(
    const topo_gaussian::PerformExperiment::Request& req) const {
  const std::string what = "~perform_experiment '" + req.name + "'";
  // the shared ~set entries (density, damping, ...) as for every experiment, then the request's own
  std::vector<std::string> assignments = params_.twin.overrides;
  for (const auto& o : req.overrides) {
    if (o.find('=') == std::string::npos)
      throw TopoError(what + " override '" + o + "'", "is not KEY=VALUE", "e.g. hanging_point=0.01,0.02,-0.03");
    assignments.push_back(req.name + "." + o);
  }
  std::vector<std::string> taken = names_;
  if (taken.size() == 1 && taken.front().empty()) taken.clear();
  workflow::RigTwinOptions x =
      experimentTwinOptions(twins_.front()->options(), req.name, req.task, assignments, taken, what);
  x.interior_quadric = twins_.front()->options().interior_quadric;
  // a hanging point the rig can reach: on the object (within two particle spacings of one of its particles)
  inference::TaskConfig c = inference::TaskConfig::load(x.task, x.task_dir);
  for (const auto& a : x.overrides) c.setAssignment(a, what);
  if (c.spec("hanging_point")) {
    const Eigen::Vector3d q = c.vector3("hanging_point");
    const VolumeCloud& cloud = twins_.front()->cloud();
    double nearest = INFINITY;
    for (const auto& X : cloud.X) nearest = std::min(nearest, (X - q).norm());
    if (!(nearest <= 2.0 * cloud.spacing))
      throw TopoError(what + " hanging_point " + listText({q.x(), q.y(), q.z()}),
                      "is " + numberText(nearest, 3) + " m from the object (farther than two particle spacings, " +
                          numberText(2.0 * cloud.spacing, 3) + " m): the rig cannot hang it there",
                      "give a point on the object's surface (object frame, metres)");
  }
  auto twin = std::make_unique<workflow::RigTwin>(x);
  for (const auto& f : req.instruments) instrumentReading(*twin, f, nullptr);  // TopoError: what it can read
  return twin;
}

double RigSimulatorNode::instrumentReading(const workflow::RigTwin& twin, const std::string& name,
                                           double* resolution) const {
  double step = 0.0, v = NAN;
  // a pose angle of the experiment as the twin set it up (a hung object's rest pose): the inclinometer
  if (name == "target_roll_deg" || name == "target_pitch_deg") {
    if (!twin.config().has(name))
      throw TopoError("~perform_experiment instrument '" + name + "'", "is not set up by this experiment's task",
                      "read it only for a hanging experiment");
    step = params_.inclinometer_resolution_deg;
    v = twin.config().number(name);
  } else {
    v = twin.feature(name);  // TopoError listing the features the task has
    if (name.size() > 2 && name.compare(name.size() - 2, 2, "_s") == 0) step = params_.timer_resolution_s;
  }
  if (resolution) *resolution = step;
  return step > 0 ? step * std::round(v / step) : v;
}

bool RigSimulatorNode::onPerformExperiment(topo_gaussian::PerformExperiment::Request& req,
                                           topo_gaussian::PerformExperiment::Response& res) {
  const auto t0 = std::chrono::steady_clock::now();
  res.accepted = false;
  if (finger_) {
    res.message = "~perform_experiment: the finger twin performs pressures, not experiments: publish the pressure "
                  "on " + nh_.resolveName("pressure_command") + " with ~pressure_profile command";
    ROS_WARN("rig_simulator: %s", res.message.c_str());
    return true;
  }
  ROS_INFO("rig_simulator: setting up experiment %s (task %s, %s) ...", req.name.c_str(), req.task.c_str(),
           listText(req.overrides).c_str());
  std::unique_ptr<workflow::RigTwin> twin;
  try {
    twin = performedTwin(req);
  } catch (const std::exception& e) {
    res.message = asciiText(e.what()) + " The experiments so far (" + listText(names_) + ") are kept.";
    ROS_ERROR("rig_simulator: experiment refused: %s", res.message.c_str());
    return true;
  }
  std::string read;
  for (const auto& f : req.instruments) {
    double step = 0.0;
    res.readings.push_back(f + "=" + numberText(instrumentReading(*twin, f, &step), 9));
    res.resolutions.push_back(step);
    read += (read.empty() ? "" : ", ") + res.readings.back();
  }
  if (names_.size() == 1 && names_.front().empty()) names_.front() = twins_.front()->config().task();
  twins_.push_back(std::move(twin));
  names_.push_back(req.name);
  // on camera now, for experiment_s; then the rotation goes on from it
  playing_ = static_cast<int>(twins_.size()) - 2;  // onTimer announces the change
  slot_start_s_ = (::ros::Time::now() - start_).toSec() - params_.experiment_s;
  publishGroundTruth(::ros::Time::now());
  res.setup_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  res.accepted = true;
  res.message = "experiment " + req.name + " (" + req.task + ") set up in " + numberText(res.setup_s, 3) +
                " s and on camera for " + numberText(params_.experiment_s) + " s" +
                (read.empty() ? std::string() : "; read: " + read);
  ROS_INFO("rig_simulator: %s", res.message.c_str());
  return true;
}

void RigSimulatorNode::publishTrueInterior(const VolumeCloud& cloud, const std::vector<double>& r,
                                           const std::vector<double>& density, const inference::TaskConfig& config,
                                           const MassProperties& mass) {
  true_interior_pub_ = pnh_.advertise<sensor_msgs::PointCloud2>("true_interior", 1, true);
  true_interior_pub_.publish(toInteriorCloud(cloud, r, density, inference::particleStiffness(config, r),
                                             params_.truth_view_frame, ::ros::Time(0)));
  // ... and drawn as interior_inference draws the recovered one: the viewer's half cut away, the
  // cavity in the hollow colour (ros/interior_markers.h)
  true_markers_pub_ = pnh_.advertise<visualization_msgs::MarkerArray>("true_interior_markers", 1, true);
  InteriorMarkerInput mi;
  mi.cloud = &cloud;
  mi.r = &r;
  mi.mass = mass;
  mi.object_frame = params_.truth_view_frame;
  mi.world_frame = params_.world_frame;
  true_markers_pub_.publish(makeInteriorMarkers(mi, ::ros::Time(0)));
}

void RigSimulatorNode::setUpCamera(const std::vector<Eigen::Vector3d>& surface,
                                   const std::vector<Eigen::Vector3d>& normals, double spacing_m) {
  camera_ = cameraFor(params_);
  shading_.background_bgr = cv::Scalar(params_.background_bgr[0], params_.background_bgr[1], params_.background_bgr[2]);
  shading_.light_dir_world =
      Eigen::Vector3d(params_.light_direction[0], params_.light_direction[1], params_.light_direction[2]);
  shading_.noise_sigma = params_.noise_sigma;
  body_.positions = surface;
  body_.normals = normals;
  body_.colours.assign(1, cv::Vec3b::all(0));
  for (int k = 0; k < 3; ++k) body_.colours[0][k] = cv::saturate_cast<uchar>(params_.object_bgr[k]);
  body_.radius_m = params_.splat_radius_m > 0 ? params_.splat_radius_m : 0.8 * spacing_m;
}

void RigSimulatorNode::setUpFinger(const ::ros::Time& now) {
  const workflow::FingerTwinOptions& o = params_.finger_twin;
  ROS_INFO("rig_simulator: solving the finger twin (spacing %s m, task '%s', %d pressure levels) ...",
           numberText(o.spacing_m).c_str(), o.task.c_str(), o.pressure_levels);
  finger_ = std::make_unique<workflow::FingerTwin>(o);  // TopoError: main reports it
  const workflow::FingerTwin& f = *finger_;
  std::string bends;
  for (double p : f.pressureLevelsPa()) bends += (bends.empty() ? "" : ", ") + numberText(f.bendDeg(p), 4);
  std::vector<double> theta(f.options().interior_quadric.data(), f.options().interior_quadric.data() + 10);
  ROS_INFO(
      "rig_simulator: finger twin: %zu particles (%zu on the surface), chamber %.3f cm3 (solid fraction %.3f), "
      "chamber quadric %s%s; bend %s deg at %s Pa; set up in %.1f s",
      f.cloud().size(), f.surfaceIndex().size(), 1e6 * f.chamberVolumeM3(), f.solidFraction(), listText(theta).c_str(),
      o.interior_quadric.size() ? "" : " (default chamber)", bends.c_str(), listText(f.pressureLevelsPa()).c_str(),
      f.setupSeconds());
  const std::string profile =
      params_.pressure_profile == "command"
          ? "set point on " + nh_.resolveName("pressure_command") + ", 0.." + numberText(f.maxPressurePa()) + " Pa"
          : "0 Pa for " + numberText(params_.pressure_rest_s) + " s, then " +
                (params_.pressure_profile == "step" ? std::string("") : std::string("a ramp to ")) +
                numberText(f.maxPressurePa()) + " Pa, every " + numberText(params_.pressure_period_s) + " s";
  ROS_INFO("rig_simulator: pressure profile %s (%s)", params_.pressure_profile.c_str(), profile.c_str());
  setUpCamera({}, f.surfaceNormals(), f.cloud().spacing);  // the positions follow the pressure

  image_pub_ = nh_.advertise<sensor_msgs::Image>("image", 2);
  info_pub_ = nh_.advertise<sensor_msgs::CameraInfo>("camera_info", 2);
  pressure_pub_ = nh_.advertise<std_msgs::Float64>("pressure_pa", 10);
  true_bend_pub_ = pnh_.advertise<std_msgs::Float64>("true_bend_deg", 10);
  surface_pub_ = nh_.advertise<sensor_msgs::PointCloud2>("surface_cloud", 1, true);
  truth_pub_ = pnh_.advertise<topo_gaussian::RigGroundTruth>("ground_truth", 1, true);
  std::vector<Eigen::Vector3d> surface;
  for (auto i : f.surfaceIndex()) surface.push_back(f.cloud().X[i]);
  surface_pub_.publish(toSurfaceCloud(surface, f.surfaceNormals(), params_.object_frame, now));
  truth_pub_.publish(toGroundTruthMsg(f, params_.pressure_period_s, params_.object_frame, now));
  // the finger stays where it is clamped: its body frame is the world's
  std::vector<geometry_msgs::TransformStamped> frames(2);
  frames[0].header.stamp = frames[1].header.stamp = now;
  frames[0].header.frame_id = frames[1].header.frame_id = params_.world_frame;
  frames[0].child_frame_id = params_.object_frame;
  frames[0].transform.rotation.w = 1.0;
  frames[1].child_frame_id = params_.truth_view_frame;
  frames[1].transform.translation.x = params_.truth_view_offset_m[0];
  frames[1].transform.translation.y = params_.truth_view_offset_m[1];
  frames[1].transform.translation.z = params_.truth_view_offset_m[2];
  frames[1].transform.rotation.w = 1.0;
  static_broadcaster_.sendTransform(frames);
  publishTrueInterior(f.cloud(), f.indicator(), f.density(), f.config(), f.truth().task.mass);
  pressure_sub_ = nh_.subscribe("pressure_command", 10, &RigSimulatorNode::onPressureCommand, this);
  start_ = last_command_ = now;
  timer_ = nh_.createTimer(::ros::Duration(1.0 / params_.fps), &RigSimulatorNode::onTimer, this);
}

void RigSimulatorNode::onPressureCommand(const std_msgs::Float64& msg) {
  const double max_pa = finger_->maxPressurePa();
  if (!(std::isfinite(msg.data) && msg.data >= 0.0 && msg.data <= max_pa)) {
    ROS_ERROR_THROTTLE(2.0,
                       "rig_simulator: pressure command %s Pa on %s is outside [0, %s] Pa, the range the twin solved: "
                       "ignored, holding %s Pa. Fix: command a gauge pressure in range, or raise ~pressure_max_pa",
                       numberText(msg.data, 6).c_str(), pressure_sub_.getTopic().c_str(), numberText(max_pa).c_str(),
                       numberText(commanded_pa_).c_str());
    return;
  }
  if (params_.pressure_profile != "command")
    ROS_WARN_THROTTLE(10.0,
                      "rig_simulator: pressure command on %s ignored: ~pressure_profile is %s (set it to command to "
                      "follow the topic)",
                      pressure_sub_.getTopic().c_str(), params_.pressure_profile.c_str());
  commanded_pa_ = msg.data;
  last_command_ = ::ros::Time::now();
}

double RigSimulatorNode::fingerPressurePa(const ::ros::Time& now) {
  const double p = profilePressurePa(params_, finger_->maxPressurePa(), (now - start_).toSec());
  if (std::isfinite(p)) return p;
  if ((now - last_command_).toSec() > params_.pressure_timeout_s)
    ROS_WARN_THROTTLE(params_.pressure_timeout_s,
                      "rig_simulator: no pressure command on %s for %.1f s: holding %s Pa. Fix: publish the set point "
                      "[Pa], e.g. `rostopic pub %s std_msgs/Float64 300000`",
                      pressure_sub_.getTopic().c_str(), (now - last_command_).toSec(),
                      numberText(commanded_pa_).c_str(), pressure_sub_.getTopic().c_str());
  return commanded_pa_;
}

bool RigSimulatorNode::cameraPose(const ::ros::Time& now, vision::SplatCamera* camera) {
  try {
    const geometry_msgs::TransformStamped tf =
        tf_buffer_.lookupTransform(params_.world_frame, params_.camera_frame, ::ros::Time(0));
    const auto& q = tf.transform.rotation;
    const auto& v = tf.transform.translation;
    camera->R_wc = Eigen::Quaterniond(q.w, q.x, q.y, q.z).normalized().toRotationMatrix();
    camera->t_wc = Eigen::Vector3d(v.x, v.y, v.z);
    if (!pose_from_tf_)
      ROS_INFO("rig_simulator: camera pose from tf %s -> %s: [%.4f, %.4f, %.4f, %.4f, %.4f, %.4f, %.4f]",
               params_.world_frame.c_str(), params_.camera_frame.c_str(), v.x, v.y, v.z, q.x, q.y, q.z, q.w);
    pose_from_tf_ = true;
    return true;
  } catch (const tf2::TransformException& e) {
    if (pose_from_tf_) {  // it was there: keep the last pose
      ROS_WARN_THROTTLE(10.0, "rig_simulator: tf %s -> %s lost (%s); keeping the last camera pose",
                        params_.world_frame.c_str(), params_.camera_frame.c_str(), e.what());
      return true;
    }
    if ((now - start_).toSec() < params_.camera_pose_timeout_s) return false;
    if (!fallback_warned_) {
      const auto& d = params_.default_camera_pose;
      camera->t_wc = Eigen::Vector3d(d[0], d[1], d[2]);
      camera->R_wc = Eigen::Quaterniond(d[6], d[3], d[4], d[5]).normalized().toRotationMatrix();
      std::string args;
      for (double v : d) args += (args.empty() ? "" : " ") + numberText(v, 6);
      ROS_WARN(
          "rig_simulator: no tf %s -> %s after %.1f s (%s); rendering from ~default_camera_pose %s. Fix: publish the "
          "camera pose, e.g. `rosrun tf2_ros static_transform_publisher %s %s %s`, or set ~default_camera_pose",
          params_.world_frame.c_str(), params_.camera_frame.c_str(), params_.camera_pose_timeout_s, e.what(),
          listText(d).c_str(), args.c_str(), params_.world_frame.c_str(), params_.camera_frame.c_str());
      fallback_warned_ = true;
    }
    return true;
  }
}

void RigSimulatorNode::onTimer(const ::ros::TimerEvent&) {
  const ::ros::Time now = ::ros::Time::now();
  if (!cameraPose(now, &camera_)) {
    ROS_INFO_THROTTLE(5.0, "rig_simulator: waiting for tf %s -> %s (up to %.1f s)", params_.world_frame.c_str(),
                      params_.camera_frame.c_str(), params_.camera_pose_timeout_s);
    return;
  }
  vision::Splats world = body_;
  if (finger_) {
    const double p = fingerPressurePa(now);
    const std::vector<Eigen::Vector3d> x = finger_->positionsAt(p);
    world.positions.clear();
    for (auto i : finger_->surfaceIndex()) world.positions.push_back(x[i]);
    std_msgs::Float64 m;
    m.data = p;
    pressure_pub_.publish(m);
    m.data = finger_->bendDeg(p);
    true_bend_pub_.publish(m);
    publishFrame(now, world);
    return;
  }
  // The experiment on camera: each plays ~experiment_s in turn (a person releasing the doll again); a
  // performed one comes on at once.
  const double t = (now - start_).toSec();
  const int n = static_cast<int>(twins_.size());
  int k = std::max(0, playing_);
  if (playing_ < 0 || (n > 1 && t - slot_start_s_ >= params_.experiment_s)) {
    k = playing_ < 0 ? 0 : (playing_ + 1) % n;
    slot_start_s_ = playing_ < 0 ? 0.0 : std::max(slot_start_s_ + params_.experiment_s, t - params_.experiment_s);
    playing_ = k;
    if (n > 1) {
      std_msgs::String name;
      name.data = names_[k];
      experiment_pub_.publish(name);
      ROS_INFO("rig_simulator: experiment %s on camera for %.1f s", names_[k].c_str(), params_.experiment_s);
    }
  }
  const inference::BodyPose pose = twins_[k]->poseAt(t - slot_start_s_);
  tf_broadcaster_.sendTransform(toTransformStamped(pose, params_.world_frame, params_.object_frame, now));

  for (std::size_t i = 0; i < world.positions.size(); ++i) {
    world.positions[i] = pose.rotation * body_.positions[i] + pose.translation;
    world.normals[i] = pose.rotation * body_.normals[i];
  }
  publishFrame(now, world);
}

void RigSimulatorNode::publishFrame(const ::ros::Time& now, const vision::Splats& world) {
  const auto t0 = std::chrono::steady_clock::now();
  shading_.noise_seed = static_cast<unsigned>(params_.seed) + static_cast<unsigned>(frames_);
  cv::Mat img;
  try {
    img = vision::renderSplats(camera_, world, shading_);
  } catch (const std::exception& e) {
    ROS_ERROR_THROTTLE(5.0, "rig_simulator: rendering failed: %s", asciiText(e.what()).c_str());
    return;
  }
  render_s_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std_msgs::Header header;
  header.stamp = now;
  header.frame_id = params_.camera_frame;
  image_pub_.publish(cv_bridge::CvImage(header, "bgr8", img).toImageMsg());
  info_pub_.publish(cameraInfoFor(camera_, params_.camera_frame, now));
  if (++frames_ == 100) {
    const double ms = 1e3 * render_s_ / frames_;
    if (ms > 1e3 / params_.fps)
      ROS_WARN(
          "rig_simulator: rendering takes %.1f ms per frame, longer than the frame period at %.1f fps: lower ~fps or "
          "~width/~height, or raise ~spacing_m",
          ms, params_.fps);
    else
      ROS_INFO("rig_simulator: %zu frames published; rendering %.1f ms per frame (%zu splats)", frames_, ms,
               world.positions.size());
  }
}

}  // namespace topo_gaussian::topo_ros
