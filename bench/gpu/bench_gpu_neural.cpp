// GPU benchmark of the neural representation (issue 20 §2: "8×512 MLP loss + gradient on 150k points
// ≤ 40 ms in float32, ≤ 50 ms float64"): one JSON line per case and precision — ms per field() and
// per loss + gradient (field + fieldBackward), the CPU path (NeuralRepresentation on all host threads,
// one evaluation) on the same points in the same run, and the achieved TFLOP/s (2·N·in·out per layer
// and GEMM: one GEMM a layer forward, three for forward + backward).
// float64 through NeuralRepresentation with backend cuda (what a task runs); float32 through
// MlpCuda with the representation's effective weights (the weight normalisation stays on the host).
// Without a CUDA device it prints {"case": "gpu_neural", "skipped": reason} and exits 0.
// Usage: bench_gpu_neural [--quick]
#include <chrono>
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
  std::vector<int> sizes{3};
  for (int l = 0; l + 1 < depth; ++l) sizes.push_back(width);
  sizes.push_back(1);
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
  std::vector<Eigen::MatrixXd> W;
  std::vector<Eigen::VectorXd> b;
  int off = 0;
  for (std::size_t l = 0; l + 1 < sizes.size(); ++l) {
    const int in = sizes[l], out = sizes[l + 1];
    const Eigen::Map<const Eigen::MatrixXd> v(t.data() + off, out, in);
    const Eigen::Map<const Eigen::VectorXd> gg(t.data() + off + out * in, out);
    W.push_back((gg.array() / v.rowwise().norm().array()).matrix().asDiagonal() * v);
    b.push_back(t.segment(off + out * in + out, out));
    off += out * in + 2 * out;
  }
  Eigen::Matrix3Xd U(3, n);
  for (int i = 0; i < n; ++i) U.col(i) = (X[i] - cpu.frame().centre) / cpu.frame().scale;
  MlpCuda mlp(sizes, U, CudaPrecision::Float32);
  std::vector<Eigen::MatrixXd> dW;
  std::vector<Eigen::VectorXd> db;
  mlp.forward(W, b, &s);
  mlp.backward(W, b, w, &dW, &db);
  t0 = Clock::now();
  for (int r = 0; r < reps; ++r) mlp.forward(W, b, &s);
  const double f32_field = since(t0) / reps;
  t0 = Clock::now();
  for (int r = 0; r < reps; ++r) {
    mlp.forward(W, b, &s);
    if (!mlp.backwardAfterForward(w, &dW, &db)) mlp.backward(W, b, w, &dW, &db);
  }
  const double f32_lg = since(t0) / reps;
  // forward + backward: 3 GEMMs per layer (the backward reuses the forward's kept activations).
  const double flops_lg = 3.0 * flops_fwd;
  const double goal32 = (depth == 8 && width == 512) ? 0.040 : 0.0, goal64 = (depth == 8 && width == 512) ? 0.050 : 0.0;
  for (int p = 0; p < 2; ++p) {
    const bool f64 = p == 0;
    const double field = f64 ? f64_field : f32_field, lg = f64 ? f64_lg : f32_lg, goal = f64 ? goal64 : goal32;
    std::printf(
        "{\"case\": \"neural_%dx%d_%s\", \"device\": \"%s\", \"points\": %d, \"parameters\": %d, \"field_ms\": %.2f, "
        "\"loss_gradient_ms\": %.2f, \"field_TFLOPs\": %.1f, \"loss_gradient_TFLOPs\": %.1f, \"baseline\": "
        "\"cpu_neural_representation\", \"cpu_field_ms\": %.1f, \"cpu_loss_gradient_ms\": %.1f, "
        "\"gpu_over_cpu_loss_gradient\": %.0f, \"goal_loss_gradient_ms\": %s, \"goal_met\": %s}\n",
        depth, width, f64 ? "f64" : "f32", cudaDeviceInfo().name.c_str(), n, cpu.numParameters(), 1e3 * field, 1e3 * lg,
        flops_fwd / field / 1e12, flops_lg / lg / 1e12, 1e3 * cpu_field, 1e3 * (cpu_field + cpu_backward),
        (cpu_field + cpu_backward) / lg, goal > 0 ? std::to_string(1e3 * goal).c_str() : "null",
        goal > 0 ? (lg <= goal ? "true" : "false") : "null");
    std::fflush(stdout);
  }
}

}  // namespace

int main(int argc, char** argv) {
  const bool quick = argc > 1 && std::strcmp(argv[1], "--quick") == 0;
  if (!cudaDeviceInfo().available) {
    std::printf("{\"case\": \"gpu_neural\", \"skipped\": \"%s\"}\n", cudaDeviceInfo().reason.c_str());
    return 0;
  }
  try {
    neuralCase(4, 32, 150000, quick ? 3 : 20);
    neuralCase(8, 512, 150000, quick ? 2 : 10);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_gpu_neural: %s\n", e.what());
    return 1;
  }
  return 0;
}
