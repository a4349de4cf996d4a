// Host side of the GPU explicit soft-body step; see include/topo_gaussian/cuda/soft_body_cuda.h.
#include "topo_gaussian/cuda/soft_body_cuda.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/cuda/backend.h"

#if TOPO_HAVE_CUDA
#include "soft_body_cuda_impl.h"
#endif

namespace topo_gaussian {

#if TOPO_HAVE_CUDA

using cuda_detail::check;
using cuda_detail::DeviceBuffer;

SoftBodyCuda::SoftBodyCuda(const SoftBodySimulator& sim, CudaPrecision precision, int lanes)
    : impl_(std::make_unique<Impl>()) {
  if (lanes == 0) {
    const double nb = double(sim.sph().neighbors().indices.size()) / double(std::max<std::size_t>(1, sim.size()));
    const bool large = sim.size() >= 50000;
    if (precision == CudaPrecision::Float64)
      lanes = large ? 2 : 4;
    else
      lanes = large ? 2 : (nb >= 48.0 ? 8 : 4);
  }
  if (lanes != 1 && lanes != 2 && lanes != 4 && lanes != 8 && lanes != 16 && lanes != 32)
    throw TopoError("CUDA soft body", "lanes_per_particle " + std::to_string(lanes) + " is not a power of 2 up to 32",
                    "use 0 (automatic), 1, 2, 4, 8, 16 or 32");
  const CudaDeviceInfo& info = cudaDeviceInfo();
  if (!info.available) throw TopoError("CUDA soft body", info.reason, "use backend cpu (or auto) on this machine");
  if (sim.size() > static_cast<std::size_t>(std::numeric_limits<int>::max() / 16))
    throw TopoError("CUDA soft body", std::to_string(sim.size()) + " particles is more than the GPU step indexes",
                    "use a coarser spacing");
  {
    const double bpp = softBodyBytesPerParticle(sim, precision == CudaPrecision::Float64 ? 8.0 : 4.0);
    requireDeviceMemory("CUDA soft body (" + std::to_string(sim.size()) + " particles)", bpp * double(sim.size()), bpp);
  }
  impl_->precision = precision;
  impl_->n = sim.size();
  impl_->dt_stable = sim.stableTimeStep();
  check(cudaSetDevice(info.device), "cudaSetDevice");
  check(cudaStreamCreateWithFlags(&impl_->stream, cudaStreamNonBlocking), "stream creation");
  impl_->body64.lanes = impl_->body32.lanes = lanes;
  impl_->body64.dependent_launch = impl_->body32.dependent_launch = info.compute_capability >= 90 ? 1 : 0;
  if (precision == CudaPrecision::Float64) {
    impl_->build(sim, &impl_->body64);
    cuda_detail::launchEvaluateForces(impl_->body64, impl_->stream);  // F̃ and M at x (f as uploaded)
  } else {
    impl_->build(sim, &impl_->body32);
    cuda_detail::launchEvaluateForces(impl_->body32, impl_->stream);
  }
  synchronize();
}

SoftBodyCuda::~SoftBodyCuda() = default;

std::size_t SoftBodyCuda::size() const { return impl_->n; }
CudaPrecision SoftBodyCuda::precision() const { return impl_->precision; }
int SoftBodyCuda::lanesPerParticle() const { return impl_->body64.lanes; }
namespace {
/// A mode switch's value: -1, 0 or 1.
int modeOf(int mode) { return mode < 0 ? -1 : (mode > 0 ? 1 : 0); }
}  // namespace

void SoftBodyCuda::dropGraph() {
  if (impl_->graph) cudaGraphExecDestroy(impl_->graph);  // captured with the kernels chosen before
  impl_->graph = nullptr;
}

void SoftBodyCuda::setCappedEvaluation(int mode) {
  impl_->body64.capped_evaluation = impl_->body32.capped_evaluation = modeOf(mode);
  dropGraph();
}
bool SoftBodyCuda::cappedEvaluation() const {
  return impl_->precision == CudaPrecision::Float64 ? cuda_detail::evaluationCapped(impl_->body64)
                                                    : cuda_detail::evaluationCapped(impl_->body32);
}
void SoftBodyCuda::setWarpEvaluation(int mode) {
  const bool before = warpEvaluation();
  impl_->body64.warp_evaluation = impl_->body32.warp_evaluation = modeOf(mode);
  dropGraph();
  // The state's evaluation (f, F̃, the records) made again by the kernel now chosen, so that what a
  // caller reads next (the constructor evaluated before the mode was set) comes from it, to the bit.
  if (warpEvaluation() != before) {
    cuda_detail::launchEvaluateForces(impl_->body32, impl_->stream);
    synchronize();
  }
}
bool SoftBodyCuda::warpEvaluation() const {
  return impl_->precision == CudaPrecision::Float64 ? cuda_detail::evaluationWarp(impl_->body64)
                                                    : cuda_detail::evaluationWarp(impl_->body32);
}

void SoftBodyCuda::step(double dt, long steps) {
  if (!std::isfinite(dt) || dt <= 0.0 || steps < 0) {
    std::ostringstream s;
    s << "time step dt = " << dt << " s, " << steps << " steps";
    throw TopoError("SoftBodyCuda::step", s.str(), "use 0 < dt <= stableTimeStep() and steps >= 0");
  }
  if (dt > impl_->dt_stable) {
    std::ostringstream s;
    s << "time step dt = " << dt << " s exceeds the explicit stability estimate " << impl_->dt_stable << " s";
    throw TopoError("SoftBodyCuda::step", s.str(), "use dt <= " + std::to_string(impl_->dt_stable) + " s");
  }
  if (steps == 0) return;
  impl_->run(dt, steps);
  unsigned long long st[cuda_detail::kStatusWords];
  check(cudaMemcpyAsync(st, impl_->status(), sizeof(st), cudaMemcpyDeviceToHost, impl_->stream), "status read");
  check(cudaStreamSynchronize(impl_->stream), "step");
  const unsigned long long none = std::numeric_limits<unsigned long long>::max();
  if (st[0] != none || st[1] != none) {
    const bool inverted = st[0] != none;
    const unsigned long long w = inverted ? st[0] : st[1];
    std::ostringstream s;
    s << (inverted ? "particle " : "velocity of particle ") << (w & 0xffffffffull)
      << (inverted ? " inverted (det F <= 0)" : " became non-finite") << " at step " << (w >> 32);
    impl_->resetStatus(impl_->status());
    throw TopoError("SoftBodyCuda::step", s.str(), "reduce the time step or stiffen the material; check the loads");
  }
}

void SoftBodyCuda::download(std::vector<Eigen::Vector3d>* x, std::vector<Eigen::Vector3d>* v) const {
  const std::size_t n = impl_->n;
  auto fetch = [&](const void* dev, std::vector<Eigen::Vector3d>* out) {
    if (!out) return;
    out->resize(n);
    if (impl_->precision == CudaPrecision::Float64) {
      std::vector<double> h(3 * n);
      check(cudaMemcpy(h.data(), dev, h.size() * sizeof(double), cudaMemcpyDeviceToHost), "download");
      for (std::size_t i = 0; i < n; ++i) (*out)[i] = Eigen::Vector3d(h[3 * i], h[3 * i + 1], h[3 * i + 2]);
    } else {
      std::vector<float> h(3 * n);
      check(cudaMemcpy(h.data(), dev, h.size() * sizeof(float), cudaMemcpyDeviceToHost), "download");
      for (std::size_t i = 0; i < n; ++i) (*out)[i] = Eigen::Vector3d(h[3 * i], h[3 * i + 1], h[3 * i + 2]);
    }
  };
  synchronize();
  const bool f64 = impl_->precision == CudaPrecision::Float64;
  fetch(f64 ? static_cast<const void*>(impl_->body64.x) : impl_->body32.x, x);
  fetch(f64 ? static_cast<const void*>(impl_->body64.v) : impl_->body32.v, v);
}

std::vector<Eigen::Vector3d> SoftBodyCuda::forces() const {
  std::vector<Eigen::Vector3d> f(impl_->n);
  synchronize();
  if (impl_->precision == CudaPrecision::Float64) {
    std::vector<double> h(3 * impl_->n);
    check(cudaMemcpy(h.data(), impl_->body64.f, h.size() * sizeof(double), cudaMemcpyDeviceToHost), "download");
    for (std::size_t i = 0; i < impl_->n; ++i) f[i] = Eigen::Vector3d(h[3 * i], h[3 * i + 1], h[3 * i + 2]);
  } else {
    std::vector<float> h(3 * impl_->n);
    check(cudaMemcpy(h.data(), impl_->body32.f, h.size() * sizeof(float), cudaMemcpyDeviceToHost), "download");
    for (std::size_t i = 0; i < impl_->n; ++i) f[i] = Eigen::Vector3d(h[3 * i], h[3 * i + 1], h[3 * i + 2]);
  }
  return f;
}

double SoftBodyCuda::time() const {
  double t = 0.0;
  synchronize();
  const double* dev = impl_->precision == CudaPrecision::Float64 ? impl_->body64.time : impl_->body32.time;
  check(cudaMemcpy(&t, dev, sizeof(double), cudaMemcpyDeviceToHost), "download");
  return t;
}

long SoftBodyCuda::stepCount() const {
  long long s = 0;
  synchronize();
  const long long* dev = impl_->precision == CudaPrecision::Float64 ? impl_->body64.step : impl_->body32.step;
  check(cudaMemcpy(&s, dev, sizeof(long long), cudaMemcpyDeviceToHost), "download");
  return static_cast<long>(s);
}

void SoftBodyCuda::synchronize() const { check(cudaStreamSynchronize(impl_->stream), "synchronize"); }

std::size_t SoftBodyCuda::deviceBytes() const {
  std::size_t b = 0;
  for (const auto& buf : impl_->buffers) b += buf->bytes;
  return b;
}

namespace {
template <class T>
std::vector<Eigen::Matrix3d> polarOnDevice(const std::vector<Eigen::Matrix3d>& A, long* fallbacks) {
  const std::size_t n = A.size();
  std::vector<T> h(9 * n);
  for (std::size_t i = 0; i < n; ++i)
    for (int k = 0; k < 9; ++k) h[9 * i + k] = static_cast<T>(A[i].data()[k]);
  DeviceBuffer a, r, fb;
  a.allocate(h.size() * sizeof(T));
  r.allocate(h.size() * sizeof(T));
  fb.allocate(sizeof(unsigned long long));
  check(cudaMemcpy(a.ptr, h.data(), h.size() * sizeof(T), cudaMemcpyHostToDevice), "upload");
  check(cudaMemset(fb.ptr, 0, sizeof(unsigned long long)), "memset");
  cuda_detail::launchPolarRotations(static_cast<const T*>(a.ptr), static_cast<T*>(r.ptr), static_cast<int>(n),
                                    static_cast<unsigned long long*>(fb.ptr), nullptr);
  check(cudaGetLastError(), "kernel launch");
  check(cudaMemcpy(h.data(), r.ptr, h.size() * sizeof(T), cudaMemcpyDeviceToHost), "download");
  unsigned long long count = 0;
  check(cudaMemcpy(&count, fb.ptr, sizeof(count), cudaMemcpyDeviceToHost), "download");
  if (fallbacks) *fallbacks = static_cast<long>(count);
  std::vector<Eigen::Matrix3d> R(n);
  for (std::size_t i = 0; i < n; ++i)
    for (int k = 0; k < 9; ++k) R[i].data()[k] = h[9 * i + k];
  return R;
}
}  // namespace

std::vector<Eigen::Matrix3d> cudaPolarRotations(const std::vector<Eigen::Matrix3d>& A, CudaPrecision precision,
                                                long* fallbacks) {
  const CudaDeviceInfo& info = cudaDeviceInfo();
  if (!info.available) throw TopoError("cudaPolarRotations", info.reason, "run on a machine with a CUDA GPU");
  if (A.empty()) return {};
  return precision == CudaPrecision::Float64 ? polarOnDevice<double>(A, fallbacks) : polarOnDevice<float>(A, fallbacks);
}

#else  // no CUDA in this build: the API exists and refuses with the reason.

struct SoftBodyCuda::Impl {};

SoftBodyCuda::SoftBodyCuda(const SoftBodySimulator&, CudaPrecision, int) {
  throw TopoError("CUDA soft body", cudaDeviceInfo().reason, "use backend cpu (or auto), or rebuild with nvcc on PATH");
}
SoftBodyCuda::~SoftBodyCuda() = default;
std::size_t SoftBodyCuda::size() const { return 0; }
CudaPrecision SoftBodyCuda::precision() const { return CudaPrecision::Float64; }
int SoftBodyCuda::lanesPerParticle() const { return 0; }
void SoftBodyCuda::setCappedEvaluation(int) {}
bool SoftBodyCuda::cappedEvaluation() const { return false; }
void SoftBodyCuda::setWarpEvaluation(int) {}
bool SoftBodyCuda::warpEvaluation() const { return false; }
void SoftBodyCuda::step(double, long) {}
void SoftBodyCuda::download(std::vector<Eigen::Vector3d>*, std::vector<Eigen::Vector3d>*) const {}
std::vector<Eigen::Vector3d> SoftBodyCuda::forces() const { return {}; }
double SoftBodyCuda::time() const { return 0.0; }
long SoftBodyCuda::stepCount() const { return 0; }
void SoftBodyCuda::synchronize() const {}
std::size_t SoftBodyCuda::deviceBytes() const { return 0; }
std::vector<Eigen::Matrix3d> cudaPolarRotations(const std::vector<Eigen::Matrix3d>&, CudaPrecision, long*) {
  throw TopoError("cudaPolarRotations", cudaDeviceInfo().reason, "run on a machine with a CUDA GPU");
}

#endif

}  // namespace topo_gaussian
