// Pear (paper §7, soft bodies): a soft pear with a stiff insert is released above the ground at a
// tilt and bounces; a camera tracks a few points on it. Infer the insert (r = 1 stiff, r = 0 soft)
// so that the simulated trajectories of those pivot points match the observed ones:
//   L = Σ_j Σ_p |x_p(t_j) − x*_p(t_j)|² / (J P s²),  s = object size,
// at the observed times t_j (each at the nearest simulation step). Explicit symplectic Euler with
// ground contact (penalty + friction) on the volume's contact samples, points of the true surface
// embedded in the particles (SoftTask::embedContactSamples; the surface particles, with a note, when
// the volume has none); reverse mode through time with
// checkpointing (SoftRollout). The target format is the ball task's: CSV rows t, x y z per point.
#include <Eigen/Geometry>
#include <cmath>
#include <optional>

#include "soft_task.h"
#include "task_factories.h"
#include "topo_gaussian/common/error.h"
#include "topo_gaussian/cuda/soft_rollout_cuda.h"
#include "topo_gaussian/inference/task_options.h"
#include "topo_gaussian/io/trajectory_csv.h"

namespace topo_gaussian::inference {
namespace {

/// The pear's own parameters, typed (the soft body's are SoftSimOptions, soft_task.h).
struct PearOptions {
  double duration_s = 0.12, dt_s = 0, sample_dt_s = 0.005, initial_height_m = 0.01;
  Eigen::Vector3d initial_velocity = Eigen::Vector3d::Zero();
  double initial_tilt_deg = 15, contact_stiffness_n_per_m = 0, friction_mu = 0.5;
  std::vector<double> pivot_points;
  std::optional<std::string> target_trajectory_file;
};

/// Its declaration and reading (inference/task_options.h), in the order `topo tasks` lists them.
constexpr auto kPearFields = [](auto& f) {
  using O = PearOptions;
  f.number("duration_s", &O::duration_s, 0.12, "s", "simulated time [s]", 0, 1e300, true);
  f.number("dt_s", &O::dt_s, 0.0, "s", "integration step [s]; 0 = 0.9 x the explicit stability limit", 0);
  f.number("sample_dt_s", &O::sample_dt_s, 0.005, "s", "spacing of the compared trajectory samples [s]", 0, 1e300,
           true);
  f.number("initial_height_m", &O::initial_height_m, 0.01, "m",
           "gap between the lowest point and the ground at release [m]", 0);
  f.vector3("initial_velocity", &O::initial_velocity, Eigen::Vector3d::Zero(), "m/s", "initial velocity [m/s]");
  f.number("initial_tilt_deg", &O::initial_tilt_deg, 15.0, "deg", "release tilt about world x [deg]", -89, 89);
  f.number("contact_stiffness_n_per_m", &O::contact_stiffness_n_per_m, 0.0, "N/m",
           "ground penalty stiffness per particle [N/m]; 0 = automatic", 0);
  f.number("friction_mu", &O::friction_mu, 0.5, "unitless", "Coulomb friction coefficient, unitless", 0);
  f.list("pivot_points", &O::pivot_points, {}, "m",
         "tracked body points x,y,z,... [m]; default: top, bottom and two side points");
  f.target("target_trajectory_file", &O::target_trajectory_file, "", "CSV: t, then x y z of each pivot point [s, m]");
};

class PearTask : public SoftTask {
 public:
  PearTask(const TaskConfig& c, const VolumeCloud& cloud) : SoftTask(c, cloud) {
    const PearOptions o = readOptions<PearOptions>(c, kPearFields);
    duration_ = o.duration_s;
    sample_dt_ = o.sample_dt_s;
    const double tilt = o.initial_tilt_deg * M_PI / 180.0;
    const Eigen::Matrix3d R = Eigen::AngleAxisd(tilt, Eigen::Vector3d::UnitX()).toRotationMatrix();
    const Eigen::Vector3d centre = cloud.centroid();
    contact_embedding_ = embedContactSamples(cloud);
    x0_.resize(cloud.size());
    double zmin = 1e300;
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      x0_[i] = R * (cloud.X[i] - centre) + centre;
      if (!contact_embedding_) zmin = std::min(zmin, x0_[i].z());
    }
    // The lowest point: of the true surface (the samples move with the particles' rotation exactly).
    if (contact_embedding_)
      for (const auto& y : cloud.contact.X) zmin = std::min(zmin, (R * (y - centre) + centre).z());
    const Eigen::Vector3d shift(0, 0, o.initial_height_m - zmin);
    for (auto& p : x0_) p += shift;
    v0_ = o.initial_velocity;
    contact_opt_.stiffness = o.contact_stiffness_n_per_m;
    contact_opt_.friction = o.friction_mu;
    contact_opt_.slip_velocity = 0.01;
    contact_mask_ = cloud.surface;
    if (std::count(contact_mask_.begin(), contact_mask_.end(), 1) == 0) contact_mask_.assign(cloud.size(), 1);
    // Pivot points (body frame) → nearest particles.
    std::vector<Eigen::Vector3d> pts;
    const std::vector<double>& pp = o.pivot_points;
    if (!pp.empty()) {
      if (pp.size() % 3 != 0) throw TopoError("pivot_points", "needs x,y,z triples", "give 3 numbers per point");
      for (std::size_t k = 0; k < pp.size(); k += 3) pts.emplace_back(pp[k], pp[k + 1], pp[k + 2]);
    } else {
      pts = {Eigen::Vector3d(centre.x(), centre.y(), hi_.z()), Eigen::Vector3d(centre.x(), centre.y(), lo_.z()),
             Eigen::Vector3d(hi_.x(), centre.y(), centre.z()), Eigen::Vector3d(centre.x(), hi_.y(), centre.z())};
    }
    for (const auto& p : pts) {
      std::size_t best = 0;
      for (std::size_t i = 1; i < cloud.size(); ++i)
        if ((cloud.X[i] - p).squaredNorm() < (cloud.X[best] - p).squaredNorm()) best = i;
      pivots_.push_back(best);
    }
    dt_user_ = o.dt_s;
    if (o.target_trajectory_file) io::readTrajectoryCsv(*o.target_trajectory_file, pivots_.size(), &obs_t_, &obs_);
    geometry_.has_point = false;
  }

  void requireTargets() const override {
    if (obs_t_.empty())
      throw TopoError("pear targets", "target_trajectory_file is not given",
                      "give a CSV of t and x y z per pivot point: --target target_trajectory_file=FILE.csv");
  }

  TaskEvaluation evaluate(const std::vector<double>& r, std::vector<double>* dL_dr) const override {
    const Materials mat = materials(r, false);
    auto sim = simulator(mat);
    if (contact_embedding_)
      sim->setContact(SoftContact({ContactObstacle::ground(0.0)}, contact_opt_, contact_embedding_));
    else
      sim->setContact(SoftContact({ContactObstacle::ground(0.0)}, contact_opt_, contact_mask_));
    sim->setPositions(x0_);
    sim->setVelocities(std::vector<Eigen::Vector3d>(x0_.size(), v0_));
    const double dt_max = dt_user_ > 0 ? dt_user_ : 0.9 * sim->stableTimeStep();
    const int N = std::max(1, static_cast<int>(std::ceil(duration_ / dt_max)));
    const double dt = duration_ / N;
    // Observation j at step k_j.
    std::vector<std::vector<std::size_t>> at_step(N + 1);
    for (std::size_t j = 0; j < obs_t_.size(); ++j) {
      const long k = std::lround(obs_t_[j] / dt);
      if (k >= 0 && k <= N) at_step[k].push_back(j);
    }
    std::size_t used = 0;
    for (const auto& v : at_step) used += v.size();
    const double norm = used > 0 ? 1.0 / (double(used) * double(pivots_.size()) * size_ * size_) : 0.0;
    const int every = std::max(1, static_cast<int>(std::lround(sample_dt_ / dt)));
    TaskEvaluation ev;
    double sq = 0.0, extent = 0.0;
    SoftRolloutOptions ro;
    ro.integrator = SoftIntegrator::SymplecticEuler;
    ro.dt = dt;
    ro.steps = N;
    // The loss and the recorded trajectory need only these states (a GPU rollout copies no others).
    ro.loss_at = [&](int k) { return !at_step[k].empty() || k % every == 0; };
    const SoftStepLoss loss = [&](int k, double t, const std::vector<Eigen::Vector3d>& x,
                                  const std::vector<Eigen::Vector3d>&, std::vector<Eigen::Vector3d>* gx,
                                  std::vector<Eigen::Vector3d>*) {
      if (!gx && k % every == 0) {  // forward pass (the backward pass always asks for gradients)
        std::vector<double> row{t};
        for (auto p : pivots_) row.insert(row.end(), {x[p].x(), x[p].y(), x[p].z()});
        ev.trajectory_rows.push_back(row);
      }
      double l = 0.0;
      for (std::size_t j : at_step[k])
        for (std::size_t q = 0; q < pivots_.size(); ++q) {
          const Eigen::Vector3d e = x[pivots_[q]] - obs_[j][q];
          l += norm * e.squaredNorm();
          if (gx) (*gx)[pivots_[q]] += 2.0 * norm * e;
          if (!gx) sq += e.squaredNorm();
        }
      return l;
    };
    // backend cuda (or auto with a GPU): the same rollout and gradient on the device (soft_rollout_cuda.h).
    SoftRolloutResult res;
    bool on_gpu = backend_ == ComputeBackend::Cuda;
    if (on_gpu) {
      try {
        res = runSoftRolloutCuda(sim.get(), ro, loss, dL_dr != nullptr);
      } catch (const GpuMemoryError& e) {
        if (backend_requested_ == ComputeBackend::Cuda) throw;
        backend_ = ComputeBackend::Cpu;  // auto: the CPU from now on, said once
        notes_.push_back(std::string("backend auto: the pear's rollout runs on the CPU: ") + e.what());
        on_gpu = false;
      }
    }
    if (!on_gpu) res = SoftRollout(sim.get(), ro).run(loss, dL_dr != nullptr);
    for (std::size_t q = 0; q < pivots_.size(); ++q) {
      Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
      for (const auto& s : obs_) {
        lo = lo.cwiseMin(s[q]);
        hi = hi.cwiseMax(s[q]);
      }
      if (!obs_.empty()) extent = std::max(extent, (hi - lo).norm());
    }
    ev.loss = res.loss;
    const double rms = used > 0 ? std::sqrt(sq / (double(used) * pivots_.size())) : 0.0;
    double lowest = 1e300;
    for (const auto& row : ev.trajectory_rows)
      for (std::size_t q = 0; q < pivots_.size(); ++q) lowest = std::min(lowest, row[3 + 3 * q]);
    // The lowest contact point (true surface sample, or surface particle) at the end of the run.
    double lowest_contact = 1e300;
    for (const auto& p : sim->contact().contactPositions(sim->positions()))
      lowest_contact = std::min(lowest_contact, p.z());
    ev.features = {
        Feature{"trajectory_rms_m", rms, "m"},
        Feature{"trajectory_rms_relative", extent > 0 ? rms / extent : 0.0, "", !obs_.empty(), 0.0, 1.0, 0.02},
        Feature{"steps", double(N), ""},
        Feature{"dt_s", dt, "s"},
        Feature{"lowest_pivot_z_m", lowest, "m"},
        Feature{"final_lowest_contact_z_m", lowest_contact, "m"},
        Feature{"contact_points", double(sim->contact().contactPositions(x0_).size()), ""}};
    std::vector<double> m;
    masses(r, &m, nullptr);
    ev.mass = massPropertiesFromMoments(computeMassMoments(cloud_.X, m));
    if (dL_dr) chain(mat, res.gradient, false, dL_dr);
    return ev;
  }

 private:
  double duration_ = 0.12, sample_dt_ = 0.005, dt_user_ = 0.0;
  std::vector<Eigen::Vector3d> x0_;
  Eigen::Vector3d v0_ = Eigen::Vector3d::Zero();
  SoftContactOptions contact_opt_;
  std::vector<std::uint8_t> contact_mask_;
  std::shared_ptr<const ContactEmbedding> contact_embedding_;  ///< null: contact on the surface particles
  std::vector<std::size_t> pivots_;
  std::vector<double> obs_t_;
  std::vector<std::vector<Eigen::Vector3d>> obs_;
};

}  // namespace

void registerPearTask(TaskList* tasks) {
  TaskDefinition t;
  t.name = "pear";
  t.summary = "a soft pear dropped at a tilt bounces on the ground: trajectories of tracked body points";
  t.declare_parameters = [](TaskParameters& p) {
    SoftDefaults d;
    d.youngs_modulus_solid = 1e6;
    d.youngs_modulus_hollow = 1e5;
    d.youngs_modulus_hollow_doc = "Young's modulus of the r = 0 material [Pa] (paper: soft 1.5e5)";
    d.youngs_modulus_hollow_paper = "soft 1.5e5";
    d.poisson_ratio_hollow_doc = "Poisson ratio of the r = 0 material, unitless";
    d.default_spacing_m = 0.008;
    d.density_hollow = 1000.0;
    declareSoftParameters(p, d);
    declareOptions<PearOptions>(p, kPearFields);
  };
  t.make = [](const TaskConfig& config, const VolumeCloud& cloud) -> std::unique_ptr<Task> {
    return std::make_unique<PearTask>(config, cloud);
  };
  t.default_shape = "pear";
  tasks->push_back(t);
}

}  // namespace topo_gaussian::inference
