// bench_gpu_floor: the explicit step's two neighbour passes alone (bench_gpu_floor.cpp says what and
// why). This is the interface between its host side (bench_gpu_floor.cpp: the package's body, the
// JSON) and its kernels (bench_gpu_floor_kernels.cu, which includes no Eigen, as src/cuda).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace topo_gaussian {
namespace bench_floor {

/// Lattice offset codes: the 33 offsets o = (X_j − X_i) / Δx with |o|² ≤ 4, the kernel's support 2h at
/// h = Δx (a pair exactly 2h apart, where W and ∇W vanish, is in the package's lists or not as the rest
/// positions round), in the order of offsetCodes().
constexpr int kCodes = 33;

enum class Variant { kPlain, kModel, kRest };

/// One body in the package's particle order, from its CorotatedSph (float64; converted to the run's T).
struct Input {
  int n = 0;
  std::vector<int> offsets, indices;  ///< the CSR neighbour lists (CorotatedSph::neighbors())
  std::vector<std::uint8_t> codes;    ///< per CSR entry, the lattice offset code of X_j − X_i
  std::vector<double> x, X;           ///< 3n: the deformed and the rest positions [m]
  std::vector<double> V, c, m;        ///< n: volumes [m³], hourglass coefficients, masses [kg]
  std::vector<double> L;              ///< 9n: the correction matrices L_i, column-major
  double g[kCodes][3] = {}, w[kCodes] = {}, Xo[kCodes][3] = {};  ///< ∇W(o Δx), W(o Δx), o Δx
  double inv_h = 0, w_scale = 0, dw_scale = 0;                   ///< the spline's 1/h, 1/(π h³), 1/(π h⁴)
};

struct Timing {
  double evaluate_us = 0, gather_us = 0, step_us = 0;  ///< each kernel alone, and the two in turn
  std::vector<double> Ft;                              ///< 9n: the evaluation's F̃ (model and rest; empty for plain)
  double force_checksum = 0;                           ///< Σ |f|: the gather's output is used
};

/// The first device's name and SM count; "" without a usable device.
std::string deviceName(int* sms);

/// Times the variant's evaluation and gather (reps launches each, then reps steps of the two) with
/// `lanes` threads a particle (1, 2 or 4) in float32 or float64. Throws std::runtime_error on a CUDA error.
Timing timeFloor(const Input& in, Variant v, int lanes, bool float64, int reps);

}  // namespace bench_floor
}  // namespace topo_gaussian
