// Host side of the GPU explicit soft-body step; see include/topo_gaussian/cuda/soft_body_cuda.h.
#include "topo_gaussian/cuda/soft_body_cuda.h"

#include <cmath>
#include <limits>
#include <sstream>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/cuda/backend.h"

#if TOPO_HAVE_CUDA
#include <cuda_runtime_api.h>

#include "soft_step_kernels.h"
#endif

namespace topo_gaussian {

#if TOPO_HAVE_CUDA

namespace {

void check(cudaError_t err, const char* what) {
  if (err != cudaSuccess)
    throw TopoError("CUDA soft body", std::string(what) + " failed: " + cudaGetErrorString(err),
                    "check that the GPU has enough free memory (deviceBytes()) and is not in use by a crashed "
                    "process; backend cpu runs without it");
}

/// A device allocation freed with its owner.
struct DeviceBuffer {
  void* ptr = nullptr;
  std::size_t bytes = 0;
  DeviceBuffer() = default;
  DeviceBuffer(const DeviceBuffer&) = delete;
  DeviceBuffer& operator=(const DeviceBuffer&) = delete;
  ~DeviceBuffer() {
    if (ptr) cudaFree(ptr);
  }
  void allocate(std::size_t b) {
    bytes = b;
    check(cudaMalloc(&ptr, b == 0 ? 1 : b), "cudaMalloc");
  }
};

}  // namespace

struct SoftBodyCuda::Impl {
  CudaPrecision precision = CudaPrecision::Float64;
  std::size_t n = 0;
  double dt_stable = 0.0;
  std::vector<std::unique_ptr<DeviceBuffer>> buffers;
  cudaStream_t stream = nullptr;
  cudaGraphExec_t graph = nullptr;
  double graph_dt = 0.0;
  long graph_steps = 0;
  cuda_detail::SoftDeviceBody<double> body64;
  cuda_detail::SoftDeviceBody<float> body32;

  ~Impl() {
    if (graph) cudaGraphExecDestroy(graph);
    if (stream) cudaStreamDestroy(stream);
  }

  template <class U>
  U* upload(const std::vector<U>& host) {
    buffers.push_back(std::make_unique<DeviceBuffer>());
    buffers.back()->allocate(host.size() * sizeof(U));
    if (!host.empty())
      check(cudaMemcpy(buffers.back()->ptr, host.data(), host.size() * sizeof(U), cudaMemcpyHostToDevice), "upload");
    return static_cast<U*>(buffers.back()->ptr);
  }
  template <class U>
  U* allocate(std::size_t count) {
    buffers.push_back(std::make_unique<DeviceBuffer>());
    buffers.back()->allocate(count * sizeof(U));
    return static_cast<U*>(buffers.back()->ptr);
  }

  template <class T>
  static std::vector<T> flat(const std::vector<Eigen::Vector3d>& v) {
    std::vector<T> out(3 * v.size());
    for (std::size_t i = 0; i < v.size(); ++i)
      for (int d = 0; d < 3; ++d) out[3 * i + d] = static_cast<T>(v[i](d));
    return out;
  }
  template <class T>
  static std::vector<T> flat(const std::vector<Eigen::Matrix3d>& m) {
    std::vector<T> out(9 * m.size());
    for (std::size_t i = 0; i < m.size(); ++i)
      for (int k = 0; k < 9; ++k) out[9 * i + k] = static_cast<T>(m[i].data()[k]);
    return out;
  }
  template <class T, std::size_t K>
  static std::vector<T> flat(const std::vector<std::array<double, K>>& a) {
    std::vector<T> out(K * a.size());
    for (std::size_t i = 0; i < a.size(); ++i)
      for (std::size_t k = 0; k < K; ++k) out[K * i + k] = static_cast<T>(a[i][k]);
    return out;
  }
  template <class T>
  static std::vector<T> cast(const std::vector<double>& v) {
    return std::vector<T>(v.begin(), v.end());
  }

  template <class T>
  void build(const SoftBodySimulator& sim, cuda_detail::SoftDeviceBody<T>* b) {
    const CorotatedSph& sph = sim.sph();
    const NeighborList& nbr = sph.neighbors();
    b->n = static_cast<int>(n);
    b->nnz = static_cast<int>(nbr.indices.size());
    b->offsets = upload(nbr.offsets);
    b->idx = upload(nbr.indices);
    b->X = upload(flat<T>(sph.restPositions()));
    b->V = upload(cast<T>(sph.volumes()));
    b->mass = upload(cast<T>(sim.masses()));
    b->mu = upload(cast<T>(sph.shearModuli()));
    b->lambda = upload(cast<T>(sph.lameLambdas()));
    b->c = upload(cast<T>(sph.hourglassCoefficients()));
    b->gh = upload(flat<T>(sph.kernelGradients()));
    b->W = upload(cast<T>(sph.kernelValues()));
    b->ghr = upload(flat<T>(sph.reverseKernelGradients()));
    b->hgw = upload(flat<T>(sph.hourglassWeights()));
    b->gsum = upload(flat<T>(sph.gradientSums()));
    b->hgsum = upload(flat<T>(sph.hourglassSums()));
    b->hourglass = sph.options().hourglass_alpha > 0.0 ? 1 : 0;
    b->moment = b->hourglass ? upload(flat<T>(sph.restMoments())) : nullptr;
    b->clamped = upload(sim.clamped());
    const PneumaticActuation& act = sim.actuation();
    b->chamber = act.chamber.empty() ? nullptr : upload(cast<T>(act.chamber));
    b->pressure_pa = act.pressure_pa;
    b->ramp_s = act.ramp_s;
    b->stvk = sph.options().model == SphEnergyModel::StVK ? 1 : 0;
    b->shape_matching = sph.options().rotation == SphRotationSource::ShapeMatchingApq ? 1 : 0;
    for (int d = 0; d < 3; ++d) b->gravity[d] = static_cast<T>(sim.options().gravity(d));
    b->damping = static_cast<T>(sim.options().damping);
    b->x = upload(flat<T>(sim.positions()));
    b->v = upload(flat<T>(sim.velocities()));
    b->f = upload(flat<T>(sim.conservativeForces()));
    b->Ft = allocate<T>(9 * n);
    b->M = allocate<T>(9 * n);
    b->time = upload(std::vector<double>{sim.time()});
    b->step = upload(std::vector<long long>{static_cast<long long>(sim.stepCount())});
    b->status = upload(std::vector<unsigned long long>(cuda_detail::kStatusWords, 0));
    resetStatus(b->status);
  }

  void resetStatus(unsigned long long* status) {
    const unsigned long long init[cuda_detail::kStatusWords] = {std::numeric_limits<unsigned long long>::max(),
                                                                std::numeric_limits<unsigned long long>::max(), 0, 0};
    check(cudaMemcpyAsync(status, init, sizeof(init), cudaMemcpyHostToDevice, stream), "status reset");
  }

  unsigned long long* status() const { return precision == CudaPrecision::Float64 ? body64.status : body32.status; }

  void launchSteps(double dt, long steps) {
    for (long s = 0; s < steps; ++s) {
      if (precision == CudaPrecision::Float64)
        cuda_detail::launchLeapfrogStep(body64, dt, stream);
      else
        cuda_detail::launchLeapfrogStep(body32, dt, stream);
    }
  }

  /// Runs `steps` steps: batches of up to kGraphSteps replayed from one captured graph.
  void run(double dt, long steps) {
    constexpr long kGraphSteps = 50;
    const long chunk = std::min(steps, kGraphSteps);
    if (chunk >= 2 && (graph == nullptr || graph_dt != dt || graph_steps != chunk)) {
      if (graph) cudaGraphExecDestroy(graph);
      graph = nullptr;
      cudaGraph_t g = nullptr;
      check(cudaStreamBeginCapture(stream, cudaStreamCaptureModeThreadLocal), "graph capture");
      launchSteps(dt, chunk);
      check(cudaStreamEndCapture(stream, &g), "graph capture");
      check(cudaGraphInstantiate(&graph, g, 0), "graph instantiation");
      cudaGraphDestroy(g);
      graph_dt = dt;
      graph_steps = chunk;
    }
    long done = 0;
    if (chunk >= 2)
      for (; done + chunk <= steps; done += chunk) check(cudaGraphLaunch(graph, stream), "graph launch");
    launchSteps(dt, steps - done);
    check(cudaGetLastError(), "kernel launch");
  }
};

SoftBodyCuda::SoftBodyCuda(const SoftBodySimulator& sim, CudaPrecision precision, int lanes)
    : impl_(std::make_unique<Impl>()) {
  if (lanes != 1 && lanes != 2 && lanes != 4 && lanes != 8 && lanes != 16 && lanes != 32)
    throw TopoError("CUDA soft body", "lanes_per_particle " + std::to_string(lanes) + " is not a power of 2 up to 32",
                    "use 8 (or 1, 2, 4, 16, 32)");
  const CudaDeviceInfo& info = cudaDeviceInfo();
  if (!info.available) throw TopoError("CUDA soft body", info.reason, "use backend cpu (or auto) on this machine");
  if (!sim.contact().empty())
    throw TopoError("CUDA soft body", "the simulator has contact, which the GPU step does not model yet",
                    "use backend cpu for soft bodies with contact (the pear); clamped bodies (beams, the finger) run "
                    "on the GPU");
  if (sim.size() > static_cast<std::size_t>(std::numeric_limits<int>::max() / 16))
    throw TopoError("CUDA soft body", std::to_string(sim.size()) + " particles is more than the GPU step indexes",
                    "use a coarser spacing");
  impl_->precision = precision;
  impl_->n = sim.size();
  impl_->dt_stable = sim.stableTimeStep();
  check(cudaSetDevice(info.device), "cudaSetDevice");
  check(cudaStreamCreateWithFlags(&impl_->stream, cudaStreamNonBlocking), "stream creation");
  impl_->body64.lanes = impl_->body32.lanes = lanes;
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
