// FingerTwin: the ROS-free core of the finger twin (rig_simulator ~object finger), a digital twin of a
// pneumatic soft-finger rig (paper §7 "Pneumatic Finger"). The finger (the default shape, its surface
// particles on the true boundary, workflow/shape_surface.h) gets a true air chamber (a quadric θ,
// binarised: r = 0 inside, 1 outside) and is clamped at its base as the finger task clamps it. The
// finger task (static mode: the quasi-static equilibrium under the chamber's gauge pressure p) is
// solved at `pressure_levels` pressures 0 = p_0 < … < p_K = max_pressure_pa; between two levels the
// shape and the bend are interpolated linearly in p (a regulator changes the pressure slowly
// against the finger's first vibration mode, ~100 Hz, so the finger follows it quasi-statically).
//
// No inverse crime: the twin simulates a finer lattice (2 mm by default) than the inference's
// default (2.5 mm), with the surface on the true boundary; the truth features are the task's own
// definitions (bend_angle_deg: finger_task.cpp) on that cloud.
//
// The default chamber (defaultChamberQuadric): an ellipsoid x ∈ [0.015, 0.065] m, |y| < 6 mm,
// z ∈ [−4.5, 0.5] mm in the 0.1 × 0.02 × 0.015 m default finger (walls 3 mm below and 7 mm above
// it): the thin lower wall stretches and the finger bends up (+z, the task's bend_normal): at the
// paper's 5e5 Pa a fraction of a degree with the task's default walls (E 1e7 Pa), 6.0 deg with the rig's soft
// elastomer (config/rigs/finger_twin.yaml: E 2e6 Pa; StVK 0.85 / 1.88 / 3.08 / 4.45 / 5.97 deg at 1–5e5 Pa;
// linear interpolation between the 1e5 Pa levels is within 0.05 deg of direct solves, 16–36 s to set up). It ends before
// the last 30 % of the length, whose two segments give the bend, so a side camera's silhouette there is the material's
// (test/unit/vision_finger_bend.cpp: a chamber bulging under them makes the silhouette's chord 24 % steeper than the
// task's).
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "topo_gaussian/inference/interior_problem.h"
#include "topo_gaussian/inference/task_config.h"
#include "topo_gaussian/physics/default_shapes.h"
#include "topo_gaussian/physics/volume_cloud.h"

namespace topo_gaussian::workflow {

struct FingerTwinOptions {
  double spacing_m = 0.002;            ///< lattice spacing of the simulated finger [m]
  std::string task = "finger";         ///< the finger task, or a YAML path of one (task: finger)
  std::string task_dir;                ///< where task names resolve (TaskConfig::load)
  std::vector<std::string> overrides;  ///< "KEY=VALUE" task parameters (materials, clamp, ...)
  Eigen::VectorXd interior_quadric;    ///< θ (10); empty = defaultChamberQuadric()
  double max_pressure_pa = 0.0;        ///< highest pressure the twin solves [Pa]; 0 = the task's pressure_pa
  int pressure_levels = 6;             ///< levels from 0 to max_pressure_pa (≥ 2)
};

class FingerTwin {
 public:
  /// Builds and solves the twin. Throws TopoError naming the option for bad options (a task other than
  /// finger, a θ of the wrong size, a chamber that holds no particle or every particle, levels < 2, a
  /// pressure ≤ 0) and when an equilibrium fails (the solver's message, with the pressure).
  explicit FingerTwin(const FingerTwinOptions& options);

  /// θ of the default chamber (see the header comment) in the quadric representation's normalised
  /// coordinates of the default finger (u = (x − (0.05, 0, 0)) / 0.05).
  static Eigen::VectorXd defaultChamberQuadric();

  const FingerTwinOptions& options() const { return options_; }
  const inference::TaskConfig& config() const { return config_; }  ///< the task at max_pressure_pa
  const DefaultShape& shape() const { return shape_; }
  const VolumeCloud& cloud() const { return cloud_; }              ///< rest cloud (body frame)
  const std::vector<double>& indicator() const { return r_; }      ///< true r_i (1 wall, 0 chamber)
  const std::vector<double>& density() const { return density_; }  ///< true ρ_i [kg/m³]
  double solidFraction() const;
  double chamberVolumeM3() const;  ///< Σ V_i over the chamber particles
  double maxPressurePa() const { return levels_pa_.back(); }
  const std::vector<double>& pressureLevelsPa() const { return levels_pa_; }
  /// The task's evaluation at the highest pressure (features, mass, rest and deformed shape).
  const inference::ProblemEvaluation& truth() const { return truth_; }
  /// The true bending angle at pressure p [deg] (p clamped to [0, max]), interpolated between levels.
  double bendDeg(double pressure_pa) const;
  /// Every particle's position at pressure p (body frame), interpolated between levels.
  std::vector<Eigen::Vector3d> positionsAt(double pressure_pa) const;
  /// The surface: indices of the surface particles (on the true boundary) and their rest normals.
  const std::vector<std::size_t>& surfaceIndex() const { return surface_index_; }
  const std::vector<Eigen::Vector3d>& surfaceNormals() const { return surface_normals_; }
  double setupSeconds() const { return setup_s_; }

 private:
  FingerTwinOptions options_;
  inference::TaskConfig config_;
  DefaultShape shape_;
  VolumeCloud cloud_;
  std::vector<double> r_, density_, levels_pa_, bend_deg_;
  std::vector<std::vector<Eigen::Vector3d>> shapes_;  ///< positions at each level
  inference::ProblemEvaluation truth_;
  std::vector<std::size_t> surface_index_;
  std::vector<Eigen::Vector3d> surface_normals_;
  double setup_s_ = 0.0;
};

}  // namespace topo_gaussian::workflow
