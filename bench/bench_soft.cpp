// Soft-body benchmark: one JSON line per case, each with a ratio against a
// baseline measured in the same process.
//   explicit_20k / explicit_100k  leapfrog steps of a clamped box (E = 1e6, ν = 0.3, ρ = 1e3, 5 mm
//       lattice, h = 1.0 × spacing, order-1 gradients, StVK) at dt = 0.5 × stableTimeStep():
//       particle-steps/s of the median step (mean and slowest beside it: the VM's neighbours make
//       single steps up to several times slower). Baseline: the force evaluation alone
//       (CorotatedSph::update) on the same body at the positions the steps reached, so
//       step_over_force_eval (median over median) is the integrator's
//       overhead (1 = none); force_eval_rotated_* is the same evaluation after a rigid 0.5 rad
//       rotation (the per-particle polar decomposition costs more away from R = I);
//       explicit_100k also gives its per-particle rate relative to explicit_20k (scaling).
//   implicit_20k  implicit Euler steps (dt = 1e-3, gravity on a clamped box, corotated linear with
//       corrected-gradient rotations): seconds per Newton and per CG iteration, and the rest-stiffness
//       preconditioner's factorisation time on its own (factor_s, paid once per design and dt). Baseline: explicit
//       leapfrog covering the same simulated time (dt / (0.5 stableTimeStep()) steps) on the same body.
//   rollout_explicit / rollout_implicit  SoftRollout with gradient: backward_s / forward_s (goal
//       ≤ 3). Baseline: the same rollout forward-only (no checkpoints stored).
//   memory_checkpointed  a 1000-step explicit rollout with gradient and checkpoint_every = ⌈√1000⌉:
//       peak stored states, their bytes (SoftRolloutResult::peak_state_bytes: 48 B per particle and
//       state, 72 in the recomputed segment, which keeps the forces) and the process max RSS (getrusage)
//       before/after the rollout. Baseline: checkpoint_every = 1000 (every state stored). The two
//       runs are done side by side in forked children (started before this process starts any
//       OpenMP thread), each on half the threads, so that each max RSS is its own and not inherited
//       from the other cases; their times are on those threads. The line is printed last.
// Every line has cpu_per_wall, the process CPU time over wall time during the case: about the
// thread count on an idle machine; lower means other processes shared the cores.
// Usage: bench_soft [--quick] [CASE_SUBSTRING]
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#ifdef _OPENMP
#include <omp.h>
#endif

#include <Eigen/Geometry>

#include "../test/unit/test_clouds.h"
#include "topo_gaussian/common/error.h"
#include "topo_gaussian/physics/soft_rollout.h"

using namespace topo_gaussian;
using Clock = std::chrono::steady_clock;
using Vec3s = std::vector<Eigen::Vector3d>;

namespace {

constexpr double kSpacing = 0.005, kYoung = 1e6, kNu = 0.3, kRho = 1e3;

double seconds(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

int threads() {
#ifdef _OPENMP
  return omp_get_max_threads();
#else
  return 1;
#endif
}

long maxRssKiB() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_maxrss;  // KiB on Linux
}

/// Process CPU time / wall time since construction: ≈ the thread count on an idle machine; lower
/// means the cores were shared with other processes (the case's timings are then pessimistic).
class CpuMeter {
 public:
  CpuMeter() : wall_(Clock::now()), cpu_(cpuSeconds()) {}
  double ratio() const { return (cpuSeconds() - cpu_) / std::max(1e-9, seconds(wall_)); }

 private:
  static double cpuSeconds() {
    rusage u{};
    getrusage(RUSAGE_SELF, &u);
    return u.ru_utime.tv_sec + u.ru_stime.tv_sec + 1e-6 * (u.ru_utime.tv_usec + u.ru_stime.tv_usec);
  }
  Clock::time_point wall_;
  double cpu_;
};

const char* g_only = nullptr;  // run only the cases whose name contains this
bool selected(const std::string& name) { return !g_only || name.find(g_only) != std::string::npos; }

/// A box of nx × ny × nz lattice cells (5 mm), centred at the origin.
VolumeCloud box(int nx, int ny, int nz) {
  return topo_test::boxCloud(nx * kSpacing, ny * kSpacing, nz * kSpacing, kSpacing);
}

CorotatedSphOptions sphOptions(bool conservative) {
  CorotatedSphOptions o;
  o.spacing = kSpacing;
  o.smoothing_factor = 1.0;
  o.gradient_order = 1;
  o.density = kRho;
  if (conservative) {  // what implicit steps and the adjoint require
    o.model = SphEnergyModel::CorotatedLinear;
    o.rotation = SphRotationSource::CorrectedGradient;
  } else {
    o.model = SphEnergyModel::StVK;
  }
  return o;
}

/// Clamp the particles of the x = min face (one layer): a cantilever under gravity.
std::vector<std::uint8_t> clampMinX(const VolumeCloud& c) {
  double xmin = 1e300;
  for (const auto& X : c.X) xmin = std::min(xmin, X.x());
  std::vector<std::uint8_t> m(c.size(), 0);
  for (std::size_t i = 0; i < c.size(); ++i) m[i] = c.X[i].x() < xmin + 0.5 * kSpacing ? 1 : 0;
  return m;
}

double meanNeighbours(const CorotatedSph& s) {
  return s.size() ? double(s.neighbors().indices.size()) / double(s.size()) : 0.0;
}

SoftBodySimulator makeSim(const VolumeCloud& c, bool conservative) {
  SoftBodySimulator sim(CorotatedSph::fromCloud(c, lameFromYoung(kYoung, kNu), sphOptions(conservative)));
  sim.setClamped(clampMinX(c));
  return sim;
}

// ---------------------------------------------------------------- 1. explicit leapfrog

double g_rate_20k = 0.0;  // particle-steps/s of explicit_20k (for the 100k scaling ratio)

void explicitCase(const std::string& name, int nx, int ny, int nz, int steps) {
  if (!selected(name)) return;
  const CpuMeter meter;
  const VolumeCloud c = box(nx, ny, nz);
  const std::size_t n = c.size();
  auto t = Clock::now();
  CorotatedSph sph = CorotatedSph::fromCloud(c, lameFromYoung(kYoung, kNu), sphOptions(false));
  const double setup_s = seconds(t);
  const double nbr = meanNeighbours(sph);
  // Leapfrog steps of the clamped box under gravity, interleaved with the baseline: the force
  // evaluation alone (CorotatedSph::update, on a copy of the SPH body) at the positions each step
  // reached, and the same after a rigid rotation of 0.5 rad about (1, 1, 1) (the polar
  // decomposition's Jacobi SVD does more sweeps away from R = I). Interleaving keeps the three
  // timings comparable when other processes share the cores.
  CorotatedSph probe = sph;
  SoftBodySimulator sim(std::move(sph));
  sim.setClamped(clampMinX(c));
  const double dt = 0.5 * sim.stableTimeStep();
  const Eigen::Matrix3d Q = Eigen::AngleAxisd(0.5, Eigen::Vector3d(1, 1, 1).normalized()).toRotationMatrix();
  Vec3s xr(n);
  double step_s = 0.0, force_s = 0.0, rotated_s = 0.0;
  std::vector<double> step_times, force_times;  // per step: the rates are of the median step
  for (int k = -1; k < steps; ++k) {            // k = -1: warm-up
    t = Clock::now();
    sim.step(dt);
    const double a = seconds(t);
    const Vec3s& x = sim.positions();
    t = Clock::now();
    probe.update(x);
    const double b = seconds(t);
    for (std::size_t i = 0; i < n; ++i) xr[i] = Q * x[i];
    t = Clock::now();
    probe.update(xr);
    const double r = seconds(t);
    if (k < 0) continue;
    step_s += a;
    force_s += b;
    rotated_s += r;
    step_times.push_back(a);
    force_times.push_back(b);
  }
  // Rates of the median step (the lab VM's neighbours make single steps up to ~20 % slower; the
  // median is what a long run sees); the mean over all steps is reported beside it.
  auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
  };
  const double rate = double(n) / median(step_times), force_rate = double(n) / median(force_times);
  const double mean_rate = double(n) * steps / step_s;
  const double slowest = double(n) / *std::max_element(step_times.begin(), step_times.end());
  double vs20k = 0.0;
  if (name == "explicit_20k")
    g_rate_20k = rate;
  else if (g_rate_20k > 0)
    vs20k = rate / g_rate_20k;
  std::printf(
      "{\"case\": \"%s\", \"threads\": %d, \"particles\": %zu, \"clamped\": %zu, \"neighbours_mean\": %.2f, "
      "\"model\": \"StVK\", \"dt_s\": %.3e, \"steps\": %d, \"seconds\": %.4f, \"setup_s\": %.3f, "
      "\"particle_steps_per_s\": %.4g, \"mean_particle_steps_per_s\": %.4g, "
      "\"slowest_step_particle_steps_per_s\": %.4g, \"goal_particle_steps_per_s\": 5e6, \"goal_met\": %s, "
      "\"baseline\": \"force_eval_only\", \"baseline_seconds\": %.4f, \"baseline_particle_steps_per_s\": %.4g, "
      "\"step_over_force_eval\": %.3f, \"per_particle_rate_vs_20k\": %.3f, "
      "\"force_eval_rotated_particle_steps_per_s\": %.4g, \"cpu_per_wall\": %.2f}\n",
      name.c_str(), threads(), n, sim.clampedCount(), nbr, dt, steps, step_s, setup_s, rate, mean_rate, slowest,
      rate >= 5e6 ? "true" : "false", force_s, force_rate, median(step_times) / median(force_times), vs20k,
      double(n) * steps / rotated_s, meter.ratio());
  std::fflush(stdout);
}

// ---------------------------------------------------------------- 2. implicit Euler

void implicitCase(const std::string& name, int nx, int ny, int nz, int steps, double dt) {
  if (!selected(name)) return;
  const VolumeCloud c = box(nx, ny, nz);
  const std::size_t n = c.size();
  const CpuMeter meter;
  SoftBodySimulator sim = makeSim(c, true);
  const double nbr = meanNeighbours(sim.sph());
  const NewtonOptions newton;  // defaults: tolerance 1e-8 × force scale, inner CG min(0.1, residual)
  int newton_it = 0, cg_it = 0;
  double worst_residual = 0.0;
  // The preconditioner's factorisation (once per design and dt; cached by the simulator) on its own.
  auto t = Clock::now();
  sim.systemPreconditioner(1.0 / (dt * dt) + sim.options().damping / dt);
  const double factor_s = seconds(t);
  t = Clock::now();
  for (int k = 0; k < steps; ++k) {
    const SolveReport r = sim.stepImplicit(dt, newton);
    newton_it += r.newton.iterations;
    cg_it += r.newton.cg_iterations;
    worst_residual = std::max(worst_residual, r.newton.residual);
  }
  const double implicit_s = seconds(t) + factor_s;
  // Baseline: explicit leapfrog over the same simulated time, same body and model.
  SoftBodySimulator ex = makeSim(c, true);
  const double dt_ex = 0.5 * ex.stableTimeStep();
  const int ex_steps_per_dt = static_cast<int>(std::ceil(dt / dt_ex));
  const int ex_steps = std::max(4, ex_steps_per_dt);  // one implicit dt worth
  ex.step(dt / ex_steps_per_dt);                      // warm-up
  t = Clock::now();
  for (int k = 0; k < ex_steps; ++k) ex.step(dt / ex_steps_per_dt);
  const double ex_s = seconds(t) / ex_steps * ex_steps_per_dt;  // per implicit dt
  const double per_step = implicit_s / steps;
  std::printf(
      "{\"case\": \"%s\", \"threads\": %d, \"particles\": %zu, \"clamped\": %zu, \"neighbours_mean\": %.2f, "
      "\"model\": \"CorotatedLinear+CorrectedGradient\", \"load\": \"gravity\", \"dt_s\": %.3e, \"steps\": %d, "
      "\"seconds\": %.4f, \"newton_iterations\": %d, \"cg_iterations\": %d, \"s_per_step\": %.4f, "
      "\"s_per_newton_iteration\": %.4f, \"s_per_cg_iteration\": %.5f, \"cg_per_newton\": %.1f, "
      "\"newton_residual_max\": %.2e, \"preconditioner\": \"%s\", \"factor_s\": %.3f, "
      "\"s_per_newton_iteration_after_factor\": %.4f, "
      "\"particle_steps_per_s\": %.4g, \"baseline\": \"explicit_same_sim_time\", "
      "\"baseline_steps_per_dt\": %d, \"baseline_seconds_per_dt\": %.4f, \"implicit_over_explicit\": %.2f, "
      "\"cpu_per_wall\": %.2f}\n",
      name.c_str(), threads(), n, sim.clampedCount(), nbr, dt, steps, implicit_s, newton_it, cg_it, per_step,
      implicit_s / std::max(1, newton_it), implicit_s / std::max(1, cg_it), double(cg_it) / std::max(1, newton_it),
      worst_residual, sim.preconditionerNote().empty() ? RestStiffnessPreconditioner::backend().c_str() : "jacobi",
      factor_s, (implicit_s - factor_s) / std::max(1, newton_it), double(n) * steps / implicit_s, ex_steps_per_dt, ex_s,
      per_step / ex_s, meter.ratio());
  std::fflush(stdout);
}

// ---------------------------------------------------------------- 3. rollout gradients

/// ℓ_k = mean_i z_i / steps (a trajectory term) + at the last step ½ Σ_i |x_i − X_i|² + ½ Σ_i |v_i|².
SoftStepLoss trajectoryLoss(const Vec3s& X, int steps) {
  return [X, steps](int k, double, const Vec3s& x, const Vec3s& v, Vec3s* gx, Vec3s* gv) {
    const std::size_t n = x.size();
    const double w = 1.0 / (double(n) * steps);
    double l = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      l += w * x[i].z();
      if (gx) (*gx)[i].z() += w;
      if (k == steps) {
        l += 0.5 * (x[i] - X[i]).squaredNorm() + 0.5 * v[i].squaredNorm();
        if (gx) (*gx)[i] += x[i] - X[i];
        if (gv) (*gv)[i] += v[i];
      }
    }
    return l;
  };
}

void rolloutCase(const std::string& name, int nx, int ny, int nz, SoftIntegrator integ, int steps, double dt_implicit) {
  if (!selected(name)) return;
  const VolumeCloud c = box(nx, ny, nz);
  const std::size_t n = c.size();
  const CpuMeter meter;
  SoftRolloutOptions ro;
  ro.integrator = integ;
  ro.steps = steps;
  SoftRolloutResult fwd, full;
  double nbr = 0.0;
  {
    SoftBodySimulator sim = makeSim(c, true);
    nbr = meanNeighbours(sim.sph());
    ro.dt = integ == SoftIntegrator::ImplicitEuler ? dt_implicit : 0.5 * sim.stableTimeStep();
    SoftRollout roll(&sim, ro);
    fwd = roll.run(trajectoryLoss(c.X, steps), false);
  }
  {
    SoftBodySimulator sim = makeSim(c, true);
    SoftRollout roll(&sim, ro);
    full = roll.run(trajectoryLoss(c.X, steps), true);
  }
  const double ratio = full.backward_s / full.forward_s;
  const int K = static_cast<int>(std::ceil(std::sqrt(double(steps))));
  std::printf(
      "{\"case\": \"%s\", \"threads\": %d, \"particles\": %zu, \"neighbours_mean\": %.2f, "
      "\"integrator\": \"%s\", \"dt_s\": %.3e, \"steps\": %d, \"checkpoint_every\": %d, \"peak_states\": %zu, "
      "\"forward_s\": %.4f, \"backward_s\": %.4f, \"backward_over_forward\": %.3f, \"goal_backward_over_forward\": 3, "
      "\"goal_met\": %s, \"baseline\": \"forward_only\", \"baseline_forward_s\": %.4f, "
      "\"forward_with_gradient_over_forward_only\": %.3f, \"backward_over_forward_only\": %.3f, "
      "\"backward_minus_recompute_over_forward_only\": %.3f, \"loss\": %.6e, \"loss_matches_forward_only\": %s, "
      "\"cpu_per_wall\": %.2f}\n",
      name.c_str(), threads(), n, nbr, integ == SoftIntegrator::ImplicitEuler ? "ImplicitEuler" : "SymplecticEuler",
      ro.dt, steps, K, full.peak_states, full.forward_s, full.backward_s, ratio, ratio <= 3.0 ? "true" : "false",
      fwd.forward_s, full.forward_s / fwd.forward_s, full.backward_s / fwd.forward_s,
      (full.backward_s - fwd.forward_s) / fwd.forward_s, full.loss,
      std::abs(full.loss - fwd.loss) <= 1e-12 * std::max(1.0, std::abs(fwd.loss)) ? "true" : "false", meter.ratio());
  std::fflush(stdout);
}

// ---------------------------------------------------------------- 4. rollout memory (forked)

struct MemoryRun {
  int ok = 0, threads = 0;
  std::size_t particles = 0, peak_states = 0, peak_state_bytes = 0;
  int checkpoint_every = 0;
  long rss_before_kib = 0, rss_after_kib = 0;
  double forward_s = 0.0, backward_s = 0.0, neighbours = 0.0, cpu_per_wall = 0.0;
  char error[256] = {0};
};

MemoryRun memoryRunChild(const VolumeCloud& c, int steps, int K) {
  MemoryRun m;
  m.checkpoint_every = K;
  m.threads = threads();
  try {
    SoftBodySimulator sim = makeSim(c, true);
    m.particles = sim.size();
    m.neighbours = meanNeighbours(sim.sph());
    SoftRolloutOptions ro;
    ro.steps = steps;
    ro.dt = 0.5 * sim.stableTimeStep();
    ro.checkpoint_every = K;
    SoftRollout roll(&sim, ro);
    m.rss_before_kib = maxRssKiB();
    const CpuMeter meter;
    const SoftRolloutResult r = roll.run(trajectoryLoss(c.X, steps), true);
    m.rss_after_kib = maxRssKiB();
    m.cpu_per_wall = meter.ratio();
    m.peak_states = r.peak_states;
    m.peak_state_bytes = r.peak_state_bytes;
    m.forward_s = r.forward_s;
    m.backward_s = r.backward_s;
    m.ok = 1;
  } catch (const std::exception& e) {
    std::snprintf(m.error, sizeof(m.error), "%s", e.what());
  }
  return m;
}

struct Child {
  pid_t pid = -1;
  int fd = -1;
};

/// Starts memoryRunChild in a fresh child process (its own max RSS) with `nthreads` OpenMP threads.
/// Must be called before this process has started OpenMP threads (libgomp's pool does not survive
/// fork()).
Child startMemoryRun(const VolumeCloud& c, int steps, int K, int nthreads) {
  int fd[2];
  Child ch;
  if (pipe(fd) != 0) return ch;
  std::fflush(stdout);
  const pid_t pid = fork();
  if (pid == 0) {
    close(fd[0]);
#ifdef _OPENMP
    omp_set_num_threads(nthreads);
#else
    (void)nthreads;
#endif
    const MemoryRun r = memoryRunChild(c, steps, K);
    ssize_t w = write(fd[1], &r, sizeof(r));
    (void)w;
    close(fd[1]);
    _exit(0);
  }
  close(fd[1]);
  if (pid < 0) {
    close(fd[0]);
    return ch;
  }
  ch.pid = pid;
  ch.fd = fd[0];
  return ch;
}

MemoryRun finishMemoryRun(const Child& ch) {
  MemoryRun m;
  if (ch.pid < 0) {
    std::snprintf(m.error, sizeof(m.error), "pipe() or fork() failed");
    return m;
  }
  std::size_t got = 0;
  char* p = reinterpret_cast<char*>(&m);
  while (got < sizeof(m)) {
    const ssize_t r = read(ch.fd, p + got, sizeof(m) - got);
    if (r <= 0) break;
    got += static_cast<std::size_t>(r);
  }
  close(ch.fd);
  int status = 0;
  waitpid(ch.pid, &status, 0);
  if (got != sizeof(m)) {
    m = MemoryRun();
    std::snprintf(m.error, sizeof(m.error), "child exited without a result (status %d)", status);
  }
  return m;
}

std::string memoryLine(int steps, const MemoryRun& ck, const MemoryRun& all) {
  if (!ck.ok || !all.ok) {
    std::string e = ck.ok ? all.error : ck.error;
    for (char& ch : e)
      if (ch == '"' || ch == '\\' || ch == '\n') ch = '\'';
    return "{\"case\": \"memory_checkpointed\", \"error\": \"" + e + "\"}\n";
  }
  auto bytes = [](const MemoryRun& m) { return double(m.peak_state_bytes); };
  auto delta = [](const MemoryRun& m) { return double(m.rss_after_kib - m.rss_before_kib) * 1024.0; };
  char buf[2048];
  std::snprintf(
      buf, sizeof(buf),
      "{\"case\": \"memory_checkpointed\", \"threads\": %d, \"particles\": %zu, \"neighbours_mean\": %.2f, "
      "\"integrator\": \"SymplecticEuler\", \"steps\": %d, \"checkpoint_every\": %d, \"peak_states\": %zu, "
      "\"state_bytes\": %.0f, \"max_rss_before_kib\": %ld, \"max_rss_after_kib\": %ld, \"rollout_rss_growth_bytes\": "
      "%.0f, "
      "\"forward_s\": %.3f, \"backward_s\": %.3f, \"backward_over_forward\": %.3f, "
      "\"baseline\": \"store_every_state\", \"baseline_checkpoint_every\": %d, \"baseline_peak_states\": %zu, "
      "\"baseline_state_bytes\": %.0f, \"baseline_max_rss_before_kib\": %ld, \"baseline_max_rss_after_kib\": %ld, "
      "\"baseline_rollout_rss_growth_bytes\": %.0f, \"baseline_forward_s\": %.3f, \"baseline_backward_s\": %.3f, "
      "\"state_bytes_ratio\": %.4f, \"max_rss_ratio\": %.4f, \"rss_growth_ratio\": %.4f, \"cpu_per_wall\": %.2f, "
      "\"baseline_cpu_per_wall\": %.2f}\n",
      ck.threads, ck.particles, ck.neighbours, steps, ck.checkpoint_every, ck.peak_states, bytes(ck), ck.rss_before_kib,
      ck.rss_after_kib, delta(ck), ck.forward_s, ck.backward_s, ck.backward_s / ck.forward_s, all.checkpoint_every,
      all.peak_states, bytes(all), all.rss_before_kib, all.rss_after_kib, delta(all), all.forward_s, all.backward_s,
      bytes(ck) / bytes(all), double(ck.rss_after_kib) / double(all.rss_after_kib),
      delta(all) > 0 ? delta(ck) / delta(all) : 0.0, ck.cpu_per_wall, all.cpu_per_wall);
  return buf;
}

}  // namespace

int main(int argc, char** argv) {
  bool quick = false;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--quick") == 0)
      quick = true;
    else
      g_only = argv[i];
  }
  try {
    // 4 first (forked children, before any OpenMP thread exists here); printed last.
    std::string memory;
    if (selected("memory_checkpointed")) {
      const VolumeCloud c = quick ? box(10, 10, 10) : box(20, 20, 12);  // 4800 particles
      const int steps = quick ? 100 : 1000;
      const int K = static_cast<int>(std::ceil(std::sqrt(double(steps))));
      // The two runs go side by side, each on half the threads (wall time; each has its own RSS).
      const int t = std::max(1, threads() / 2);
      const Child a = startMemoryRun(c, steps, K, t);
      const Child b = startMemoryRun(c, steps, steps, t);
      const MemoryRun ck = finishMemoryRun(a);
      const MemoryRun all = finishMemoryRun(b);
      memory = memoryLine(steps, ck, all);
    }
    // 1. explicit: 40×25×20 = 20k and 80×50×25 = 100k particles.
    explicitCase("explicit_20k", 40, 25, 20, quick ? 5 : 200);
    explicitCase("explicit_100k", 80, 50, 25, quick ? 2 : 40);
    // 2. implicit at 20k.
    implicitCase("implicit_20k", 40, 25, 20, quick ? 1 : 2, 1e-3);
    // 3. rollout gradients: explicit 200 steps at 8k (40×20×10), implicit 20 steps at 2k (20×10×10).
    rolloutCase("rollout_explicit", 40, 20, 10, SoftIntegrator::SymplecticEuler, quick ? 20 : 200, 0.0);
    rolloutCase("rollout_implicit", 20, 10, 10, SoftIntegrator::ImplicitEuler, quick ? 4 : 20, 1e-3);
    std::fputs(memory.c_str(), stdout);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_soft: %s\n", e.what());
    return 1;
  }
  return 0;
}
