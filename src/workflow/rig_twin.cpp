// RigTwin: a default shape with a known interior, simulated once and replayed as a seamless loop.
#include "topo_gaussian/workflow/rig_twin.h"

#include "topo_gaussian/geometry/contact_samples.h"
#include "topo_gaussian/geometry/ingest.h"
#include "topo_gaussian/geometry/shape_generator.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/number_text.h"
#include "topo_gaussian/inference/body_motion.h"
#include "topo_gaussian/inference/task_registry.h"
#include "topo_gaussian/vision/particle_normals.h"
#include "topo_gaussian/workflow/shape_surface.h"

namespace topo_gaussian::workflow {

using namespace inference;  // the twin runs an inference task
namespace {

constexpr double kDeg = 180.0 / M_PI;
constexpr double kHangingClearanceM = 0.005;  ///< a hanging twin's lowest point above the table at release

/// Tasks whose motion the twin can replay, for messages: "tumbler, hanging".
std::string twinTaskList() {
  std::string s;
  for (const auto& t : taskDefinitions())
    if (t.twin) s += (s.empty() ? "" : ", ") + t.name;
  return s;
}

/// What the twin needs from the task (its registered RigTwinMotion); throws for a task without one.
const RigTwinMotion& twinMotion(const std::string& task) {
  const TaskDefinition& t = taskDefinition(task);
  if (!t.twin)
    throw TopoError("rig twin task '" + task + "'", "has no motion the twin can replay",
                    "use a task with one: " + twinTaskList() + " (e.g. task tumbler for the tumbler shape)");
  return *t.twin;
}

const Feature* findFeature(const ProblemEvaluation& ev, const std::string& name) {
  for (const auto& f : ev.task.features)
    if (f.name == name) return &f;
  return nullptr;
}

double rotationDeg(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  return 2.0 * std::acos(std::min(1.0, std::abs(a.dot(b)))) * kDeg;
}

}  // namespace

std::string RigTwin::defaultTaskFor(const std::string& shape) {
  std::string fallback;
  for (const auto& t : taskDefinitions()) {
    if (!t.twin) continue;
    for (const auto& s : t.twin->default_for_shapes) {
      if (s == shape) return t.name;
      if (s == "*" && fallback.empty()) fallback = t.name;
    }
  }
  if (fallback.empty())
    throw TopoError("rig twin shape '" + shape + "'", "has no default task",
                    "name the task (one of " + twinTaskList() + ")");
  return fallback;
}

Eigen::VectorXd RigTwin::defaultInteriorQuadric(const std::string& task) {
  const TaskDefinition* t = findTaskDefinition(task);
  if (!t || !t->twin || !(t->twin->cavity_radius > 0))
    throw TopoError("rig twin task '" + task + "'", "has no default interior",
                    "give the interior quadric (10 numbers) or use a task with one: " + twinTaskList());
  const Eigen::Vector3d u0 = t->twin->cavity_centre;
  const double rho = t->twin->cavity_radius;
  Eigen::VectorXd theta(10);
  theta << 1, 1, 1, 0, 0, 0, -2 * u0.x(), -2 * u0.y(), -2 * u0.z(), u0.squaredNorm() - rho * rho;
  return theta;
}

ContactSamples exactShapeContactSamples(const DefaultShape& shape, const VolumeCloud& cloud, double spacing_m,
                                        int mirror_axis) {
  if (!(spacing_m >= 0.0) || !std::isfinite(spacing_m))
    throw TopoError("rig twin contact spacing " + numberText(spacing_m, 4) + " m", "is negative or not finite",
                    "give a positive spacing in metres, or 0 for d / 400");
  geometry::ContactSampleOptions o;
  o.spacing_m = spacing_m;
  ContactSamples c = geometry::sampleContactSurface(geometry::makeDefaultShapeMesh(shape.name, 512), cloud, o, nullptr);
  // The mesh's faces lie within ~(2π R / 512)² / (8 R) of the surface (0.4 µm on the doll): bracket
  // each sample by a quarter of the spacing along its normal and bisect to the boundary.
  const double t = 0.25 * c.spacing;
  for (std::size_t k = 0; k < c.size(); ++k) {
    Eigen::Vector3d in = c.X[k] - t * c.normal[k], out = c.X[k] + t * c.normal[k];
    if (!shape.inside(in) || shape.inside(out)) continue;  // an edge or a corner: keep the mesh's point
    while ((out - in).norm() > 1e-12) {
      const Eigen::Vector3d mid = 0.5 * (in + out);
      (shape.inside(mid) ? in : out) = mid;
    }
    c.X[k] = in;
  }
  // The true solid rocks about a horizontal axis without spinning about the vertical: the motion is its
  // own mirror image across the vertical plane normal to the axis. An uneven sample set is not, and the
  // small yaw torques of its friction springs add up (the twin doll turned 2.8° about the vertical in 9
  // periods). Where the shape is its own mirror image across that plane through its centre (every
  // sample's image lies on the surface as the sample does), the samples are joined by their images,
  // each taking half the area: the set then has the motion's symmetry.
  if (mirror_axis == 0 || mirror_axis == 1) {
    const double centre = 0.5 * (shape.lo[mirror_axis] + shape.hi[mirror_axis]);
    auto mirror = [&](Eigen::Vector3d v, bool point) {
      v[mirror_axis] = point ? 2.0 * centre - v[mirror_axis] : -v[mirror_axis];
      return v;
    };
    bool symmetric = true;
    for (std::size_t k = 0; k < c.size() && symmetric; ++k) {
      const Eigen::Vector3d m = mirror(c.X[k], true), n = mirror(c.normal[k], false);
      symmetric = shape.inside(m - t * n) == shape.inside(c.X[k] - t * c.normal[k]) &&
                  shape.inside(m + t * n) == shape.inside(c.X[k] + t * c.normal[k]);
    }
    if (symmetric) {
      const std::size_t n0 = c.size();
      for (std::size_t k = 0; k < n0; ++k) {
        c.area[k] *= 0.5;
        c.X.push_back(mirror(c.X[k], true));
        c.normal.push_back(mirror(c.normal[k], false));
        c.area.push_back(c.area[k]);
      }
    }
  }
  c.origin = "exact " + shape.name + " surface";
  return c;
}

RigTwin::RigTwin(const RigTwinOptions& options) : options_(options) {
  const auto t0 = std::chrono::steady_clock::now();
  if (options_.loop_cycles < 2 || options_.loop_cycles > 1000)
    throw TopoError("rig twin loop cycles " + std::to_string(options_.loop_cycles), "must be 2..1000",
                    "use about 8 periods per loop");
  shape_ = defaultShape(options_.shape);  // unknown shape: lists the valid names
  if (options_.surface_file.empty()) {
    cloud_ = defaultShapeCloud(shape_, options_.spacing_m);
    buildSurface();
  } else {
    geometry::IngestOptions io;  // what cloud_ingest does with ~surface_file and ~spacing_m
    io.fill.spacing_m = options_.spacing_m;
    cloud_ = geometry::ingestFile(options_.surface_file, io).cloud;
    surface_points_.clear();
    for (std::size_t i = 0; i < cloud_.size(); ++i)
      if (cloud_.surface[i]) surface_points_.push_back(cloud_.X[i]);
    surface_normals_ = vision::estimateOutwardNormals(cloud_.X, surface_points_, 2.5 * cloud_.spacing);
    scan_points_ = surface_points_;
    scan_normals_ = surface_normals_;
  }
  if (options_.task.empty()) options_.task = defaultTaskFor(shape_.name);
  config_ = TaskConfig::load(options_.task, options_.task_dir);
  if (options_.undamped && config_.has("contact_damping_ratio")) config_.setNumber("contact_damping_ratio", 0.0);
  for (const auto& a : options_.overrides) config_.setAssignment(a, "rig twin set");
  if (options_.surface_file.empty()) {
    // Rocking about a horizontal lattice axis, the motion is its own mirror image across the vertical
    // plane normal to that axis.
    int mirror_axis = -1;
    if (config_.has("rocking_axis")) {
      const Eigen::Vector3d a = config_.vector3("rocking_axis").cwiseAbs();
      for (int k = 0; k < 2; ++k)
        if (a[k] > 0 && a[k] >= (1 - 1e-12) * a.norm()) mirror_axis = k;
    }
    cloud_.contact = exactShapeContactSamples(shape_, cloud_, options_.contact_spacing_m, mirror_axis);
  }
  const RigTwinMotion& replay = twinMotion(config_.task());
  if (replay.fallback_duration_s > 0 && !(config_.number(replay.duration_parameter) > 0))
    config_.setNumber(replay.duration_parameter, replay.fallback_duration_s);

  Eigen::VectorXd theta = options_.interior_quadric;
  if (theta.size() == 0) theta = defaultInteriorQuadric(config_.task());
  if (theta.size() != 10 || !theta.allFinite())
    throw TopoError(
        "rig twin interior quadric",
        "must be 10 finite numbers [a_xx a_yy a_zz a_xy a_xz a_yz b_x b_y b_z c] (got " + std::to_string(theta.size()) +
            ")",
        "give θ of s(u) = uᵀAu + bᵀu + c in normalised coordinates, or leave it empty for the default cavity");
  options_.interior_quadric = theta;
  TaskConfig quadric = config_;
  quadric.set("representation", "quadric", "rig twin");

  // Truth: the task exactly as configured.
  try {
    const InteriorProblem problem(quadric, cloud_);
    problem.indicator(theta, &r_);
    truth_ = problem.evaluateIndicator(r_, nullptr);
    std::vector<double> m;
    problem.task().masses(r_, &m, nullptr);
    density_.resize(m.size());
    for (std::size_t i = 0; i < m.size(); ++i) density_[i] = m[i] / cloud_.V[i];
  } catch (const TopoError& e) {
    throw TopoError(std::string("rig twin: simulating the true interior of the ") + shape_.name + " (" +
                    config_.task() + " task) failed: " + e.what());
  }
  if (replay.hangs) restAtHangingPose(&quadric);
  const Feature* period = findFeature(truth_, replay.period_feature);
  if (!period || !(period->value > 0))
    throw TopoError("rig twin: the true interior of the " + shape_.name,
                    "produces no oscillation period (" + replay.period_feature + ") in " +
                        config_.valueText(replay.duration_parameter),
                    "raise " + replay.duration_parameter + " or choose an interior that oscillates (e.g. the default)");

  // The loop: a longer run of the same motion when the configured one is too short.
  const double need_s = (options_.loop_cycles + 1.5) * period->value;
  if (need_s > config_.number(replay.duration_parameter)) {
    TaskConfig longer = quadric;
    longer.setNumber(replay.duration_parameter, need_s);
    try {
      buildLoop(InteriorProblem(longer, cloud_).evaluateIndicator(r_, nullptr).task, period->value);
    } catch (const TopoError& e) {
      throw TopoError(std::string("rig twin: the ") + numberText(need_s) + " s loop simulation of the " + shape_.name +
                      " failed: " + e.what());
    }
  } else {
    buildLoop(truth_.task, period->value);
  }
  simulation_s_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

double RigTwin::feature(const std::string& name) const {
  if (const Feature* f = findFeature(truth_, name)) return f->value;
  std::string names;
  for (const auto& f : truth_.task.features) names += (names.empty() ? "" : ", ") + f.name;
  throw TopoError("rig twin feature '" + name + "'", "is not a feature of the " + config_.task() + " task",
                  "use one of " + names);
}

void RigTwin::restAtHangingPose(TaskConfig* quadric) {
  try {
    const TaskGeometry g = InteriorProblem(*quadric, cloud_).task().geometry();
    if (!g.has_point || !(g.gravity.normalized().z() < -0.999999)) return;  // the rest pose needs gravity along −z
    const RollPitch rest = hangingRestPose(truth_.task.mass.com, g.point);
    for (TaskConfig* c : {&config_, quadric}) {
      c->setNumber("target_roll_deg", rest.roll_deg);
      c->setNumber("target_pitch_deg", rest.pitch_deg);
    }
    truth_ = InteriorProblem(*quadric, cloud_).evaluateIndicator(r_, nullptr);
  } catch (const TopoError& e) {
    throw TopoError(std::string("rig twin: hanging the true interior of the ") + shape_.name +
                    " at rest failed: " + e.what());
  }
}

void RigTwin::buildLoop(const TaskEvaluation& run, double period_s) {
  const std::vector<double>& y = run.signal;
  const std::vector<double>& t = run.signal_time_s;
  if (y.size() < 5 || t.size() != y.size() || run.motion.size() != y.size())
    throw TopoError("rig twin: the " + config_.task() + " simulation", "returned no sampled motion to replay",
                    "this task cannot drive the twin; use one of " + twinTaskList());
  // Released at rest: the first sample is a turning point; the equilibrium is about the mean of a
  // (nearly undamped) oscillation. Release-side turning points are the local extrema on that side
  // beyond half the release amplitude, one per period (contact jitter merges into the larger one).
  double eq = 0;
  for (double v : y) eq += v / static_cast<double>(y.size());
  const double side = y[0] >= eq ? 1.0 : -1.0;  // +1: released on the high side
  const double a0 = side * (y[0] - eq);
  if (!(a0 > 0))
    throw TopoError("rig twin: the " + config_.task() + " motion", "does not swing (amplitude 0)",
                    "release it off its equilibrium (initial_tilt_deg / swing_tilt_deg)");
  struct Turn {
    double t, amplitude;
  };
  std::vector<Turn> turns;  // release-side turning points after the release
  for (std::size_t k = 1; k + 1 < y.size(); ++k) {
    const double a = side * (y[k - 1] - eq), b = side * (y[k] - eq), c = side * (y[k + 1] - eq);
    if (!(b >= a && b > c && b > 0.5 * a0) || t[k] < 0.5 * period_s) continue;
    const double den = a - 2 * b + c;
    const double delta = std::abs(den) > 1e-300 ? 0.5 * (a - c) / den : 0.0;
    const Turn turn{t[k] + delta * (t[k + 1] - t[k]), b - 0.25 * (a - c) * delta};
    if (!turns.empty() && turn.t - turns.back().t < 0.5 * period_s) {
      if (turn.amplitude > turns.back().amplitude) turns.back() = turn;
      continue;
    }
    turns.push_back(turn);
  }
  if (turns.empty())
    throw TopoError("rig twin: the " + config_.task() + " motion", "never returns to its release side",
                    "check the interior: the object must oscillate about a stable equilibrium");
  // The last turning point that returns to the release state within 0.5 % of the amplitude in angle
  // and 0.2 spacings in position; else the one with the smallest jump. Every swing of the loop then
  // reaches at least 99.5 % of the release amplitude, so a tracker window that misses the seam still
  // sees the maximum tilt within 0.5 %.
  motion_ = run.motion;
  if (twinMotion(config_.task()).hangs && !surface_points_.empty()) {
    // held with its lowest point 5 mm above the table (z = 0), where the rig's camera looks
    double z_min = 1e300;
    for (const auto& x : surface_points_)
      z_min = std::min(z_min, (motion_.front().rotation * x + motion_.front().translation).z());
    const Eigen::Vector3d lift(0, 0, kHangingClearanceM - z_min);
    for (auto& p : motion_) p.translation += lift;
  }
  const BodyPose& p0 = motion_.front();
  const double tol_rot = std::max(0.005 * a0, 0.01), tol_pos = 0.2 * cloud_.spacing;
  int chosen = -1, best = 0;
  double best_score = 1e300;
  std::vector<double> rot(turns.size()), pos(turns.size());
  for (std::size_t j = 0; j < turns.size(); ++j) {
    const BodyPose p = inference::poseAt(motion_, turns[j].t);
    rot[j] = rotationDeg(p.rotation, p0.rotation);
    pos[j] = (p.translation - p0.translation).norm();
    if (rot[j] <= tol_rot && pos[j] <= tol_pos) chosen = static_cast<int>(j);
    const double score = rot[j] / tol_rot + pos[j] / tol_pos;
    if (score < best_score) best_score = score, best = static_cast<int>(j);
  }
  if (chosen < 0) chosen = best;
  loop_s_ = turns[chosen].t;
  loop_periods_ = chosen + 1;
  seam_rotation_deg_ = rot[chosen];
  seam_translation_m_ = pos[chosen];
  decay_per_cycle_ = (1.0 - turns.back().amplitude / a0) / static_cast<double>(turns.size());
  loop_signal_.clear();
  loop_time_.clear();
  for (std::size_t k = 0; k < y.size() && t[k] <= loop_s_; ++k) {
    loop_time_.push_back(t[k]);
    loop_signal_.push_back(y[k]);
  }
}

void RigTwin::buildSurface() {
  projectSurfaceOntoShape(shape_, &cloud_, &surface_points_, &surface_normals_);
  if (options_.scan_spacing_m > 0 && options_.scan_spacing_m != cloud_.spacing) {
    VolumeCloud scan;
    try {
      scan = defaultShapeCloud(shape_, options_.scan_spacing_m);
    } catch (const TopoError& e) {
      throw TopoError(std::string("rig twin scan spacing: ") + e.what());
    }
    projectSurfaceOntoShape(shape_, &scan, &scan_points_, &scan_normals_);
  } else {
    scan_points_ = surface_points_;
    scan_normals_ = surface_normals_;
  }
}

BodyPose RigTwin::poseAt(double t_s) const {
  double tau = t_s > 0 && std::isfinite(t_s) ? std::fmod(t_s, loop_s_) : 0.0;
  BodyPose p = inference::poseAt(motion_, tau);
  p.t = t_s;
  return p;
}

}  // namespace topo_gaussian::workflow
