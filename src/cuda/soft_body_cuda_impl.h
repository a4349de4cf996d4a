// Host-side state of a soft body on the GPU (SoftBodyCuda::Impl): device buffers, the stream, the
// captured step graph and the device layout (soft_step_kernels.h). Shared by soft_body_cuda.cpp and
// soft_rollout_cuda.cpp; only compiled with TOPO_HAVE_CUDA.
#pragma once

#include <cuda_runtime_api.h>

#include <algorithm>
#include <array>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "soft_step_kernels.h"
#include "topo_gaussian/common/error.h"
#include "topo_gaussian/cuda/soft_body_cuda.h"
#include "topo_gaussian/physics/sph_kernel.h"

namespace topo_gaussian {

namespace cuda_detail {

/// Throws TopoError naming `input` when err is not cudaSuccess; the runtime's last error is cleared
/// first, so a later launch check does not report this one again.
inline void check(cudaError_t err, const char* what, const char* input = "CUDA soft body") {
  if (err != cudaSuccess) {
    cudaGetLastError();
    throw TopoError(input, std::string(what) + " failed: " + cudaGetErrorString(err),
                    "check that the GPU has enough free memory and is not in use by a crashed process; backend cpu "
                    "runs without it");
  }
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
  void free() {
    if (ptr) cudaFree(ptr);
    ptr = nullptr;
    bytes = 0;
  }
  void allocate(std::size_t b, const char* input = "CUDA soft body") {
    free();
    bytes = b;
    check(cudaMalloc(&ptr, b == 0 ? 1 : b), "cudaMalloc", input);
  }
};

}  // namespace cuda_detail

using cuda_detail::check;
using cuda_detail::DeviceBuffer;

/// Whether the step recomputes ĝ and W per entry (order-1 gradients, SoftDeviceBody::L).
inline bool recomputesKernelGradients(const SoftBodySimulator& sim) { return sim.sph().options().gradient_order == 1; }

/// Device bytes per particle of a body (SoftDeviceBody's arrays: 54 values and 5 bytes per particle
/// with the double-buffered x, 11 values and 4 bytes per neighbour entry; with recomputed gradients
/// 27 values (the gather's record, Σ V_j ∇W) and 104 bytes (X and L in float64) more), T the
/// precision's size.
inline double softBodyBytesPerParticle(const SoftBodySimulator& sim, double T) {
  const double nb = double(sim.sph().neighbors().indices.size()) / double(std::max<std::size_t>(1, sim.size()));
  return 54.0 * T + 5.0 + nb * (4.0 + 11.0 * T) + (recomputesKernelGradients(sim) ? 27.0 * T + 104.0 : 0.0);
}

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
    b->ghr = upload(flat<T>(sph.reverseKernelGradients()));  // the adjoint's gather streams these
    b->hgw = upload(flat<T>(sph.hourglassWeights()));
    if (recomputesKernelGradients(sim)) {
      const double h = sph.smoothingLength();
      std::vector<Eigen::Matrix3d> L(n);
      std::vector<Eigen::Vector3d> gsum_raw(n, Eigen::Vector3d::Zero());
      std::vector<double> Xr(4 * n, 0.0);
      for (std::size_t i = 0; i < n; ++i) {
        L[i] = sph.correction(i);
        // loadRest's layout: (X_0, X_1) of every particle, then (X_2, V)
        Xr[2 * i] = sph.restPositions()[i](0);
        Xr[2 * i + 1] = sph.restPositions()[i](1);
        Xr[2 * n + 2 * i] = sph.restPositions()[i](2);
        Xr[2 * n + 2 * i + 1] = sph.volumes()[i];
        for (int e = nbr.offsets[i]; e < nbr.offsets[i + 1]; ++e) {
          const int j = nbr.indices[e];
          gsum_raw[i] += sph.volumes()[j] * cubicSplineGradW(sph.restPositions()[j] - sph.restPositions()[i], h);
        }
      }
      b->L = upload(flat<double>(L));
      b->Xr = upload(Xr);
      b->gsum_raw = upload(flat<T>(gsum_raw));
      b->rec = allocate<T>(cuda_detail::kRecord * n);
      b->inv_h = 1.0 / h;
      b->w_scale = 1.0 / (M_PI * h * h * h);
      b->dw_scale = 1.0 / (M_PI * h * h * h * h);
    }
    b->gsum = upload(flat<T>(sph.gradientSums()));
    b->hgsum = upload(flat<T>(sph.hourglassSums()));
    b->hourglass = sph.options().hourglass_alpha > 0.0 ? 1 : 0;
    b->hg_alpha_over_h2 = sph.options().hourglass_alpha / (sph.smoothingLength() * sph.smoothingLength());
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
    buildContact(sim, b);
    b->x = upload(flat<T>(sim.positions()));
    b->v = upload(flat<T>(sim.velocities()));
    b->f = upload(flat<T>(sim.conservativeForces()));
    b->Ft = allocate<T>(9 * n);
    b->M = allocate<T>(9 * n);
    b->time = upload(std::vector<double>{sim.time()});
    b->step = upload(std::vector<long long>{static_cast<long long>(sim.stepCount())});
    b->x_alt = allocate<T>(3 * n);
    b->time_alt = allocate<double>(1);
    b->step_alt = allocate<long long>(1);
    b->status = upload(std::vector<unsigned long long>(cuda_detail::kStatusWords, 0));
    resetStatus(b->status);
  }

  /// The simulator's contact (obstacles, the embedded samples or the candidate particles, their
  /// transpose for the scatter to the particles).
  template <class T>
  void buildContact(const SoftBodySimulator& sim, cuda_detail::SoftDeviceBody<T>* b) {
    const SoftContact& sc = sim.contact();
    if (sc.empty()) return;
    cuda_detail::ContactDevice<T>& c = b->contact;
    if (sc.obstacles().size() > static_cast<std::size_t>(cuda_detail::ContactDevice<T>::kMaxObstacles))
      throw TopoError("CUDA soft body", std::to_string(sc.obstacles().size()) + " contact obstacles",
                      "use at most " + std::to_string(cuda_detail::ContactDevice<T>::kMaxObstacles));
    c.obstacles = static_cast<int>(sc.obstacles().size());
    for (int o = 0; o < c.obstacles; ++o) {
      const ContactObstacle& ob = sc.obstacles()[o];
      c.kind[o] = ob.kind == ContactObstacle::Kind::HalfSpace ? 0 : 1;
      c.offset[o] = static_cast<T>(ob.offset);
      for (int d = 0; d < 3; ++d) {
        c.normal[o][d] = static_cast<T>(ob.normal(d));
        c.lo[o][d] = static_cast<T>(ob.lo(d));
        c.hi[o][d] = static_cast<T>(ob.hi(d));
      }
    }
    c.stiffness = static_cast<T>(sc.options().stiffness);
    c.friction = static_cast<T>(sc.options().friction);
    c.slip_velocity = static_cast<T>(sc.options().slip_velocity);
    c.margin = static_cast<T>(sc.options().margin);
    std::vector<int> off{0}, idx, anchor;
    std::vector<double> phi, omega;
    if (sc.embedded()) {
      const ContactEmbedding& E = *sc.embedding();
      off = E.offsets();
      idx = E.particles();
      phi = E.phi();
      omega = E.weights();
      for (std::size_t k = 0; k < E.size(); ++k) anchor.push_back(E.anchor(k));
      c.embedded = 1;
      c.band = static_cast<T>(E.nearBand());
    } else {
      for (std::size_t i = 0; i < n; ++i)
        if (sc.mask().empty() || sc.mask()[i]) {
          idx.push_back(static_cast<int>(i));
          phi.push_back(1.0);
          omega.push_back(1.0);
          anchor.push_back(static_cast<int>(i));
          off.push_back(static_cast<int>(idx.size()));
        }
    }
    const int points = static_cast<int>(off.size()) - 1;
    // Transpose (particle → its points, in point order).
    std::vector<int> toff(n + 1, 0), tpt(idx.size());
    std::vector<double> tphi(idx.size());
    for (int i : idx) ++toff[i + 1];
    for (std::size_t i = 0; i < n; ++i) toff[i + 1] += toff[i];
    std::vector<int> fill(toff.begin(), toff.end() - 1);
    for (int k = 0; k < points; ++k)
      for (int q = off[k]; q < off[k + 1]; ++q) {
        const int e = fill[idx[q]]++;
        tpt[e] = k;
        tphi[e] = phi[q];
      }
    c.points = points;
    c.off = upload(off);
    c.idx = upload(idx);
    c.phi = upload(cast<T>(phi));
    c.omega = upload(cast<T>(omega));
    c.anchor = upload(anchor);
    c.toff = upload(toff);
    c.tpt = upload(tpt);
    c.tphi = upload(cast<T>(tphi));
    c.fn = upload(std::vector<T>(3 * static_cast<std::size_t>(points), T(0)));
    c.ffr = upload(std::vector<T>(3 * static_cast<std::size_t>(points), T(0)));
    c.adj = upload(std::vector<T>(6 * static_cast<std::size_t>(points), T(0)));
    c.pfr = upload(std::vector<T>(3 * n, T(0)));
  }

  void resetStatus(unsigned long long* status) {
    const unsigned long long init[cuda_detail::kStatusWords] = {std::numeric_limits<unsigned long long>::max(),
                                                                std::numeric_limits<unsigned long long>::max(), 0, 0};
    check(cudaMemcpyAsync(status, init, sizeof(init), cudaMemcpyHostToDevice, stream), "status reset");
  }

  unsigned long long* status() const { return precision == CudaPrecision::Float64 ? body64.status : body32.status; }

  void launchSteps(double dt, long steps) {
    if (precision == CudaPrecision::Float64)
      cuda_detail::launchLeapfrogSteps(body64, dt, steps, stream);
    else
      cuda_detail::launchLeapfrogSteps(body32, dt, steps, stream);
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

}  // namespace topo_gaussian
