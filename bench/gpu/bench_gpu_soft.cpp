// GPU benchmark of the explicit soft-body step: one JSON line per case, each with the
// CPU path (SoftBodySimulator::step on all host threads) on the same body in the same run.
//   explicit_<N>_<h>_<precision>  a clamped box (5 mm lattice, E 1e6, ν 0.3, StVK, A_pq rotations,
//       hourglass 0.1) of N particles, smoothing length h = 1.0 or 1.5 spacings, leapfrog at
//       dt = 0.5 × stableTimeStep(): particle-steps/s and µs per step of SoftBodyCuda::step over
//       `steps` steps (graph batches, one status read at the end), the CPU's rate over a few
//       steps, gpu_over_cpu, and the memory traffic: model_bytes_per_particle_step (what the
//       kernels stream: per CSR entry the index (ĝ, W and the gather's weights are recomputed);
//       per particle the state and constants, neighbours' records counted once), the achieved
//       bandwidth that implies and its share of the measured device-to-device copy bandwidth
//       (copy_GBs, read + write).
//   rollout_<N>  the explicit rollout with its gradient (runSoftRolloutCuda against SoftRollout, float64,
//       checkpoints every ⌈√steps⌉, a host loss called every step on both): forward and backward
//       seconds, backward / forward (the median of three GPU runs, the three beside it; neither time
//       holds the device allocations, made before the forward), and the speed-up of forward +
//       backward over the CPU;
//       *_loss_every_100: the loss counts every 100th step only (SoftRolloutOptions::loss_at);
//       *_keep_all: the default checkpointing, every state kept on the GPU (they fit), no recomputation.
// Without a CUDA device it prints one line {"case": "gpu", "skipped": reason} and exits 0.
// --capped -1|0|1: the evaluation kernel with its registers capped by the grid's size (the default), never,
// or always (SoftBodyCuda::setCappedEvaluation). --warp -1|0|1: float32's evaluation finished one thread a particle
// by the grid's size (the default), never, or always (SoftBodyCuda::setWarpEvaluation).
// Usage: bench_gpu_soft [--quick] [--lanes L] [--capped M] [--warp M] [CASE_SUBSTRING]    (bench/gpu/README.md: building on
// a GPU machine)
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#ifdef _OPENMP
#include <omp.h>
#endif

#include "../../test/unit/test_clouds.h"
#include "topo_gaussian/common/error.h"
#include "topo_gaussian/cuda/backend.h"
#include "topo_gaussian/cuda/soft_body_cuda.h"
#include "topo_gaussian/cuda/soft_rollout_cuda.h"

using namespace topo_gaussian;
using Clock = std::chrono::steady_clock;

namespace {

constexpr double kSpacing = 0.005;
const char* g_only = nullptr;
double g_copy_GBs = 0.0;

double seconds(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

int threads() {
#ifdef _OPENMP
  return omp_get_max_threads();
#else
  return 1;
#endif
}

std::unique_ptr<SoftBodySimulator> makeBody(int nx, int ny, int nz, double hfac) {
  const VolumeCloud c = topo_test::boxCloud(nx * kSpacing, ny * kSpacing, nz * kSpacing, kSpacing);
  CorotatedSphOptions o;
  o.spacing = kSpacing;
  o.smoothing_factor = hfac;
  auto sim = std::make_unique<SoftBodySimulator>(CorotatedSph::fromCloud(c, lameFromYoung(1e6, 0.3), o));
  double xmin = 1e300;
  for (const auto& X : c.X) xmin = std::min(xmin, X.x());
  std::vector<std::uint8_t> clamp(c.size(), 0);
  for (std::size_t i = 0; i < c.size(); ++i) clamp[i] = c.X[i].x() < xmin + 0.5 * kSpacing;
  sim->setClamped(clamp);
  return sim;
}

int g_lanes = 0;    // automatic
int g_capped = -1;  // by the grid's size
int g_warp = -1;    // by the grid's size (float32)

void gpuCase(const std::string& base, int nx, int ny, int nz, double hfac, int gpu_steps, int cpu_steps) {
  for (CudaPrecision p : {CudaPrecision::Float64, CudaPrecision::Float32}) {
    const std::string name = base + (p == CudaPrecision::Float64 ? "_f64" : "_f32");
    if (g_only && name.find(g_only) == std::string::npos) continue;
    auto t = Clock::now();
    auto sim = makeBody(nx, ny, nz, hfac);
    const double setup_s = seconds(t);
    const std::size_t n = sim->size();
    const double nb = double(sim->sph().neighbors().indices.size()) / double(n);
    const double dt = 0.5 * sim->stableTimeStep();
    t = Clock::now();
    SoftBodyCuda gpu(*sim, p, g_lanes);
    gpu.setCappedEvaluation(g_capped);
    gpu.setWarpEvaluation(g_warp);
    const double upload_s = seconds(t);
    gpu.step(dt, 100);  // warm-up: graph capture, caches, clocks
    t = Clock::now();
    gpu.step(dt, gpu_steps);
    gpu.synchronize();
    const double gpu_s = seconds(t);
    const double gpu_rate = double(n) * gpu_steps / gpu_s;
    // CPU path, same body: median of cpu_steps steps after one warm-up.
    std::vector<double> times;
    for (int k = -1; k < cpu_steps; ++k) {
      t = Clock::now();
      sim->step(dt);
      if (k >= 0) times.push_back(seconds(t));
    }
    std::sort(times.begin(), times.end());
    const double cpu_rate = double(n) / times[times.size() / 2];
    const double T = p == CudaPrecision::Float64 ? 8.0 : 4.0;
    // Order-1 gradients are recomputed (soft_step_kernels.h): per entry only the index (both
    // kernels); per particle 96 values (evaluate: x, c, μ, λ, C, writes F̃ and the 24-value record;
    // gather: the record as a neighbour's, c, V, x, Σ V ∇W, hourglass sums, m, v, writes f, v, next
    // x) and 145 bytes (X, V and L in float64, X and V again in the gather, offsets, clamp flag).
    const bool recomputed = sim->sph().options().gradient_order == 1;
    const double bytes = recomputed ? 8.0 * nb + 96.0 * T + 145.0 : (8.0 + 11.0 * T) * nb + 83.0 * T + 17.0;
    const double achieved = gpu_rate * bytes / 1e9;
    std::printf(
        "{\"case\": \"%s\", \"device\": \"%s\", \"particles\": %zu, \"neighbours_mean\": %.1f, \"precision\": \"%s\", "
        "\"lanes_per_particle\": %d, \"capped_evaluation\": %s, \"warp_evaluation\": %s, \"dt_s\": %.3e, \"steps\": "
        "%d, \"gpu_seconds\": %.4f, \"particle_steps_per_s\": "
        "%.4g, \"us_per_step\": %.2f, "
        "\"baseline\": \"cpu_step\", \"cpu_threads\": %d, \"cpu_particle_steps_per_s\": %.4g, \"gpu_over_cpu\": %.1f, "
        "\"model_bytes_per_particle_step\": %.0f, \"achieved_GBs\": %.0f, \"copy_GBs\": %.0f, "
        "\"bandwidth_share\": %.3f, \"bandwidth_bound_particle_steps_per_s\": %.4g, \"setup_s\": %.2f, "
        "\"upload_s\": %.3f, \"device_MiB\": %.1f}\n",
        name.c_str(), cudaDeviceInfo().name.c_str(), n, nb, p == CudaPrecision::Float64 ? "float64" : "float32",
        gpu.lanesPerParticle(), gpu.cappedEvaluation() ? "true" : "false", gpu.warpEvaluation() ? "true" : "false", dt,
        gpu_steps, gpu_s, gpu_rate, 1e6 * gpu_s / gpu_steps, threads(), cpu_rate, gpu_rate / cpu_rate, bytes, achieved,
        g_copy_GBs, g_copy_GBs > 0 ? achieved / g_copy_GBs : 0.0, g_copy_GBs * 1e9 / bytes, setup_s, upload_s,
        double(gpu.deviceBytes()) / (1024.0 * 1024.0));
    std::fflush(stdout);
  }
}

/// SoftRollout (explicit, with gradient) on the GPU and on the CPU from the same state; the loss is
/// Σ_k Σ_i (z_i − Z_i) (host callback). keep_all: the default checkpointing (every state kept on the
/// GPU when they fit, no recomputation); else checkpoints every ⌈√steps⌉ and each segment recomputed.
void rolloutCase(const std::string& name, int nx, int ny, int nz, int steps, int loss_every, bool keep_all) {
  if (g_only && name.find(g_only) == std::string::npos) return;
  auto loss = [](int, double, const std::vector<Eigen::Vector3d>& x, const std::vector<Eigen::Vector3d>&,
                 std::vector<Eigen::Vector3d>* dx, std::vector<Eigen::Vector3d>*) {
    double l = 0.0;
    for (std::size_t i = 0; i < x.size(); ++i) {
      l += x[i].z();
      if (dx) (*dx)[i].z() += 1.0;
    }
    return l;
  };
  auto cpu = makeBody(nx, ny, nz, 1.0);
  SoftRolloutOptions o;
  o.dt = 0.5 * cpu->stableTimeStep();
  o.steps = steps;
  if (loss_every > 1) o.loss_at = [loss_every](int k) { return k % loss_every == 0; };
  o.checkpoint_every = keep_all ? 0 : static_cast<int>(std::ceil(std::sqrt(double(steps))));
  runSoftRolloutCuda(
      makeBody(nx, ny, nz, 1.0).get(),
      [&] {
        SoftRolloutOptions w = o;
        w.steps = 10;
        return w;
      }(),
      loss, true);  // warm-up
  // Three GPU runs (each from the same start, a fresh body): the one with the median backward / forward
  // is reported, the three ratios beside it (one run of 100k particles takes ~0.1 s, where the host's
  // scheduling moves a ratio by ~0.1).
  std::vector<SoftRolloutResult> runs;
  for (int r = 0; r < 3; ++r) {
    auto body = makeBody(nx, ny, nz, 1.0);
    runs.push_back(runSoftRolloutCuda(body.get(), o, loss, true));
  }
  auto ratio = [](const SoftRolloutResult& r) { return r.backward_s / r.forward_s; };
  std::vector<double> ratios;
  for (const auto& r : runs) ratios.push_back(ratio(r));
  std::vector<SoftRolloutResult> sorted = runs;
  std::sort(sorted.begin(), sorted.end(),
            [&](const SoftRolloutResult& a, const SoftRolloutResult& b) { return ratio(a) < ratio(b); });
  const SoftRolloutResult g = sorted[1];
  const SoftRolloutResult c = SoftRollout(cpu.get(), o).run(loss, true);
  const double n = double(cpu->size());
  std::printf(
      "{\"case\": \"%s\", \"device\": \"%s\", \"particles\": %.0f, \"steps\": %d, \"loss_every\": %d, "
      "\"checkpoint_every\": %d, \"gpu_peak_states\": %zu, \"precision\": \"float64\", "
      "\"gpu_forward_s\": %.4f, \"gpu_backward_s\": %.4f, \"gpu_backward_over_forward\": %.2f, "
      "\"gpu_backward_over_forward_runs\": [%.2f, %.2f, %.2f], \"baseline\": \"cpu_soft_rollout\", \"cpu_threads\": "
      "%d, \"cpu_forward_s\": %.4f, \"cpu_backward_s\": %.4f, "
      "\"gpu_over_cpu_forward_plus_backward\": %.1f, \"loss_relative_difference\": %.2e}\n",
      name.c_str(), cudaDeviceInfo().name.c_str(), n, steps, loss_every, o.checkpoint_every, g.peak_states, g.forward_s,
      g.backward_s, g.backward_s / g.forward_s, ratios[0], ratios[1], ratios[2], threads(), c.forward_s, c.backward_s,
      (c.forward_s + c.backward_s) / (g.forward_s + g.backward_s), std::abs(g.loss - c.loss) / std::abs(c.loss));
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
  bool quick = false;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--quick") == 0)
      quick = true;
    else if (std::strcmp(argv[i], "--lanes") == 0 && i + 1 < argc)
      g_lanes = std::atoi(argv[++i]);
    else if (std::strcmp(argv[i], "--capped") == 0 && i + 1 < argc)
      g_capped = std::atoi(argv[++i]);
    else if (std::strcmp(argv[i], "--warp") == 0 && i + 1 < argc)
      g_warp = std::atoi(argv[++i]);
    else
      g_only = argv[i];
  }
  const CudaDeviceInfo& info = cudaDeviceInfo();
  if (!info.available) {
    std::printf("{\"case\": \"gpu\", \"skipped\": \"%s\"}\n", info.reason.c_str());
    return 0;
  }
  try {
    g_copy_GBs = cudaCopyBandwidthGBs();
    const int s = quick ? 10 : 1;
    // ~9k particles (the finger's size): 30 × 18 × 16 = 8640 cells.
    gpuCase("explicit_9k_h1.0", 30, 18, 16, 1.0, 20000 / s, 20 / s + 3);
    gpuCase("explicit_9k_h1.5", 30, 18, 16, 1.5, 20000 / s, 20 / s + 3);
    // 1e5: 80 × 50 × 25; 1e6: 160 × 100 × 63.
    gpuCase("explicit_100k_h1.0", 80, 50, 25, 1.0, 2000 / s, 10 / s + 2);
    gpuCase("explicit_100k_h1.5", 80, 50, 25, 1.5, 2000 / s, 10 / s + 2);
    // between 9k and 100k: where the warp evaluation starts to pay (bench/gpu/README.md)
    gpuCase("explicit_20k_h1.0", 40, 25, 20, 1.0, 2000 / s, 10 / s + 2);
    gpuCase("explicit_35k_h1.0", 50, 35, 20, 1.0, 2000 / s, 10 / s + 2);
    gpuCase("explicit_50k_h1.0", 50, 40, 25, 1.0, 2000 / s, 10 / s + 2);
    gpuCase("explicit_70k_h1.0", 70, 40, 25, 1.0, 2000 / s, 10 / s + 2);
    if (!quick) gpuCase("explicit_1m_h1.0", 160, 100, 63, 1.0, 200, 3);
    // Rollouts with gradient: 9k and 100k particles, checkpoints every ⌈√steps⌉ and (_keep_all, the
    // default where the states fit) every state kept.
    for (const bool all : {false, true}) {
      const std::string tail = all ? "_keep_all" : "";
      rolloutCase("rollout_9k" + tail, 30, 18, 16, quick ? 50 : 400, 1, all);
      rolloutCase("rollout_100k" + tail, 80, 50, 25, quick ? 20 : 100, 1, all);
      // The loss at every 100th step only (SoftRolloutOptions::loss_at: the other states stay on the GPU).
      rolloutCase("rollout_9k_loss_every_100" + tail, 30, 18, 16, quick ? 100 : 400, 100, all);
      rolloutCase("rollout_100k_loss_every_100" + tail, 80, 50, 25, quick ? 100 : 200, 100, all);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_gpu_soft: %s\n", e.what());
    return 1;
  }
  return 0;
}
