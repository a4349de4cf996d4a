// `topo infer` and `topo simulate`: thin front ends of topo_inference's Pipeline.
#include <cstdio>
#include <iomanip>
#include <iostream>
#include <new>
#include <sstream>

#include "args.h"
#include "commands.h"
#include "topo_gaussian/common/error.h"
#include "topo_gaussian/cuda/backend.h"
#include "topo_gaussian/geometry/ingest.h"
#include "topo_gaussian/inference/report.h"
#include "topo_gaussian/io/interior_ply.h"
#include "topo_gaussian/io/motion_features_json.h"
#include "topo_gaussian/io/task_dir.h"
#include "topo_gaussian/io/text_file.h"
#include "topo_gaussian/io/volume_ply.h"
#include "topo_gaussian/physics/default_shapes.h"
#include "topo_gaussian/workflow/inference_run.h"

namespace topo_gaussian::tools {
namespace {

const char* kInferHelp =
    "usage: topo infer --task TASK (--surface FILE | --volume VOLUME.ply) --output DIR [options]\n"
    "       (finger, pear: without --surface/--volume the default shape of `topo shape` is used)\n"
    "\n"
    "Finds an interior (solid/hollow per particle) whose simulated behaviour matches the targets.\n"
    "Writes the run folder DIR (the same as the interior_inference node writes, and loads):\n"
    "volume.ply, interior.ply (x y z r solid density), report.json (task, targets, achieved features,\n"
    "loss history, timings, centre of mass, hanging/support point, gravity, and the \"interface\":\n"
    "smoothness and watertightness of the solid region's mesh), signal.csv for tasks with a signal,\n"
    "and the export of topo export (interior.stl, slices.png, loss.png, signal.png, inertial.urdf,\n"
    "inertial.sdf, export.json);\n"
    "prints one progress line per iteration on stderr.\n"
    "\n"
    "  --task TASK            hanging | balance | stand | tumbler | qiqi | ball, or a task YAML file\n"
    "                         (names resolve to config/tasks/TASK.yaml when it exists; $TOPO_TASK_DIR), or\n"
    "                         a file of several experiments of one object (`experiments:` list, see docs/inference.md)\n"
    "  --experiment [NAME=]FILE  one more experiment of the same object (repeatable): a task YAML file\n"
    "                         or name; NAME defaults to the file's stem. One interior fits all of them\n"
    "                         (joint loss); a target of one experiment is --target NAME.TARGET=VALUE\n"
    "  --surface FILE         a surface (3DGS .ply, points, mesh) filled with `topo fill` defaults first\n"
    "  --count N              particles when filling --surface (default 20000)\n"
    "  --volume FILE          a volume .ply written by `topo fill`\n"
    "  --representation R     point | quadric | neural (same as --set representation=R)\n"
    "  --backend B            auto | cpu | cuda: where the particle kernels run (same as --set backend=B;\n"
    "                         auto: a CUDA GPU when present, said on stderr; cuda without one: exit 1)\n"
    "  --features [NAME=]FILE.json  motion features as `topo track --json` writes them (repeatable;\n"
    "                         NAME: the experiment they belong to): the task takes its\n"
    "                         targets from them (tumbler: period, max tilt; hanging/balance/stand: the\n"
    "                         equilibrium angle; finger: the bend) and signal.png compares the signals\n"
    "  --target NAME=VALUE    an observed feature, e.g. period_s=0.25 (repeatable; wins over --features)\n"
    "  --set KEY=VALUE        any task parameter, e.g. density_solid=1200 (repeatable)\n"
    "  --list-params          print every parameter of the task with its default and exit\n"
    "  --output DIR           the run folder (created; a folder that holds anything, e.g. an earlier run,\n"
    "                         is refused before any work)\n"
    "  --force                with --output: remove an earlier run's files there first (only the names\n"
    "                         a run writes; every other file is kept)\n"
    "  --no-export            no STL and pictures (volume.ply, interior.ply, report.json, signal.csv only)\n"
    "  --json                 print report.json on stdout at the end\n"
    "  --quiet                no progress lines\n"
    "exit codes: 0 targets reached, 3 finished without reaching the targets, 1 bad input, 2 bad usage\n";

const char* kSimulateHelp =
    "usage: topo simulate --task TASK --volume VOLUME.ply [--interior INTERIOR.ply] [--set KEY=VALUE ...] [--json]\n"
    "       (finger, pear, cantilever: without --volume the default shape of `topo shape` is used;\n"
    "        topo simulate --task cantilever --volume BEAM.ply --set youngs_modulus_solid=1e7 --json\n"
    "        prints tip_deflection_m and modal_frequency_hz next to Euler-Bernoulli theory;\n"
    "        --set vibration=true also measures first_frequency_hz by time stepping, minutes)\n"
    "\n"
    "Simulates a given interior (fully solid without --interior) and prints its features, e.g. the\n"
    "rocking period_s and max_tilt_deg for the tumbler, the centre-of-mass offset for hanging.\n"
    "\n"
    "  --task TASK            as for topo infer\n"
    "  --volume FILE          volume .ply (or --surface FILE [--count N] to fill one first)\n"
    "  --interior FILE        interior.ply from topo infer (same volume)\n"
    "  --backend B            auto | cpu | cuda (same as --set backend=B)\n"
    "  --set KEY=VALUE        task parameter (repeatable); --target NAME=VALUE also accepted\n"
    "  --signal FILE.csv      write the simulated signal (time, value) as CSV\n"
    "  --trajectory FILE.csv  ball: write the tracked points (t, x y z per point), usable as a target\n"
    "  --json                 print the features as one JSON object\n";

/// The task with --representation and --set applied (targets are the run's: see inferCommand).
inference::TaskConfig loadConfig(const Args& a) {
  const std::vector<std::string> experiments = a.has("experiment") ? a.all("experiment") : std::vector<std::string>{};
  if (!a.has("task") && experiments.empty()) throw UsageError("--task (or --experiment) is required");
  inference::TaskConfig c =
      inference::TaskConfig::loadWithExperiments(a.str("task"), experiments, io::defaultTaskDir(), a.all("set"));
  if (a.has("representation")) c.set("representation", a.str("representation"), "--representation");
  if (a.has("backend")) c.set("backend", a.str("backend"), "--backend");
  for (const auto& s : a.all("set")) c.setAssignment(s, "--set");
  return c;
}

/// --volume, or --surface filled with `topo fill` defaults, or null (the task's default shape).
std::shared_ptr<const VolumeCloud> loadVolume(const Args& a) {
  if (a.has("volume") && a.has("surface")) throw UsageError("give one of --volume or --surface, not both");
  if (a.has("volume")) return std::make_shared<VolumeCloud>(io::readVolumePly(a.str("volume")));
  if (!a.has("surface")) return nullptr;
  geometry::IngestOptions options;
  options.fill.target_count = static_cast<std::size_t>(a.integer("count", 20000));
  geometry::IngestResult r = geometry::ingestFile(a.str("surface"), options);
  std::cerr << "[topo] filled " << a.str("surface") << ": " << r.cloud.size() << " particles, spacing "
            << r.cloud.spacing << " m\n";
  return std::make_shared<VolumeCloud>(std::move(r.cloud));
}

/// The volume for simulate: as for infer, the task's default shape when none is given.
VolumeCloud volumeOrDefaultShape(const Args& a, const inference::TaskConfig& config) {
  if (auto v = loadVolume(a)) return *v;
  const std::string shape = inference::defaultShapeForTask(config.task());
  if (shape.empty())
    throw UsageError("give --volume or --surface (tasks with a default shape: finger, pear, cantilever)");
  const double h = config.number("default_spacing_m");
  VolumeCloud c = defaultShapeCloud(shape, h);
  std::cerr << "[topo] no --volume/--surface: using the default " << shape << " shape (" << c.size() << " particles at "
            << h << " m; `topo shape " << shape << "` writes it)\n";
  return c;
}

}  // namespace

int inferCommand(const std::vector<std::string>& argv) {
  const Args a(argv, {"help", "json", "quiet", "list-params", "no-export", "force"},
               {"task", "surface", "volume", "representation", "backend", "output", "count"},
               {"target", "set", "experiment", "features"});
  if (a.has("help")) {
    std::cout << kInferHelp;
    return 0;
  }
  const inference::TaskConfig config = loadConfig(a);
  if (a.has("list-params")) {
    std::cout << config.help();
    return 0;
  }
  if (!a.has("output")) throw UsageError("--output DIR is required");
  workflow::InferenceRunRequest rq;
  rq.config = config;
  rq.volume = loadVolume(a);
  if (!rq.volume && inference::defaultShapeForTask(config.task()).empty())
    throw UsageError("give --volume or --surface (tasks with a default shape: finger, pear, cantilever)");
  for (const auto& f : a.has("features") ? a.all("features") : std::vector<std::string>{}) {
    const auto [experiment, file] = inference::TaskConfig::splitNamedValue(f);
    auto window = std::make_shared<motion::MotionFeatures>(io::readMotionFeaturesJson(file));
    if (!experiment.empty()) window->experiment = experiment;
    if (!rq.observed && window->experiment.empty())
      rq.observed = window;
    else
      rq.observed_experiments.push_back(window);
  }
  rq.targets = a.all("target");
  rq.targets_origin = "--target";
  rq.output_dir = a.str("output");
  rq.replace_output = a.has("force");
  rq.export_files = !a.has("no-export");
  const bool quiet = a.has("quiet");
  rq.progress = [&](const inference::IterationInfo& it) {
    if (!quiet)
      std::fprintf(stderr, "[topo infer] iteration %4d  loss %.6e  |grad| %.3e  best %.6e  %.2f s\n", it.iteration,
                   it.loss, it.gradient_norm, it.best_loss, it.elapsed_s);
    return true;
  };
  for (const auto& e : config.experiments())
    std::cerr << "[topo infer] experiment " << e.name << ": task " << e.config.task() << " (" << e.config.source()
              << "), weight " << e.weight << "\n";
  std::cerr << "[topo infer] task " << config.task() << " (" << config.source() << "), representation "
            << config.text("representation") << ", optimizer " << config.text("optimizer") << ", at most "
            << config.integer("max_evaluations") << " evaluations (max_evaluations)\n";
  std::string backend_line;  // refuses backend cuda without a GPU before anything runs
  resolveBackend(parseComputeBackend(config.text("backend"), "--backend"), "--backend", &backend_line);
  std::cerr << "[topo infer] " << backend_line << "\n";
  const workflow::InferenceRunOutcome out = workflow::runInference(rq);
  const inference::InferenceResult& res = out.result;
  if (!res.start.empty()) std::cerr << "[topo infer] " << res.start << "\n";
  for (const auto& w : res.warnings) std::cerr << "[topo infer] warning: " << w << "\n";
  std::cerr << "[topo infer] " << out.message << "\n";
  if (res.spread.computed) {  // the sentence is in the message above; here the ranges behind it
    const inference::DesignSpread& d = res.spread;
    std::cerr << "[topo infer] how sure: " << d.accepted << " designs fit as well (of " << d.tried + 1
              << " tried; rule: " << d.rule << "): solid fraction " << d.solid_fraction_min << " .. "
              << d.solid_fraction_max << ", mass " << d.mass_min_kg << " .. " << d.mass_max_kg
              << " kg, centre of mass (" << d.com_min_m.transpose() << ") .. (" << d.com_max_m.transpose()
              << ") m; undetermined volume " << 100.0 * d.undetermined_fraction << " %\n";
  }
  if (res.region.available) {  // the sentence is in the message above; here the numbers behind it
    const inference::RegionUncertainty& g = res.region;
    std::cerr << "[topo infer] the region: " << g.samples << " designs that fit the observations to their noise ("
              << g.noise_scale << " x the tolerances), each a fit to the observations perturbed by it (" << g.iterations
              << " Levenberg-Marquardt iterations, " << g.solves_converged << " converged); " << g.free_directions
              << " of " << g.directions << " directions free; ";
    if (g.free_directions == 0)
      std::cerr << "region IoU with this design " << g.iou_mean << " (10-90 %: " << g.iou_p10 << "-" << g.iou_p90
                << "); ";
    std::cerr << "undetermined volume " << 100.0 * g.undetermined_fraction << " %\n";
  }
  for (const auto& f : res.final.task.features) {
    std::cerr << "[topo infer]   " << std::setw(28) << std::left << f.name << " " << f.value << " " << f.unit;
    if (f.has_target) std::cerr << "   (target " << f.target << (f.reached() ? ", reached)" : ", NOT reached)");
    std::cerr << "\n";
  }
  const inference::IdentifiabilityAnalysis& id = res.identifiability;
  if (id.available) {
    std::cerr << "[topo infer] what the experiments determine (linearised std; determined below " << 100 * id.threshold
              << " % of its own size):\n";
    for (const auto& m : id.moments)
      std::cerr << "[topo infer]   " << std::setw(4) << std::left << m.name << " "
                << (m.determined ? "DETERMINED" : "FREE      ") << "  std " << m.std << " " << m.unit << "\n";
  }
  if (!id.summary.empty()) std::cerr << "[topo infer] " << id.summary << "\n";
  for (const auto& n : id.notes) std::cerr << "[topo infer] identifiability: " << n << "\n";
  std::cerr << "[topo infer] wrote " << out.files.size() << " files to " << out.output_dir << "\n";
  if (a.has("json")) std::cout << out.report_json;
  return res.targets_reached ? 0 : 3;
}

int simulateCommand(const std::vector<std::string>& argv) {
  const Args a(argv, {"help", "json", "list-params"},
               {"task", "surface", "volume", "interior", "representation", "backend", "count", "signal", "trajectory"},
               {"target", "set"});
  if (a.has("help")) {
    std::cout << kSimulateHelp;
    return 0;
  }
  const inference::TaskConfig config = loadConfig(a);
  if (a.has("list-params")) {
    std::cout << config.help();
    return 0;
  }
  {
    std::string line;  // refuses backend cuda without a GPU before anything runs
    resolveBackend(parseComputeBackend(config.text("backend"), "--backend"), "--backend", &line);
    std::cerr << "[topo simulate] " << line << "\n";
  }
  inference::TaskConfig targeted = config;
  for (const auto& s : a.all("target")) {
    const auto* spec = targeted.spec(s.substr(0, s.find('=')));
    if (spec && !spec->is_target)
      throw TopoError("--target " + spec->name, "is a parameter, not an observed feature", "use --set " + s);
    targeted.setAssignment(s, "--target");
  }
  const VolumeCloud cloud = volumeOrDefaultShape(a, targeted);
  std::vector<double> r;
  if (a.has("interior")) {
    const std::string path = a.str("interior");
    const io::InteriorPly interior = io::readInteriorPlyData(path, cloud.size());  // count, r in [0, 1]
    // Same count is not enough: the interior must have been computed on these particles.
    const double tolerance = 0.01 * (cloud.spacing > 0 ? cloud.spacing : 1e-3);
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      if ((interior.X[i] - cloud.X[i]).norm() <= tolerance) continue;
      std::ostringstream msg;
      msg << "particle " << i << " is at (" << interior.X[i].transpose() << ") but particle " << i << " of the volume ("
          << (a.has("volume") ? a.str("volume") : std::string("the task's default shape")) << ") is at ("
          << cloud.X[i].transpose() << "): the interior was computed on another volume";
      throw TopoError(path, msg.str(), "give the volume that topo infer was run on (--volume of that run)");
    }
    r = interior.r;
  }
  const inference::InteriorProblem problem(targeted, cloud);
  for (const auto& w : {inference::pointOutsideObjectNote(problem.task().geometry(), cloud)})
    if (!w.empty()) std::cerr << "[topo simulate] warning: " << w << "\n";
  inference::ProblemEvaluation ev;
  try {
    ev = problem.evaluateIndicator(r.empty() ? std::vector<double>(cloud.size(), 1.0) : r, nullptr);
  } catch (const std::bad_alloc&) {
    throw TopoError("task " + targeted.task() + " (" + std::to_string(cloud.size()) + " particles)",
                    "ran out of memory while simulating",
                    "use a larger dt_s, a shorter duration_s or fewer particles (a larger spacing)");
  }
  if (a.has("signal")) {
    std::ostringstream os;
    os << "time_s," << (ev.task.signal_name.empty() ? "value" : ev.task.signal_name) << "\n" << std::setprecision(10);
    for (std::size_t k = 0; k < ev.task.signal.size(); ++k)
      os << ev.task.signal_time_s[k] << "," << ev.task.signal[k] << "\n";
    io::writeTextFile(a.str("signal"), os.str());
  }
  if (a.has("trajectory")) {
    if (ev.task.trajectory_rows.empty())
      throw TopoError("--trajectory", "task '" + targeted.task() + "' tracks no points",
                      "use it with --task ball or pear");
    std::ostringstream os;
    os << "# t, then x y z of each tracked point [s, m]\n" << std::setprecision(12);
    for (const auto& row : ev.task.trajectory_rows) {
      for (std::size_t k = 0; k < row.size(); ++k) os << (k ? "," : "") << row[k];
      os << "\n";
    }
    io::writeTextFile(a.str("trajectory"), os.str());
  }
  if (a.has("json")) {
    std::cout << inference::simulationJson(ev, targeted, problem.task().geometry()) << "\n";
  } else {
    for (const auto& f : ev.task.features) std::cout << f.name << " = " << f.value << " " << f.unit << "\n";
  }
  return 0;
}

}  // namespace topo_gaussian::tools
