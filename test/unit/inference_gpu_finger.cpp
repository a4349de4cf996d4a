// The finger and cantilever tasks with backend cuda: their Newton solves precondition with
// the rest stiffness's dense Cholesky factor on the GPU (cuda/dense_cholesky_cuda.h); the finger's loss,
// bend and whole-task gradient dL/dr, the cantilever's tip and first frequency agree with backend cpu
// (the host's sparse factor) to 1e-8, and the tasks say where the factor is. Built in the catkin package and in the
// core build where the inference libraries are found (a GPU machine: bench/gpu/README.md); skips without a device.
#include <gtest/gtest.h>

#include <cmath>

#include "gpu_test.h"
#include "test_clouds.h"
#include "topo_gaussian/cuda/backend.h"
#include "topo_gaussian/inference/task.h"
#include "topo_gaussian/physics/default_shapes.h"

using namespace topo_gaussian;
using namespace topo_gaussian::inference;

namespace {

/// The task with backend cuda; checks that it says the factor and the products run on the GPU.
std::unique_ptr<Task> makeTaskOnGpu(TaskConfig c, const VolumeCloud& cloud) {
  c.set("backend", "cuda");
  ::testing::internal::CaptureStderr();
  auto task = makeTask(c, cloud);
  const std::string said = ::testing::internal::GetCapturedStderr();
  EXPECT_NE(said.find("the rest stiffness's Cholesky factor on the GPU (dense"), std::string::npos) << said;
  EXPECT_NE(said.find("the stiffness products of the linear solves on the GPU"), std::string::npos) << said;
  return task;
}

TEST(FingerOnGpu, LossBendAndGradientAgreeWithTheCpu) {
  SKIP_WITHOUT_GPU();
  const VolumeCloud cloud = defaultShapeCloud("finger", 0.003);
  std::vector<double> r = topo_test::fingerChamberBelowAxis(cloud);
  for (std::size_t i = 0; i < r.size(); ++i) r[i] = 0.2 + 0.6 * r[i];  // intermediate materials: every term moves
  TaskConfig c = TaskConfig::defaults("finger");
  c.setNumber("bend_angle_deg", 1.0);
  c.set("backend", "cpu");
  const auto cpu = makeTask(c, cloud);
  const auto gpu = makeTaskOnGpu(c, cloud);
  std::vector<double> gc, gg;
  const TaskEvaluation ec = cpu->evaluate(r, &gc), eg = gpu->evaluate(r, &gg);
  ASSERT_EQ(gc.size(), gg.size());
  double bend_c = NAN, bend_g = NAN;
  for (const auto& f : ec.features)
    if (f.name == "bend_angle_deg") bend_c = f.value;
  for (const auto& f : eg.features)
    if (f.name == "bend_angle_deg") bend_g = f.value;
  std::printf("[finger gpu] %zu particles: bend %.9f deg (cpu) %.9f deg (cuda), loss %.6e / %.6e\n", cloud.size(),
              bend_c, bend_g, ec.loss, eg.loss);
  EXPECT_GT(std::abs(bend_c), 0.05);
  EXPECT_NEAR(bend_g, bend_c, 1e-8 * std::abs(bend_c));
  EXPECT_NEAR(eg.loss, ec.loss, 1e-8 * ec.loss);
  double num = 0.0, den = 0.0;
  for (std::size_t i = 0; i < gc.size(); ++i) {
    num += (gg[i] - gc[i]) * (gg[i] - gc[i]);
    den += gc[i] * gc[i];
  }
  EXPECT_LT(std::sqrt(num), 1e-8 * std::sqrt(den));
  for (const std::string& n : gpu->notes()) EXPECT_EQ(n.find("not the GPU"), std::string::npos) << n;
}

}  // namespace

// The cantilever's static solve and its inverse iteration for the first frequency (each CG
// preconditioned by the GPU's factor under backend cuda) give the CPU's tip and frequency.
TEST(CantileverOnGpu, TipAndFrequencyAgreeWithTheCpu) {
  SKIP_WITHOUT_GPU();
  const VolumeCloud cloud = defaultShapeCloud("beam", 0.005);
  TaskConfig c = TaskConfig::defaults("cantilever");
  c.set("vibration", "false");
  c.set("backend", "cpu");
  const TaskEvaluation ec = makeTask(c, cloud)->evaluate(std::vector<double>(cloud.size(), 1.0), nullptr);
  const auto gpu = makeTaskOnGpu(c, cloud);
  const TaskEvaluation eg = gpu->evaluate(std::vector<double>(cloud.size(), 1.0), nullptr);
  for (const char* name : {"tip_deflection_m", "modal_frequency_hz"}) {
    double vc = NAN, vg = NAN;
    for (const auto& f : ec.features)
      if (f.name == name) vc = f.value;
    for (const auto& f : eg.features)
      if (f.name == name) vg = f.value;
    std::printf("[cantilever gpu] %zu particles: %s %.12g (cpu) %.12g (cuda)\n", cloud.size(), name, vc, vg);
    EXPECT_TRUE(std::isfinite(vc) && vc != 0.0) << name;
    EXPECT_NEAR(vg, vc, 1e-8 * std::abs(vc)) << name;
  }
}
