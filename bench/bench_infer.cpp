// Inference benchmark: per task and representation, one JSON line with particles,
// iterations, end-to-end time, time per loss+gradient evaluation, and the ratio of one analytic
// gradient to one finite-difference gradient (central differences, 2·P loss evaluations) measured
// in the same run (projected from one loss evaluation when 2·P evaluations would take too long).
// finger_quadric: the pneumatic finger's inference at about 10k particles (goal: under 10 minutes on
// 2 CPU cores), set up as the finger recovery test (inference_soft) but at 1.5 mm (quick: 3 mm) and
// with the default (paper) materials.
// --backend auto|cpu|cuda: every case's task parameter `backend` (default: the task's, auto); the
// neural 8 × 512 case runs end to end where the backend resolves to a GPU (one evaluation on the CPU).
// The core build (-DTOPO_CORE_ONLY=ON with the inference libraries: a GPU machine, bench/gpu/README.md)
// runs inference::runInference without the run folder (run_folder_s 0).
// --set KEY=VALUE (repeatable): a task parameter of every case, e.g. --set warm_start=0 for an A/B run.
// evaluation_mean_s: the optimisation's time over the loss + gradient evaluations it simulated
// (InferenceResult::evaluation_s: the start design's, evaluated before it, is not counted). The
// finite-difference timing runs its evaluations one after another on one problem, so a task that
// starts from the last design's solution (the finger's warm_start) runs them warm; the projected one
// uses loss_only_s, measured on a fresh problem.
// --progress-every K: the stderr progress line (loss, gradient norm, time) every K evaluations (default 10).
// rest_factors / rest_factor_reuses: the process's kept rest-stiffness factors (the GPU's, rest_factor_reuse.h) made
// and reused by the case's inference, and rest_factors_renewed_during_use of them made within a design's
// solves (0 where no factor is kept).
// Usage: bench_infer [--quick] [--backend B] [--set KEY=VALUE]... [--progress-every K] [CASE_SUBSTRING]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include "../test/unit/test_clouds.h"
#include "topo_gaussian/common/error.h"
#include "topo_gaussian/cuda/backend.h"
#include "topo_gaussian/inference/pipeline.h"
#include "topo_gaussian/physics/default_shapes.h"
#include "topo_gaussian/physics/rest_factor_reuse.h"
#ifndef TOPO_BENCH_CORE_ONLY
#include "topo_gaussian/workflow/inference_run.h"
#endif

using namespace topo_gaussian;
using namespace topo_gaussian::inference;
using Clock = std::chrono::steady_clock;

namespace {

double seconds(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

std::vector<double> cavity(const VolumeCloud& c, const Eigen::Vector3d& centre, double radius) {
  std::vector<double> r(c.size(), 1.0);
  for (std::size_t i = 0; i < c.size(); ++i)
    if (!c.surface[i] && (c.X[i] - centre).norm() < radius) r[i] = 0.0;
  return r;
}

const char* g_only = nullptr;                            // run only the cases whose name contains this
const char* g_backend = nullptr;                         // --backend: every case's task parameter backend
std::vector<std::pair<std::string, std::string>> g_set;  // --set KEY=VALUE: every case's task parameter
int g_progress_every = 10;                               // --progress-every K: a stderr line every K evaluations

void runCase(const std::string& name, TaskConfig c, const VolumeCloud& cloud, bool run_inference, int fd_limit) {
  if (g_only && name.find(g_only) == std::string::npos) return;
  if (g_backend) c.set("backend", g_backend);
  for (const auto& [key, value] : g_set) {
    try {
      c.set(key, value);
    } catch (const TopoError& e) {  // a parameter of another task (e.g. the finger's warm_start)
      std::fprintf(stderr, "[bench_infer] %s: --set %s not applied: %s\n", name.c_str(), key.c_str(), e.what());
    }
  }
  const InteriorProblem p(c, cloud);
  const Eigen::VectorXd theta = p.initialParameters();
  Eigen::VectorXd g;
  auto t = Clock::now();
  p.evaluate(theta, &g);
  const double grad_s = seconds(t);
  // The loss alone on a problem of its own: the task keeps the last design's equilibrium (the finger's
  // warm_start), so the same design again would cost nothing.
  const InteriorProblem p_loss(c, cloud);
  t = Clock::now();
  p_loss.evaluate(theta, nullptr);
  const double loss_s = seconds(t);
  const int P = p.numParameters();
  std::fprintf(stderr, "[bench_infer] %s: %d parameters, loss + gradient %.3f s, loss %.3f s\n", name.c_str(), P,
               grad_s, loss_s);
  double fd_s;
  bool projected = false;
  if (P <= fd_limit) {
    t = Clock::now();
    for (int k = 0; k < P; ++k) {
      Eigen::VectorXd e = Eigen::VectorXd::Zero(P);
      e[k] = 1e-6;
      p.evaluate(theta + e, nullptr);
      p.evaluate(theta - e, nullptr);
    }
    fd_s = seconds(t);
  } else {
    fd_s = 2.0 * P * loss_s;
    projected = true;
  }
  double total_s = 0, evaluation_s = 0;
  int iterations = 0;
  double loss0 = 0, loss1 = 0;
  bool reached = false;
  std::string message;
  double run_folder_s = 0;
  const RestFactorReuse::Counts factors_before = RestFactorReuse::gpuShared()->counts();
  if (run_inference) {
    t = Clock::now();
    // Progress on stderr every 10 evaluations (long cases: the neural network, the finger).
    const ProgressCallback progress = [&name](const IterationInfo& it) {
      if (it.iteration % g_progress_every == 0)
        std::fprintf(stderr, "[bench_infer] %s: evaluation %d, loss %.3e, |gradient| %.2e, %.1f s\n", name.c_str(),
                     it.iteration, it.loss, it.gradient_norm, it.elapsed_s);
      return true;
    };
#ifdef TOPO_BENCH_CORE_ONLY
    const InferenceResult r = runInference(c, cloud, progress);
    total_s = r.setup_s + r.optimize_s;
    std::fprintf(stderr, "[bench_infer] %s: setup %.2f s, optimisation %.2f s, after it (analyses) %.2f s\n",
                 name.c_str(), r.setup_s, r.optimize_s, seconds(t) - total_s);
#else
    // The run as a user gets it (workflow::runInference, as topo infer and the node): the inference,
    // then its run folder without the pictures; end_to_end_s is the inference alone, comparable
    // across versions, run_folder_s the files around it.
    workflow::InferenceRunRequest rq;
    rq.config = c;
    rq.volume = std::make_shared<VolumeCloud>(cloud);
    rq.output_dir = "/tmp/topo_bench_infer/" + name;
    rq.replace_output = true;  // the bench's own folder, the previous run's files replaced (topo infer --force)
    rq.export_files = false;
    rq.progress = progress;
    const workflow::InferenceRunOutcome run = workflow::runInference(rq);
    const InferenceResult& r = run.result;
    total_s = r.setup_s + r.optimize_s;
    run_folder_s = seconds(t) - total_s;
#endif
    iterations = r.optimizer.iterations;
    evaluation_s = r.evaluation_s;
    loss0 = r.initial.loss;
    loss1 = r.final.loss;
    reached = r.targets_reached;
    message = r.optimizer.message;
    for (char& ch : message)
      if (ch == '"' || ch == '\\') ch = '\'';
  }
  const RestFactorReuse::Counts factors = RestFactorReuse::gpuShared()->counts();
  std::printf(
      "{\"case\": \"%s\", \"task\": \"%s\", \"representation\": \"%s\", \"particles\": %zu, \"parameters\": %d, "
      "\"iterations\": %d, \"end_to_end_s\": %.4f, \"evaluation_mean_s\": %.4f, \"loss_gradient_s\": %.5f, "
      "\"loss_only_s\": %.5f, "
      "\"fd_gradient_s\": %.4f, \"fd_projected\": %s, \"analytic_over_fd\": %.3g, \"loss_initial\": %.3e, "
      "\"loss_final\": %.3e, \"targets_reached\": %s, \"run_folder_s\": %.3f, \"backend\": \"%s\", "
      "\"rest_factors\": %ld, \"rest_factor_reuses\": %ld, \"rest_factors_renewed_during_use\": %ld, "
      "\"stopped\": \"%s\"}\n",
      name.c_str(), c.task().c_str(), c.text("representation").c_str(), cloud.size(), P, iterations, total_s,
      evaluation_s, grad_s, loss_s, fd_s, projected ? "true" : "false", grad_s / fd_s, loss0, loss1,
      reached ? "true" : "false", run_folder_s, c.text("backend").c_str(), factors.factors - factors_before.factors,
      factors.reuses - factors_before.reuses, factors.renewed_during_use - factors_before.renewed_during_use,
      message.c_str());
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
  bool quick = false;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--quick") == 0)
      quick = true;
    else if (std::strcmp(argv[i], "--backend") == 0) {
      if (i + 1 >= argc || argv[i + 1][0] == '-') {
        std::fprintf(stderr, "bench_infer: --backend needs a value: auto, cpu or cuda\n");
        return 2;
      }
      g_backend = argv[++i];
    } else if (std::strcmp(argv[i], "--progress-every") == 0 && i + 1 < argc) {
      g_progress_every = std::max(1, std::atoi(argv[++i]));
    } else if (std::strcmp(argv[i], "--set") == 0) {
      const char* kv = i + 1 < argc ? std::strchr(argv[i + 1], '=') : nullptr;
      if (!kv) {
        std::fprintf(stderr, "bench_infer: --set needs KEY=VALUE, a task parameter, e.g. --set warm_start=0\n");
        return 2;
      }
      g_set.emplace_back(std::string(argv[i + 1], static_cast<std::size_t>(kv - argv[i + 1])), std::string(kv + 1));
      ++i;
    } else
      g_only = argv[i];
  }
  // ~100k particles: a 0.4 × 0.2 × 0.12 m box at 4 mm spacing (quick: 8 mm).
  const double h = quick ? 0.008 : 0.004;
  const VolumeCloud box = topo_test::boxCloud(0.4, 0.2, 0.12, h);
  const std::vector<double> box_gt = cavity(box, Eigen::Vector3d(0.08, 0.02, 0.0), 0.05);
  {
    TaskConfig c = TaskConfig::defaults("hanging");
    const ProblemEvaluation gt = simulateInterior(c, box, box_gt);
    c.setVector("hanging_point", Eigen::Vector3d(gt.task.mass.com.x(), gt.task.mass.com.y(), 0.06));
    runCase("hanging_quadric", c, box, true, 1000);
    TaskConfig cp = c;
    cp.set("representation", "point");
    cp.set("optimizer", "lbfgs");
    runCase("hanging_point", cp, box, true, 0);
    TaskConfig cn = c;
    cn.set("representation", "neural");
    cn.set("neural_depth", "4");
    cn.set("neural_width", "32");
    runCase("hanging_neural_4x32", cn, box, true, 0);
    if (!quick) {
      TaskConfig cd = c;
      cd.set("representation", "neural");  // the paper's default 8 x 512: end to end on a GPU, else one evaluation
      const bool gpu = resolveBackend(parseComputeBackend(g_backend ? g_backend : "auto")) == ComputeBackend::Cuda;
      runCase(gpu ? "hanging_neural_8x512" : "hanging_neural_8x512_one_evaluation", cd, box, gpu, 0);
    }
  }
  {
    const VolumeCloud tumbler = topo_test::tumblerCloud(0.05, 0.6, quick ? 0.005 : 0.0033);
    TaskConfig c = TaskConfig::defaults("tumbler");
    c.set("density_solid", "5000");
    c.set("duration_s", "2.0");
    const ProblemEvaluation gt = simulateInterior(c, tumbler, cavity(tumbler, Eigen::Vector3d(0, 0.012, 0.008), 0.025));
    c.setNumber("period_s", gt.task.features[0].value);
    c.setNumber("max_tilt_deg", gt.task.features[1].value);
    c.set("max_evaluations", quick ? "10" : "60");
    runCase("tumbler_quadric_2s", c, tumbler, true, 1000);
  }
  {
    const VolumeCloud vessel = topo_test::boxCloud(0.1, 0.12, 0.15, quick ? 0.01 : 0.005);
    TaskConfig c = TaskConfig::defaults("qiqi");
    c.set("target_tilts_deg", "10, 5, -20");
    c.set("max_evaluations", quick ? "5" : "40");
    runCase("qiqi_quadric", c, vessel, true, 1000);
  }
  if (!g_only || std::string("pear_quadric").find(g_only) != std::string::npos) {
    // The pear bouncing on the ground (its rollout and gradient run on the GPU under backend cuda): ground
    // truth a stiff spherical insert in the bulb, its pivot trajectories the target (as the recovery test,
    // inference_soft), the start r = 0.5 everywhere.
    const VolumeCloud pear = defaultShapeCloud("pear", quick ? 0.01 : 0.005);
    TaskConfig c = TaskConfig::defaults("pear");
    c.set("duration_s", "0.08");
    if (g_backend) c.set("backend", g_backend);  // the truth on the same backend as the inference
    std::vector<double> gt(pear.size(), 0.0);
    for (std::size_t i = 0; i < pear.size(); ++i)
      if ((pear.X[i] - Eigen::Vector3d(0, 0, 0.04)).norm() < 0.022) gt[i] = 1.0;
    const ProblemEvaluation truth = simulateInterior(c, pear, gt);
    const std::string csv = "/tmp/bench_infer_pear_target.csv";
    {
      std::ofstream out(csv);
      for (const auto& row : truth.task.trajectory_rows) {
        for (std::size_t k = 0; k < row.size(); ++k) out << (k ? "," : "") << row[k];
        out << "\n";
      }
    }
    c.set("target_trajectory_file", csv);
    c.set("max_evaluations", quick ? "5" : "40");
    c.set("initial_field", "0.0");
    runCase("pear_quadric", c, pear, true, 0);
  }
  {
    const VolumeCloud finger = defaultShapeCloud("finger", quick ? 0.003 : 0.0015);
    TaskConfig c = TaskConfig::defaults("finger");  // the paper's real finger: 10 MPa walls
    std::vector<double> truth(10, 0.0), start(10, 0.0);
    truth[8] = 3.0, truth[9] = 0.09;     // chamber below z_n = -0.03 (ground truth)
    start[2] = 100.0, start[9] = -0.25;  // chamber around the axis (start)
    c.setList("initial_parameters", truth);
    if (!g_only || std::string("finger_quadric").find(g_only) != std::string::npos) {
      const InteriorProblem gt(c, finger);
      ProblemEvaluation ev;
      gt.evaluate(gt.initialParameters(), nullptr, &ev);
      c.setNumber("bend_angle_deg", ev.task.features[0].value);
    }
    c.setList("initial_parameters", start);
    c.set("max_evaluations", "30");
    runCase("finger_quadric", c, finger, true, 0);
  }
  return 0;
}
