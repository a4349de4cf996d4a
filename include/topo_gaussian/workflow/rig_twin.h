// RigTwin: the ROS-free core of the `rig_simulator` node, a digital twin of a lab rig. It builds a
// default shape's particle cloud, gives it a known interior (a quadric θ: the ground truth), simulates
// the task once (the tumbler released at rest at initial_tilt_deg; the hanging object swinging from
// its hanging point), keeps the features that interior produces (what the inference must recover),
// and replays the motion forever as a seamless loop: poseAt(t) for any t ≥ 0.
//
// The loop: a motion released at rest returns to (almost) its release state at every turning point
// on the release side, a whole number of periods later. Of a simulation of loop_cycles + 1.5
// periods, the loop is cut at the last such turning point that is back within 0.5 % of the release
// amplitude and 0.2 spacings of the release position (time refined by a parabola through the
// signal), so the replay is continuous in pose and (≈ zero) velocity at the seam and every swing
// reaches at least 99.5 % of the release tilt; seamRotationDeg() and seamTranslationM() report
// what is left of the jump, amplitudeDecayPerCycle() the damping. Without such a turning point
// (a damped motion) the loop is the one with the smallest jump.
//
// The cloud is the shape's lattice with its surface particles moved onto the true boundary, so the
// ground contact is the real round bottom: on the plain lattice the tumbler stands on its flat
// lowest layer (an 11 mm disc at 2.5 mm spacing) and rocks like a block about the disc's edge, with
// a period that falls by a third as the swing decays. With the contact damping off (`undamped`, the
// default) the replayed tumbler keeps 99.9 % of its amplitude per period.
//
// A hanging object (RigTwinMotion::hangs) is released swing_tilt_deg off the pose its true interior
// rests in (the target_roll_deg / target_pitch_deg of its config() are set to it, hangingRestPose),
// as a rig lets it settle on its string before the swing, and is held with its lowest point 5 mm
// above the table (z = 0) that the rig's camera watches.
//
// Its ground contact is on samples of the shape's exact surface (exactShapeContactSamples): topo
// fill's evenly spread samples of a fine mesh of the shape (512 segments a circle), each moved along its
// normal onto the exact boundary, at contact_spacing_m (default d / 400, as topo fill does for a mesh),
// joined by their mirror images across the vertical plane normal to the rocking axis (the motion's
// symmetry: without it the doll turned 2.8° about the vertical in 9 periods).
// The lattice crossings that defaultShapeCloud carries (shapeContactSamples) are uneven where the
// lattice lines meet the round bottom at a grazing angle: with them the doll's first-cycle period
// wandered −1.53 … +0.88 % of the exact rolling period over release tilts 5…25°; with these samples it
// stays within 0.1 % (RigTwin.TumblerPeriodOverReleaseTilts), so the video the twin renders is the
// smooth solid's motion, not an artefact of the sampling the inference shares.
//
// The truth features are those of the task as configured (after `undamped` and the overrides) on
// that cloud; the long simulation for the loop only extends the same motion.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "topo_gaussian/inference/interior_problem.h"
#include "topo_gaussian/inference/task.h"
#include "topo_gaussian/inference/task_config.h"
#include "topo_gaussian/physics/default_shapes.h"
#include "topo_gaussian/physics/volume_cloud.h"

namespace topo_gaussian::workflow {

struct RigTwinOptions {
  std::string shape = "tumbler";       ///< a default shape (defaultShapeNames())
  double spacing_m = 0.0025;           ///< lattice spacing of the particle cloud [m]
  std::string task;                    ///< task name or YAML path; empty = the shape's task (tumbler → tumbler)
  std::string task_dir;                ///< where task names resolve to NAME.yaml (TaskConfig::load)
  std::vector<std::string> overrides;  ///< "KEY=VALUE" task parameters
  Eigen::VectorXd interior_quadric;    ///< θ (10); empty = defaultInteriorQuadric(task)
  int loop_cycles = 8;                 ///< the loop is cut within the first loop_cycles periods (≥ 2)
  bool undamped = true;                ///< contact_damping_ratio = 0 (before the overrides), for a seamless loop
  /// A surface file (mesh, points, 3DGS) of the object, filled exactly as cloud_ingest / `topo fill`
  /// fill it (geometry::ingestFile at spacing_m, default cleaning): the twin then simulates the very
  /// particle cloud the lab pipeline will infer on (a plain lattice, contact on its staircase), so
  /// its truth is reachable by construction. Empty: the default shape `shape` with its surface on
  /// the true boundary (above).
  std::string surface_file;
  double scan_spacing_m = 0.001;  ///< point spacing of the simulated scan (scanPoints); 0 = spacing_m
  /// Spacing of the contact samples on the shape's exact surface [m]; 0 = d / 400 (d the lattice's
  /// bounding-box diagonal; geometry::defaultContactSpacing of a mesh). Default shapes only.
  double contact_spacing_m = 0.0;
};

/// Contact samples on a default shape's exact surface at spacing_m (0 = d / 400): the samples topo fill
/// takes of a mesh (geometry::sampleContactSurface: Poisson-disk, Lloyd-relaxed, area-weighted) of a
/// 512-segment mesh of the shape, each moved along its normal onto the boundary of shape.inside
/// (bisection to 1e-12 m). `cloud` is the shape's lattice (defaultShapeCloud). mirror_axis 0 or 1: when
/// the shape is its own mirror image across the plane normal to x (0) or y (1) through its centre, the
/// samples are joined by their mirror images (half the area each), so a body rocking about that axis
/// is not spun about the vertical by the sampling; −1: none.
ContactSamples exactShapeContactSamples(const DefaultShape& shape, const VolumeCloud& cloud, double spacing_m,
                                        int mirror_axis = -1);

class RigTwin {
 public:
  /// Builds and simulates the twin. Throws TopoError naming the option for bad options (unknown
  /// shape or task, a task without a motion, a θ of the wrong size or non-finite) and when the
  /// simulation fails (the task's own message: no oscillation, divergence, ...).
  explicit RigTwin(const RigTwinOptions& options);

  /// The ground-truth quadric for a task: a spherical cavity |u − u0| < ρ in the normalised
  /// coordinates of the quadric representation (s(u) = |u − u0|² − ρ², r ≈ 0 inside). Tumbler: u0 =
  /// (0, 0, 0.4), ρ = 0.5 — a hollow sphere of radius 25 mm centred 4.5 mm above the body origin,
  /// cut by the pinned shell under the flat top: it lowers the centre of mass and shortens the
  /// rocking period by about 10 % against the solid tumbler. Hanging: u0 = (0, 0, 0.3), ρ = 0.4 — a
  /// cavity in the upper half on the axis: the object hangs straight and swings in one plane (an
  /// off-axis cavity would make it swing in two, which never loops), 2 % slower than solid (pear).
  /// (Each task's RigTwinMotion cavity, inference/task_registry.h.) Throws TopoError for other tasks.
  static Eigen::VectorXd defaultInteriorQuadric(const std::string& task);
  /// The task whose registered RigTwinMotion names the shape (tumbler → tumbler), else the one
  /// registered for every other shape (hanging).
  static std::string defaultTaskFor(const std::string& shape);

  const RigTwinOptions& options() const { return options_; }
  const inference::TaskConfig& config() const { return config_; }
  const DefaultShape& shape() const { return shape_; }
  /// The simulated cloud: lattice of spacing_m, surface particles on the true boundary (body frame).
  const VolumeCloud& cloud() const { return cloud_; }
  const std::vector<double>& indicator() const { return r_; }      ///< true r_i (1 solid, 0 hollow)
  const std::vector<double>& density() const { return density_; }  ///< true ρ_i [kg/m³]
  double solidFraction() const { return truth_.solid_fraction; }
  /// The task's evaluation of the true interior, as configured (features, mass, signal, motion).
  const inference::ProblemEvaluation& truth() const { return truth_; }
  /// A truth feature by name (period_s, max_tilt_deg, ...); throws TopoError listing the names.
  double feature(const std::string& name) const;

  /// The object's surface for rendering and for a simulated scan, body frame: the cloud's surface
  /// particles, which were moved along their estimated outward normal onto the shape's boundary
  /// (bisection on the exact inside test), with those normals.
  const std::vector<Eigen::Vector3d>& surfacePoints() const { return surface_points_; }
  const std::vector<Eigen::Vector3d>& surfaceNormals() const { return surface_normals_; }
  /// A simulated scan of the surface (what a depth camera or a reconstruction gives, for
  /// cloud_ingest): the same construction on a lattice of scan_spacing_m, so a denser sampling of
  /// the true boundary with outward normals, body frame.
  const std::vector<Eigen::Vector3d>& scanPoints() const { return scan_points_; }
  const std::vector<Eigen::Vector3d>& scanNormals() const { return scan_normals_; }

  /// Body pose (world = rotation · X + translation) at any t ≥ 0 (negative t = 0): the looped motion,
  /// interpolated (translation linear, rotation slerp) between the simulated samples.
  inference::BodyPose poseAt(double t_s) const;
  double loopSeconds() const { return loop_s_; }
  int loopCycles() const { return loop_periods_; }               ///< periods in one loop
  double seamRotationDeg() const { return seam_rotation_deg_; }  ///< pose jump at the seam
  double seamTranslationM() const { return seam_translation_m_; }
  /// Relative loss of swing amplitude per period over the loop, (1 − A_last/A_0)/periods.
  double amplitudeDecayPerCycle() const { return decay_per_cycle_; }
  /// The simulated signal of the looped motion (tilt or swing angle, degrees) and its times.
  const std::vector<double>& loopSignal() const { return loop_signal_; }
  const std::vector<double>& loopSignalTime() const { return loop_time_; }
  double simulationSeconds() const { return simulation_s_; }  ///< wall time of both simulations

 private:
  void buildSurface();
  /// A hanging task (RigTwinMotion::hangs): sets the target pose of config_ and *quadric to the pose
  /// the true interior rests in and simulates the truth again, so the twin swings about its rest.
  void restAtHangingPose(inference::TaskConfig* quadric);
  void buildLoop(const inference::TaskEvaluation& run, double period_s);

  RigTwinOptions options_;
  inference::TaskConfig config_;
  DefaultShape shape_;
  VolumeCloud cloud_;
  std::vector<double> r_, density_;
  inference::ProblemEvaluation truth_;
  std::vector<Eigen::Vector3d> surface_points_, surface_normals_, scan_points_, scan_normals_;
  std::vector<inference::BodyPose> motion_;
  std::vector<double> loop_signal_, loop_time_;
  double loop_s_ = 0, seam_rotation_deg_ = 0, seam_translation_m_ = 0, decay_per_cycle_ = 0, simulation_s_ = 0;
  int loop_periods_ = 0;
};

}  // namespace topo_gaussian::workflow
