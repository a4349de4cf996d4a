// Task: the physics of one inference problem (paper §6–7). Given the indicator r_i of every
// particle it returns the loss (features vs observed targets), dLoss/dr_i, and the simulated
// features. Rigid tasks (hanging, balance, stand, tumbler, ball) depend on r only through the mass
// properties (m, c, I) and chain their gradient through them; qiqi (the tilting vessel) also moves
// water into the cavity, so it differentiates its equilibrium directly (implicit function theorem).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <memory>
#include <string>
#include <vector>

#include "topo_gaussian/inference/body_motion.h"
#include "topo_gaussian/inference/task_config.h"
#include "topo_gaussian/physics/mass_properties.h"
#include "topo_gaussian/physics/run_limits.h"
#include "topo_gaussian/physics/volume_cloud.h"
#include "topo_gaussian/topology/materials.h"

namespace topo_gaussian::inference {

struct Feature {
  std::string name;
  double value = 0.0;
  std::string unit;
  bool has_target = false;
  double target = 0.0;
  /// |value − target| relative to max(|target|, scale); ≤ tolerance counts as reached.
  double scale = 1.0;
  double tolerance = 0.01;
  bool reached() const;
};

/// One observed quantity of a rigid task, linearised in the ten mass properties p = (m, cx, cy, cz, Ixx,
/// Iyy, Izz, Ixy, Ixz, Iyz) (MassProperties::toVector order): y ≈ y(p₀) + d_dp · (p − p₀). These are the
/// residual components the loss compares (never a norm: it is not differentiable where it is matched),
/// with the noise at which a person calls the observation matched. inference/identifiability.h stacks them.
struct Observation {
  std::string name;
  double value = 0.0;  ///< simulated value at this design
  std::string unit;
  bool has_target = false;  ///< measured (in the loss); false: what this experiment would observe
  double target = 0.0;
  double noise = 1.0;  ///< the feature's tolerance in the value's unit (> 0)
  Eigen::Matrix<double, 10, 1> d_dp = Eigen::Matrix<double, 10, 1>::Zero();  ///< dy/dp
};

/// Geometry a task reports for pictures and report.json (world frame of the target pose).
struct TaskGeometry {
  bool has_point = false;
  std::string point_name;                           ///< "hanging_point", "support_point", "pivot_point"
  Eigen::Vector3d point = Eigen::Vector3d::Zero();  ///< body frame [m]
  Eigen::Vector3d gravity = Eigen::Vector3d(0, 0, -9.81);
};

struct TaskEvaluation {
  double loss = 0.0;
  std::vector<Feature> features;
  MassProperties mass;                        ///< of the vessel/object material
  std::vector<double> signal_time_s, signal;  ///< simulated signal (tilt [deg], ...) when dynamic
  std::string signal_name;
  /// Tracked points over time (ball): rows of t, then x y z per tracked point — the format of
  /// target_trajectory_file, so a simulated design can serve as an observation.
  std::vector<std::vector<double>> trajectory_rows;
  /// Rigid motion of the object (tumbler, ball, hanging swing), sampled like the signal; empty for
  /// tasks without one (static poses, soft bodies).
  std::vector<BodyPose> motion;
  /// Soft tasks: particle positions (object frame, the cloud's order) at a few instants, for a replay:
  /// shapes[k] at shape_time_s[k]. The finger: the rest shape at 0 and the solved shape at the full
  /// pressure at 1 s (static mode; a replay blends them linearly) or at the ramp's end (implicit).
  /// Empty for rigid tasks.
  std::vector<double> shape_time_s;
  std::vector<std::vector<Eigen::Vector3d>> shapes;
  /// Rigid tasks (hanging, balance, tumbler, ball): the observed quantities with dy/dp. Empty for tasks
  /// whose observations depend on more than (m, c, I) or that only bound them (stand, qiqi, soft tasks).
  std::vector<Observation> observations;
};

class Task {
 public:
  virtual ~Task() = default;
  const std::string& name() const { return name_; }
  /// Loss and features for indicator r (size N). dL_dr (optional) is overwritten.
  virtual TaskEvaluation evaluate(const std::vector<double>& r, std::vector<double>* dL_dr) const = 0;
  /// Throws TopoError when a target the loss needs is missing (names the --target to give).
  virtual void requireTargets() const {}
  virtual TaskGeometry geometry() const { return geometry_; }
  /// The per-particle density model (solid ↔ hollow).
  const MaterialInterpolation& density() const { return density_; }
  /// Particle masses m_i = ρ(r_i) V_i and dm_i/dr_i.
  void masses(const std::vector<double>& r, std::vector<double>* m, std::vector<double>* dm_dr) const;
  /// Object size used to make losses dimensionless: bounding-box diagonal [m].
  double size() const { return size_; }
  /// Polled by the task's simulations (physics/run_limits.h): when it returns true they throw
  /// SimulationCancelled within a few ms of work. Set before evaluating; null = never stop.
  void setShouldStop(StopCheck stop) { should_stop_ = std::move(stop); }
  const StopCheck& shouldStop() const { return should_stop_; }
  /// Warnings for a person found while building the task (e.g. contact on the lattice staircase because
  /// the volume has no contact samples); runInference adds them to InferenceResult::warnings.
  const std::vector<std::string>& notes() const { return notes_; }

 protected:
  /// require_gravity: refuse a zero gravity vector (rigid tasks; soft tasks may run without, e.g.
  /// an actuated finger).
  Task(const TaskConfig& config, const VolumeCloud& cloud, bool require_gravity = true);
  /// What a rigid task needs from r: the raw moments, (m, c, I) and, for gradients, dm_i/dr_i.
  struct RigidMass {
    MassMoments moments;
    MassProperties props;
    std::vector<double> dm_dr;  ///< empty unless asked for
  };
  RigidMass rigidMass(const std::vector<double>& r, bool with_gradient) const;
  /// dL/dr_i from dL/d(m, c, I) through the mass-property Jacobian and ρ(r). Overwrites dL_dr.
  void chainToIndicator(const RigidMass& mass, const Eigen::Matrix<double, 10, 1>& dL_dprops,
                        std::vector<double>* dL_dr) const;
  std::string name_;
  const VolumeCloud& cloud_;
  MaterialInterpolation density_;
  double size_ = 1.0;
  Eigen::Vector3d lo_, hi_;
  TaskGeometry geometry_;
  StopCheck should_stop_;
  /// Mutable: an evaluation may add one (backend auto falling back to the CPU when the GPU lacks
  /// memory); runInference collects the notes before and after the optimisation.
  mutable std::vector<std::string> notes_;
};

/// Fewest particles a task accepts: an interior is inferred from how its particles differ, and the
/// mass moments of fewer particles cannot change independently.
constexpr std::size_t kMinTaskParticles = 8;

/// A note when the task's hanging/support/pivot point lies outside the object: outside the
/// particles' bounding box grown by one spacing, or farther than two spacings from every particle
/// ("" when it is inside or the task has none). Not an error: the object may hang from a hook.
std::string pointOutsideObjectNote(const TaskGeometry& geometry, const VolumeCloud& cloud);

/// Builds the task named by config.task() (its registered factory, inference/task_registry.h). The
/// cloud must outlive the task.
/// Throws TopoError for an empty/invalid cloud or inconsistent parameters.
std::unique_ptr<Task> makeTask(const TaskConfig& config, const VolumeCloud& cloud);

/// Rotation of the target pose: roll about world x, then pitch about world y (degrees).
Eigen::Matrix3d targetRotation(double roll_deg, double pitch_deg);

/// The pose an object hung from a point rests in, as targetRotation's angles: with d = c − point (body
/// frame) and gravity along −z, roll = atan2(−d_y, −d_z), then pitch = atan2(d_x, √(d_y² + d_z²)), so
/// that targetRotation(roll, pitch) · d points straight down. Throws TopoError when c is at the point.
struct RollPitch {
  double roll_deg = 0.0, pitch_deg = 0.0;
};
RollPitch hangingRestPose(const Eigen::Vector3d& com_m, const Eigen::Vector3d& point_m);

}  // namespace topo_gaussian::inference
