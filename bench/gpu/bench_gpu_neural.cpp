// GPU benchmark of the neural representation (target: 8×512 MLP loss + gradient on 150k points
// ≤ 40 ms in float32, ≤ 50 ms float64): one JSON line per case and precision — ms per field() and
// per loss + gradient (field + fieldBackward), the CPU path (NeuralRepresentation on all host threads,
// one evaluation) on the same points in the same run, and the achieved TFLOP/s (2·N·in·out per layer
// and GEMM: one GEMM a layer forward, three for forward + backward).
// float64 through NeuralRepresentation with backend cuda (what a task runs); float32 (exact, and
// TF32 on the tensor cores) through MlpCuda with the representation's effective weights (the weight
// normalisation stays on the host), each with its field's largest error against float64 over the
// largest |s|. backward_ms = loss_gradient_ms − field_ms (the backward after a forward).
// Without a CUDA device it prints {"case": "gpu_neural", "skipped": reason} and exits 0.
// Usage: bench_gpu_neural [--quick] [--case DEPTHxWIDTH]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "topo_gaussian/cuda/backend.h"
#include "topo_gaussian/cuda/mlp_cuda.h"
#include "topo_gaussian/topology/neural_representation.h"

using namespace topo_gaussian;
using Clock = std::chrono::steady_clock;

namespace {

double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

void neuralCase(int depth, int width, int n, int reps) {
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(-0.1, 0.1);
  std::vector<Eigen::Vector3d> X(n);
  for (auto& x : X) x = Eigen::Vector3d(u(rng), u(rng), u(rng));
  NeuralOptions o;
  o.depth = depth;
  o.width = width;
  o.backend = ComputeBackend::Cpu;
  const NeuralRepresentation cpu(o, X);
  o.backend = ComputeBackend::Cuda;
  const NeuralRepresentation gpu(o, X);
  const Eigen::VectorXd t = cpu.initialParameters();
  std::vector<double> w(n, 1.0 / n), s;
  Eigen::VectorXd g;
  const std::vector<int> sizes = cpu.layerSizes();
  double flops_fwd = 0.0;
  for (std::size_t l = 0; l + 1 < sizes.size(); ++l) flops_fwd += 2.0 * n * sizes[l] * sizes[l + 1];
  // CPU: one evaluation of each.
  auto t0 = Clock::now();
  cpu.field(t, &s);
  const double cpu_field = since(t0);
  t0 = Clock::now();
  cpu.fieldBackward(t, w, &g);
  const double cpu_backward = since(t0);
  // GPU float64 (warm-up first: cuBLAS load, allocation).
  gpu.field(t, &s);
  gpu.fieldBackward(t, w, &g);
  t0 = Clock::now();
  for (int r = 0; r < reps; ++r) gpu.field(t, &s);
  const double f64_field = since(t0) / reps;
  t0 = Clock::now();
  for (int r = 0; r < reps; ++r) {
    gpu.field(t, &s);
    gpu.fieldBackward(t, w, &g);
  }
  const double f64_lg = since(t0) / reps;
  // GPU float32 through MlpCuda with the same effective weights.
  const std::vector<Eigen::MatrixXd> W = cpu.weights(t);
  const std::vector<Eigen::VectorXd> b = cpu.biases(t);
  Eigen::Matrix3Xd U(3, n);
  for (int i = 0; i < n; ++i) U.col(i) = (X[i] - cpu.frame().centre) / cpu.frame().scale;
  std::vector<double> s64;
  gpu.field(t, &s64);
  struct Row {
    const char* name;
    double field, lg, goal, err;
  };
  std::vector<Row> rows{{"f64", f64_field, f64_lg, (depth == 8 && width == 512) ? 0.050 : 0.0, 0.0}};
  for (const MlpMath math : {MlpMath::Exact, MlpMath::Tf32}) {
    MlpCuda mlp(sizes, U, CudaPrecision::Float32, math);
    std::vector<Eigen::MatrixXd> dW;
    std::vector<Eigen::VectorXd> db;
    mlp.forward(W, b, &s);
    mlp.backward(W, b, w, &dW, &db);
    double err = 0.0, scale = 0.0;  // largest |s32 − s64| over the largest |s64|
    for (int i = 0; i < n; ++i) err = std::max(err, std::abs(s[i] - s64[i])), scale = std::max(scale, std::abs(s64[i]));
    t0 = Clock::now();
    for (int r = 0; r < reps; ++r) mlp.forward(W, b, &s);
    const double field = since(t0) / reps;
    t0 = Clock::now();
    for (int r = 0; r < reps; ++r) {
      mlp.forward(W, b, &s);
      if (!mlp.backwardAfterForward(w, &dW, &db)) mlp.backward(W, b, w, &dW, &db);
    }
    rows.push_back({math == MlpMath::Tf32 ? "f32_tf32" : "f32", field, since(t0) / reps,
                    (depth == 8 && width == 512) ? 0.040 : 0.0, err / scale});
  }
  // forward + backward: 3 GEMMs per layer (the backward reuses the forward's kept activations).
  const double flops_lg = 3.0 * flops_fwd;
  for (const Row& r : rows) {
    std::printf(
        "{\"case\": \"neural_%dx%d_%s\", \"device\": \"%s\", \"points\": %d, \"parameters\": %d, \"field_ms\": %.2f, "
        "\"backward_ms\": %.2f, \"loss_gradient_ms\": %.2f, \"field_TFLOPs\": %.1f, \"loss_gradient_TFLOPs\": %.1f, "
        "\"field_error_vs_f64\": %.1e, \"baseline\": \"cpu_neural_representation\", \"cpu_field_ms\": %.1f, "
        "\"cpu_loss_gradient_ms\": %.1f, \"gpu_over_cpu_loss_gradient\": %.0f, \"goal_loss_gradient_ms\": %s, "
        "\"goal_met\": %s}\n",
        depth, width, r.name, cudaDeviceInfo().name.c_str(), n, cpu.numParameters(), 1e3 * r.field,
        1e3 * (r.lg - r.field), 1e3 * r.lg, flops_fwd / r.field / 1e12, flops_lg / r.lg / 1e12, r.err, 1e3 * cpu_field,
        1e3 * (cpu_field + cpu_backward), (cpu_field + cpu_backward) / r.lg,
        r.goal > 0 ? std::to_string(1e3 * r.goal).c_str() : "null",
        r.goal > 0 ? (r.lg <= r.goal ? "true" : "false") : "null");
    std::fflush(stdout);
  }
}

}  // namespace

int main(int argc, char** argv) {
  bool quick = false;
  std::string only;  // --case DEPTHxWIDTH: that network only (for a profiler)
  for (int a = 1; a < argc; ++a) {
    if (std::strcmp(argv[a], "--quick") == 0)
      quick = true;
    else if (std::strcmp(argv[a], "--case") == 0 && a + 1 < argc)
      only = argv[++a];
    else {
      std::fprintf(stderr, "usage: bench_gpu_neural [--quick] [--case DEPTHxWIDTH]\n");
      return 2;
    }
  }
  if (!cudaDeviceInfo().available) {
    std::printf("{\"case\": \"gpu_neural\", \"skipped\": \"%s\"}\n", cudaDeviceInfo().reason.c_str());
    return 0;
  }
  try {
    if (only.empty() || only == "4x32") neuralCase(4, 32, 150000, quick ? 3 : 20);
    if (only.empty() || only == "8x512") neuralCase(8, 512, 150000, quick ? 2 : 10);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_gpu_neural: %s\n", e.what());
    return 1;
  }
  return 0;
}
