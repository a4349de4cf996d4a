// `topo infer` and `topo simulate`: thin front ends of topo_inference's Pipeline.
#include <sys/stat.h>

#include <cstdio>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "args.h"
#include "commands.h"
#include "topo_gaussian/geometry/ingest.h"
#include "topo_gaussian/geometry/volume_io.h"
#include "topo_gaussian/physics/default_shapes.h"
#include "topo_gaussian/inference/interior_export.h"
#include "topo_gaussian/inference/pipeline.h"
#include "topo_gaussian/common/error.h"

#ifndef TOPO_DEFAULT_TASK_DIR
#define TOPO_DEFAULT_TASK_DIR ""
#endif

namespace topo_gaussian::tools {
namespace {

const char* kInferHelp =
    "usage: topo infer --task TASK (--surface FILE | --volume VOLUME.ply) --output DIR [options]\n"
    "       (finger, pear: without --surface/--volume the default shape of `topo shape` is used)\n"
    "\n"
    "Finds an interior (solid/hollow per particle) whose simulated behaviour matches the targets.\n"
    "Writes DIR/interior.ply (x y z r solid density) and DIR/report.json (task, targets, achieved\n"
    "features, loss history, timings, centre of mass, hanging/support point, gravity, and the\n"
    "\"interface\": smoothness and watertightness of the solid region's mesh, see topo export), and\n"
    "prints one progress line per iteration on stderr.\n"
    "\n"
    "  --task TASK            hanging | balance | stand | tumbler | qiqi | ball, or a task YAML file\n"
    "                         (names resolve to config/tasks/TASK.yaml when it exists; $TOPO_TASK_DIR)\n"
    "  --surface FILE         a surface (3DGS .ply, points, mesh) filled with `topo fill` defaults first\n"
    "  --count N              particles when filling --surface (default 20000)\n"
    "  --volume FILE          a volume .ply written by `topo fill`\n"
    "  --representation R     point | quadric | neural (same as --set representation=R)\n"
    "  --target NAME=VALUE    an observed feature, e.g. period_s=0.25 (repeatable)\n"
    "  --set KEY=VALUE        any task parameter, e.g. density_solid=1200 (repeatable)\n"
    "  --list-params          print every parameter of the task with its default and exit\n"
    "  --output DIR           output directory (created)\n"
    "  --json                 print report.json on stdout at the end\n"
    "  --quiet                no progress lines\n"
    "exit codes: 0 targets reached, 3 finished without reaching the targets, 1 bad input, 2 bad usage\n";

const char* kSimulateHelp =
    "usage: topo simulate --task TASK --volume VOLUME.ply [--interior INTERIOR.ply] [--set KEY=VALUE ...] [--json]\n"
    "       (finger, pear, cantilever: without --volume the default shape of `topo shape` is used;\n"
    "        topo simulate --task cantilever --volume BEAM.ply --set youngs_modulus_solid=1e7 --json\n"
    "        prints tip_deflection_m and first_frequency_hz next to Euler-Bernoulli theory)\n"
    "\n"
    "Simulates a given interior (fully solid without --interior) and prints its features, e.g. the\n"
    "rocking period_s and max_tilt_deg for the tumbler, the centre-of-mass offset for hanging.\n"
    "\n"
    "  --task TASK            as for topo infer\n"
    "  --volume FILE          volume .ply (or --surface FILE [--count N] to fill one first)\n"
    "  --interior FILE        interior.ply from topo infer (same volume)\n"
    "  --set KEY=VALUE        task parameter (repeatable); --target NAME=VALUE also accepted\n"
    "  --signal FILE.csv      write the simulated signal (time, value) as CSV\n"
    "  --trajectory FILE.csv  ball: write the tracked points (t, x y z per point), usable as a target\n"
    "  --json                 print the features as one JSON object\n";

std::string taskDir() {
  const char* env = std::getenv("TOPO_TASK_DIR");
  return env ? env : TOPO_DEFAULT_TASK_DIR;
}

inference::TaskConfig loadConfig(const Args& a) {
  if (!a.has("task")) throw UsageError("--task is required");
  inference::TaskConfig c = inference::TaskConfig::load(a.str("task"), taskDir());
  if (a.has("representation")) c.set("representation", a.str("representation"), "--representation");
  for (const auto& s : a.all("set")) c.setAssignment(s, "--set");
  for (const auto& s : a.all("target")) {
    const auto eq = s.find('=');
    const std::string key = s.substr(0, eq);
    const auto* spec = c.spec(key);
    if (spec && !spec->is_target)
      throw TopoError("--target " + key, "is a parameter, not an observed feature", "use --set " + s);
    c.setAssignment(s, "--target");
  }
  return c;
}

VolumeCloud loadVolume(const Args& a, const inference::TaskConfig& config) {
  if (!a.has("volume") && !a.has("surface")) {
    // Soft tasks bring a default shape of their own (see `topo shape`).
    const std::string shape = inference::defaultShapeForTask(config.task());
    if (!shape.empty()) {
      const double h = config.number("default_spacing_m");
      VolumeCloud c = defaultShapeCloud(shape, h);
      std::cerr << "[topo] no --volume/--surface: using the default " << shape << " shape (" << c.size()
                << " particles at " << h << " m; `topo shape " << shape << "` writes it)\n";
      return c;
    }
  }
  if (a.has("volume") == a.has("surface"))
    throw UsageError("give exactly one of --volume or --surface (tasks finger, pear and cantilever have a default shape)");
  if (a.has("volume")) return geometry::readVolumePly(a.str("volume"));
  geometry::IngestOptions io;
  io.fill.target_count = static_cast<std::size_t>(a.integer("count", 20000));
  geometry::IngestResult r = geometry::ingestFile(a.str("surface"), io);
  std::cerr << "[topo] filled " << a.str("surface") << ": " << r.cloud.size() << " particles, spacing "
            << r.cloud.spacing << " m\n";
  return std::move(r.cloud);
}

void writeText(const std::string& path, const std::string& text) {
  std::ofstream out(path);
  if (!out) throw TopoError(path, "cannot be written", "check that the directory exists and is writable");
  out << text;
}

}  // namespace

int inferCommand(const std::vector<std::string>& argv) {
  const Args a(argv, {"help", "json", "quiet", "list-params"},
               {"task", "surface", "volume", "representation", "output", "count"}, {"target", "set"});
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
  const std::string dir = a.str("output");
  ::mkdir(dir.c_str(), 0755);
  struct stat st;
  if (::stat(dir.c_str(), &st) != 0 || !S_ISDIR(st.st_mode))
    throw TopoError(dir, "is not a directory and cannot be created", "give a writable output directory");
  const VolumeCloud cloud = loadVolume(a, config);
  const bool quiet = a.has("quiet");
  std::cerr << "[topo infer] task " << config.task() << " (" << config.source() << "), representation "
            << config.text("representation") << ", " << cloud.size() << " particles, optimizer "
            << config.text("optimizer") << ", at most " << config.integer("max_iterations") << " iterations\n";
  const inference::InferenceResult res = inference::runInference(
      config, cloud, [&](const inference::IterationInfo& it) {
        if (!quiet) {
          std::fprintf(stderr, "[topo infer] iteration %4d  loss %.6e  |grad| %.3e  best %.6e  %.2f s\n", it.iteration,
                       it.loss, it.gradient_norm, it.best_loss, it.elapsed_s);
        }
        return true;
      });
  inference::writeInteriorPly(dir + "/interior.ply", cloud, res.r, res.density, config.boolean("continuous_material"));
  std::string report = inference::reportJson(res, config);
  try {  // the interface's smoothness and printability (topo export writes the STL and pictures)
    const inference::InterfaceQuality q = inference::measureInterface(cloud, res.r);
    report = inference::withInterfaceSection(report, q);
  } catch (const TopoError& e) {
    std::cerr << "[topo infer] no \"interface\" section in report.json: " << e.what() << "\n";
  }
  writeText(dir + "/report.json", report);
  std::cerr << "[topo infer] " << res.message << "\n";
  for (const auto& f : res.final.task.features) {
    std::cerr << "[topo infer]   " << std::setw(28) << std::left << f.name << " " << f.value << " " << f.unit;
    if (f.has_target) std::cerr << "   (target " << f.target << (f.reached() ? ", reached)" : ", NOT reached)");
    std::cerr << "\n";
  }
  std::cerr << "[topo infer] wrote " << dir << "/interior.ply and " << dir << "/report.json\n";
  if (a.has("json")) std::cout << report;
  return res.targets_reached ? 0 : 3;
}

int simulateCommand(const std::vector<std::string>& argv) {
  const Args a(argv, {"help", "json", "list-params"},
               {"task", "surface", "volume", "interior", "representation", "count", "signal", "trajectory"},
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
  const VolumeCloud cloud = loadVolume(a, config);
  std::vector<double> r;
  if (a.has("interior")) r = inference::readInteriorPly(a.str("interior"), cloud.size());
  const inference::InteriorProblem problem(config, cloud);
  const inference::ProblemEvaluation ev = problem.evaluateIndicator(r.empty() ? std::vector<double>(cloud.size(), 1.0) : r, nullptr);
  if (a.has("signal")) {
    std::ostringstream os;
    os << "time_s," << (ev.task.signal_name.empty() ? "value" : ev.task.signal_name) << "\n" << std::setprecision(10);
    for (std::size_t k = 0; k < ev.task.signal.size(); ++k) os << ev.task.signal_time_s[k] << "," << ev.task.signal[k] << "\n";
    writeText(a.str("signal"), os.str());
  }
  if (a.has("trajectory")) {
    if (ev.task.trajectory_rows.empty())
      throw TopoError("--trajectory", "task '" + config.task() + "' tracks no points", "use it with --task ball or pear");
    std::ostringstream os;
    os << "# t, then x y z of each tracked point [s, m]\n" << std::setprecision(12);
    for (const auto& row : ev.task.trajectory_rows) {
      for (std::size_t k = 0; k < row.size(); ++k) os << (k ? "," : "") << row[k];
      os << "\n";
    }
    writeText(a.str("trajectory"), os.str());
  }
  if (a.has("json")) {
    std::cout << inference::simulationJson(ev, config, problem.task().geometry()) << "\n";
  } else {
    for (const auto& f : ev.task.features) std::cout << f.name << " = " << f.value << " " << f.unit << "\n";
  }
  return 0;
}

}  // namespace topo_gaussian::tools
