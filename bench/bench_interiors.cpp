// Interiors against ground truth that is not the inference's own lattice.
//
// Every case is an object (a shared mesh read where it lies, or a generated shape) with a known
// interior: a geometric solid R in metres (sphere, ellipsoid, box or half-space) of a second
// material (an off-centre cavity, a heavy insert, the hollow of a shell, the light part of a
// two-material body), the rest of the body solid:
//   ρ(x) = density_hollow for x ∈ R, density_solid elsewhere (the task's two materials, r = 0 ↔ R).
// The reference observations come from a FINER simulation: the surface filled as `topo fill` does
// (geometry/ingest.h) at half the default spacing, with the true-surface contact samples of that
// fill, and R rasterised on that finer lattice as the inside fraction of each cell (4³ samples per
// cell, so a cell cut by ∂R carries its exact share to ~1 %). The true moments (m, c, I) are those
// of the fine lattice. Noise (seeded per case, std::mt19937): hanging angles ± N(0, 0.05°), rocking
// period × (1 + N(0, 0.1 %)), maximum tilt ± N(0, 0.05°). The object is weighed once, as a lab does
// (rigid motion alone never fixes the mass): the first hanging experiment carries the target mass_kg,
// the true mass × (1 + N(0, 0.1 %)) from its own generator; the quadric then starts from a region of
// the other material with that mass (InteriorProblem::weighedCavityStart: the volume's equivalent
// ellipsoid scaled, or a sphere with --weighed-start sphere). --unweighed leaves it out.
// Every hang is also timed swinging on a horizontal axle through its point, along world x and then y, in
// the pose it rests in (the compound-pendulum method; hanging's axle_swing_period_s and
// cross_axle_swing_period_s: 2π √(I_a/(m g d)) with the elliptic amplitude correction, exact for a rigid
// body on a hinge), evaluated on the fine reference, × (1 + N(0, 0.1 %)) from a third generator:
// rigid poses fix m and c only, the swings the inertia. --no-swings leaves them out.
//
// The inference runs at the user's default resolution (topo fill defaults: ~50k particles; --quick:
// ~6k), default settings apart from the representation stated per case, on 2–3 experiments. A
// fourth, held out, is only predicted: the design the inference returns against the fine reference.
//
// Per case: IoU of the true and recovered solid region and of R itself (on the inference's
// particles, by volume: true = inside fractions, recovered = r ≥ 0.5), mass / CoM / inertia errors
// against the fine reference (CoM: |Δc| over the bounding-box diagonal, and over the shift the
// interior causes, |c_true − c_plain| with c_plain the body all of its other material), and the
// held-out prediction error; beside them the same errors of the body all of its other material
// (fully solid, or the body material alone for a heavy insert: the unweighed start, the baseline of the
// same run), and in the JSON those of the design the optimiser started from (`start`). One JSON line per case, a
// table, and one PNG per case (true over recovered slices) in the output folder.
//
// Usage: bench_interiors [--quick] [--check] [--unweighed] [--no-swings] [--weighed-start sphere|ellipsoid]
//                       [--max-evaluations N] [--restarts N] [--out DIR] [CASE_SUBSTRING]
//   [--world ours|peer]
//   --world peer: the reference observations come from the peer world instead of the finer simulation
//   (interiors/peer_reference.h: exact mass moments of the true mesh and region, closed-form hangs and axle
//   swings, Bullet's rocking seen through an independent renderer and the tracker); the held-out
//   experiment is then a hang's axle swing (closed form) or a rocking period (Bullet).
//   --check: exit 1 when a case's mass or inertia error, or its held-out error, exceeds the
//   tolerances below (the quick mode's test in `make test`).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <functional>
#include <opencv2/core.hpp>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/json.h"
#include "topo_gaussian/common/number_text.h"
#include "topo_gaussian/geometry/cleaning.h"
#include "topo_gaussian/geometry/ingest.h"
#include "topo_gaussian/geometry/shape_generator.h"
#include "topo_gaussian/geometry/surface_reader.h"
#include "topo_gaussian/inference/interior_problem.h"
#include "topo_gaussian/inference/motion_targets.h"
#include "topo_gaussian/inference/oscillation.h"
#include "topo_gaussian/inference/pipeline.h"
#include "topo_gaussian/inference/region_uncertainty.h"
#include "topo_gaussian/vision/figure.h"
#include "topo_gaussian/vision/motion_features.h"
#include "topo_gaussian/vision/slice_picture.h"
#include "topo_gaussian/workflow/motion_video.h"
#ifdef TOPO_HAVE_PEER_WORLD
#include "interiors/peer_reference.h"
#endif

using namespace topo_gaussian;
using namespace topo_gaussian::inference;
using Clock = std::chrono::steady_clock;
using Eigen::Vector3d;

namespace {

// The goal for every case: mass, inertia and the held-out prediction within 2 %.
constexpr double kGoal = 0.02;

// Noise of the reference observations (documented above).
// --noise K multiplies every noise below (and the video's pixel noise) by K: 0 gives exact observations,
// which separates what the noise leaves open from what the model and the optimiser do.
double g_noise = 1.0;
constexpr double kAngleNoiseDeg = 0.05;
constexpr double kPeriodNoiseRel = 0.001;
// The object on a lab balance: its mass × (1 + N(0, 0.1 %)), from its own generator (seed + 1000), so
// the other observations' noise is the same with and without it.
constexpr double kScaleNoiseRel = 0.001;
bool g_weigh = true;  // --unweighed: no scale reading
// Every hang is also timed swinging on a horizontal axle through its point, along world x and then along
// y (hanging's axle_swing_period_s, cross_axle_swing_period_s: the compound-pendulum method), each period
// × (1 + N(0, kPeriodNoiseRel)) from its own generator (seed + 2000). --no-swings: the hangs' poses only.
bool g_swing = true;
// --no-video: the tumbler cases' observations as numbers (the reference's features with noise) instead of
// through rendered video and the tracker, to tell the tracker's error from the inference's.
bool g_video = true;
bool g_peer = false;         // --world peer
std::string g_frames_dir;    // --frames DIR: the peer world's rendered frames as PNGs, a folder per experiment
std::string g_weighed_start;  // --weighed-start sphere|ellipsoid (empty: the task default)
std::string g_quadric_field;  // --quadric-field auto|algebraic|distance (empty: the task default)

double seconds(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

/// The true region R of the second material, a geometric solid in the object's frame [m].
struct Region {
  enum Kind { Sphere, Ellipsoid, Box, HalfSpace } kind = Sphere;
  Vector3d centre = Vector3d::Zero();
  Vector3d half = Vector3d::Zero();     ///< radius (x), semi-axes, or half edges [m]
  Vector3d normal = Vector3d::UnitX();  ///< HalfSpace: R = {x : n·(x − centre) > 0}
  bool inside(const Vector3d& x) const {
    const Vector3d d = x - centre;
    switch (kind) {
      case Sphere:
        return d.norm() < half.x();
      case Ellipsoid:
        return d.cwiseQuotient(half).squaredNorm() < 1.0;
      case Box:
        return (d.cwiseAbs() - half).maxCoeff() < 0.0;
      case HalfSpace:
        return normal.dot(d) > 0.0;
    }
    return false;
  }
  std::string text() const {
    char b[200];
    const char* names[] = {"sphere", "ellipsoid", "box", "half-space"};
    if (kind == HalfSpace)
      std::snprintf(b, sizeof b, "%s n=(%.2f,%.2f,%.2f) through (%.4f,%.4f,%.4f) m", names[kind], normal.x(),
                    normal.y(), normal.z(), centre.x(), centre.y(), centre.z());
    else
      std::snprintf(b, sizeof b, "%s at (%.4f,%.4f,%.4f) m, half (%.4f,%.4f,%.4f) m", names[kind], centre.x(),
                    centre.y(), centre.z(), half.x(), half.y(), half.z());
    return b;
  }
};

/// Solid fraction t_i = 1 − |cell_i ∩ R| / |cell_i| (n³ samples of the cube of side h around X_i).
std::vector<double> solidFraction(const VolumeCloud& c, const Region& R, int n) {
  std::vector<double> t(c.size(), 1.0);
  const double h = c.spacing;
#pragma omp parallel for schedule(static)
  for (long i = 0; i < static_cast<long>(c.size()); ++i) {
    int in = 0;
    for (int a = 0; a < n; ++a)
      for (int b = 0; b < n; ++b)
        for (int k = 0; k < n; ++k)
          in += R.inside(c.X[i] + h * Vector3d((a + 0.5) / n - 0.5, (b + 0.5) / n - 0.5, (k + 0.5) / n - 0.5));
    t[i] = 1.0 - static_cast<double>(in) / (n * n * n);
  }
  return t;
}

/// One experiment: hang from a point (static pose; optionally swinging, for a held-out prediction)
/// or rock on the ground about an axis.
struct ExperimentSpec {
  std::string name;
  std::string task;  ///< "hanging" | "tumbler"
  Vector3d where;    ///< hanging: point as fractions of the bounding box; tumbler: rocking axis
  double tilt_deg = 10.0;
};

struct CaseSpec {
  std::string name, object, interior;
  std::function<geometry::SurfaceData()> surface;  ///< generated shapes
  /// The peer world's true object when it is finer than the surface the user fills (a smooth body:
  /// Bullet rolls a finely faceted hull as it rolls the smooth one; a coarse hull's facets knock energy out
  /// of every rocking swing).
  std::function<geometry::SurfaceData()> peer_surface;
  std::string path;                                // shared meshes (read where they lie)
  double scale = 1.0;
  std::string up_axis = "z";
  /// The region from the coarse cloud (its bounds, its surface particles): geometric, in metres.
  std::function<Region(const VolumeCloud&)> region;
  double density_solid = 1000, density_hollow = 0;
  /// true: R is the solid (denser) material and the body around it the other (a heavy insert: the
  /// density model needs density_solid ≥ density_hollow, so the insert is the solid, r = 1 in R).
  bool region_is_solid = false;
  /// Start design's field s (initial_field; NAN: the default 0.3, fully solid). A heavy insert is the
  /// solid material, so its cases start from the body material alone (−0.3: r ≈ 0.002 everywhere).
  double initial_field = NAN;
  std::string representation = "quadric";
  bool pin_shell = true;
  std::vector<ExperimentSpec> experiments;
  ExperimentSpec held_out;
  bool quick = false;  ///< part of --quick
  /// The rocking experiments are observed as a lab does: the reference motion rendered by the rig
  /// camera and measured by the motion tracker (workflow/motion_video.h), targets by the task's rule
  /// (inference/motion_targets.h), instead of the simulator's numbers with noise.
  bool video = false;
  /// --check bounds: the goals (2 %) unless a case states why it cannot meet one today; such a
  /// bound is a regression guard, and the table still says "missed" against the 2 % goal.
  double check_mass = kGoal, check_inertia = kGoal, check_held_out = kGoal;
  std::string check_note;
};

Vector3d boundsPoint(const VolumeCloud& c, const Vector3d& f) {
  Vector3d lo, hi;
  c.bounds(&lo, &hi);
  return lo + f.cwiseProduct(hi - lo);
}

/// Largest sphere radius at `centre` that stays two spacings clear of every surface particle.
double clearance(const VolumeCloud& c, const Vector3d& centre) {
  double d = 1e300;
  for (std::size_t i = 0; i < c.size(); ++i)
    if (c.surface[i]) d = std::min(d, (c.X[i] - centre).norm());
  return d - 2.0 * c.spacing;
}

/// A sphere of radius min(want, clearance) around the centroid moved by f × the bounding box's extent.
std::function<Region(const VolumeCloud&)> sphereAt(const Vector3d& f, double want_m) {
  return [f, want_m](const VolumeCloud& c) {
    Region R;
    R.kind = Region::Sphere;
    Vector3d lo, hi;
    c.bounds(&lo, &hi);
    R.centre = c.centroid() + f.cwiseProduct(hi - lo);
    R.half = Vector3d::Constant(std::min(want_m, clearance(c, R.centre)));
    if (R.half.x() <= 0) throw TopoError("bench case region", "has no room inside the object", "move its centre");
    return R;
  };
}

const Feature* findFeature(const TaskEvaluation& ev, const std::string& name) {
  for (const auto& f : ev.features)
    if (f.name == name) return &f;
  return nullptr;
}

double featureValue(const TaskEvaluation& ev, const std::string& name) {
  const Feature* f = findFeature(ev, name);
  if (!f) throw TopoError("simulated features", "have no " + name, "check the experiment's task");
  return f->value;
}

/// Roll and pitch (targetRotation) that bring c − p onto −z: the pose of the body hung at p.
void hangingPose(const Vector3d& d, double* roll_deg, double* pitch_deg) {
  const double roll = std::atan2(-d.y(), -d.z());
  const double n = std::hypot(d.y(), d.z());
  *roll_deg = roll * 180.0 / M_PI;
  *pitch_deg = std::atan2(d.x(), n) * 180.0 / M_PI;
}

// max_evaluations: the task default (200, with its stall rule) in the full bench: fewer (60) stop the
// steel-ball tumbler while its loss is still falling (it converges at ~150 evaluations). --quick: 25.
int g_max_evaluations = 0;  // --max-evaluations N (old name --max-iterations; 0: the task default); --quick: 25
// restarts of the design spread (inference/design_spread.h): 0 by default (the region's uncertainty
// comes from inference/region_uncertainty.h, seconds a case; the spread's two restarts make the full
// bench about three times as long); --restarts 2 for the task default.
int g_restarts = 0;  // --restarts N; -1 = the task default

void setShared(TaskConfig& c, const CaseSpec& s) {
  c.set("representation", s.representation);
  bool rocks = false;
  for (const auto& e : s.experiments) rocks = rocks || e.task != "hanging";
  if (g_max_evaluations > 0 && rocks) c.setNumber("max_evaluations", g_max_evaluations);
  if (g_restarts >= 0) c.setNumber("restarts", g_restarts);
  if (std::isfinite(s.initial_field)) c.setNumber("initial_field", s.initial_field);
  c.setNumber("density_solid", s.density_solid);
  c.setNumber("density_hollow", s.density_hollow);
  c.set("pin_shell", s.pin_shell ? "true" : "false");
  if (!g_weighed_start.empty()) c.set("weighed_start", g_weighed_start);
  if (!g_quadric_field.empty()) c.set("quadric_field", g_quadric_field);
}

/// The experiment's config without targets (hanging point / rocking axis from the spec).
TaskConfig experimentConfig(const CaseSpec& s, const ExperimentSpec& e, const VolumeCloud& coarse, bool swing) {
  TaskConfig c = TaskConfig::defaults(e.task);
  setShared(c, s);
  if (e.task == "hanging") {
    c.setVector("hanging_point", boundsPoint(coarse, e.where));
    if (swing) {
      c.setNumber("swing_duration_s", 3.0);
      c.setNumber("swing_tilt_deg", 5.0);
    }
  } else {
    c.setVector("rocking_axis", e.where.normalized());
    c.setNumber("initial_tilt_deg", e.tilt_deg);
  }
  return c;
}

/// Sets the experiment's targets from the reference evaluation `ref` (with noise when rng != null).
void setTargets(TaskConfig& c, const ExperimentSpec& e, const TaskEvaluation& ref, std::mt19937* rng) {
  std::normal_distribution<double> N(0.0, 1.0);
  auto noise = [&](double sigma) { return rng ? g_noise * sigma * N(*rng) : 0.0; };
  if (e.task == "hanging") {
    double roll, pitch;
    hangingPose(ref.mass.com - c.vector3("hanging_point"), &roll, &pitch);
    c.setNumber("target_roll_deg", roll + noise(kAngleNoiseDeg));
    c.setNumber("target_pitch_deg", pitch + noise(kAngleNoiseDeg));
  } else {
    c.setNumber("period_s", featureValue(ref, "period_s") * (1.0 + noise(kPeriodNoiseRel)));
    c.setNumber("max_tilt_deg", featureValue(ref, "max_tilt_deg") + noise(kAngleNoiseDeg));
  }
}

/// The held-out experiment's predicted feature: swing period (hanging) or rocking period (tumbler).
/// The held-out experiment's predicted feature: swing period (hanging, simulated: released 5° about
/// world x off the true hanging pose) or rocking period (tumbler).
std::string heldOutFeature(const ExperimentSpec& e) { return e.task == "hanging" ? "swing_period_s" : "period_s"; }

struct Errors {
  double mass = 0, com_size = 0, com_shift = 0, inertia = 0, held_out = 0;
};

Errors errorsOf(const MassProperties& m, const MassProperties& truth, const MassProperties& full, double diag,
                double held, double held_truth) {
  Errors e;
  e.mass = std::abs(m.mass - truth.mass) / truth.mass;
  e.com_size = (m.com - truth.com).norm() / diag;
  const double shift = (truth.com - full.com).norm();
  e.com_shift = shift > 0 ? (m.com - truth.com).norm() / shift : 0.0;
  e.inertia = (m.inertia - truth.inertia).norm() / truth.inertia.norm();
  e.held_out = std::abs(held - held_truth) / std::abs(held_truth);
  return e;
}

/// An experiment seen through video, as a lab sees it: the reference motion on the fine cloud (a
/// rocking: 4 s from the release; a hang: a 4 s swing released 3° about world x off its rest pose),
/// its contact samples (the true surface, thinned to ≤ 20 000) rendered at 60 frames/s by the rig
/// camera along −x with 2 grey levels of pixel noise, tracked, and the task's targets taken from the
/// tracker's features by the task's rule (rocking: period, max tilt, amplitude, rest tilt; hanging:
/// the roll, the angle that camera sees; the pitch stays the numbers' one). For a hang the tracker is
/// told the rest roll to the nearest 10° (what the operator sees; a silhouette's axes are known only
/// modulo 90°). A hang resting pitched more than 10° (about y) is not seen by that camera and stays
/// numbers. The reference's own values beside them for the report.
struct VideoObservation {
  int frames = 0;
  double render_ms = 0, tracked_period_s = NAN, tracked_max_tilt_deg = NAN, tracked_rest_roll_deg = NAN;
  double reference_period_s = NAN, reference_max_tilt_deg = NAN, reference_rest_roll_deg = NAN;
  /// Rocking: |tracked tilt| − |reference tilt| over the frames [deg], and the reference clip's period and
  /// largest tilt by the task's rule at the frame rate (an exact tracker's targets).
  double tilt_error_mean_deg = NAN, tilt_error_max_deg = NAN, clip_period_s = NAN, clip_max_tilt_deg = NAN;
  std::string targets, note;
};

VideoObservation observeThroughVideo(TaskConfig& c, const VolumeCloud& fine, const std::vector<double>& r_fine) {
  VideoObservation v;
  const bool hang = c.task() == "hanging";
  TaskConfig clip = c;
  if (hang) {
    clip.setNumber("swing_duration_s", 4.0);
    clip.setNumber("swing_tilt_deg", 3.0);
  } else {
    clip.setNumber("duration_s", 4.0);  // a longer clip than the task's own simulation
  }
  const ProblemEvaluation ref = simulateInterior(clip, fine, r_fine);
  if (ref.task.motion.empty()) throw TopoError("video observation", "the reference has no motion", "use a rigid task");
  workflow::MotionVideoOptions o;
  if (hang) {
    double pitch;
    hangingPose(ref.task.mass.com - c.vector3("hanging_point"), &v.reference_rest_roll_deg, &pitch);
    o.tilt_reference_deg = 10.0 * std::round(v.reference_rest_roll_deg / 10.0);
  } else {
    v.reference_period_s = featureValue(simulateInterior(c, fine, r_fine).task, "period_s");
    v.reference_max_tilt_deg = featureValue(ref.task, "max_tilt_deg");
  }
  const std::size_t stride = std::max<std::size_t>(1, fine.contact.size() / 20000);
  std::vector<Vector3d> P, N;
  for (std::size_t i = 0; i < fine.contact.size(); i += stride) {
    P.push_back(fine.contact.X[i]);
    N.push_back(fine.contact.normal[i]);
  }
  const auto& motion = ref.task.motion;
  const BodyPose p0 = motion.front();
  const Vector3d target = p0.rotation * fine.centroid() + p0.translation;
  o.fps = 60.0;
  const double fps_used = o.fps;
  o.start_s = p0.t;
  o.duration_s = motion.back().t - p0.t;
  o.splat_radius_m = 0.8 * fine.contact.spacing * std::sqrt(double(stride));
  o.render_ms = &v.render_ms;
  o.noise_sigma *= g_noise;
  const vision::TrackResult track = workflow::trackRenderedMotion(
      P, N, [&](double t) { return poseAt(motion, t); }, workflow::rigCameraAlongX(target), o);
  v.frames = track.frames_used;
  const motion::MotionFeatures f = vision::toMotionFeatures(track);
  v.tracked_period_s = f.period_s;
  if (hang)
    v.tracked_rest_roll_deg = f.equilibrium_deg;
  else
    v.tracked_max_tilt_deg = f.max_tilt_deg;
  if (!hang) {
    // The tracker against the reference clip at the frames' times: the error of the tilt's magnitude (a
    // camera on the other side mirrors the sign), and the clip's own features by the task's rule at the
    // frame rate (what an exact tracker would give).
    const auto& ts = ref.task.signal_time_s;
    const auto& ys = ref.task.signal;
    const auto at = [&](double t, double* y) {  // the reference's tilt at t (linear), false outside
      const std::size_t j = std::upper_bound(ts.begin(), ts.end(), t) - ts.begin();
      if (j == 0 || j >= ts.size()) return false;
      const double w = (t - ts[j - 1]) / (ts[j] - ts[j - 1]);
      *y = (1 - w) * ys[j - 1] + w * ys[j];
      return true;
    };
    // The tracker's frames (times from its first frame, the clip's start; rendered frames are not lost).
    double sum = 0, y = 0;
    int count = 0;
    for (std::size_t k = 0; k < f.time_s.size(); ++k) {
      if (!at(ts.front() + (f.time_s[k] - f.time_s.front()), &y)) break;
      const double e = std::abs(f.angle_deg[k]) - std::abs(y);
      sum += e;
      ++count;
      v.tilt_error_max_deg = std::max(std::isfinite(v.tilt_error_max_deg) ? v.tilt_error_max_deg : 0.0, std::abs(e));
    }
    if (count > 0) v.tilt_error_mean_deg = sum / count;
    // The clip sampled at the frame rate on its own (uniform, released at rest), by the task's rule.
    std::vector<double> y_frames;
    for (int k = 0; at(ts.front() + k / fps_used, &y); ++k) y_frames.push_back(y);
    const int cycles = c.has("measured_cycles") ? c.integer("measured_cycles") : 2;
    const auto clip_features = analyseOscillation(y_frames, 0.0, 1.0 / fps_used, cycles, true);
    if (clip_features.valid) v.clip_period_s = clip_features.period, v.clip_max_tilt_deg = clip_features.max_abs;
  }
  const MotionTargets mt = targetsFromMotion(c, f);
  for (const auto& [name, value] : mt.targets) {
    c.setNumber(name, value);
    v.targets += (v.targets.empty() ? "" : ", ") + name + " " + numberText(value, 6);
  }
  v.note = mt.note;
  if (mt.targets.empty())
    throw TopoError("video observation of experiment (" + c.task() + ")",
                    "gave no targets: " + mt.note + " " + track.message, "check the camera and the clip");
  return v;
}

/// {"key": value, ...} from values already in JSON.
std::string jsonObject(std::initializer_list<std::pair<const char*, std::string>> fields) {
  std::string out;
  for (const auto& [key, value] : fields) out += (out.empty() ? "{" : ", ") + json::quote(key) + ": " + value;
  return out + "}";
}

#ifdef TOPO_HAVE_PEER_WORLD
/// The object's true mesh in the frame `topo fill` gives its cloud (the same reading, up axis and scale).
geometry::SurfaceData trueMesh(const CaseSpec& s) {
  geometry::SurfaceData m = s.peer_surface ? s.peer_surface() : s.path.empty() ? s.surface() : geometry::readSurface(s.path);
  geometry::applyUpAxis(m, s.up_axis);
  geometry::CleanOptions clean;
  clean.scale = s.scale;
  geometry::cleanSurface(m, clean);
  return m;
}

bench::PeerObject peerObject(const CaseSpec& s, const Region& R) {
  bench::PeerRegion p;
  p.kind = static_cast<bench::PeerRegion::Kind>(R.kind);
  p.centre = R.centre;
  p.half = R.half;
  p.normal = R.normal;
  return s.region_is_solid ? bench::makePeerObject(trueMesh(s), p, s.density_hollow, s.density_solid)
                           : bench::makePeerObject(trueMesh(s), p, s.density_solid, s.density_hollow);
}

/// A hang's axle swing in the peer world: the body at rest (c below the point), the axle along world x
/// (psi = 0) or y (psi = 90°), as the hanging task names them, by the closed form of peer_reference.h.
double peerAxlePeriod(const TaskConfig& c, const MassProperties& truth, double psi_deg) {
  const Vector3d p = c.vector3("hanging_point");
  const RollPitch rest = hangingRestPose(truth.com, p);
  const Eigen::Matrix3d R = targetRotation(rest.roll_deg, rest.pitch_deg);
  const double psi = (c.number("axle_heading_deg") + psi_deg) * M_PI / 180.0;
  const Vector3d axle = R.transpose() * Vector3d(std::cos(psi), std::sin(psi), 0.0);
  return bench::axleSwingPeriod(truth, p, axle, c.number("axle_swing_amplitude_deg"), c.vector3("gravity").norm());
}
#endif

struct CaseResult {
  std::string name;
  std::size_t particles = 0;
  double iou_solid = 0, iou_region = 0, seconds = 0, loss_truth = NAN;
  double iou_expected = NAN;  ///< the inference's own region uncertainty: IoU expected of designs that fit
  double iou_p10 = NAN, iou_p90 = NAN;  ///< its 10–90 % band, where the true region's IoU should lie
  bool called_determined = false;       ///< the region analysis calls the region determined (mean ≥ 0.9)
  Errors rec, base, start;    ///< recovered; the body alone (unweighed start); the optimiser's start
  Errors truth_lattice;       ///< the true interior on the inference's lattice (the lattice's own error)
  bool pass = true;           ///< within the case's --check bounds
  bool goal = true;           ///< mass, inertia and held out within 2 %
};

geometry::IngestResult fill(const CaseSpec& s, double spacing_m, std::size_t target_count) {
  geometry::IngestOptions o;
  o.up_axis = s.up_axis;
  o.clean.scale = s.scale;
  o.fill.spacing_m = spacing_m;
  o.fill.target_count = target_count;
  if (!s.path.empty()) return geometry::ingestFile(s.path, o);
  geometry::SurfaceData surface = s.surface();
  return geometry::ingestSurface(surface, o);
}

CaseResult runCase(const CaseSpec& s, bool quick, unsigned seed, const std::string& out_dir) {
  const auto t0 = Clock::now();
  CaseResult out;
  out.name = s.name;
  // The user's resolution (topo fill defaults), and the reference at half its spacing.
  const std::size_t count = quick ? 6000 : geometry::FillOptions().target_count;
  const geometry::IngestResult coarse_fill = fill(s, 0.0, count);
  const VolumeCloud& coarse = coarse_fill.cloud;
  // The peer world needs no finer fill: its references are exact or Bullet's.
  const geometry::IngestResult fine_fill = g_peer ? geometry::IngestResult{} : fill(s, coarse.spacing / 2.0, count);
  const VolumeCloud& fine = fine_fill.cloud;
  std::fprintf(stderr, "[%s] fills: %zu + %zu particles, %.1f s\n", s.name.c_str(), coarse.size(), fine.size(),
               seconds(t0));
  const Region R = s.region(coarse);
#ifdef TOPO_HAVE_PEER_WORLD
  std::optional<bench::PeerObject> peer;
  if (g_peer) {
    peer = peerObject(s, R);
    std::fprintf(stderr, "[%s] peer world: exact mass %.6g kg, centre of mass (%.5f, %.5f, %.5f) m\n", s.name.c_str(),
                 peer->truth.mass, peer->truth.com.x(), peer->truth.com.y(), peer->truth.com.z());
  }
#endif
  std::vector<double> r_fine = solidFraction(fine, R, 4);
  std::vector<double> t_coarse = solidFraction(coarse, R, 4);
  if (s.region_is_solid) {
    for (double& v : r_fine) v = 1.0 - v;
    for (double& v : t_coarse) v = 1.0 - v;
  }
  Vector3d lo, hi;
  coarse.bounds(&lo, &hi);
  const double diag = (hi - lo).norm();

  // Reference (fine) observations with noise, and the joint config of the inference.
  std::mt19937 rng(seed);
  TaskConfig joint = TaskConfig::common();
  setShared(joint, s);
  MassProperties truth;
  std::mt19937 scale_rng(seed + 1000), swing_rng(seed + 2000);
  std::string video_json;  // the experiments observed through video
  double scale_kg = NAN;
  for (const auto& e : s.experiments) {
    TaskConfig c = experimentConfig(s, e, coarse, false);
#ifdef TOPO_HAVE_PEER_WORLD
    if (peer) {
      truth = peer->truth;
      std::normal_distribution<double> N(0.0, 1.0);
      if (e.task == "hanging") {
        const RollPitch rest = hangingRestPose(truth.com, c.vector3("hanging_point"));
        c.setNumber("target_roll_deg", rest.roll_deg + g_noise * kAngleNoiseDeg * N(rng));
        c.setNumber("target_pitch_deg", rest.pitch_deg + g_noise * kAngleNoiseDeg * N(rng));
        if (g_swing) {
          c.setNumber("axle_swing_period_s",
                      peerAxlePeriod(c, truth, 0.0) * (1.0 + g_noise * kPeriodNoiseRel * N(swing_rng)));
          c.setNumber("cross_axle_swing_period_s",
                      peerAxlePeriod(c, truth, 90.0) * (1.0 + g_noise * kPeriodNoiseRel * N(swing_rng)));
        }
        if (g_weigh && !std::isfinite(scale_kg)) {
          scale_kg = truth.mass * (1.0 + g_noise * kScaleNoiseRel * N(scale_rng));
          c.setNumber("mass_kg", scale_kg);
        }
      } else {
        const bench::PeerRockingVideo v = bench::observeRockingThroughPeerVideo(
            c, *peer, 4.0, 60.0, g_noise, g_frames_dir.empty() ? "" : g_frames_dir + "/" + s.name + "_" + e.name);
        std::string targets;
        for (const auto& [name, value] : v.targets)
          targets += (targets.empty() ? "" : ", ") + name + " " + numberText(value, 6);
        std::fprintf(stderr,
                     "[%s] %s in the peer world: Bullet period %.5f s, max tilt %.3f deg; %d frames rendered (%.1f ms "
                     "each), tracked period %.5f s, max tilt %.3f deg, |tilt| off Bullet's by %+.3f deg on average (at "
                     "most %.3f): targets %s; %s\n",
                     s.name.c_str(), e.name.c_str(), v.bullet_period_s, v.bullet_max_tilt_deg, v.frames, v.render_ms,
                     v.tracked_period_s, v.tracked_max_tilt_deg, v.tilt_error_mean_deg, v.tilt_error_max_deg,
                     targets.c_str(), v.note.c_str());
        const std::string text = jsonObject({{"experiment", json::quote(e.name)},
                                             {"world", json::quote("peer")},
                                             {"frames", std::to_string(v.frames)},
                                             {"render_ms", json::num(v.render_ms)},
                                             {"bullet_period_s", json::num(v.bullet_period_s)},
                                             {"bullet_max_tilt_deg", json::num(v.bullet_max_tilt_deg)},
                                             {"tracked_period_s", json::num(v.tracked_period_s)},
                                             {"tracked_max_tilt_deg", json::num(v.tracked_max_tilt_deg)},
                                             {"tilt_error_mean_deg", json::num(v.tilt_error_mean_deg)},
                                             {"tilt_error_max_deg", json::num(v.tilt_error_max_deg)},
                                             {"targets", json::quote(targets)}});
        video_json += (video_json.empty() ? "" : ", ") + text;
      }
      joint.addExperiment(e.name, 1.0, c);
      continue;
    }
#endif
    const ProblemEvaluation ref = simulateInterior(c, fine, r_fine);
    truth = ref.task.mass;
    // A hang that rests pitched (about y) is not seen by the camera along x: it stays numbers.
    double roll = 0, pitch = 0;
    if (e.task == "hanging") hangingPose(ref.task.mass.com - c.vector3("hanging_point"), &roll, &pitch);
    if (s.video && g_video && std::abs(pitch) <= 10.0) {
      if (e.task == "hanging") setTargets(c, e, ref.task, &rng);  // the pitch; the roll comes from the video
      const VideoObservation v = observeThroughVideo(c, fine, r_fine);
      std::fprintf(stderr,
                   "[%s] %s through video: %d frames (%.1f ms each), tracked period %.5f s (reference %.5f), "
                   "max tilt %.3f deg (reference %.3f), rest roll %.3f deg (reference %.3f); the tracked |tilt| is "
                   "off the reference clip's by %+.3f deg on average (at most %.3f), the clip by the task's rule: "
                   "period %.5f s, max tilt %.3f deg: targets %s%s%s\n",
                   s.name.c_str(), e.name.c_str(), v.frames, v.render_ms, v.tracked_period_s, v.reference_period_s,
                   v.tracked_max_tilt_deg, v.reference_max_tilt_deg, v.tracked_rest_roll_deg, v.reference_rest_roll_deg,
                   v.tilt_error_mean_deg, v.tilt_error_max_deg, v.clip_period_s, v.clip_max_tilt_deg, v.targets.c_str(),
                   v.note.empty() ? "" : "; ", v.note.c_str());
      char text[1200];
      std::snprintf(text, sizeof text,
                    "{\"experiment\": %s, \"frames\": %d, \"render_ms\": %s, \"tracked_period_s\": %s, "
                    "\"reference_period_s\": %s, \"tracked_max_tilt_deg\": %s, \"reference_max_tilt_deg\": %s, "
                    "\"tracked_rest_roll_deg\": %s, \"reference_rest_roll_deg\": %s, \"tilt_error_mean_deg\": %s, "
                    "\"tilt_error_max_deg\": %s, \"clip_period_s\": %s, \"clip_max_tilt_deg\": %s, \"targets\": %s}",
                    json::quote(e.name).c_str(), v.frames, json::num(v.render_ms).c_str(),
                    json::num(v.tracked_period_s).c_str(), json::num(v.reference_period_s).c_str(),
                    json::num(v.tracked_max_tilt_deg).c_str(), json::num(v.reference_max_tilt_deg).c_str(),
                    json::num(v.tracked_rest_roll_deg).c_str(), json::num(v.reference_rest_roll_deg).c_str(),
                    json::num(v.tilt_error_mean_deg).c_str(), json::num(v.tilt_error_max_deg).c_str(),
                    json::num(v.clip_period_s).c_str(), json::num(v.clip_max_tilt_deg).c_str(),
                    json::quote(v.targets).c_str());
      video_json += (video_json.empty() ? "" : ", ") + std::string(text);
    } else {
      setTargets(c, e, ref.task, &rng);
    }
    if (g_swing && e.task == "hanging") {  // timed on two axles in the pose it rests in
      TaskConfig rest = experimentConfig(s, e, coarse, false);
      rest.setNumber("target_roll_deg", roll);
      rest.setNumber("target_pitch_deg", pitch);
      const TaskEvaluation timed = simulateInterior(rest, fine, r_fine).task;
      for (const char* name : {"axle_swing_period_s", "cross_axle_swing_period_s"})
        c.setNumber(name,
                    featureValue(timed, name) *
                        (1.0 + g_noise * kPeriodNoiseRel * std::normal_distribution<double>(0.0, 1.0)(swing_rng)));
    }
    if (g_weigh && e.task == "hanging" && !std::isfinite(scale_kg)) {  // weighed once, with the first hang
      scale_kg =
          ref.task.mass.mass * (1.0 + g_noise * kScaleNoiseRel * std::normal_distribution<double>(0.0, 1.0)(scale_rng));
      c.setNumber("mass_kg", scale_kg);
    }
    joint.addExperiment(e.name, 1.0, c);
  }
  const TaskConfig full_cfg = experimentConfig(s, s.experiments.front(), coarse, false);
  // The body without its interior (all of the other material): what |c_true − c_plain| measures against.
  MassProperties full_fine;
  TaskConfig held = experimentConfig(s, s.held_out, coarse, !g_peer);
  std::string hf = heldOutFeature(s.held_out);
  double held_truth = NAN;
  std::optional<double> swing_truth;  // the held-out swing's closed form (ours: the fine reference's)
#ifdef TOPO_HAVE_PEER_WORLD
  if (peer) {
    // Held out in the peer world: a hang's axle swing in its true rest pose (closed form), or Bullet's
    // rocking period.
    full_fine = peer->plain;
    if (s.held_out.task == "hanging") {
      const RollPitch rest = hangingRestPose(truth.com, held.vector3("hanging_point"));
      held.setNumber("target_roll_deg", rest.roll_deg);
      held.setNumber("target_pitch_deg", rest.pitch_deg);
      hf = "axle_swing_period_s";
      held_truth = peerAxlePeriod(held, truth, 0.0);
    } else {
      held_truth = bench::peerRockingPeriod(held, *peer);
    }
  }
#endif
  if (!g_peer) {
    // The body without its interior (all of the other material): what |c_true − c_plain| measures against.
    full_fine =
        simulateInterior(full_cfg, fine, std::vector<double>(fine.size(), s.region_is_solid ? 0.0 : 1.0)).task.mass;
    // Held out: the reference's prediction (no noise), then its config with the true pose.
    setTargets(held, s.held_out, simulateInterior(held, fine, r_fine).task, nullptr);
    const ProblemEvaluation held_ref = simulateInterior(held, fine, r_fine);  // in the true pose
    held_truth = featureValue(held_ref.task, hf);
    if (const Feature* f = findFeature(held_ref.task, "swing_period_closed_form_s")) swing_truth = f->value;
  }

  std::fprintf(stderr, "[%s] reference simulated, %.1f s\n", s.name.c_str(), seconds(t0));
  const InferenceResult result = runInference(joint, coarse, [&](const IterationInfo& it) {
    std::fprintf(stderr, "[%s] iteration %d loss %.3e (%.1f s)\n", s.name.c_str(), it.iteration, it.loss, seconds(t0));
    return true;
  });
  std::fprintf(stderr, "[%s] inference: %s, %.1f s (%.3f s per evaluation)\n", s.name.c_str(),
               result.optimizer.message.c_str(), seconds(t0), result.evaluation_s);
  for (const auto& e : result.final.experiments)
    for (const auto& f : e.eval.features)
      if (f.has_target)
        std::fprintf(stderr, "[%s]   %s.%s = %.6g (target %.6g)\n", s.name.c_str(), e.name.c_str(), f.name.c_str(),
                     f.value, f.target);
  const ProblemEvaluation held_rec = simulateInterior(held, coarse, result.r);
  out.rec = errorsOf(result.final.task.mass, truth, full_fine, diag, featureValue(held_rec.task, hf), held_truth);
  const Feature* swing_rec = findFeature(held_rec.task, "swing_period_closed_form_s");
  const double swing_err = swing_truth && swing_rec ? std::abs(swing_rec->value - *swing_truth) / *swing_truth : NAN;
  // Baseline: the body all of its other material (the unweighed start), on the inference's lattice.
  const std::vector<double> r_plain(coarse.size(), s.region_is_solid ? 0.0 : 1.0);
  out.base = errorsOf(simulateInterior(full_cfg, coarse, r_plain).task.mass, truth, full_fine, diag,
                      featureValue(simulateInterior(held, coarse, r_plain).task, hf), held_truth);
  // The design the optimiser started from (weighed: a region of the other material with the scale's mass).
  std::vector<double> r_start;
  {
    const InteriorProblem problem(joint, coarse);
    problem.indicator(problem.initialParameters(), &r_start);
  }
  const ProblemEvaluation held_start = simulateInterior(held, coarse, r_start);
  out.start = errorsOf(result.initial.task.mass, truth, full_fine, diag, featureValue(held_start.task, hf), held_truth);

  std::vector<double> rec_solid(coarse.size()), rec_region(coarse.size()), t_region(coarse.size());
  for (std::size_t i = 0; i < coarse.size(); ++i) {
    rec_solid[i] = result.r[i] >= 0.5 ? 1.0 : 0.0;
    rec_region[i] = s.region_is_solid ? rec_solid[i] : 1.0 - rec_solid[i];
    t_region[i] = s.region_is_solid ? t_coarse[i] : 1.0 - t_coarse[i];
  }
  // The joint loss of the true interior on the inference's lattice (its inside fractions): below the
  // found design's, the optimiser stopped short of a design that fits better; above it, the lattice
  // and the model cannot reproduce the reference's observations to their noise.
  const ProblemEvaluation truth_eval = simulateInterior(joint, coarse, t_coarse);
  out.loss_truth = truth_eval.loss;
  // The true interior on the inference's lattice against the fine reference: the lattice's own error
  // (what no design on this lattice can do better than).
  const ProblemEvaluation truth_plain = simulateInterior(full_cfg, coarse, t_coarse);
  out.truth_lattice = errorsOf(truth_plain.task.mass, truth, full_fine, diag,
                               featureValue(simulateInterior(held, coarse, t_coarse).task, hf), held_truth);
  for (const auto& e : truth_eval.experiments)
    for (const auto& f : e.eval.features)
      if (f.has_target)
        std::fprintf(stderr, "[%s]   the true interior on this lattice: %s.%s = %.6g (target %.6g)\n", s.name.c_str(),
                     e.name.c_str(), f.name.c_str(), f.value, f.target);
  std::fprintf(stderr, "[%s] loss: found %.3e, the true interior on this lattice %.3e\n", s.name.c_str(),
               result.final.loss, out.loss_truth);
  out.iou_solid = volumeIou(coarse.V, t_coarse, rec_solid);
  out.iou_region = volumeIou(coarse.V, t_region, rec_region);
  out.particles = coarse.size();

  // True over recovered slices.
  std::filesystem::create_directories(out_dir);
  const cv::Mat a =
      vision::drawInteriorSlices(coarse.X, t_coarse, coarse.spacing, s.name + ": truth (" + s.interior + ")");
  const cv::Mat b = vision::drawInteriorSlices(coarse.X, result.r, coarse.spacing, s.name + ": recovered");
  cv::Mat both;
  cv::vconcat(a, b, both);
  const std::string png = out_dir + "/" + s.name + ".png";
  vision::writePng(both, png);
  out.seconds = seconds(t0);
  out.iou_expected = result.region.available ? result.region.iou_mean : NAN;
  out.iou_p10 = result.region.available ? result.region.iou_p10 : NAN;
  out.iou_p90 = result.region.available ? result.region.iou_p90 : NAN;
  out.called_determined = result.region.available && result.region.iou_mean >= 0.9;

  // determined: the identifiability analysis: the moments the experiments determine
  // and how many combinations of the ten they pin; then how much of the volume the designs that fit
  // as well disagree on (the design spread).
  std::string determined;
  const auto& id = result.identifiability;
  for (const auto& m : id.moments)
    if (m.determined) determined += (determined.empty() ? "" : " ") + m.name;
  determined = (determined.empty() ? std::string("none") : determined) + " (" +
               std::to_string(id.determined_directions) + " of 10 combinations; undetermined volume " +
               numberText(100.0 * std::max(result.spread.undetermined_fraction,
                                           result.region.available ? result.region.undetermined_fraction : 0.0),
                          3) +
               " %)";

  std::string names;
  int hangs = 0, rocks = 0;
  for (const auto& e : s.experiments) {
    names += (names.empty() ? "" : ",") + e.name;
    (e.task == "hanging" ? hangs : rocks) += 1;
  }
  // What the experiments observe, by kind (not an analysis): each hanging pose gives the direction
  // of c from its point (2 numbers), each rocking its period and maximum tilt (2 numbers of m, c, I).
  // Timed swings: each hang's two axle periods (one inertia combination each).
  char observes[300];
  std::snprintf(observes, sizeof observes,
                "%d numbers: c from %d hanging pose%s%s; %d rocking experiment%s (period, max tilt)%s%s",
                2 * (hangs + rocks) + (g_swing ? 2 * hangs : 0) + (g_weigh ? 1 : 0), hangs, hangs == 1 ? "" : "s",
                hangs >= 2 ? " (c fixed)" : "", rocks, rocks == 1 ? "" : "s",
                g_swing && hangs > 0 ? "; each hang timed swinging on two axles (inertia about them)" : "",
                g_weigh ? "; weighed" : "");
  std::printf(
      "{\"case\": %s, \"world\": %s, \"object\": %s, \"interior\": %s, \"region\": %s, \"representation\": %s, \"pin_shell\": %s, "
      "\"particles\": %zu, \"spacing_m\": %s, \"reference_particles\": %zu, \"reference_spacing_m\": %s, "
      "\"experiments\": %s, \"held_out\": %s, \"held_out_feature\": %s, \"max_evaluations\": %d, \"iterations\": %d, "
      "\"loss_final\": %s, \"loss_truth\": %s, "
      "\"targets_reached\": %s, \"iou_solid\": %s, \"iou_region\": %s, \"mass_err\": %s, \"com_err_over_size\": %s, "
      "\"com_err_over_shift\": %s, \"inertia_err\": %s, \"held_out_err\": %s, \"baseline_start\": {\"mass_err\": %s, "
      "\"com_err_over_size\": %s, \"com_err_over_shift\": %s, \"inertia_err\": %s, \"held_out_err\": %s}, "
      "\"video\": [%s], \"scale_kg\": %s, \"start\": {\"design\": %s, \"mass_err\": %s, \"inertia_err\": %s, "
      "\"held_out_err\": %s}, \"truth_on_lattice\": {\"mass_err\": %s, \"com_err_over_size\": %s, \"inertia_err\": %s, "
      "\"held_out_err\": %s}, "
      "\"held_out_pendulum_closed_form_err\": %s, \"solid_fraction_true\": %s, \"solid_fraction_recovered\": %s, "
      "\"observes\": %s, \"determined\": %s, \"region_uncertainty\": {\"iou_mean\": %s, \"iou_p10\": %s, \"iou_p90\": %s, "
      "\"undetermined_fraction\": %s, \"noise_scale\": %s, \"free_directions\": %d, \"sentence\": %s}, "
      "\"goal_met\": %s, \"check_note\": %s, \"png\": %s, \"seconds\": %s}\n",
      json::quote(s.name).c_str(), g_peer ? "\"peer\"" : "\"ours\"", json::quote(s.object).c_str(), json::quote(s.interior).c_str(),
      json::quote(R.text()).c_str(), json::quote(s.representation).c_str(), s.pin_shell ? "true" : "false",
      coarse.size(), json::num(coarse.spacing).c_str(), fine.size(), json::num(fine.spacing).c_str(),
      json::quote(names).c_str(), json::quote(s.held_out.name).c_str(), json::quote(hf).c_str(),
      int(joint.integer("max_evaluations")), result.optimizer.iterations, json::num(result.final.loss).c_str(),
      json::num(out.loss_truth).c_str(), result.targets_reached ? "true" : "false", json::num(out.iou_solid).c_str(),
      json::num(out.iou_region).c_str(), json::num(out.rec.mass).c_str(), json::num(out.rec.com_size).c_str(),
      json::num(out.rec.com_shift).c_str(), json::num(out.rec.inertia).c_str(), json::num(out.rec.held_out).c_str(),
      json::num(out.base.mass).c_str(), json::num(out.base.com_size).c_str(), json::num(out.base.com_shift).c_str(),
      json::num(out.base.inertia).c_str(), json::num(out.base.held_out).c_str(), video_json.c_str(),
      json::num(scale_kg).c_str(), json::quote(result.start).c_str(), json::num(out.start.mass).c_str(),
      json::num(out.start.inertia).c_str(), json::num(out.start.held_out).c_str(),
      json::num(out.truth_lattice.mass).c_str(), json::num(out.truth_lattice.com_size).c_str(),
      json::num(out.truth_lattice.inertia).c_str(), json::num(out.truth_lattice.held_out).c_str(),
      json::num(swing_err).c_str(), json::num(truth_plain.solid_fraction).c_str(),
      json::num(result.final.solid_fraction).c_str(), json::quote(observes).c_str(), json::quote(determined).c_str(),
      json::num(result.region.iou_mean).c_str(), json::num(result.region.iou_p10).c_str(),
      json::num(result.region.iou_p90).c_str(),
      json::num(result.region.undetermined_fraction).c_str(), json::num(result.region.noise_scale).c_str(),
      result.region.free_directions,
      json::quote(result.region.available ? result.region.sentence : result.region.note).c_str(),
      out.rec.mass <= kGoal && out.rec.inertia <= kGoal && out.rec.held_out <= kGoal ? "true" : "false",
      json::quote(s.check_note).c_str(), json::quote(png).c_str(), json::num(out.seconds).c_str());
  std::fflush(stdout);
  out.goal = out.rec.mass <= kGoal && out.rec.inertia <= kGoal && out.rec.held_out <= kGoal;
  out.pass = out.rec.mass <= s.check_mass && out.rec.inertia <= s.check_inertia && out.rec.held_out <= s.check_held_out;
  if (!out.pass)
    std::fprintf(stderr,
                 "[%s] outside its --check bounds: mass %.4f (bound %.3f), inertia %.4f (%.3f), held out %.4f (%.3f)\n",
                 s.name.c_str(), out.rec.mass, s.check_mass, out.rec.inertia, s.check_inertia, out.rec.held_out,
                 s.check_held_out);
  return out;
}

std::string sharedData() {
  for (const char* p : {"../shared/data", "../../shared/data"})  // from the repository root (or build/)
    if (std::filesystem::exists(std::string(p) + "/meshes/spot.obj")) return p;
  return "";
}

geometry::SurfaceData ellipsoid(const Vector3d& semi, int segments = 96) {
  geometry::SurfaceData s = geometry::makeSphere(1.0, segments, segments / 2);
  for (auto& p : s.points) p = p.cwiseProduct(semi);
  s.normals.clear();
  s.source = "generated ellipsoid";
  return s;
}

std::vector<CaseSpec> cases(const std::string& data) {
  std::vector<CaseSpec> all;
  const ExperimentSpec rock_x{"rock_x", "tumbler", Vector3d::UnitX(), 10.0};
  const ExperimentSpec rock_y{"rock_y", "tumbler", Vector3d::UnitY(), 10.0};
  const ExperimentSpec rock_diag{"rock_diag", "tumbler", Vector3d(1, 1, 0), 15.0};
  const ExperimentSpec hang_top{"hang_top", "hanging", Vector3d(0.5, 0.5, 1.0)};
  const ExperimentSpec hang_side{"hang_side", "hanging", Vector3d(0.95, 0.5, 0.7)};
  const ExperimentSpec hang_back{"hang_back", "hanging", Vector3d(0.3, 0.95, 0.6)};
  const ExperimentSpec swing_corner{"swing_corner", "hanging", Vector3d(0.15, 0.2, 0.9)};
  const std::vector<ExperimentSpec> hangs = {hang_top, hang_side, hang_back};
  // A fourth hanging point, off every face's centre line (the *_four_hangs cases).
  const ExperimentSpec hang_corner{"hang_corner", "hanging", Vector3d(0.85, 0.1, 0.8)};

  auto tumbler = [] { return geometry::makeDefaultShapeMesh("tumbler", 128); };
  // The peer's tumbler: 512 segments (Bullet's period 1.1 % long at 256, 0.07 % off our simulator at 512).
  auto tumbler_fine = [] { return geometry::makeDefaultShapeMesh("tumbler", 512); };
  {
    CaseSpec c;
    c.name = "tumbler_cavity";
    c.object = "default tumbler (sphere R 0.05 m cut at z 0.02)";
    c.interior = "off-centre spherical cavity";
    c.surface = tumbler;
    c.peer_surface = tumbler_fine;
    c.region = sphereAt(Vector3d(0.1, 0.05, -0.05), 0.018);
    c.video = true;
    c.experiments = {rock_x, hang_top, hang_side};
    c.held_out = rock_diag;
    c.quick = true;
    // Unweighed (--unweighed), the features were matched by a grey design with the cavity's volume
    // spread over the body (solid fraction 0.99 vs 0.94, mass 4.8 % off, cavity IoU 0); weighed, the
    // goal's 2 % bounds hold.
    all.push_back(c);
  }
  {
    CaseSpec c;
    c.name = "tumbler_insert";
    c.object = "default tumbler (sphere R 0.05 m cut at z 0.02)";
    c.interior = "heavy steel ball insert (7800 in 1000 kg/m^3), low and off-centre";
    c.surface = tumbler;
    c.peer_surface = tumbler_fine;
    c.region = sphereAt(Vector3d(-0.1, 0.05, -0.15), 0.012);
    c.video = true;
    c.region_is_solid = true;
    c.density_solid = 7800, c.density_hollow = 1000;
    c.pin_shell = false;
    c.initial_field = -0.3;
    c.experiments = {rock_x, hang_top, hang_side};
    c.held_out = rock_diag;
    all.push_back(c);
  }
  {
    CaseSpec c;
    c.name = "ellipsoid_shell";
    c.object = "generated ellipsoid, semi-axes 0.06 x 0.045 x 0.04 m";
    c.interior = "hollow shell: inner ellipsoid 0.8 x the semi-axes, 4 mm above the centre";
    c.surface = [] { return ellipsoid(Vector3d(0.06, 0.045, 0.04)); };
    c.peer_surface = [] { return ellipsoid(Vector3d(0.06, 0.045, 0.04), 512); };
    c.region = [](const VolumeCloud&) {
      Region R;
      R.kind = Region::Ellipsoid;
      R.centre = Vector3d(0, 0, 0.004);
      R.half = 0.8 * Vector3d(0.06, 0.045, 0.04);
      return R;
    };
    c.experiments = {rock_x, hang_top, hang_side};
    c.held_out = swing_corner;
    all.push_back(c);
  }
  {
    CaseSpec c;
    c.name = "box_two_material";
    c.object = "generated box 0.12 x 0.08 x 0.06 m";
    c.interior = "two materials: wood 400 kg/m^3 for x > 0.015 m, resin 1200 kg/m^3 elsewhere";
    c.surface = [] { return geometry::makeBox(Vector3d(0.12, 0.08, 0.06)); };
    c.region = [](const VolumeCloud&) {
      Region R;
      R.kind = Region::HalfSpace;
      R.centre = Vector3d(0.015, 0, 0);
      R.normal = Vector3d::UnitX();
      return R;
    };
    c.density_solid = 1200;
    c.density_hollow = 400;
    c.pin_shell = false;
    c.experiments = hangs;
    c.held_out = swing_corner;
    c.quick = true;
    all.push_back(c);
  }
  if (!data.empty()) {
    {
      CaseSpec c;
      c.name = "spot_cavity";
      c.object = "spot.obj x 0.1 (cow, y up)";
      c.interior = "off-centre spherical cavity in the body";
      c.path = data + "/meshes/spot.obj";
      c.scale = 0.1, c.up_axis = "y";
      c.region = sphereAt(Vector3d(0.05, 0.0, 0.05), 0.03);
      c.experiments = hangs;
      c.held_out = swing_corner;
      all.push_back(c);
    }
    {
      CaseSpec c;
      c.name = "fish_insert";
      c.object = "fish.obj (blub) x 0.1, y up";
      c.interior = "heavy insert: lead box (11300 in 1000 kg/m^3)";
      c.path = data + "/meshes/fish.obj";
      c.scale = 0.1, c.up_axis = "y";
      c.region = [](const VolumeCloud& cl) {
        Region R;
        R.kind = Region::Box;
        Vector3d lo, hi;
        cl.bounds(&lo, &hi);
        R.centre = cl.centroid() + Vector3d(0.05, -0.1, 0.05).cwiseProduct(hi - lo);
        R.half = Vector3d(0.012, 0.01, 0.008);
        return R;
      };
      c.region_is_solid = true;
      c.density_solid = 11300, c.density_hollow = 1000;
      c.pin_shell = false;
      c.initial_field = -0.3;
      c.experiments = hangs;
      c.held_out = swing_corner;
      all.push_back(c);
    }
    {
      CaseSpec c;
      c.name = "penguin_hollow";
      c.object = "penguin.obj x 0.1, y up";
      c.interior = "large spherical hollow (as large as fits, two spacings from the skin)";
      c.path = data + "/meshes/penguin.obj";
      c.scale = 0.1, c.up_axis = "y";
      c.region = sphereAt(Vector3d(0.0, 0.0, -0.05), 1.0);
      c.experiments = hangs;
      c.held_out = swing_corner;
      all.push_back(c);
    }
    {
      CaseSpec c;
      c.name = "bunny_two_material";
      c.object = "bunny.off (Stanford bunny, ~0.16 m), y up";
      c.interior = "two materials: light foam 300 kg/m^3 above a tilted plane, 1000 kg/m^3 below";
      c.path = data + "/meshes/bunny.off";
      c.up_axis = "y";
      c.region = [](const VolumeCloud& cl) {
        Region R;
        R.kind = Region::HalfSpace;
        R.centre = boundsPoint(cl, Vector3d(0.5, 0.5, 0.55));
        R.normal = Vector3d(0.3, 0.0, 1.0).normalized();
        return R;
      };
      c.density_hollow = 300;
      c.pin_shell = false;
      c.experiments = hangs;
      c.held_out = swing_corner;
      c.quick = true;
      // Without the timed swings (--no-swings) three hanging poses and a weighing fix m and c, not the
      // inertia: 2.08 % (full) / 2.11 % (quick); with them 0.40 % (quick).
      all.push_back(c);
    }
  }
  // The same bodies hung from a fourth point, off every face's centre line: its rest pose turns the two
  // axles' directions away from the other hangs' (whose poses share the body's x and y), so the eight
  // swings fix all six inertia components and the experiments determine all ten moments (the
  // condition for IoU ≥ 0.9). Appended, so the cases above keep their noise seeds.
  const std::size_t first = all.size();
  for (std::size_t k = 0; k < first; ++k) {
    const std::string& n = all[k].name;
    if (n != "box_two_material" && n != "spot_cavity" && n != "penguin_hollow") continue;
    CaseSpec c = all[k];
    c.name = n.substr(0, n.find('_')) + "_four_hangs";
    c.object += ", hung from four points";
    c.experiments.push_back(hang_corner);
    c.quick = false;
    all.push_back(c);
  }
  return all;
}

}  // namespace

int main(int argc, char** argv) {
  bool quick = false, check = false;
  const char* only = nullptr;
  std::string out_dir = "/tmp/topo_bench_interiors";
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--quick") == 0)
      quick = true;
    else if (std::strcmp(argv[i], "--check") == 0)
      check = true;
    else if ((std::strcmp(argv[i], "--max-evaluations") == 0 || std::strcmp(argv[i], "--max-iterations") == 0) &&
             i + 1 < argc)
      g_max_evaluations = std::atoi(argv[++i]);
    else if (std::strcmp(argv[i], "--restarts") == 0 && i + 1 < argc)
      g_restarts = std::atoi(argv[++i]);
    else if (std::strcmp(argv[i], "--unweighed") == 0)
      g_weigh = false;
    else if (std::strcmp(argv[i], "--no-video") == 0)
      g_video = false;
    else if (std::strcmp(argv[i], "--no-swings") == 0)
      g_swing = false;
    else if (std::strcmp(argv[i], "--weighed-start") == 0 && i + 1 < argc)
      g_weighed_start = argv[++i];
    else if (std::strcmp(argv[i], "--quadric-field") == 0 && i + 1 < argc)
      g_quadric_field = argv[++i];
    else if (std::strcmp(argv[i], "--noise") == 0 && i + 1 < argc)
      g_noise = std::atof(argv[++i]);
    else if (std::strcmp(argv[i], "--world") == 0 && i + 1 < argc) {
      const std::string w = argv[++i];
      if (w != "ours" && w != "peer") {
        std::fprintf(stderr, "bench_interiors: --world %s: give ours or peer\n", w.c_str());
        return 2;
      }
      g_peer = w == "peer";
#ifndef TOPO_HAVE_PEER_WORLD
      if (g_peer) {
        std::fprintf(stderr,
                     "bench_interiors: --world peer needs the peer world, which is built only where Bullet is "
                     "found: install libbullet-dev (scripts/install_deps.sh) and rebuild\n");
        return 2;
      }
#endif
    } else if (std::strcmp(argv[i], "--frames") == 0 && i + 1 < argc)
      g_frames_dir = argv[++i];
    else if (std::strcmp(argv[i], "--out") == 0 && i + 1 < argc)
      out_dir = argv[++i];
    else
      only = argv[i];
  }
  if (quick && g_max_evaluations == 0) g_max_evaluations = 25;
  const auto t0 = Clock::now();
  const std::string data = sharedData();
  if (data.empty()) std::fprintf(stderr, "shared data not found: running the generated shapes only\n");
  std::vector<CaseResult> results;
  unsigned seed = 1;
  try {
    for (const CaseSpec& c : cases(data)) {
      ++seed;
      if ((quick && !c.quick) || (only && c.name.find(only) == std::string::npos)) continue;
      try {
        results.push_back(runCase(c, quick, seed, out_dir));
      } catch (const TopoError& e) {
        if (!g_peer) throw;
        // The peer world cannot model every object (an open mesh has no exact moments, a region may
        // reach outside it): the case is skipped with the reason, the others run.
        std::printf("{\"case\": %s, \"world\": \"peer\", \"skipped\": %s}\n", json::quote(c.name).c_str(),
                    json::quote(e.what()).c_str());
        std::fprintf(stderr, "[%s] skipped in the peer world: %s\n", c.name.c_str(), e.what());
      }
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_interiors: %s\n", e.what());
    return 2;
  }
  std::printf("\n%-20s %8s %7s %7s %7s %13s %7s %8s %8s %8s %8s | start design: %4s %8s %8s %7s\n", "case",
              "particles", "IoU", "IoU_R", "IoU_exp", "band 10-90%", "mass%", "CoM/L%", "CoM/dc%", "inert%", "held%",
              "mass%", "CoM/dc%", "inert%", "held%");
  bool ok = true;
  int met = 0, banded = 0, in_band = 0, called = 0, called_wrong = 0;
  for (const auto& r : results) {
    char band[40] = "-";
    if (std::isfinite(r.iou_p10)) {
      const bool in = r.iou_region >= r.iou_p10 && r.iou_region <= r.iou_p90;
      std::snprintf(band, sizeof band, "%.2f-%.2f %s", r.iou_p10, r.iou_p90, in ? "in" : "out");
      ++banded;
      in_band += in;
    }
    if (r.called_determined) {
      ++called;
      called_wrong += r.iou_region < 0.9;
    }
    std::printf("%-20s %8zu %7.3f %7.3f %7.3f %13s %7.2f %8.3f %8.1f %8.2f %8.2f | %18.2f %8.1f %8.2f %7.2f\n",
                r.name.c_str(), r.particles, r.iou_solid, r.iou_region, r.iou_expected, band, 100 * r.rec.mass,
                100 * r.rec.com_size, 100 * r.rec.com_shift, 100 * r.rec.inertia, 100 * r.rec.held_out,
                100 * r.base.mass, 100 * r.base.com_shift, 100 * r.base.inertia, 100 * r.base.held_out);
    ok = ok && r.pass;
    met += r.goal;
  }
  std::printf("goal (mass, inertia, held out within %.0f %%): met in %d of %zu cases\n", 100 * kGoal, met,
              results.size());
  // Calibration of the region analysis: the true region's IoU with the design found should lie in the band
  // it reports (10-90 %) in at least 80 % of the cases, and no region called determined (expected IoU
  // ≥ 0.9) should have a true IoU below 0.9.
  std::printf("calibration: the true IoU_R lies in the reported 10-90 %% band in %d of %d cases; called determined: "
              "%d, of them with IoU_R < 0.9: %d\n",
              in_band, banded, called, called_wrong);
  std::printf("total %.1f s\n", seconds(t0));
  if (check && !ok) {
    std::printf("FAIL: a case's mass, inertia or held-out error exceeds its --check bound (see stderr)\n");
    return 1;
  }
  return 0;
}
