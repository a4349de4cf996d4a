// Ball (paper appendix, "type of simulation"): a rigid ball with an unknown interior is dropped on
// the floor, bounces and spins; the simulated trajectories of a few tracked body points (pivot
// points; the spin shows in the surface points) must match the observed ones. Loss: mean squared
// distance over samples and points, over the object size². Forward mode through the rigid
// simulation (Dual10), as for the tumbler. Observations (TaskEvaluation::observations): the tracked
// points' coordinates at up to 30 observed times, with d/d(m, c, I).
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <optional>
#include <sstream>

#include "rigid_options.h"
#include "task_factories.h"
#include "topo_gaussian/common/error.h"
#include "topo_gaussian/inference/task_options.h"
#include "topo_gaussian/io/trajectory_csv.h"
#include "topo_gaussian/physics/rigid_body.h"

namespace topo_gaussian::inference {
namespace {

/// The ball's own parameters, typed (the rigid motion's are RigidSimOptions, rigid_options.h).
struct BallOptions {
  double initial_height_m = 0;
  Eigen::Vector3d initial_velocity = Eigen::Vector3d::Zero(), initial_angular_velocity = Eigen::Vector3d::Zero();
  std::vector<double> pivot_points;
  std::optional<std::string> target_trajectory_file;
};

/// Its declaration and reading (inference/task_options.h), in the order `topo tasks` lists them.
constexpr auto kBallFields = [](auto& f) {
  using O = BallOptions;
  f.number("initial_height_m", &O::initial_height_m, 0.3, "m", "drop height of the lowest point above the ground [m]",
           0);
  f.vector3("initial_velocity", &O::initial_velocity, Eigen::Vector3d::Zero(), "m/s", "initial velocity [m/s]");
  f.vector3("initial_angular_velocity", &O::initial_angular_velocity, Eigen::Vector3d::Zero(), "rad/s",
            "initial angular velocity, world frame [rad/s]");
  f.list("pivot_points", &O::pivot_points, {}, "m",
         "tracked body points x,y,z,... [m]; default: centroid and two surface points");
  f.target("target_trajectory_file", &O::target_trajectory_file, "", "CSV: t, then x y z of each pivot point [s, m]");
};

class BallTask : public Task {
 public:
  BallTask(const TaskConfig& c, const VolumeCloud& cloud) : Task(c, cloud) {
    options_ = rigidOptionsFromConfig(c, geometry_.gravity);
    const BallOptions o = readOptions<BallOptions>(c, kBallFields);
    height_ = o.initial_height_m;
    v0_ = o.initial_velocity;
    w0_ = o.initial_angular_velocity;
    centroid_ = cloud.centroid();
    std::string note;
    contact_ = groundContactPoints(cloud, &note, &options_.ground.point_weights);
    if (!note.empty()) notes_.push_back(note);
    if (contact_.empty())
      throw TopoError("volume cloud", "has neither contact samples nor surface particles for ground contact",
                      "fill it with `topo fill`");
    const std::vector<double>& pp = o.pivot_points;
    if (!pp.empty()) {
      if (pp.size() % 3 != 0) throw TopoError("pivot_points", "needs x,y,z triples", "give 3 numbers per point");
      for (std::size_t k = 0; k < pp.size(); k += 3) pivots_.emplace_back(pp[k], pp[k + 1], pp[k + 2]);
    } else {
      // Default: the centroid and the surface particles furthest along +x and +y (they show the spin).
      pivots_.push_back(centroid_);
      Eigen::Vector3d bx = contact_[0], by = contact_[0];
      for (const auto& p : contact_) {
        if (p.x() > bx.x()) bx = p;
        if (p.y() > by.y()) by = p;
      }
      pivots_.push_back(bx);
      pivots_.push_back(by);
    }
    zmin_ = 1e300;
    for (const auto& p : contact_) zmin_ = std::min(zmin_, p.z());
    if (o.target_trajectory_file) readTrajectory(*o.target_trajectory_file);
  }

  const std::vector<Eigen::Vector3d>& pivots() const { return pivots_; }

  void requireTargets() const override {
    if (obs_t_.empty())
      throw TopoError("ball targets", "target_trajectory_file is not given",
                      "give a CSV of t and x y z per pivot point: --target target_trajectory_file=FILE.csv");
  }

  void readTrajectory(const std::string& path) { io::readTrajectoryCsv(path, pivots_.size(), &obs_t_, &obs_); }

  TaskEvaluation evaluate(const std::vector<double>& r, std::vector<double>* dL_dr) const override {
    const RigidMass rm = rigidMass(r, dL_dr != nullptr);
    TaskEvaluation ev;
    ev.mass = rm.props;
    const RigidInertia<Dual10> I = seedInertia(ev.mass);
    // The body frame is placed in the world by a fixed shift (the shape does not move when c does):
    // body point b is at b + shift, so the centre of mass starts at c + shift.
    const Eigen::Vector3d shift(0, 0, height_ - zmin_);
    RigidState<Dual10> s0;
    s0.orientation = Eigen::Quaternion<Dual10>(Dual10(1), Dual10(0), Dual10(0), Dual10(0));
    s0.position = I.com + shift.cast<Dual10>();
    const Vec3<Dual10> w0 = w0_.cast<Dual10>();
    // initial_velocity is the velocity of the centroid: v_c = v0 + ω × (c − centroid).
    s0.velocity = v0_.cast<Dual10>() + w0.cross(I.com - centroid_.cast<Dual10>());
    s0.angular_velocity = w0;
    const RigidTrajectory<Dual10> traj = simulateRigid(I, s0, contact_, withStop(options_, should_stop_));
    auto pointAt = [&](std::size_t k, const Eigen::Vector3d& b) -> Vec3<Dual10> {
      const auto& s = traj.states[k];
      return s.position + s.orientation * (b.cast<Dual10>() - I.com);
    };
    ev.signal_name = "centroid_height_m";
    ev.signal_time_s = traj.time_s;
    double apex = -1e300, first_contact = -1;
    for (std::size_t k = 0; k < traj.states.size(); ++k) {
      std::vector<double> row{traj.time_s[k]};
      for (const auto& b : pivots_) {
        const Vec3<Dual10> x = pointAt(k, b);
        row.insert(row.end(), {x[0].value(), x[1].value(), x[2].value()});
      }
      ev.trajectory_rows.push_back(row);
      ev.motion.push_back(bodyPoseOf(traj.time_s[k], traj.states[k], ev.mass.com));
      const double z = pointAt(k, centroid_)[2].value();
      ev.signal.push_back(z);
      if (first_contact < 0 && z - (centroid_.z() - zmin_) <= 1e-3 * size_) first_contact = traj.time_s[k];
      if (first_contact >= 0 && traj.time_s[k] > first_contact + 0.02) apex = std::max(apex, z);
    }
    Eigen::Matrix<double, 10, 1> dL = Eigen::Matrix<double, 10, 1>::Zero();
    if (!obs_t_.empty()) {
      const double dt = traj.time_s[1] - traj.time_s[0];
      Dual10 sum(0);
      int count = 0;
      for (std::size_t j = 0; j < obs_t_.size(); ++j) {
        const double u = obs_t_[j] / dt;
        std::size_t k = static_cast<std::size_t>(std::floor(u));
        if (u < 0 || k + 1 >= traj.states.size()) continue;
        const double a = u - k;
        for (std::size_t p = 0; p < pivots_.size(); ++p) {
          const Vec3<Dual10> x = (1 - a) * pointAt(k, pivots_[p]) + a * pointAt(k + 1, pivots_[p]);
          sum += (x - obs_[j][p].cast<Dual10>()).squaredNorm();
          ++count;
        }
      }
      if (count == 0)
        throw TopoError("target_trajectory_file", "has no samples inside the simulated time", "raise duration_s");
      const Dual10 loss = sum / (count * size_ * size_);
      ev.loss = loss.value();
      dL = loss.derivatives();
      ev.features.push_back(Feature{"rms_error_m", std::sqrt(sum.value() / count), "m", true, 0.0, 1e-3 * size_, 1.0});
    }
    addObservations(traj, I, &ev);
    ev.features.push_back(Feature{"apex_height_m", apex, "m"});
    ev.features.push_back(Feature{"final_spin_rad_s", traj.states.back().angular_velocity.norm().value(), "rad/s"});
    ev.features.push_back(Feature{"mass_kg", ev.mass.mass, "kg"});
    if (dL_dr) chainToIndicator(rm, dL, dL_dr);
    return ev;
  }

 private:
  // Observations: the trajectory residual components (x, y, z of every tracked point) at up to
  // kObservedTimes of the observed sample times (evenly strided; without a target trajectory, of the
  // simulated output times). Noise: the rms_error_m tolerance 1e-3·size, divided by √stride so that
  // the strided rows carry the information of all samples (each stands for `stride` of them).
  static constexpr std::size_t kObservedTimes = 30;
  void addObservations(const RigidTrajectory<Dual10>& traj, const RigidInertia<Dual10>& I, TaskEvaluation* ev) const {
    const double dt = traj.time_s.size() > 1 ? traj.time_s[1] - traj.time_s[0] : options_.output_dt_s;
    std::vector<double> times = obs_t_;
    if (times.empty())
      for (std::size_t k = 1; k < traj.time_s.size(); ++k) times.push_back(traj.time_s[k]);
    const std::size_t stride = std::max<std::size_t>(1, (times.size() + kObservedTimes - 1) / kObservedTimes);
    const double noise = 1e-3 * size_ / std::sqrt(double(stride));
    const char* axis[3] = {"x", "y", "z"};
    for (std::size_t j = 0; j < times.size(); j += stride) {
      const double u = times[j] / dt;
      const std::size_t k = static_cast<std::size_t>(std::floor(std::max(u, 0.0)));
      if (u < 0 || k + 1 >= traj.states.size()) continue;
      const double a = u - k;
      for (std::size_t p = 0; p < pivots_.size(); ++p) {
        auto at = [&](std::size_t n) {
          const auto& s = traj.states[n];
          return Vec3<Dual10>(s.position + s.orientation * (pivots_[p].cast<Dual10>() - I.com));
        };
        const Vec3<Dual10> x = (1 - a) * at(k) + a * at(k + 1);
        for (int c = 0; c < 3; ++c) {
          Observation o{"point" + std::to_string(p) + "_" + axis[c] + "_m@" + std::to_string(times[j]) + "s",
                        x[c].value(),
                        "m",
                        !obs_t_.empty(),
                        obs_t_.empty() ? 0.0 : obs_[j][p][c],
                        noise,
                        x[c].derivatives()};
          ev->observations.push_back(o);
        }
      }
    }
  }

  RigidSimOptions options_;
  double height_ = 0, zmin_ = 0;
  Eigen::Vector3d v0_, w0_, centroid_;
  std::vector<Eigen::Vector3d> contact_, pivots_;
  std::vector<double> obs_t_;
  std::vector<std::vector<Eigen::Vector3d>> obs_;
};

}  // namespace

void registerBallTask(TaskList* tasks) {
  TaskDefinition t;
  t.name = "ball";
  t.summary = "a ball dropped on the floor bounces and spins: trajectories of tracked body points";
  t.declare_parameters = [](TaskParameters& p) {
    // Contact damping 0.05: a bounce keeps ~85 % of its speed, and a rolling ball loses < 0.5 % of g sin β
    // to the damper (0.3 made it roll 2.6 % slow down a 15° incline).
    declareRigidMotionParameters(p, 1.0, 0.05);
    declareOptions<BallOptions>(p, kBallFields);
  };
  t.make = [](const TaskConfig& config, const VolumeCloud& cloud) -> std::unique_ptr<Task> {
    return std::make_unique<BallTask>(config, cloud);
  };
  tasks->push_back(t);
}

}  // namespace topo_gaussian::inference
