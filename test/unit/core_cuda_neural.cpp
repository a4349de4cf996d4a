// The neural representation on the GPU (cuda/mlp_cuda.h): float64 field and gradient
// against the CPU's NeuralRepresentation to 1e-10, float32 within its stated tolerance, the GPU
// gradient against central differences of the GPU field, blocks of points (more than 65 536).
// Without a device: backend cuda is refused with the reason, auto is exactly the CPU.
#include <gtest/gtest.h>

#include <random>
#include <string>

#include "gpu_test.h"
#include "topo_gaussian/common/error.h"
#include "topo_gaussian/cuda/backend.h"
#include "topo_gaussian/cuda/mlp_cuda.h"
#include "topo_gaussian/topology/neural_representation.h"

using namespace topo_gaussian;

namespace {

std::vector<Eigen::Vector3d> randomPoints(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-0.1, 0.1);
  std::vector<Eigen::Vector3d> X(n);
  for (auto& x : X) x = Eigen::Vector3d(u(rng), u(rng), 0.5 * u(rng));
  return X;
}

NeuralOptions net(int depth, int width, ComputeBackend backend) {
  NeuralOptions o;
  o.depth = depth;
  o.width = width;
  o.backend = backend;
  return o;
}

/// θ0 with a random perturbation (so that every parameter matters and the field is not flat).
Eigen::VectorXd perturbed(const NeuralRepresentation& r, unsigned seed) {
  Eigen::VectorXd t = r.initialParameters();
  std::mt19937 rng(seed);
  std::normal_distribution<double> nd(0.0, 0.05);
  for (Eigen::Index k = 0; k < t.size(); ++k) t[k] *= 1.0 + nd(rng);
  return t;
}

std::vector<double> weightsOf(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> nd;
  std::vector<double> w(n);
  for (auto& x : w) x = nd(rng);
  return w;
}

double relMax(const std::vector<double>& a, const std::vector<double>& b) {
  double d = 0.0, m = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    d = std::max(d, std::abs(a[i] - b[i]));
    m = std::max(m, std::abs(b[i]));
  }
  return d / m;
}

}  // namespace

TEST(CudaNeural, WithoutADeviceCudaIsRefusedAndAutoIsTheCpu) {
  if (cudaDeviceInfo().available) GTEST_SKIP() << "a CUDA device is present (" << cudaDeviceInfo().name << ")";
  const auto X = randomPoints(500, 3);
  const NeuralRepresentation cpu(net(3, 16, ComputeBackend::Cpu), X), autob(net(3, 16, ComputeBackend::Auto), X);
  const Eigen::VectorXd t = perturbed(cpu, 5);
  std::vector<double> a, b;
  cpu.field(t, &a);
  autob.field(t, &b);
  EXPECT_EQ(a, b);
  const NeuralRepresentation gpu(net(3, 16, ComputeBackend::Cuda), X);
  try {
    gpu.field(t, &b);
    FAIL() << "backend cuda accepted without a device";
  } catch (const TopoError& e) {
    EXPECT_NE(std::string(e.what()).find(cudaDeviceInfo().reason), std::string::npos) << e.what();
  }
}

TEST(CudaNeural, Float64FieldAndGradientMatchTheCpu) {
  SKIP_WITHOUT_GPU();
  struct Case {
    int depth, width, n;
  };
  // 70 000 points: two blocks of the GPU MLP (65 536 + 4 464).
  for (const Case c : {Case{3, 16, 2000}, Case{8, 64, 5000}, Case{4, 32, 70000}}) {
    const auto X = randomPoints(c.n, 11);
    const NeuralRepresentation cpu(net(c.depth, c.width, ComputeBackend::Cpu), X);
    const NeuralRepresentation gpu(net(c.depth, c.width, ComputeBackend::Cuda), X);
    const Eigen::VectorXd t = perturbed(cpu, 7);
    std::vector<double> sc, sg;
    cpu.field(t, &sc);
    gpu.field(t, &sg);
    const std::vector<double> w = weightsOf(c.n, 13);
    Eigen::VectorXd gc, gg;
    cpu.fieldBackward(t, w, &gc);
    gpu.fieldBackward(t, w, &gg);
    const double ds = relMax(sg, sc);
    const double dg = (gg - gc).cwiseAbs().maxCoeff() / gc.cwiseAbs().maxCoeff();
    EXPECT_LT(ds, 1e-10) << c.depth << "x" << c.width;
    EXPECT_LT(dg, 1e-10) << c.depth << "x" << c.width;
    std::printf("[ parity   ] neural %dx%d on %d points, float64: field %.2e gradient %.2e\n", c.depth, c.width, c.n,
                ds, dg);
  }
}

TEST(CudaNeural, GradientMatchesCentralDifferencesOfTheGpuField) {
  SKIP_WITHOUT_GPU();
  const auto X = randomPoints(3000, 17);
  const NeuralRepresentation gpu(net(4, 32, ComputeBackend::Cuda), X);
  const Eigen::VectorXd t = perturbed(gpu, 19);
  const std::vector<double> w = weightsOf(3000, 23);
  auto loss = [&](const Eigen::VectorXd& th) {
    std::vector<double> s;
    gpu.field(th, &s);
    double l = 0.0;
    for (std::size_t i = 0; i < s.size(); ++i) l += w[i] * s[i];
    return l;
  };
  Eigen::VectorXd g;
  gpu.fieldBackward(t, w, &g);
  // Steps below the ReLU kink margin, so the central difference is exact to O(h²).
  std::vector<double> margin;
  gpu.kinkMargin(t, &margin);
  const double m = *std::min_element(margin.begin(), margin.end());
  std::mt19937 rng(29);
  std::normal_distribution<double> nd;
  for (int k = 0; k < 4; ++k) {
    Eigen::VectorXd d(t.size());
    for (Eigen::Index q = 0; q < d.size(); ++q) d[q] = nd(rng);
    d /= d.norm();
    const double h = std::min(1e-5, 0.1 * m / std::max(1.0, 10.0 * t.cwiseAbs().maxCoeff()));
    const double fd = (loss(t + h * d) - loss(t - h * d)) / (2.0 * h);
    const double an = g.dot(d);
    // The difference's round-off is about ε |L| √N / h ≈ 1e-6 at these steps (|L| ≈ 16, N = 3000).
    EXPECT_NEAR(an, fd, 1e-5 * std::max(1.0, std::abs(fd))) << "direction " << k << ", h " << h;
  }
}

TEST(CudaNeural, Float32StaysWithinItsStatedTolerance) {
  SKIP_WITHOUT_GPU();
  // float32 through MlpCuda directly against the CPU's float64: 1e-4 of the largest value.
  const auto X = randomPoints(20000, 31);
  const NeuralRepresentation cpu(net(8, 128, ComputeBackend::Cpu), X);
  const Eigen::VectorXd t = perturbed(cpu, 37);
  std::vector<double> sc;
  cpu.field(t, &sc);
  Eigen::Matrix3Xd U(3, X.size());
  for (std::size_t i = 0; i < X.size(); ++i) U.col(i) = (X[i] - cpu.frame().centre) / cpu.frame().scale;
  // Effective weights: the representation's own (weight normalisation on the host).
  const std::vector<int> sizes = cpu.layerSizes();
  const std::vector<Eigen::MatrixXd> W = cpu.weights(t);
  const std::vector<Eigen::VectorXd> b = cpu.biases(t);
  MlpCuda mlp(sizes, U, CudaPrecision::Float32);
  std::vector<double> s32;
  mlp.forward(W, b, &s32);
  const double e = relMax(s32, sc);
  EXPECT_LT(e, 1e-4);
  std::printf("[ parity   ] neural 8x128 on 20000 points, float32: field %.2e\n", e);
}

TEST(CudaNeural, Tf32IsRefusedWithFloat64) {
  // Checked before the device is asked for: the same message on every machine.
  Eigen::Matrix3Xd U = Eigen::Matrix3Xd::Zero(3, 4);
  try {
    MlpCuda mlp({3, 8, 1}, U, CudaPrecision::Float64, MlpMath::Tf32);
    FAIL() << "TF32 with float64 was accepted";
  } catch (const TopoError& e) {
    EXPECT_NE(std::string(e.what()).find("TF32"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("Float32"), std::string::npos) << e.what();
  }
}

TEST(CudaNeural, Tf32TensorCoresStayWithinTheirStatedTolerance) {
  SKIP_WITHOUT_GPU();
  // TF32 (10-bit mantissa products, float32 sums) against float64 on the GPU, the paper's width,
  // dL/ds of random sign (so the gradient's sums over points cancel: the hard case). Measured:
  // field 5.7e-5 of the largest |s| (float32 1.2e-7), the worst layer's dL/dW or dL/db 5.1e-2
  // (Frobenius, relative; float32 1.2e-3). Bounds: 2e-4 and 0.1 (float32 1e-6 and 3e-3).
  const int n = 20000;
  const auto X = randomPoints(n, 41);
  const NeuralRepresentation cpu(net(8, 512, ComputeBackend::Cpu), X);
  const Eigen::VectorXd t = perturbed(cpu, 43);
  Eigen::Matrix3Xd U(3, n);
  for (int i = 0; i < n; ++i) U.col(i) = (X[i] - cpu.frame().centre) / cpu.frame().scale;
  const std::vector<int> sizes = cpu.layerSizes();
  const std::vector<Eigen::MatrixXd> W = cpu.weights(t);
  const std::vector<Eigen::VectorXd> b = cpu.biases(t);
  const std::vector<double> w = weightsOf(n, 47);
  struct Out {
    std::vector<double> s;
    std::vector<Eigen::MatrixXd> dW;
    std::vector<Eigen::VectorXd> db;
  };
  auto run = [&](CudaPrecision p, MlpMath m) {
    MlpCuda mlp(sizes, U, p, m);
    EXPECT_EQ(mlp.math(), m);
    Out o;
    mlp.forward(W, b, &o.s);
    EXPECT_TRUE(mlp.backwardAfterForward(w, &o.dW, &o.db));
    return o;
  };
  const Out r64 = run(CudaPrecision::Float64, MlpMath::Exact);
  const Out r32 = run(CudaPrecision::Float32, MlpMath::Exact);
  const Out rtf = run(CudaPrecision::Float32, MlpMath::Tf32);
  auto gradErr = [&](const Out& o) {
    double e = 0.0;
    for (std::size_t l = 0; l < r64.dW.size(); ++l) {
      e = std::max(e, (o.dW[l] - r64.dW[l]).norm() / r64.dW[l].norm());
      e = std::max(e, (o.db[l] - r64.db[l]).norm() / r64.db[l].norm());
    }
    return e;
  };
  const double f32 = relMax(r32.s, r64.s), ftf = relMax(rtf.s, r64.s);
  const double g32 = gradErr(r32), gtf = gradErr(rtf);
  std::printf(
      "[ parity   ] neural 8x512 on %d points: float32 field %.2e gradient %.2e | TF32 field %.2e gradient %.2e\n", n,
      f32, g32, ftf, gtf);
  EXPECT_LT(f32, 1e-6);
  EXPECT_LT(g32, 3e-3);
  EXPECT_LT(ftf, 2e-4);
  EXPECT_LT(gtf, 0.1);
  EXPECT_GT(ftf, f32) << "TF32 did not change the products: were the tensor cores used?";
}
