// Compute backend switch: where the particle kernels run.
//
//   backend: auto | cpu | cuda    (task YAML `backend`, CLI `--backend`, node `~backend`)
//
// auto runs on a CUDA GPU when this build has the CUDA backend (nvcc was found when it was
// configured) and the driver reports a device, otherwise on the CPU; resolveBackend() says which in
// a log line. cuda on a machine without one is refused with the reason (no nvcc at build time, no
// driver, no device). The CUDA code lives in src/cuda (kernels *.cu without Eigen, host *.cpp) and
// is part of topo_physics; without nvcc the same functions exist and report "built without CUDA".
#pragma once

#include <cstddef>
#include <string>

#include "topo_gaussian/common/error.h"

namespace topo_gaussian {

enum class ComputeBackend { Auto, Cpu, Cuda };

/// "auto", "cpu", "cuda" (case-insensitive). Throws TopoError naming `what` and the value otherwise.
ComputeBackend parseComputeBackend(const std::string& value, const std::string& what = "backend");
std::string toString(ComputeBackend backend);

struct CudaDeviceInfo {
  bool built = false;      ///< this build has the CUDA backend
  bool available = false;  ///< a device answered
  int device = -1;
  std::string name;            ///< e.g. "NVIDIA H100 80GB HBM3"
  int multiprocessors = 0;     ///< SM count
  int compute_capability = 0;  ///< major × 10 + minor
  double memory_gib = 0.0;     ///< total device memory
  std::string reason;          ///< why not available (empty when available)
};

/// The first CUDA device (queried once, then cached).
const CudaDeviceInfo& cudaDeviceInfo();

/// Auto → Cuda when cudaDeviceInfo().available, else Cpu. Cuda when none is available throws
/// TopoError naming `what`, the reason and the fix (backend cpu or auto). *log_line (if given) says
/// what was chosen and why, e.g. "backend auto: CUDA on NVIDIA H100 80GB HBM3 (132 SMs)".
ComputeBackend resolveBackend(ComputeBackend requested, const std::string& what = "backend",
                              std::string* log_line = nullptr);

/// The GPU has too little free memory for a job: thrown before anything is allocated, naming what
/// is needed, what is free and how many particles would fit. Under backend auto a caller may fall
/// back to the CPU (the pear task does, with a note).
class GpuMemoryError : public TopoError {
 public:
  using TopoError::TopoError;
};

/// Throws GpuMemoryError naming `what` when `bytes` exceed 90 % of the device's free memory;
/// `bytes_per_particle` gives the particle count that would fit. No-op without a device.
void requireDeviceMemory(const std::string& what, double bytes, double bytes_per_particle);

/// Device-to-device copy bandwidth [GB/s], bytes read plus bytes written, of a `bytes` copy (best
/// of 5 after a warm-up): the memory-bandwidth bound benchmarks compare against. Throws without a
/// device.
double cudaCopyBandwidthGBs(std::size_t bytes = std::size_t(1) << 30);

}  // namespace topo_gaussian
