// The soft body's stiffness product on the GPU; see include/topo_gaussian/cuda/soft_stiffness_cuda.h.
#include "topo_gaussian/cuda/soft_stiffness_cuda.h"

#include <string>
#include <vector>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/cuda/backend.h"
#include "topo_gaussian/cuda/soft_body_cuda.h"

#if TOPO_HAVE_CUDA
#include <cuda_runtime_api.h>

#include "soft_body_cuda_impl.h"  // SoftBodyCuda::Impl, check
#endif

namespace topo_gaussian {

#if TOPO_HAVE_CUDA

namespace {

constexpr const char* kInput = "GPU stiffness product";

class StiffnessCuda : public ExternalStiffness {
 public:
  explicit StiffnessCuda(const SoftBodySimulator& sim)
      : gpu_(sim, CudaPrecision::Float64), I_(gpu_.impl()), b_(I_.body64), n_(sim.size()) {
    requireDeviceMemory(kInput, 8.0 * 33.0 * double(n_), 8.0 * 33.0);  // R, a, out, work: 9 + 3 + 3 + 18 values
    R_ = I_.allocate<double>(9 * n_);
    a_ = I_.allocate<double>(3 * n_);
    out_ = I_.allocate<double>(3 * n_);
    work_ = I_.allocate<double>(18 * n_);
    check(cudaMallocHost(reinterpret_cast<void**>(&pinned_), sizeof(double) * 3 * n_), "cudaMallocHost", kInput);
  }
  ~StiffnessCuda() override {
    if (pinned_) cudaFreeHost(pinned_);
  }

  void setState(const std::vector<Eigen::Vector3d>& x, double time_s, double pressure_pa, double ramp_s) override {
    if (x.size() != n_)
      throw TopoError(kInput, std::to_string(x.size()) + " positions for " + std::to_string(n_) + " particles",
                      "pass the simulator's positions");
    for (std::size_t i = 0; i < n_; ++i)
      for (int d = 0; d < 3; ++d) pinned_[3 * i + d] = x[i](d);
    cudaStream_t s = I_.stream;
    check(cudaMemcpyAsync(b_.x, pinned_, sizeof(double) * 3 * n_, cudaMemcpyHostToDevice, s), "upload", kInput);
    cuda_detail::launchSetClock(b_.time, time_s, s);
    b_.pressure_pa = pressure_pa;
    b_.ramp_s = ramp_s;
    b_.R = R_;
    cuda_detail::launchEvaluateState(b_, s);  // F̃, R at x
    check(cudaGetLastError(), "state kernel", kInput);
    check(cudaStreamSynchronize(s), "state evaluation", kInput);  // pinned_ is reused by the next upload
  }

  void product(const Eigen::VectorXd& p, Eigen::VectorXd* out) override {
    if (static_cast<std::size_t>(p.size()) != 3 * n_)
      throw TopoError(kInput, std::to_string(p.size()) + " values for " + std::to_string(3 * n_) + " unknowns",
                      "pass 3 values per particle");
    cudaStream_t s = I_.stream;
    std::copy(p.data(), p.data() + p.size(), pinned_);
    check(cudaMemcpyAsync(a_, pinned_, sizeof(double) * 3 * n_, cudaMemcpyHostToDevice, s), "upload", kInput);
    cuda_detail::launchStiffnessProduct(b_, a_, out_, work_, s);
    check(cudaGetLastError(), "stiffness kernels", kInput);
    check(cudaMemcpyAsync(pinned_, out_, sizeof(double) * 3 * n_, cudaMemcpyDeviceToHost, s), "download", kInput);
    check(cudaStreamSynchronize(s), "stiffness product", kInput);
    out->resize(static_cast<Eigen::Index>(3 * n_));
    for (std::size_t k = 0; k < 3 * n_; ++k) (*out)[static_cast<Eigen::Index>(k)] = -pinned_[k];  // the gather is −K p
  }

 private:
  SoftBodyCuda gpu_;
  SoftBodyCuda::Impl& I_;
  cuda_detail::SoftDeviceBody<double>& b_;
  std::size_t n_ = 0;
  double *R_ = nullptr, *a_ = nullptr, *out_ = nullptr, *work_ = nullptr;
  double* pinned_ = nullptr;
};

}  // namespace

std::unique_ptr<ExternalStiffness> makeStiffnessCuda(const SoftBodySimulator& sim) {
  if (!cudaDeviceInfo().available)
    throw TopoError("GPU stiffness product", "no CUDA device: " + cudaDeviceInfo().reason,
                    "use backend cpu or auto (the host's products)");
  return std::make_unique<StiffnessCuda>(sim);
}

#else  // no CUDA backend in this build

std::unique_ptr<ExternalStiffness> makeStiffnessCuda(const SoftBodySimulator&) {
  throw TopoError("GPU stiffness product", "this build has no CUDA backend (nvcc was not found when it was configured)",
                  "use backend cpu or auto, or rebuild with the CUDA toolkit");
}

#endif

}  // namespace topo_gaussian
