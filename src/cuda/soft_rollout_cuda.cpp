// The explicit rollout and its adjoint on the GPU; see include/topo_gaussian/cuda/soft_rollout_cuda.h.
#include "topo_gaussian/cuda/soft_rollout_cuda.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <future>
#include <sstream>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/cuda/backend.h"

#if TOPO_HAVE_CUDA
#include "soft_body_cuda_impl.h"
#endif

namespace topo_gaussian {

namespace {

void checkOptions(const SoftBodySimulator& sim, const SoftRolloutOptions& o) {
  if (o.integrator != SoftIntegrator::SymplecticEuler)
    throw TopoError("CUDA soft rollout", "implicit Euler steps are not on the GPU yet",
                    "use the explicit (symplectic Euler) integrator, or backend cpu");
  if (!std::isfinite(o.dt) || o.dt <= 0.0 || o.steps < 1) {
    std::ostringstream s;
    s << "dt = " << o.dt << " s, steps = " << o.steps;
    throw TopoError("CUDA soft rollout", s.str(), "use dt > 0 and at least one step");
  }
  if (o.dt > sim.stableTimeStep()) {
    std::ostringstream s;
    s << "dt = " << o.dt << " s exceeds the explicit stability estimate " << sim.stableTimeStep() << " s";
    throw TopoError("CUDA soft rollout", s.str(), "use dt <= stableTimeStep() (e.g. half of it)");
  }
}

double since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

#if TOPO_HAVE_CUDA

namespace {

using Vec3s = std::vector<Eigen::Vector3d>;

template <class T>
cuda_detail::SoftDeviceBody<T>& bodyOf(SoftBodyCuda::Impl& I);
template <>
cuda_detail::SoftDeviceBody<double>& bodyOf<double>(SoftBodyCuda::Impl& I) {
  return I.body64;
}
template <>
cuda_detail::SoftDeviceBody<float>& bodyOf<float>(SoftBodyCuda::Impl& I) {
  return I.body32;
}

template <class T>
void toHost(const T* dev, std::size_t n, cudaStream_t s, Vec3s* out) {
  std::vector<T> h(3 * n);
  check(cudaMemcpyAsync(h.data(), dev, h.size() * sizeof(T), cudaMemcpyDeviceToHost, s), "download");
  check(cudaStreamSynchronize(s), "download");
  out->resize(n);
  for (std::size_t i = 0; i < n; ++i) (*out)[i] = Eigen::Vector3d(h[3 * i], h[3 * i + 1], h[3 * i + 2]);
}

template <class T>
void toDevice(const Vec3s& v, T* dev, cudaStream_t s) {
  std::vector<T> h(3 * v.size());
  for (std::size_t i = 0; i < v.size(); ++i)
    for (int d = 0; d < 3; ++d) h[3 * i + d] = static_cast<T>(v[i](d));
  check(cudaMemcpyAsync(dev, h.data(), h.size() * sizeof(T), cudaMemcpyHostToDevice, s), "upload");
  check(cudaStreamSynchronize(s), "upload");  // h goes out of scope
}

template <class T>
std::vector<double> scalarsToHost(const T* dev, std::size_t n, cudaStream_t s) {
  std::vector<T> h(n);
  check(cudaMemcpyAsync(h.data(), dev, n * sizeof(T), cudaMemcpyDeviceToHost, s), "download");
  check(cudaStreamSynchronize(s), "download");
  return std::vector<double>(h.begin(), h.end());
}

/// Throws when the kernels flagged a non-finite or inverted particle; `where` names the step.
void checkStatus(SoftBodyCuda::Impl& I, const std::string& where) {
  unsigned long long st[cuda_detail::kStatusWords];
  check(cudaMemcpyAsync(st, I.status(), sizeof(st), cudaMemcpyDeviceToHost, I.stream), "status read");
  check(cudaStreamSynchronize(I.stream), "status read");
  const unsigned long long none = std::numeric_limits<unsigned long long>::max();
  if (st[0] == none && st[1] == none) return;
  const bool inverted = st[0] != none;
  std::ostringstream s;
  s << "particle " << ((inverted ? st[0] : st[1]) & 0xffffffffull)
    << (inverted ? " inverted (det F <= 0)" : " became non-finite") << " at " << where;
  I.resetStatus(I.status());
  throw TopoError("CUDA soft rollout", s.str(), "reduce dt or check the material and loads");
}

template <class T>
SoftRolloutResult rollout(SoftBodySimulator* sim, const SoftRolloutOptions& opt, const SoftStepLoss& loss,
                          bool with_gradient, CudaPrecision precision) {
  const std::size_t n = sim->size();
  const int N = opt.steps;
  const double dt = opt.dt, t0 = sim->time();
  SoftBodyCuda gpu(*sim, precision);
  // The group evaluation kernel at every size: float32 gradients are held to their tolerance with it
  // (forced, the warp kernel moved the test's x0 error from 8.7e-4 to 1.2e-3, bench/gpu/README.md).
  gpu.setWarpEvaluation(0);
  SoftBodyCuda::Impl& I = gpu.impl();
  cuda_detail::SoftDeviceBody<T>& b = bodyOf<T>(I);
  cudaStream_t s = I.stream;
  const std::size_t bytes3 = 3 * n * sizeof(T);
  auto copy = [&](T* dst, const T* src) {
    check(cudaMemcpyAsync(dst, src, bytes3, cudaMemcpyDeviceToDevice, s), "device copy");
  };
  // A stored state: x, v, f (9n values), the evaluation its adjoint step reads at x_k (F̃, R: 18n; the
  // gather's record or M is only the step's own scratch, in the body's buffers) and its clock.
  const std::size_t eval_values = 18 * n;
  const double state_bytes = static_cast<double>((9 * n + eval_values) * sizeof(T) + sizeof(double));
  // With checkpoint_every ≤ 0 every state is kept when they fit in half of the free memory (then the
  // backward recomputes nothing); else checkpoints every K = ⌈√N⌉ steps (or checkpoint_every) and
  // each segment recomputed.
  bool keep_all = false;
  if (with_gradient && opt.checkpoint_every <= 0) {
    std::size_t free_b = 0, total_b = 0;
    if (cudaMemGetInfo(&free_b, &total_b) == cudaSuccess)
      keep_all = (N + 1.0) * state_bytes + 70.0 * sizeof(T) * n <= 0.5 * static_cast<double>(free_b);
    else
      cudaGetLastError();
  }
  const int K = keep_all                   ? N
                : opt.checkpoint_every > 0 ? std::min(opt.checkpoint_every, N)
                                           : static_cast<int>(std::ceil(std::sqrt(double(N))));
  // The segment's states (one segment of K steps, or all N with keep_all).
  T* seg = nullptr;
  T* seg_eval = nullptr;
  double* seg_time = nullptr;
  // The adjoint's work space, allocated with them before the forward starts (neither pass's time
  // holds a cudaMalloc).
  T *xb = nullptr, *vb = nullptr, *dl = nullptr, *G = nullptr, *work = nullptr;
  if (with_gradient) {
    seg = I.allocate<T>(static_cast<std::size_t>(K + 1) * 9 * n);
    seg_eval = I.allocate<T>(static_cast<std::size_t>(K + 1) * eval_values);
    seg_time = I.allocate<double>(static_cast<std::size_t>(K + 1));
    xb = I.allocate<T>(3 * n);
    vb = I.allocate<T>(3 * n);
    dl = I.allocate<T>(6 * n);
    G = I.allocate<T>(4 * n);                                   // mass, mu, lambda, chamber
    work = I.allocate<T>((30 + cuda_detail::kRecord) * n + 4);  // + 4: the record 16-byte aligned
  }
  // The body at segment state q: its x, v, f, evaluation and clock.
  auto at = [&](int q) {
    cuda_detail::SoftDeviceBody<T> bq = b;
    bq.x = seg + static_cast<std::size_t>(q) * 9 * n;
    bq.v = bq.x + 3 * n;
    bq.f = bq.x + 6 * n;
    T* e = seg_eval + static_cast<std::size_t>(q) * eval_values;
    bq.Ft = e;
    bq.R = e + 9 * n;
    bq.time = seg_time + q;
    return bq;
  };

  SoftRolloutResult res;
  // The last segment [last0, N) runs in the forward into the segment's slots, so the backward starts
  // without recomputing it (keep_all: the whole rollout is that segment). The segments before it end
  // where the next begins, counted back from last0 in steps of K (the first one the shortest):
  // checkpoints at their starts, each segment recomputed once.
  const int last0 = !with_gradient ? N : keep_all ? 0 : std::max(0, N - K);
  std::vector<int> starts;  // ascending, all < last0
  if (with_gradient && !keep_all && last0 > 0) {
    for (int p = last0 - K; p > 0; p -= K) starts.push_back(p);
    starts.push_back(0);
    std::reverse(starts.begin(), starts.end());
  }
  // Checkpoints (x, v, f) in device memory, one allocation for all (9n values each), and their clocks
  // (the recomputation continues the forward's clock, not t0 + k dt from the host).
  std::vector<T*> checkpoints;
  T* checkpoint_store = starts.empty() ? nullptr : I.allocate<T>(starts.size() * 9 * n);
  double* checkpoint_time = checkpoint_store ? I.allocate<double>(starts.size()) : nullptr;
  auto copyClock = [&](double* dst, const double* src) {
    check(cudaMemcpyAsync(dst, src, sizeof(double), cudaMemcpyDeviceToDevice, s), "device copy");
  };
  auto counts = [&](int k) { return !opt.loss_at || opt.loss_at(k); };
  auto tf = std::chrono::steady_clock::now();
  Vec3s x, v;
  if (counts(0)) {
    toHost(b.x, n, s, &x);
    toHost(b.v, n, s, &v);
    res.loss = loss(0, t0, x, v, nullptr, nullptr);
  }
  for (int k = 0; k < N; ++k) {
    if (checkpoints.size() < starts.size() && k == starts[checkpoints.size()]) {
      T* c = checkpoint_store + checkpoints.size() * 9 * n;
      copy(c, b.x);
      copy(c + 3 * n, b.v);
      copy(c + 6 * n, b.f);
      copyClock(checkpoint_time + checkpoints.size(), b.time);
      checkpoints.push_back(c);
    }
    if (k == last0) {  // the last segment's first state: the body's x, v, f, its evaluation and clock
      copy(seg, b.x);
      copy(seg + 3 * n, b.v);
      copy(seg + 6 * n, b.f);
      copyClock(seg_time, b.time);
      cuda_detail::launchEvaluateState(at(0), s);
    }
    if (k >= last0)
      cuda_detail::launchSymplecticStepInto(at(k - last0), at(k - last0 + 1), dt, s);
    else
      cuda_detail::launchSymplecticStep(b, dt, s);
    check(cudaGetLastError(), "kernel launch");
    if (!counts(k + 1) && k + 1 < N) continue;  // no host copy: the loss is zero at this step
    checkStatus(I, "the explicit steps up to " + std::to_string(k + 1));
    const T* xs = k + 1 > last0 ? seg + static_cast<std::size_t>(k + 1 - last0) * 9 * n : b.x;
    toHost(xs, n, s, &x);
    toHost(xs == b.x ? b.v : xs + 3 * n, n, s, &v);
    if (counts(k + 1)) res.loss += loss(k + 1, t0 + (k + 1) * dt, x, v, nullptr, nullptr);
  }
  res.forward_s = since(tf);
  res.peak_states = checkpoints.size() + (with_gradient ? static_cast<std::size_t>(N - last0 + 1) : 0);
  res.peak_state_bytes = res.peak_states * 9 * n * sizeof(T);
  const Vec3s x_end = x, v_end = v;
  const double t_end = t0 + N * dt;
  if (!with_gradient) {
    sim->evaluateAt(x_end, t_end);
    sim->setVelocities(v_end);
    return res;
  }

  auto tb = std::chrono::steady_clock::now();
  // The simulator is left at the final state on the host (SoftRollout's contract): its evaluation
  // there runs on a host thread while the device works backwards (the loop below only reads its
  // copy of the clamp flags; the loss callback is given the states, not the simulator).
  const std::vector<std::uint8_t> clamped = sim->clamped();  // the loop's copy: sim changes meanwhile
  std::future<void> restored = std::async(std::launch::async, [&] {
    sim->evaluateAt(x_end, t_end);
    sim->setVelocities(v_end);
  });
  check(cudaMemsetAsync(G, 0, 4 * n * sizeof(T), s), "memset");
  {
    Vec3s xb0(n, Eigen::Vector3d::Zero()), vb0(n, Eigen::Vector3d::Zero());
    if (counts(N)) loss(N, t_end, x_end, v_end, &xb0, &vb0);
    toDevice(xb0, xb, s);
    toDevice(vb0, vb, s);
  }
  const bool chamber = b.chamber != nullptr;
  // From the last segment (its states kept by the forward) back to the first, each earlier one
  // recomputed from its checkpoint.
  const int segments = static_cast<int>(starts.size()) + 1;
  for (int sg = segments - 1; sg >= 0; --sg) {
    const bool kept = sg == segments - 1;
    const int k0 = kept ? last0 : starts[sg], k1 = kept ? N : sg + 1 < segments - 1 ? starts[sg + 1] : last0;
    if (!kept) {
      // Recompute the segment from its checkpoint, each step out of place into the next state's slot
      // (x, v, f, the evaluation at x, the clock): no copies, no clock set from the host.
      check(cudaMemcpyAsync(seg, checkpoints[sg], 9 * n * sizeof(T), cudaMemcpyDeviceToDevice, s), "device copy");
      copyClock(seg_time, checkpoint_time + sg);
      cuda_detail::launchEvaluateState(at(0), s);  // F̃, R at the checkpoint (its f is kept)
      for (int k = k0; k < k1; ++k) cuda_detail::launchSymplecticStepInto(at(k - k0), at(k - k0 + 1), dt, s);
      check(cudaGetLastError(), "kernel launch");
      checkStatus(I, "the recomputed segment from step " + std::to_string(k0));
    }
    for (int k = k1 - 1; k >= k0; --k) {
      const T* st = seg + static_cast<std::size_t>(k - k0) * 9 * n;
      // x_k, v_k (the friction adjoint's velocity), f_k and F̃, R at x_k: all kept by the recomputation
      const cuda_detail::SoftDeviceBody<T> bk = at(k - k0);
      cuda_detail::launchAdjointStep(bk, st + 6 * n, dt, xb, vb, G, G + n, G + 2 * n, chamber ? G + 3 * n : nullptr,
                                     work, s);
      cuda_detail::launchContactAdjoint(bk, xb, vb, G, work, s);  // a = work[0, 3n)
      check(cudaGetLastError(), "kernel launch");
      // ∂ℓ_k/∂x_k and ∂ℓ_k/∂v_k from the host loss.
      if (!counts(k)) continue;
      Vec3s xk, vk, dlx(n, Eigen::Vector3d::Zero()), dlv(n, Eigen::Vector3d::Zero());
      toHost(st, n, s, &xk);
      toHost(st + 3 * n, n, s, &vk);
      loss(k, t0 + k * dt, xk, vk, &dlx, &dlv);
      for (std::size_t i = 0; i < n; ++i)
        if (clamped[i]) dlx[i].setZero(), dlv[i].setZero();
      toDevice(dlx, dl, s);
      toDevice(dlv, dl + 3 * n, s);
      cuda_detail::launchAdd(xb, dl, static_cast<int>(3 * n), s);
      cuda_detail::launchAdd(vb, dl + 3 * n, static_cast<int>(3 * n), s);
    }
  }
  SoftDesignGradient& g = res.gradient;
  g.mass = scalarsToHost(G, n, s);
  g.mu = scalarsToHost(G + n, n, s);
  g.lambda = scalarsToHost(G + 2 * n, n, s);
  g.chamber = chamber ? scalarsToHost(G + 3 * n, n, s) : std::vector<double>(n, 0.0);
  toHost(xb, n, s, &g.x0);
  toHost(vb, n, s, &g.v0);
  for (std::size_t i = 0; i < n; ++i)
    if (clamped[i]) g.x0[i].setZero(), g.v0[i].setZero();
  // the checkpoints and one segment's states with their evaluations
  res.peak_state_bytes = (res.peak_states * 9 * n + static_cast<std::size_t>(K + 1) * eval_values) * sizeof(T);
  restored.get();  // rethrows what the host evaluation threw
  res.backward_s = since(tb);
  return res;
}

}  // namespace

SoftRolloutResult runSoftRolloutCuda(SoftBodySimulator* sim, const SoftRolloutOptions& options,
                                     const SoftStepLoss& loss, bool with_gradient, CudaPrecision precision) {
  if (!sim) throw TopoError("CUDA soft rollout", "no simulator", "pass a SoftBodySimulator");
  const CudaDeviceInfo& info = cudaDeviceInfo();
  if (!info.available) throw TopoError("CUDA soft rollout", info.reason, "use backend cpu (or auto) on this machine");
  checkOptions(*sim, options);
  {
    // The body, the checkpoints, one recomputed segment with each state's evaluation (F̃, R: 18 values a
    // particle) and the adjoint's arrays (70 values a particle: x̄, v̄, the loss gradient, the design gradients and the
    // step's work, its gather record included).
    const double T = precision == CudaPrecision::Float64 ? 8.0 : 4.0;
    const int N = options.steps;
    const int K = options.checkpoint_every > 0 ? std::min(options.checkpoint_every, N)
                                               : static_cast<int>(std::ceil(std::sqrt(double(N))));
    const double states = std::ceil(double(N) / K) + (with_gradient ? K + 1 : 0);
    const double evaluations = with_gradient ? (K + 1) * 18.0 : 0.0;
    const double bpp =
        softBodyBytesPerParticle(*sim, T) + T * (9.0 * states + evaluations + (with_gradient ? 70.0 : 0.0));
    requireDeviceMemory(
        "CUDA soft rollout (" + std::to_string(sim->size()) + " particles, " + std::to_string(N) + " steps)",
        bpp * double(sim->size()), bpp);
  }
  return precision == CudaPrecision::Float64 ? rollout<double>(sim, options, loss, with_gradient, precision)
                                             : rollout<float>(sim, options, loss, with_gradient, precision);
}

#else

SoftRolloutResult runSoftRolloutCuda(SoftBodySimulator* sim, const SoftRolloutOptions& options, const SoftStepLoss&,
                                     bool, CudaPrecision) {
  if (sim) checkOptions(*sim, options);
  (void)since;
  throw TopoError("CUDA soft rollout", cudaDeviceInfo().reason, "use backend cpu (or auto), or rebuild with nvcc");
}

#endif

}  // namespace topo_gaussian
