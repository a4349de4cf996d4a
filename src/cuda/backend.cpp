// Compute backend switch; see include/topo_gaussian/cuda/backend.h.
#include "topo_gaussian/cuda/backend.h"

#include <algorithm>
#include <cctype>
#include <sstream>

#include "topo_gaussian/common/error.h"

#if TOPO_HAVE_CUDA
#include <cuda_runtime_api.h>
#endif

namespace topo_gaussian {

ComputeBackend parseComputeBackend(const std::string& value, const std::string& what) {
  std::string v = value;
  std::transform(v.begin(), v.end(), v.begin(), [](unsigned char c) { return std::tolower(c); });
  if (v == "auto") return ComputeBackend::Auto;
  if (v == "cpu") return ComputeBackend::Cpu;
  if (v == "cuda" || v == "gpu") return ComputeBackend::Cuda;
  throw TopoError(what, "backend '" + value + "' is not one of auto, cpu, cuda",
                  "use auto (a CUDA GPU when present, else the CPU), cpu or cuda");
}

std::string toString(ComputeBackend backend) {
  switch (backend) {
    case ComputeBackend::Auto:
      return "auto";
    case ComputeBackend::Cpu:
      return "cpu";
    case ComputeBackend::Cuda:
      return "cuda";
  }
  return "?";
}

namespace {

CudaDeviceInfo queryDevice() {
  CudaDeviceInfo info;
#if TOPO_HAVE_CUDA
  info.built = true;
  int count = 0;
  const cudaError_t err = cudaGetDeviceCount(&count);
  if (err != cudaSuccess) {
    info.reason = std::string("the CUDA runtime found no usable device (") + cudaGetErrorString(err) + ")";
    cudaGetLastError();  // clear the sticky error of a failed query
    return info;
  }
  if (count < 1) {
    info.reason = "the CUDA driver reports no device";
    return info;
  }
  cudaDeviceProp prop{};
  if (cudaGetDeviceProperties(&prop, 0) != cudaSuccess) {
    info.reason = "the properties of CUDA device 0 could not be read";
    cudaGetLastError();
    return info;
  }
  info.available = true;
  info.device = 0;
  info.name = prop.name;
  info.multiprocessors = prop.multiProcessorCount;
  info.compute_capability = prop.major * 10 + prop.minor;
  info.memory_gib = static_cast<double>(prop.totalGlobalMem) / (1024.0 * 1024.0 * 1024.0);
#else
  info.reason = "this build has no CUDA backend (nvcc was not found when it was configured, or -DTOPO_CUDA=OFF)";
#endif
  return info;
}

}  // namespace

const CudaDeviceInfo& cudaDeviceInfo() {
  static const CudaDeviceInfo info = queryDevice();
  return info;
}

ComputeBackend resolveBackend(ComputeBackend requested, const std::string& what, std::string* log_line) {
  const CudaDeviceInfo& info = cudaDeviceInfo();
  std::ostringstream s;
  s << "backend " << toString(requested) << ": ";
  ComputeBackend chosen = ComputeBackend::Cpu;
  if (requested == ComputeBackend::Cpu) {
    s << "CPU";
  } else if (info.available) {
    chosen = ComputeBackend::Cuda;
    s << "CUDA on " << info.name << " (" << info.multiprocessors << " SMs, " << static_cast<int>(info.memory_gib + 0.5)
      << " GiB)";
  } else if (requested == ComputeBackend::Cuda) {
    throw TopoError(what, "backend cuda was asked for, but " + info.reason,
                    "use backend auto (the CPU when no GPU is present) or cpu, or run on a machine with a CUDA GPU "
                    "and a build configured with nvcc");
  } else {
    s << "CPU (no CUDA GPU: " << info.reason << ")";
  }
  if (log_line) *log_line = s.str();
  return chosen;
}

void requireDeviceMemory(const std::string& what, double bytes, double bytes_per_particle) {
#if TOPO_HAVE_CUDA
  if (!cudaDeviceInfo().available) return;
  std::size_t free_b = 0, total_b = 0;
  if (cudaMemGetInfo(&free_b, &total_b) != cudaSuccess) {
    cudaGetLastError();
    return;
  }
  const double usable = 0.9 * static_cast<double>(free_b);
  if (bytes <= usable) return;
  std::ostringstream s;
  s << "needs " << static_cast<long long>(bytes / (1024.0 * 1024.0)) << " MiB on " << cudaDeviceInfo().name << " but "
    << static_cast<long long>(free_b / (1024.0 * 1024.0)) << " MiB are free (of "
    << static_cast<long long>(total_b / (1024.0 * 1024.0)) << " MiB): about "
    << static_cast<long long>(usable / std::max(1.0, bytes_per_particle)) << " particles would fit";
  throw GpuMemoryError(
      what, s.str(),
      "use a coarser particle spacing (or fewer steps), free the GPU, or use backend cpu (backend auto "
      "falls back to the CPU)");
#else
  (void)what;
  (void)bytes;
  (void)bytes_per_particle;
#endif
}

double cudaCopyBandwidthGBs(std::size_t bytes) {
  const CudaDeviceInfo& info = cudaDeviceInfo();
  if (!info.available) throw TopoError("cudaCopyBandwidthGBs", info.reason, "run on a machine with a CUDA GPU");
#if TOPO_HAVE_CUDA
  void *a = nullptr, *b = nullptr;
  if (cudaMalloc(&a, bytes) != cudaSuccess || cudaMalloc(&b, bytes) != cudaSuccess) {
    if (a) cudaFree(a);
    throw TopoError("cudaCopyBandwidthGBs", "could not allocate 2 x " + std::to_string(bytes) + " bytes",
                    "pass a smaller size");
  }
  cudaMemset(a, 1, bytes);
  cudaEvent_t e0, e1;
  cudaEventCreate(&e0);
  cudaEventCreate(&e1);
  float best_ms = 1e30f;
  for (int k = 0; k < 6; ++k) {
    cudaEventRecord(e0);
    cudaMemcpy(b, a, bytes, cudaMemcpyDeviceToDevice);
    cudaEventRecord(e1);
    cudaEventSynchronize(e1);
    float ms = 0.0f;
    cudaEventElapsedTime(&ms, e0, e1);
    if (k > 0) best_ms = std::min(best_ms, ms);
  }
  cudaEventDestroy(e0);
  cudaEventDestroy(e1);
  cudaFree(a);
  cudaFree(b);
  return 2.0 * static_cast<double>(bytes) / (1e-3 * best_ms) / 1e9;
#else
  (void)bytes;
  return 0.0;
#endif
}

}  // namespace topo_gaussian
