// GPU benchmark of the soft body's static solve (the finger): one JSON line per case and
// preconditioner, the host's sparse Cholesky (CHOLMOD where the build found it) and the GPU's dense one
// (cuda/dense_cholesky_cuda.h) on the same body in the same run.
//   static_finger_<spacing>  the default finger (0.1 × 0.02 × 0.02 m) at 1.5 mm (9212 particles) or
//       3 mm, StVK, walls E 1e7 ν 0.45, a chamber below the axis E 1e6 ν 0 at 5e5 Pa, clamped over
//       its first 10 mm, as the finger task's static mode (2 load steps, Newton tolerance 1e-8): the
//       factorisation (with K0's assembly), one preconditioner application (mean of 20), one Hessian
//       product and one force evaluation on the host (mean of 20), the whole static solve, its
//       gradient (staticEquilibriumGradient: one adjoint solve) and, for the GPU, how many
//       preconditioner applications the solve and the gradient made. The GPU's factor is applied four
//       ways (DenseCholeskyApply): triangular solves, the explicit inverse by dsymv and by dgemv, and the
//       inverse factor in float32 (its factor_s includes trtri and the float32 copy); on the
//       GPU the stiffness products (hessian_product_ms) are the GPU's too (cuda/soft_stiffness_cuda.h).
// Without a CUDA device it prints one line {"case": "gpu", "skipped": reason} and exits 0.
// Usage: bench_gpu_static [--quick] [CASE_SUBSTRING]
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#ifdef _OPENMP
#include <omp.h>
#endif

#include "../../test/unit/test_soft_bodies.h"
#include "topo_gaussian/cuda/backend.h"
#include "topo_gaussian/cuda/dense_cholesky_cuda.h"
#include "topo_gaussian/cuda/soft_stiffness_cuda.h"
#include "topo_gaussian/physics/default_shapes.h"
#include "topo_gaussian/physics/soft_body.h"
#include "topo_gaussian/physics/soft_rollout.h"

using namespace topo_gaussian;
using Clock = std::chrono::steady_clock;

namespace {

double seconds(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

/// The GPU's factor, counting its applications.
struct CountingSolver : CholeskySolver {
  std::unique_ptr<CholeskySolver> inner;
  long* solves;
  CountingSolver(long* counter, DenseCholeskyApply apply) : inner(makeDenseCholeskyCuda(0.0, apply)), solves(counter) {}
  bool factorize(const Eigen::SparseMatrix<double>& lower) override { return inner->factorize(lower); }
  void solve(const Eigen::VectorXd& r, Eigen::VectorXd* z) const override {
    ++*solves;
    inner->solve(r, z);
  }
  std::string name() const override { return inner->name(); }
  double bytes() const override { return inner->bytes(); }
};

std::unique_ptr<SoftBodySimulator> makeFinger(const VolumeCloud& cloud, const SoftBodyOptions& so) {
  double xmin = 1e300;
  for (const auto& X : cloud.X) xmin = std::min(xmin, X.x());
  std::vector<std::uint8_t> clamp(cloud.size(), 0), chamber(cloud.size(), 0);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3d& X = cloud.X[i];
    clamp[i] = X.x() < xmin + 0.01;
    chamber[i] = !cloud.surface[i] && X.x() > xmin + 0.02 && X.x() < xmin + 0.085 && X.z() > -0.006 &&
                 X.z() < -0.0005 && std::abs(X.y()) < 0.006;
  }
  return topo_test::pneumaticBody(cloud, clamp, chamber, lameFromYoung(1e7, 0.45), lameFromYoung(1e6, 0.0), 5e5, so);
}

void runCase(const std::string& name, double spacing) {
  const VolumeCloud cloud = defaultShapeCloud("finger", spacing);
  // the host; the GPU's triangular solves, inverse × symv, inverse × gemv, float32 inverse factor
  for (const int mode : {-1, 0, 1, 2, 3}) {
    const bool gpu = mode >= 0;
    long solves = 0;
    SoftBodyOptions so;
    if (gpu) {
      const auto apply = static_cast<DenseCholeskyApply>(mode);
      so.cholesky_external = [&solves, apply] { return std::make_unique<CountingSolver>(&solves, apply); };
      so.stiffness_external = [](const SoftBodySimulator& body) { return makeStiffnessCuda(body); };
      so.cholesky_external_required = true;
    }
    auto sim = makeFinger(cloud, so);
    const std::size_t n = sim->size();
    auto t = Clock::now();
    const LinearOperator pre = sim->systemPreconditioner(0.0);
    const double factor_s = seconds(t);
    Eigen::VectorXd r = Eigen::VectorXd::Random(3 * static_cast<Eigen::Index>(n)), z, Hp;
    pre(r, &z);  // warm-up
    t = Clock::now();
    for (int k = 0; k < 20; ++k) pre(r, &z);
    const double apply_ms = 1e3 * seconds(t) / 20.0;
    t = Clock::now();
    for (int k = 0; k < 20; ++k) sim->systemProduct(r, 0.0, &Hp);
    const double product_ms = 1e3 * seconds(t) / 20.0;
    t = Clock::now();
    for (int k = 0; k < 20; ++k) sim->evaluateAt(sim->positions(), 0.0);
    const double forces_ms = 1e3 * seconds(t) / 20.0;
    solves = 0;
    t = Clock::now();
    const SolveReport rep = sim->solveStatic(NewtonOptions(), 2);
    const double static_s = seconds(t);
    const long static_solves = solves;
    std::vector<Eigen::Vector3d> dL_dx(n, Eigen::Vector3d::Zero());
    for (std::size_t i = 0; i < n; ++i) dL_dx[i].z() = sim->positions()[i].x() > 0.09 ? 1.0 : 0.0;
    solves = 0;
    t = Clock::now();
    staticEquilibriumGradient(*sim, dL_dx);
    const double gradient_s = seconds(t);
    double tip = 0.0;
    for (std::size_t i = 0; i < n; ++i) tip = std::max(tip, (sim->positions()[i] - sim->restPositions()[i]).norm());
    std::printf(
        "{\"case\": \"%s\", \"apply\": \"%s\", \"preconditioner\": \"%s\", \"particles\": %zu, \"threads\": %d, "
        "\"factor_s\": %.4f, "
        "\"apply_ms\": %.3f, \"hessian_product_ms\": %.3f, \"forces_ms\": %.3f, \"static_s\": %.3f, "
        "\"newton_iterations_last_load_step\": %d, \"cg_iterations_last_load_step\": %d, \"gradient_s\": %.3f, "
        "\"applications_static\": %ld, \"applications_gradient\": %ld, \"max_displacement_m\": %.9e}\n",
        name.c_str(),
        mode < 0    ? "host"
        : mode == 0 ? "triangular"
        : mode == 1 ? "inverse_symv"
        : mode == 2 ? "inverse_gemv"
                    : "inverse_factor_float32",
        sim->preconditionerWhere().c_str(), n,
#ifdef _OPENMP
        omp_get_max_threads(),
#else
        1,
#endif
        factor_s, apply_ms, product_ms, forces_ms, static_s, rep.newton.iterations, rep.newton.cg_iterations,
        gradient_s, gpu ? static_solves : -1L, gpu ? solves : -1L, tip);
    std::fflush(stdout);
  }
}

}  // namespace

int main(int argc, char** argv) {
  bool quick = false;
  const char* only = nullptr;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--quick") == 0)
      quick = true;
    else
      only = argv[i];
  }
  if (!cudaDeviceInfo().available) {
    std::printf("{\"case\": \"gpu\", \"skipped\": \"%s\"}\n", cudaDeviceInfo().reason.c_str());
    return 0;
  }
  for (const double h : quick ? std::vector<double>{0.003} : std::vector<double>{0.003, 0.0015}) {
    const std::string name = "static_finger_" + std::to_string(static_cast<int>(std::lround(h * 1e4))) + "e-4m";
    if (only && name.find(only) == std::string::npos) continue;
    runCase(name, h);
  }
  return 0;
}
