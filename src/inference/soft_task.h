// Internal: what the soft-body tasks (finger, pear, cantilever) share — the SPH discretisation of
// the volume cloud (built once), the materials from r (Young's modulus and density interpolated
// like the rigid tasks' density; chamber weight 1 − r), and the chain from the simulator's design
// gradient (∂L/∂m_i, ∂L/∂μ_i, ∂L/∂λ_i, ∂L/∂w_i) back to ∂L/∂r_i.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "topo_gaussian/cuda/backend.h"
#include "topo_gaussian/inference/task.h"
#include "topo_gaussian/inference/task_options.h"
#include "topo_gaussian/inference/task_registry.h"
#include "topo_gaussian/physics/soft_rollout.h"

namespace topo_gaussian::inference {

/// The parameters every soft task has, typed (declared and read by softSimFields below).
struct SoftSimOptions {
  double youngs_modulus_solid = 1e7, youngs_modulus_hollow = 1e7;  ///< [Pa]
  double poisson_ratio = 0.3, poisson_ratio_hollow = 0.3, stiffness_power = 1.0;
  std::string energy_model = "corotated_linear";
  int gradient_order = 1;
  double smoothing_factor = 1.5, hourglass_alpha = 0.1, damping_per_s = 0.0, newton_tolerance = 1e-8;
  double default_spacing_m = 0.004;  ///< [m]
};

class SoftTask : public Task {
 public:
  /// Frees the GPU factor kept for the next design (RestFactorReuse::gpuShared()), if any.
  ~SoftTask() override;

 protected:
  SoftTask(const TaskConfig& config, const VolumeCloud& cloud);

  struct Materials {
    std::vector<double> mass, dmass_dr, mu, dmu_dr, lambda, dlambda_dr, chamber;  ///< chamber w_i = 1 − r_i (finger)
  };
  Materials materials(const std::vector<double>& r, bool with_chamber) const;
  /// A simulator with the design applied (clamps, contact, actuation are the task's business).
  std::unique_ptr<SoftBodySimulator> simulator(const Materials& m) const;
  /// ∂L/∂r_i = ∂L/∂m_i dm_i/dr_i + ∂L/∂μ_i dμ_i/dr_i + ∂L/∂λ_i dλ_i/dr_i − ∂L/∂w_i.
  void chain(const Materials& m, const SoftDesignGradient& g, bool with_chamber, std::vector<double>* dL_dr) const;
  /// Ground contact on the object's true surface: the cloud's contact samples embedded
  /// in the particles (contact_embedding.h), each weighted by its area over the lattice cell's face
  /// h² so that the penalty stiffness per unit area is the surface particles' (the task's stiffness
  /// stays "per particle"); samples finer than 0.4 h are merged into cells of h/2 first
  /// (mergeContactSamples). Null when the cloud has no contact samples; then a note for a person is
  /// added to notes_ (the surface particles, the lattice staircase, carry the contact).
  std::shared_ptr<const ContactEmbedding> embedContactSamples(const VolumeCloud& cloud);
  /// After a solve: when its linear solves ran on Jacobi instead of the rest stiffness's Cholesky
  /// factor (a limit refused the factor: SoftBodySimulator::preconditionerNote()), or on the host's
  /// factor where the GPU's was asked for, says so once per kind, in notes_ and on stderr (Jacobi:
  /// every Newton step then takes thousands of CG iterations).
  void notePreconditioner(const SoftBodySimulator& sim) const;
  /// Tasks with Newton solves (finger, cantilever) call this once built: under a resolved backend cuda,
  /// the rest stiffness's Cholesky factor is computed and applied on the GPU (cuda/dense_cholesky_cuda.h),
  /// and the linear solves' stiffness products run there too (cuda/soft_stiffness_cuda.h),
  /// when its dense factor fits the GPU's free memory; otherwise backend cuda asked for explicitly is
  /// refused (GpuMemoryError naming the particles that fit) and auto keeps it on the host with a note.
  /// with_contact: the body has contact (an obstacle), whose Hessian is the host's: the products stay there.
  void usePreconditionerOnGpu(bool with_contact = false);

  /// The task's `backend`, resolved (cuda/backend.h): Cuda only when a GPU is present; backend cuda
  /// without one is refused when the task is built.
  /// Mutable: backend auto falls back to the CPU for good when the GPU lacks memory (with a note).
  mutable ComputeBackend backend_ = ComputeBackend::Cpu;
  ComputeBackend backend_requested_ = ComputeBackend::Auto;
  SoftSimOptions soft_;  ///< the shared soft parameters, as the config gives them
  CorotatedSph sph_;     ///< rest discretisation, material replaced per evaluation
  /// The Lamé parameters are interpolated between the two materials' values (from E and ν of each)
  /// with the SIMP power of the stiffness.
  MaterialInterpolation mu_interp_, lambda_interp_;
  double E_solid_ = 0.0, rho_solid_ = 0.0;
  SoftBodyOptions sim_options_;
};

/// The defaults in which the soft tasks' shared parameters differ.
struct SoftDefaults {
  double youngs_modulus_solid = 1e7, youngs_modulus_hollow = 1e7;  ///< [Pa]
  std::string youngs_modulus_hollow_doc, youngs_modulus_hollow_paper;
  double poisson_ratio = 0.3, poisson_ratio_hollow = 0.3;
  std::string poisson_ratio_hollow_doc;
  double stiffness_power = 1.0;
  int gradient_order = 1;
  double default_spacing_m = 0.004;
  double density_hollow = 1000.0;  ///< [kg/m^3] (density_solid stays 1000)
  bool pin_shell = false;
  std::string energy_model = "corotated_linear";  ///< corotated_linear | stvk
};

/// The fields of SoftSimOptions (inference/task_options.h) with the defaults of d, in the order `topo tasks`
/// lists them: materials, SPH, Newton, default spacing (paper §6.1 soft, table 2: Young's modulus
/// interpolated by r like the density). Reading needs no defaults: readOptions<SoftSimOptions>(c, softSimFields()).
inline auto softSimFields(const SoftDefaults& d = SoftDefaults()) {
  return [d](auto& f) {
    using O = SoftSimOptions;
    f.number("youngs_modulus_solid", &O::youngs_modulus_solid, d.youngs_modulus_solid, "Pa",
             "Young's modulus of the r = 1 material [Pa] (paper: stiff 3e7, real finger 1e7)", 0, 1e300, true)
        .paper("stiff 3e7, real finger 1e7");
    f.number("youngs_modulus_hollow", &O::youngs_modulus_hollow, d.youngs_modulus_hollow, "Pa",
             d.youngs_modulus_hollow_doc, 0, 1e300, true)
        .paper(d.youngs_modulus_hollow_paper);
    f.number("poisson_ratio", &O::poisson_ratio, d.poisson_ratio, "unitless",
             "Poisson ratio nu of the r = 1 material, unitless (paper: 0.4; real finger 0.49)", -0.99, 0.499)
        .paper("0.4; real finger 0.49");
    f.number("poisson_ratio_hollow", &O::poisson_ratio_hollow, d.poisson_ratio_hollow, "unitless",
             d.poisson_ratio_hollow_doc, -0.99, 0.499);
    f.number("stiffness_power", &O::stiffness_power, d.stiffness_power, "unitless",
             "SIMP power of the Young's modulus interpolation, unitless", 1, 10);
    f.text("energy_model", &O::energy_model, d.energy_model, "corotated_linear (Cauchy strain) | stvk (Green strain)",
           {"corotated_linear", "stvk"});
    f.integer("gradient_order", &O::gradient_order, d.gradient_order, "unitless",
              "SPH kernel gradient, unitless: 1 corrected (paper), 2 quadratic MLS (exact in bending)", 1, 2)
        .paper("1");
    f.number("smoothing_factor", &O::smoothing_factor, 1.5, "unitless",
             "SPH smoothing length h as a multiple of the particle spacing, unitless", 0.8, 3);
    f.number("hourglass_alpha", &O::hourglass_alpha, 0.1, "unitless",
             "zero-energy-mode penalty relative to mu, unitless", 0);
    f.number("damping_per_s", &O::damping_per_s, 0.0, "1/s", "mass-proportional damping c [1/s]", 0);
    f.number("newton_tolerance", &O::newton_tolerance, 1e-8, "unitless",
             "Newton convergence: max residual force / load scale, unitless", 0, 1, true);
    f.number("default_spacing_m", &O::default_spacing_m, d.default_spacing_m, "m",
             "particle spacing of the generated default shape when no volume is given [m]", 0, 1e300, true);
  };
}

/// Declares the parameters every soft task reads (softSimFields(d)) and the common defaults the soft
/// tasks change (densities, pin_shell, restarts).
void declareSoftParameters(TaskParameters& p, const SoftDefaults& d);

/// ½ Σ (x − X)·… helpers are per task; this one is shared: the CorotatedSph options of the soft
/// parameters, for the r = 1 material's density [kg/m^3] and the lattice spacing [m].
CorotatedSphOptions sphOptions(const SoftSimOptions& o, double density, double spacing);

}  // namespace topo_gaussian::inference
