// What the explicit step's two neighbour passes cost on their own: the passes of
// src/cuda/soft_step_kernels.cu on the package's own body, without the work the step does around them.
// One JSON line per case.
//
// The package's step is two kernels over the CSR neighbour lists:
//   evaluation  F̃_i = Σ_j V_j (x_j − x_i) ⊗ ĝ_ij,  D_i = Σ_j W_ij V_j (x_j − x_i) ⊗ X_ji   (A_pq, hourglass)
//               then the polar rotation, P, M_i and a 24-value record (N_i = M_i L_i, F̃_i, x_i, c_i, V_i);
//   gather      f_k = −V_k Σ_j N_j ∇W(X_kj) − hourglass (Σ_j W c_j F̃_j X_jk, Σ_j W (c_k V_j + c_j V_k)(x_j − x_k))
//               then the kicks and the drift.
// The bench runs both passes with their loads, sums and stores as the package has them (its particle
// order and CSR lists, taken from a CorotatedSph built as bench_gpu_soft builds its boxes; the 16-byte
// record chunks; L lanes a particle) and takes everything else away: there is no polar rotation, stress
// or pneumatic term (the record holds F̃ − D where the package has M L), and the gather's epilogue is
// one kick and drift. Three variants, each beside the others in the same run:
//   plain_*  a plain reference step: F̃ alone, a record of F̃'s 9 values (in whole 16-byte chunks),
//            the gather's N ∇W sum alone; the baseline the others are divided by (over_plain);
//   model_*  this package's passes (F̃ and D, the hourglass sums, the 24-value record) with ĝ_ij =
//            L_i ∇W(o Δx), W and X_ji from a table by lattice offset o in shared memory;
//   rest_*   model_* with ĝ, W and X_ji computed per neighbour as the package does (from the rest
//            positions and volumes: float64 in the evaluation, T in the gather; its own cubicSpline
//            and loadRest), which a `topo fill` body's off-lattice boundary particles need.
// Each line carries the evaluation's F̃ against the CPU's (CorotatedSph::updateState at the same x:
// the largest difference over the largest entry), so a variant that computed something else would
// show. The package's own step on the same body: bench_gpu_soft explicit_100k_h1.0 / explicit_1m_h1.0.
//
// Usage: bench_gpu_floor [--reps N] [CASE_SUBSTRING] (--reps: timed launches a kernel, default 500 at
// 100k and 100 at 1M; 1 for a profiler). Without a CUDA device it prints one skip line and exits 0.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "../../test/unit/test_clouds.h"
#include "bench_gpu_floor.h"
#include "topo_gaussian/physics/corotated_sph.h"
#include "topo_gaussian/physics/sph_kernel.h"

using namespace topo_gaussian;
using namespace topo_gaussian::bench_floor;

namespace {

constexpr double kSpacing = 0.005;  // m, as bench_gpu_soft

/// The lattice offsets of the codes (bench_gpu_floor.h): every o ∈ {−2, …, 2}³ with |o|² ≤ 4.
std::vector<std::array<int, 3>> offsetCodes() {
  std::vector<std::array<int, 3>> o;
  for (int c = -2; c <= 2; ++c)
    for (int b = -2; b <= 2; ++b)
      for (int a = -2; a <= 2; ++a)
        if (a * a + b * b + c * c <= 4) o.push_back({a, b, c});
  return o;
}

/// The box of bench_gpu_soft's explicit_* cases (5 mm lattice, h = 1.0 spacing, E 1 MPa, ν 0.3,
/// defaults otherwise: A_pq rotations, hourglass α 0.1) and its data in the package's order, deformed
/// by a smooth shear and twist so that F̃ ≠ I.
Input makeInput(int nx, int ny, int nz, std::unique_ptr<CorotatedSph>* sph_out) {
  const VolumeCloud cloud = topo_test::boxCloud(nx * kSpacing, ny * kSpacing, nz * kSpacing, kSpacing);
  CorotatedSphOptions o;
  o.spacing = kSpacing;
  o.smoothing_factor = 1.0;
  CorotatedSph sph = CorotatedSph::fromCloud(cloud, lameFromYoung(1e6, 0.3), o);
  Input in;
  in.n = static_cast<int>(sph.restPositions().size());
  in.offsets = sph.neighbors().offsets;
  in.indices = sph.neighbors().indices;
  const auto& X = sph.restPositions();
  std::vector<Eigen::Vector3d> x(X.size());
  for (std::size_t i = 0; i < X.size(); ++i) {
    const Eigen::Vector3d& p = X[i];
    x[i] = p + Eigen::Vector3d(0.02 * p.y() + 1e-3 * std::sin(40.0 * p.z()), 0.01 * p.z() - 0.03 * p.x(),
                               0.015 * p.x() + 1e-3 * std::cos(30.0 * p.y()));
  }
  for (int i = 0; i < in.n; ++i)
    for (int d = 0; d < 3; ++d) {
      in.X.push_back(X[i][d]);
      in.x.push_back(x[i][d]);
    }
  in.V = sph.volumes();
  in.m = sph.masses();
  in.c = sph.hourglassCoefficients();
  if (in.c.empty()) in.c.assign(in.n, 0.0);
  for (int i = 0; i < in.n; ++i)
    for (int k = 0; k < 9; ++k) in.L.push_back(sph.correction(i)(k % 3, k / 3));
  const double h = sph.smoothingLength();
  in.inv_h = 1.0 / h;
  in.w_scale = 1.0 / (M_PI * h * h * h);
  in.dw_scale = in.w_scale / h;
  const auto codes = offsetCodes();
  if (static_cast<int>(codes.size()) != kCodes) throw std::runtime_error("offsetCodes() does not give kCodes offsets");
  for (int c = 0; c < kCodes; ++c) {
    const Eigen::Vector3d r = kSpacing * Eigen::Vector3d(codes[c][0], codes[c][1], codes[c][2]);
    const Eigen::Vector3d g = cubicSplineGradW(r, h);
    in.w[c] = cubicSplineW(r, h);
    for (int d = 0; d < 3; ++d) in.g[c][d] = g[d], in.Xo[c][d] = r[d];
  }
  in.codes.resize(in.indices.size());
  for (int i = 0; i < in.n; ++i)
    for (int e = in.offsets[i]; e < in.offsets[i + 1]; ++e) {
      const Eigen::Vector3d o = (X[in.indices[e]] - X[i]) / kSpacing;
      const std::array<int, 3> oi = {static_cast<int>(std::lround(o.x())), static_cast<int>(std::lround(o.y())),
                                     static_cast<int>(std::lround(o.z()))};
      const auto it = std::find(codes.begin(), codes.end(), oi);
      if (it == codes.end() || (o - Eigen::Vector3d(oi[0], oi[1], oi[2])).norm() > 1e-9)
        throw std::runtime_error("a neighbour off the lattice offsets (|o|² ≤ 4)");
      in.codes[e] = static_cast<std::uint8_t>(it - codes.begin());
    }
  sph.updateState(x);
  *sph_out = std::make_unique<CorotatedSph>(std::move(sph));
  return in;
}

/// max |F̃_gpu − F̃_cpu| / max |F̃_cpu| over all particles and entries.
double ftError(const std::vector<double>& Ft, const CorotatedSph& sph) {
  double diff = 0.0, scale = 0.0;
  for (std::size_t i = 0; i < sph.restPositions().size(); ++i) {
    const Eigen::Matrix3d& F = sph.deformationGradient(i);
    for (int k = 0; k < 9; ++k) {
      diff = std::max(diff, std::abs(Ft[9 * i + k] - F(k % 3, k / 3)));
      scale = std::max(scale, std::abs(F(k % 3, k / 3)));
    }
  }
  return diff / scale;
}

void runSize(const std::string& device, const char* size, int nx, int ny, int nz, int reps, const char* only) {
  const char* names[] = {"plain_", "model_", "rest_"};
  const auto tailOf = [&](int precision, int lanes) {
    return std::string(size) + (precision == 32 ? "_f32" : "_f64") + "_lanes" + std::to_string(lanes);
  };
  const auto wanted = [&](const std::string& tail) {  // a case runs beside its plain baseline
    bool w = !only;
    for (const char* v : names) w = w || (v + tail).find(only) != std::string::npos;
    return w;
  };
  bool any = false;
  for (int precision : {32, 64})
    for (int lanes : {1, 2, 4}) any = any || wanted(tailOf(precision, lanes));
  if (!any) return;
  std::unique_ptr<CorotatedSph> sph;
  const Input in = makeInput(nx, ny, nz, &sph);
  const double neighbours = double(in.indices.size()) / in.n;
  for (int precision : {32, 64}) {
    for (int lanes : {1, 2, 4}) {
      const std::string tail = tailOf(precision, lanes);
      if (!wanted(tail)) continue;
      double plain_us = 0.0;
      for (Variant v : {Variant::kPlain, Variant::kModel, Variant::kRest}) {
        const std::string name = names[static_cast<int>(v)] + tail;
        const Timing t = timeFloor(in, v, lanes, precision == 64, reps);
        if (v == Variant::kPlain) plain_us = t.step_us;
        std::printf(
            "{\"case\": \"%s\", \"device\": \"%s\", \"particles\": %d, \"neighbours_mean\": %.2f, \"precision\": "
            "\"float%d\", \"lanes\": %d, \"evaluate_us\": %.2f, \"gather_us\": %.2f, \"us_per_step\": %.2f, "
            "\"particle_steps_per_s\": %.4g",
            name.c_str(), device.c_str(), in.n, neighbours, precision, lanes, t.evaluate_us, t.gather_us, t.step_us,
            in.n / (1e-6 * t.step_us));
        if (v != Variant::kPlain) {
          std::printf(", \"baseline\": \"plain_%s\", \"over_plain\": %.3f", tail.c_str(), t.step_us / plain_us);
          std::printf(", \"ft_error_vs_cpu\": %.2e", ftError(t.Ft, *sph));
        }
        std::printf(", \"force_checksum\": %.6e}\n", t.force_checksum);
        std::fflush(stdout);
      }
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  const char* only = nullptr;
  int reps = 0;
  for (int a = 1; a < argc; ++a) {
    if (std::strcmp(argv[a], "--reps") == 0) {
      if (a + 1 >= argc) {
        std::fprintf(stderr, "bench_gpu_floor: --reps needs a number of launches, e.g. --reps 1\n");
        return 2;
      }
      reps = std::max(1, std::atoi(argv[++a]));
    } else {
      only = argv[a];
    }
  }
  int sms = 0;
  const std::string device = deviceName(&sms);
  if (device.empty()) {
    std::printf("{\"case\": \"gpu\", \"skipped\": \"the CUDA runtime found no usable device\"}\n");
    return 0;
  }
  try {
    // The boxes of bench_gpu_soft's explicit_100k_h1.0 and explicit_1m_h1.0.
    runSize(device, "100k", 80, 50, 25, reps ? reps : 500, only);
    runSize(device, "1m", 160, 100, 63, reps ? reps : 100, only);
  } catch (const std::exception& e) {
    std::string what = e.what();  // a JSON string: no quotes or backslashes inside
    std::replace(what.begin(), what.end(), '"', '\'');
    std::replace(what.begin(), what.end(), '\\', '/');
    std::printf("{\"case\": \"gpu\", \"error\": \"%s\"}\n", what.c_str());
    return 1;
  }
  return 0;
}
