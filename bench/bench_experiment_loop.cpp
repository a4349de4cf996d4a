// The rig performs the next experiment (issue 47 §3), measured: workflow::runExperimentLoop on the tumbler
// with the rig twin's default cavity (RigTwin::defaultInteriorQuadric("tumbler"): a hollow sphere of
// radius 25 mm centred 4.5 mm above the body origin, cut flat under the pinned shell), starting from the
// rig demo's experiments (scripts/demo.sh, launch/demo.launch): rock10 and rock25 (the tumbler released
// at 10° and 25°) and a weighed hang from (0, 0.04, 0.02) m, with contact_damping_ratio=0,
// measured_cycles=1 and density_solid=5000. After every inference the identifiability analysis suggests
// the next experiment; a performer carries it out and the loop infers again, until the stopping rule
// (workflow/experiment_loop.h decideNextStep) ends it.
//
// Worlds (--world):
//   ours  the rig twin (workflow::RigTwin, its lattice at twin_spacing with the surface on the true
//         boundary, its true interior) performs the experiments: workflow::TwinPerformer (simulated
//         features + noise: angles 0.1°, periods 0.1 %, the scale 0.1 %, seeded);
//   peer  no inverse crime: the true object is the tumbler mesh at 512 segments with the twin's cavity as a
//         sphere cut by a horizontal plane (fitted to the twin's hollow particles), its exact moments
//         (interiors/peer_reference.h); hangs by the closed-form rest pose, swings by the compound
//         pendulum's closed form, rocking by Bullet (the first two through the peer camera's video and the
//         tracker, a suggested rock as Bullet's numbers), with the same noise.
// In both worlds the inference runs on the tumbler mesh (128 segments) filled as cloud_ingest / topo
// fill do at the rig's 4 mm (--quick: 5 mm), so the inference's lattice is never the truth's.
// The truth on that lattice: ours, the twin's true indicator averaged over each cell; peer, the
// cavity's inside fraction of each cell (4³ samples).
//
// Per step: one table line (experiments, what was added, determined moments, uncertain volume %, the
// cavity's IoU against the truth, mass / centre-of-mass / inertia errors) and one JSON line; at the end
// the verdict against the goal: all ten moments determined and cavity IoU ≥ 0.85 in at most 5
// experiments.
//
// Usage: bench_experiment_loop [--world ours|peer] [--max-experiments 5] [--quick] [--seed N]
//                              [--max-evaluations N] [--restarts N] [--max-uncertain F] [--candidates all|static]
//   --candidates static: the suggestions are hangs and axle swings only (IdentifiabilityOptions
//   max_dynamic_candidates = 0: the loop never rocks it about another axis).
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/json.h"
#include "topo_gaussian/common/number_text.h"
#include "topo_gaussian/common/stopwatch.h"
#include "topo_gaussian/geometry/cleaning.h"
#include "topo_gaussian/geometry/ingest.h"
#include "topo_gaussian/geometry/shape_generator.h"
#include "topo_gaussian/inference/pipeline.h"
#include "topo_gaussian/inference/region_uncertainty.h"
#include "topo_gaussian/workflow/experiment_loop.h"
#include "topo_gaussian/workflow/rig_twin.h"
#ifdef TOPO_HAVE_PEER_WORLD
#include "interiors/peer_reference.h"
#endif

using namespace topo_gaussian;
using namespace topo_gaussian::inference;
using Eigen::Vector3d;

namespace {

constexpr double kGoalIou = 0.85;
constexpr int kGoalExperiments = 5;

/// The rig demo's shared overrides, and each first experiment's own.
const std::vector<std::string> kDemoOverrides{"contact_damping_ratio=0", "measured_cycles=1", "density_solid=5000"};

struct Options {
  bool peer = false, quick = false;
  int max_experiments = 5, max_evaluations = 0, restarts = 0;
  double max_uncertain = workflow::ExperimentLoopOptions().max_uncertain_fraction;
  unsigned seed = 1;
  std::string candidates = "all";  ///< all | static (hangs and swings, never rock it)
};

void applyOverrides(TaskConfig& c, const Options& o) {
  for (const auto& a : kDemoOverrides) {
    const auto eq = a.find('=');
    if (c.spec(a.substr(0, eq))) c.setAssignment(a, "the rig demo's overrides");
  }
  c.set("representation", "quadric");
  c.setNumber("restarts", o.restarts);
  if (o.max_evaluations > 0) c.setNumber("max_evaluations", o.max_evaluations);
}

/// The three first experiments without targets: rock10, rock25, hang (demo.launch).
std::vector<std::pair<std::string, TaskConfig>> demoExperiments(const Options& o) {
  TaskConfig rock10 = TaskConfig::defaults("tumbler");
  applyOverrides(rock10, o);
  TaskConfig rock25 = rock10;
  rock25.setNumber("initial_tilt_deg", 25.0);
  TaskConfig hang = TaskConfig::defaults("hanging");
  applyOverrides(hang, o);
  hang.setVector("hanging_point", Vector3d(0, 0.04, 0.02));
  return {{"rock10", rock10}, {"rock25", rock25}, {"hang", hang}};
}

std::string names(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& n : v) s += (s.empty() ? "" : " ") + n;
  return s.empty() ? "-" : s;
}

struct Errors {
  double mass = NAN, com = NAN, inertia = NAN;  ///< relative; com over the tumbler's size (0.1 m)
};

Errors errorsOf(const MassProperties& m, const MassProperties& truth) {
  Errors e;
  e.mass = std::abs(m.mass - truth.mass) / truth.mass;
  e.com = (m.com - truth.com).norm() / 0.1;
  e.inertia = (m.inertia - truth.inertia).norm() / truth.inertia.norm();
  return e;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "bench_experiment_loop: %s needs a value\n", a.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--quick")
      o.quick = true;
    else if (a == "--world") {
      const std::string w = next();
      if (w != "ours" && w != "peer") {
        std::fprintf(stderr, "bench_experiment_loop: --world %s: give ours or peer\n", w.c_str());
        return 2;
      }
      o.peer = w == "peer";
    } else if (a == "--max-experiments")
      o.max_experiments = std::atoi(next().c_str());
    else if (a == "--max-evaluations")
      o.max_evaluations = std::atoi(next().c_str());
    else if (a == "--restarts")
      o.restarts = std::atoi(next().c_str());
    else if (a == "--max-uncertain")
      o.max_uncertain = std::atof(next().c_str());
    else if (a == "--candidates") {
      o.candidates = next();
      if (o.candidates != "all" && o.candidates != "static") {
        std::fprintf(stderr, "bench_experiment_loop: --candidates %s: give all or static\n", o.candidates.c_str());
        return 2;
      }
    } else if (a == "--seed")
      o.seed = static_cast<unsigned>(std::atoi(next().c_str()));
    else {
      std::fprintf(stderr,
                   "usage: bench_experiment_loop [--world ours|peer] [--max-experiments 5] [--quick] [--seed N] "
                   "[--max-evaluations N] [--restarts N] [--max-uncertain F] [--candidates all|static]\n");
      return 2;
    }
  }
#ifndef TOPO_HAVE_PEER_WORLD
  if (o.peer) {
    std::fprintf(stderr,
                 "bench_experiment_loop: --world peer needs the peer world, which is built only where Bullet is found: "
                 "install libbullet-dev (scripts/install_deps.sh) and rebuild\n");
    return 2;
  }
#endif
  if (o.quick && o.max_evaluations == 0) o.max_evaluations = 25;
  const auto t0 = Clock::now();
  try {
    // The twin: its lattice, its true interior (both worlds: the peer world's cavity is fitted to it).
    workflow::RigTwinOptions to;
    to.shape = "tumbler";
    to.spacing_m = o.quick ? 0.0035 : 0.0025;
    to.overrides = {"measured_cycles=1", "density_solid=5000"};
    to.loop_cycles = 2;
    const workflow::RigTwin twin(to);
    std::fprintf(stderr, "[twin] %zu particles at %.4f m, solid fraction %.4f, mass %.5f kg (%.1f s)\n",
                 twin.cloud().size(), to.spacing_m, twin.solidFraction(), twin.truth().task.mass.mass,
                 secondsSince(t0));

    // The inference's cloud: the tumbler mesh filled as topo fill does, at the rig's spacing.
    geometry::IngestOptions io;
    io.fill.spacing_m = o.quick ? 0.005 : 0.004;
    const geometry::IngestResult filled = geometry::ingestSurface(geometry::makeDefaultShapeMesh("tumbler", 128), io);
    const VolumeCloud& cloud = filled.cloud;
    std::fprintf(stderr, "[cloud] %zu particles at %.4f m\n", cloud.size(), cloud.spacing);

    // The truth on the inference's cloud (solid fraction per particle) and its moments.
    std::vector<double> t_solid;
    MassProperties truth = twin.truth().task.mass;
    std::string world_note;
#ifdef TOPO_HAVE_PEER_WORLD
    std::optional<bench::PeerObject> peer;
    bench::PeerRegion region;
    if (o.peer) {
      // The twin's cavity as a sphere cut flat: its radius from the hollow particles' extent across x and y,
      // its centre from their lowest point, the cut from their highest (each ± half a spacing).
      const VolumeCloud& tc = twin.cloud();
      Vector3d lo = Vector3d::Constant(1e9), hi = Vector3d::Constant(-1e9);
      for (std::size_t i = 0; i < tc.size(); ++i)
        if (twin.indicator()[i] < 0.5) lo = lo.cwiseMin(tc.X[i]), hi = hi.cwiseMax(tc.X[i]);
      const double h = tc.spacing;
      region.kind = bench::PeerRegion::SphereBelow;
      const double radius = 0.25 * ((hi.x() - lo.x()) + (hi.y() - lo.y())) + 0.5 * h;
      region.half = Vector3d::Constant(radius);
      region.centre = Vector3d(0.5 * (lo.x() + hi.x()), 0.5 * (lo.y() + hi.y()), lo.z() - 0.5 * h + radius);
      region.cut_z_m = hi.z() + 0.5 * h;
      geometry::SurfaceData mesh = geometry::makeDefaultShapeMesh("tumbler", 512);
      geometry::cleanSurface(mesh, geometry::CleanOptions{});
      peer = bench::makePeerObject(mesh, region, 5000.0, 0.0);
      truth = peer->truth;
      world_note = "peer: cavity sphere r " + numberText(radius, 4) + " m at (" + numberText(region.centre.x(), 3) +
                   ", " + numberText(region.centre.y(), 3) + ", " + numberText(region.centre.z(), 4) +
                   ") m cut at z " + numberText(region.cut_z_m, 4) + " m";
      t_solid.assign(cloud.size(), 1.0);
      const int n = 4;
      for (std::size_t i = 0; i < cloud.size(); ++i) {
        int in = 0;
        for (int a = 0; a < n; ++a)
          for (int b = 0; b < n; ++b)
            for (int k = 0; k < n; ++k)
              in += region.inside(cloud.X[i] + cloud.spacing * Vector3d((a + 0.5) / n - 0.5, (b + 0.5) / n - 0.5,
                                                                         (k + 0.5) / n - 0.5));
        t_solid[i] = 1.0 - static_cast<double>(in) / (n * n * n);
      }
      std::fprintf(stderr, "[peer] %s; exact mass %.5f kg (twin %.5f), centre of mass z %.5f m (twin %.5f)\n",
                   world_note.c_str(), truth.mass, twin.truth().task.mass.mass, truth.com.z(),
                   twin.truth().task.mass.com.z());
    }
#endif
    if (!o.peer) {
      t_solid = workflow::transferField(twin.cloud(), twin.indicator(), cloud);
      world_note = "ours: the rig twin at " + numberText(to.spacing_m, 3) + " m";
    }
    std::vector<double> t_cavity(cloud.size());
    for (std::size_t i = 0; i < cloud.size(); ++i) t_cavity[i] = 1.0 - t_solid[i];
    const auto cavity_iou = [&](const InferenceResult& res) {
      std::vector<double> rec(cloud.size());
      for (std::size_t i = 0; i < cloud.size(); ++i) rec[i] = res.r[i] >= 0.5 ? 0.0 : 1.0;
      return volumeIou(cloud.V, t_cavity, rec);
    };

    // The performer and the first experiments' observations.
    const workflow::MeasurementNoise noise{0.1, 0.001, 0.001, o.seed};
    workflow::TwinPerformer twin_performer(twin, noise);
    workflow::ExperimentPerformer performer = std::ref(twin_performer);
    TaskConfig first = TaskConfig::common();
    applyOverrides(first, o);
#ifdef TOPO_HAVE_PEER_WORLD
    std::mt19937 rng(o.seed);
    std::normal_distribution<double> N(0.0, 1.0);
    auto peer_hang = [&](TaskConfig c, bool weigh, bool swing) {
      const bench::PeerHang h = bench::peerHang(c, *peer);
      if (swing) {
        c.setNumber("axle_swing_period_s", h.axle_swing_period_s * (1.0 + noise.period_relative * N(rng)));
        c.setNumber("cross_axle_swing_period_s", h.cross_axle_swing_period_s * (1.0 + noise.period_relative * N(rng)));
      }
      c.setNumber("target_roll_deg", h.roll_deg + noise.angle_deg * N(rng));
      c.setNumber("target_pitch_deg", h.pitch_deg + noise.angle_deg * N(rng));
      if (weigh) c.setNumber("mass_kg", peer->truth.mass * (1.0 + noise.mass_relative * N(rng)));
      return c;
    };
    if (o.peer) {
      performer = [&](const ExperimentSuggestion& s) {
        if (s.config.task() == "hanging") return peer_hang(s.config, false, s.kind == "swing");
        TaskConfig c = s.config;  // a rock about another axis: Bullet's numbers (the camera along x sees only x)
        const bench::PeerRocking r = bench::peerRocking(c, *peer);
        c.setNumber("period_s", r.period_s * (1.0 + noise.period_relative * N(rng)));
        c.setNumber("max_tilt_deg", workflow::measuredMaxTilt(c, r.max_tilt_deg + noise.angle_deg * N(rng)));
        return c;
      };
    }
#endif
    for (auto& [name, c] : demoExperiments(o)) {
      TaskConfig observed;
#ifdef TOPO_HAVE_PEER_WORLD
      if (o.peer) {
        if (c.task() == "hanging") {
          observed = peer_hang(c, true, false);
        } else {
          observed = c;
          const bench::PeerRockingVideo v = bench::observeRockingThroughPeerVideo(observed, *peer, 4.0, 60.0, 1.0);
          std::fprintf(stderr, "[peer] %s: Bullet period %.5f s, max tilt %.3f deg; tracked %.5f s, %.3f deg\n",
                       name.c_str(), v.bullet_period_s, v.bullet_max_tilt_deg, v.tracked_period_s,
                       v.tracked_max_tilt_deg);
        }
      }
#endif
      if (!o.peer) observed = twin_performer.perform(c, c.task() == "hanging", false);
      std::string targets;
      for (const auto& sp : observed.specs())
        if (sp.is_target && observed.has(sp.name)) targets += " " + sp.name + "=" + observed.valueText(sp.name);
      std::fprintf(stderr, "[%s] %s observed:%s\n", o.peer ? "peer" : "twin", name.c_str(), targets.c_str());
      first.addExperiment(name, 1.0, observed);
    }

    std::printf("bench_experiment_loop --world %s%s%s: tumbler with the twin's default cavity (%s), inference cloud %zu "
                "particles at %.4f m\n",
                o.peer ? "peer" : "ours", o.quick ? " --quick" : "",
                o.candidates == "static" ? " --candidates static" : "", world_note.c_str(), cloud.size(), cloud.spacing);
    std::printf("%4s %3s %-10s %-3s %-40s %9s %6s %7s %7s %7s %8s %8s\n", "step", "exp", "added", "det",
                "determined moments", "uncert%", "IoU", "mass%", "CoM/L%", "inert%", "infer_s", "perf_s");
    workflow::ExperimentLoopOptions lo;
    lo.max_experiments = o.max_experiments;
    lo.max_uncertain_fraction = o.max_uncertain;
    if (o.candidates == "static") {
      IdentifiabilityOptions io_static;
      io_static.max_dynamic_candidates = 0;
      lo.identifiability = io_static;
    }
    workflow::ExperimentLoopCallbacks cb;
    cb.truth_iou = cavity_iou;
    bool goal = false;
    int goal_experiments = 0;
    cb.progress = [&](const IterationInfo& it) {
      std::fprintf(stderr, "  iteration %d loss %.3e (%.0f s)\n", it.iteration, it.loss, secondsSince(t0));
      return true;
    };
    cb.on_step = [&](const workflow::ExperimentLoopStep& s, const InferenceResult& res) {
      const Errors e = errorsOf(s.mass, truth);
      const int n = static_cast<int>(s.experiment_names.size());
      std::printf("%4d %3d %-10s %-3zu %-40s %9.2f %6.3f %7.2f %7.3f %7.2f %8.1f %8.1f\n", s.step, n,
                  s.added.empty() ? "-" : s.added.c_str(), s.determined.size(), names(s.determined).c_str(),
                  100.0 * s.uncertain_fraction, s.truth_iou, 100 * e.mass, 100 * e.com, 100 * e.inertia,
                  s.inference_s, s.perform_s);
      std::string overrides;
      for (const auto& a : s.suggested.overrides) overrides += (overrides.empty() ? "" : ";") + a;
      std::printf(
          "{\"bench\": \"experiment_loop\", \"world\": %s, \"quick\": %s, \"step\": %d, \"experiments\": %d, "
          "\"experiment_names\": %s, \"added\": %s, \"added_sentence\": %s, \"determined\": %s, \"free\": %s, "
          "\"determined_directions\": %d, \"uncertain_fraction\": %s, \"region_iou_mean\": %s, \"cavity_iou\": %s, "
          "\"mass_error\": %s, \"com_error_over_size\": %s, \"inertia_error\": %s, \"targets_reached\": %s, "
          "\"suggestion\": %s, \"suggestion_task\": %s, \"suggestion_overrides\": %s, \"decision\": %s, "
          "\"reason\": %s, \"inference_s\": %s, \"perform_s\": %s, \"elapsed_s\": %s}\n",
          json::quote(o.peer ? "peer" : "ours").c_str(), o.quick ? "true" : "false", s.step, n,
          json::quote(names(s.experiment_names)).c_str(), json::quote(s.added).c_str(),
          json::quote(s.added_sentence).c_str(), json::quote(names(s.determined)).c_str(),
          json::quote(names(s.free)).c_str(), s.determined_directions, json::num(s.uncertain_fraction).c_str(),
          json::num(s.region_iou_mean).c_str(), json::num(s.truth_iou).c_str(), json::num(e.mass).c_str(),
          json::num(e.com).c_str(), json::num(e.inertia).c_str(), s.targets_reached ? "true" : "false",
          json::quote(s.has_suggestion ? s.suggestion.sentence : "").c_str(),
          json::quote(s.suggested.task).c_str(), json::quote(overrides).c_str(),
          json::quote(workflow::verdictName(s.decision.verdict)).c_str(), json::quote(s.decision.reason).c_str(),
          json::num(s.inference_s).c_str(), json::num(s.perform_s).c_str(), json::num(secondsSince(t0)).c_str());
      std::fflush(stdout);
      for (const auto& e : res.final.experiments)
        for (const auto& f : e.eval.features)
          if (f.has_target)
            std::fprintf(stderr, "[step %d]   %s.%s = %.6g (target %.6g, %+.3f %%)\n", s.step, e.name.c_str(),
                         f.name.c_str(), f.value, f.target, f.target != 0 ? 100.0 * (f.value / f.target - 1) : NAN);
      {  // each moment's relative std and the size of its part in J's null space (√Σ_null V_jk²)
        const auto& id = res.identifiability;
        std::string line;
        for (int j = 0; j < static_cast<int>(id.moments.size()); ++j) {
          double null2 = 0;
          for (int k = id.rank; k < 10; ++k) null2 += id.V(j, k) * id.V(j, k);
          char b[120];
          std::snprintf(b, sizeof b, " %s %.3g%%/%.2g", id.moments[j].name.c_str(), 100 * id.moments[j].std_relative,
                        std::sqrt(null2));
          line += b;
        }
        std::fprintf(stderr, "[step %d]   sigma %.3g, rank %d; std%%/null part:%s\n", s.step, id.noise_scale, id.rank,
                     line.c_str());
      }
      const auto& cands = res.identifiability.candidates;
      for (std::size_t k = 0; k < cands.size() && k < 6; ++k)
        std::fprintf(stderr, "[step %d]   candidate %zu: gain %.3f, directions after %d, fixes %s: %s\n", s.step, k + 1,
                     cands[k].score_gain, cands[k].directions_after, names(cands[k].newly_determined).c_str(),
                     cands[k].sentence.c_str());
      std::fprintf(stderr, "[step %d] %s\n[step %d] %s\n", s.step, res.identifiability.summary.c_str(), s.step,
                   res.region.available ? res.region.sentence.c_str() : res.region.note.c_str());
      if (!goal && s.free.empty() && s.truth_iou >= kGoalIou && n <= kGoalExperiments) {
        goal = true;
        goal_experiments = n;
      }
    };
    const workflow::ExperimentLoopResult loop = workflow::runExperimentLoop(cloud, first, performer, lo, cb);
    std::printf("loop ended: %s\n", loop.decision.reason.c_str());
    // The true interior on the inference's lattice against all the observations: what no design on this
    // lattice can fit better (the lattice's own error), beside the design found.
    {
      const ProblemEvaluation te = simulateInterior(loop.experiments, cloud, t_solid);
      std::string worst;
      double worst_rel = 0;
      for (const auto& e : te.experiments)
        for (const auto& f : e.eval.features)
          if (f.has_target && f.target != 0) {
            const double rel = f.value / f.target - 1;
            std::fprintf(stderr, "[truth on the lattice]   %s.%s = %.6g (target %.6g, %+.3f %%)\n", e.name.c_str(),
                         f.name.c_str(), f.value, f.target, 100 * rel);
            if (std::abs(rel) > std::abs(worst_rel)) worst_rel = rel, worst = e.name + "." + f.name;
          }
      std::printf("the true interior on this lattice: loss %.3e (found %.3e), mass %.3f %% off, worst feature %s "
                  "%+.3f %%\n",
                  te.loss, loop.last.final.loss, 100 * (te.task.mass.mass / truth.mass - 1), worst.c_str(),
                  100 * worst_rel);
      std::printf("{\"bench\": \"experiment_loop\", \"world\": %s, \"truth_on_lattice_loss\": %s, \"found_loss\": %s, "
                  "\"worst_feature\": %s, \"worst_relative\": %s}\n",
                  json::quote(o.peer ? "peer" : "ours").c_str(), json::num(te.loss).c_str(),
                  json::num(loop.last.final.loss).c_str(), json::quote(worst).c_str(), json::num(worst_rel).c_str());
    }
    if (goal)
      std::printf("goal (all ten moments determined and cavity IoU >= %.2f in at most %d experiments): MET with %d "
                  "experiments\n",
                  kGoalIou, kGoalExperiments, goal_experiments);
    else
      std::printf("goal (all ten moments determined and cavity IoU >= %.2f in at most %d experiments): MISSED (last "
                  "step: %zu determined, cavity IoU %.3f)\n",
                  kGoalIou, kGoalExperiments, loop.steps.back().determined.size(), loop.steps.back().truth_iou);
    std::printf("total %.1f s\n", secondsSince(t0));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_experiment_loop: %s\n", e.what());
    return 2;
  }
  return 0;
}
