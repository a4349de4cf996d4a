// Shared soft-task machinery; see soft_task.h.
#include "soft_task.h"

#include <algorithm>
#include <cmath>
#include <iostream>
#include <sstream>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/number_text.h"
#include "topo_gaussian/cuda/dense_cholesky_cuda.h"
#include "topo_gaussian/cuda/soft_stiffness_cuda.h"

namespace topo_gaussian::inference {

void declareSoftParameters(TaskParameters& p, const SoftDefaults& d) {
  declareOptions<SoftSimOptions>(p, softSimFields(d));
  p.setDefault("density_hollow", d.density_hollow);
  p.setDefault("density_solid", 1000.0);
  p.setDefault("pin_shell", d.pin_shell ? 1.0 : 0.0);
  p.setDefault("restarts", 0.0);  // a soft fit costs minutes: the design spread only when asked for
}

CorotatedSphOptions sphOptions(const SoftSimOptions& soft, double density, double spacing) {
  CorotatedSphOptions o;
  o.spacing = spacing;
  o.smoothing_factor = soft.smoothing_factor;
  o.hourglass_alpha = soft.hourglass_alpha;
  o.gradient_order = soft.gradient_order;
  o.density = density;
  o.model = soft.energy_model == "stvk" ? SphEnergyModel::StVK : SphEnergyModel::CorotatedLinear;
  // Rotations from the corrected gradient: the forces are then the exact gradient of the energy,
  // which Newton's line search and the adjoints need.
  o.rotation = SphRotationSource::CorrectedGradient;
  return o;
}

namespace {

/// The spacing of a cloud whose interior particles lie on a lattice (every offset from the first
/// interior particle a whole number of spacings, within 5 %): SPH needs lattice neighbourhoods. A
/// boundary particle (surface flag) of `topo fill` sits at the centroid of its cell's inside part, up
/// to half a spacing (and a little more where a sliver of a neighbouring cell was merged into it) from
/// its cell centre; it may be up to 0.75 spacings off. Throws naming the first particle off the lattice.
double latticeSpacing(const VolumeCloud& cloud, const std::string& task) {
  const double h = cloud.spacing;  // carried by every volume (Task validated it)
  auto boundary = [&](std::size_t i) { return i < cloud.surface.size() && cloud.surface[i]; };
  std::size_t ref = 0;
  while (ref < cloud.size() && boundary(ref)) ++ref;
  if (ref == cloud.size()) ref = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3d q = (cloud.X[i] - cloud.X[ref]) / h;
    const Eigen::Vector3d off = (q - q.array().round().matrix()).cwiseAbs();
    if (off.maxCoeff() > (boundary(i) ? 0.75 : 0.05))
      throw TopoError("volume cloud for task '" + task + "'",
                      "particle " + std::to_string(i) + " is " + numberText(off.maxCoeff() * h, 3) +
                          " m off the lattice of spacing " + numberText(h, 4) + " m through particle " +
                          std::to_string(ref) + " (soft tasks need lattice particles for their SPH neighbourhoods)",
                      "fill the surface with topo fill (a lattice), or give the cloud's spacing");
  }
  return h;
}

}  // namespace

SoftTask::SoftTask(const TaskConfig& c, const VolumeCloud& cloud)
    : Task(c, cloud, false),
      soft_(readOptions<SoftSimOptions>(c, softSimFields())),
      sph_(cloud.X, cloud.V, lameFromYoung(soft_.youngs_modulus_solid, soft_.poisson_ratio),
           sphOptions(soft_, c.number("density_solid"), latticeSpacing(cloud, c.task()))) {
  backend_requested_ = parseComputeBackend(c.text("backend"), "task parameter backend");
  backend_ = resolveBackend(backend_requested_, "task parameter backend");
  const LameParameters solid = lameFromYoung(soft_.youngs_modulus_solid, soft_.poisson_ratio);
  const LameParameters hollow = lameFromYoung(soft_.youngs_modulus_hollow, soft_.poisson_ratio_hollow);
  E_solid_ = soft_.youngs_modulus_solid;
  rho_solid_ = sph_.options().density;  // density_solid, as the SPH took it
  for (auto* m : {&mu_interp_, &lambda_interp_}) {
    m->power = soft_.stiffness_power;
    m->continuous = c.boolean("continuous_material");
  }
  mu_interp_.value_r0 = hollow.mu;
  mu_interp_.value_r1 = solid.mu;
  mu_interp_.floor = 1e-6 * solid.mu;
  lambda_interp_.value_r0 = hollow.lambda;
  lambda_interp_.value_r1 = solid.lambda;
  lambda_interp_.floor = 1e-12 * solid.mu;
  mu_interp_.validate("shear modulus (youngs_modulus, poisson_ratio)");
  lambda_interp_.validate("Lame lambda (youngs_modulus, poisson_ratio)");
  sim_options_.gravity = geometry_.gravity;
  sim_options_.damping = soft_.damping_per_s;
}

SoftTask::~SoftTask() {
  if (sim_options_.rest_factor_reuse) sim_options_.rest_factor_reuse->clear();
}

std::shared_ptr<const ContactEmbedding> SoftTask::embedContactSamples(const VolumeCloud& cloud) {
  if (cloud.contact.empty()) {
    std::size_t n = 0;
    for (auto s : cloud.surface) n += s ? 1 : 0;
    notes_.push_back("the volume has no contact samples on the true surface: the " + name_ +
                     " task's contact uses its " + std::to_string(n) +
                     " surface particles (the lattice staircase: the body rests and bounces up to half a spacing off "
                     "its true surface); fill it again with `topo fill` to get them");
    return nullptr;
  }
  const double h = cloud.spacing;
  std::vector<Eigen::Vector3d> Y = cloud.contact.X, normal = cloud.contact.normal;
  std::vector<double> area = cloud.contact.area;
  // About 2 samples per spacing are enough for the contact; finer ones only cost (the embedding is
  // linear in their number): merge them into cells of h/2 (contact_embedding.h).
  if (cloud.contact.spacing > 0.0 && cloud.contact.spacing < 0.4 * h) mergeContactSamples(0.5 * h, &Y, &normal, &area);
  std::vector<double> w;
  w.reserve(area.size());
  for (double a : area) w.push_back(a / (h * h));
  return std::make_shared<const ContactEmbedding>(cloud.X, Y, w, h);
}

SoftTask::Materials SoftTask::materials(const std::vector<double>& r, bool with_chamber) const {
  Materials m;
  masses(r, &m.mass, &m.dmass_dr);
  mu_interp_.apply(r, &m.mu, &m.dmu_dr);
  lambda_interp_.apply(r, &m.lambda, &m.dlambda_dr);
  const std::size_t n = r.size();
  if (with_chamber) {
    m.chamber.resize(n);
    for (std::size_t i = 0; i < n; ++i) m.chamber[i] = 1.0 - r[i];
  }
  return m;
}

std::unique_ptr<SoftBodySimulator> SoftTask::simulator(const Materials& m) const {
  CorotatedSph sph = sph_;
  sph.setMaterial(m.mu, m.lambda);
  SoftBodyOptions options = sim_options_;
  options.should_stop = should_stop_;
  auto sim = std::make_unique<SoftBodySimulator>(std::move(sph), options);
  sim->setMasses(m.mass);
  return sim;
}

void SoftTask::usePreconditionerOnGpu(bool with_contact) {
  if (backend_ != ComputeBackend::Cuda) return;
  const std::size_t unknowns = 3 * sph_.size();
  std::string refused = denseCholeskyRefusal(unknowns);
  const bool memory = !refused.empty();
  if (!memory) refused = denseCholeskyLibraryError();  // cuSOLVER loaded now, not at the first evaluation
  if (!refused.empty() && backend_requested_ == ComputeBackend::Cuda) {
    if (memory)
      throw GpuMemoryError("task parameter backend (cuda), " + name_ + " task", refused,
                           "use a coarser particle spacing, free the GPU, or backend auto (the factor on the host)");
    throw TopoError("task parameter backend (cuda), " + name_ + " task", refused,
                    "install the CUDA toolkit's cuSOLVER, or use backend auto (the factor on the host) or cpu");
  }
  sim_options_.cholesky_external_required = backend_requested_ == ComputeBackend::Cuda;
  // The products need ~33 values a particle on the device; a body with contact keeps them on the host
  // (the contact's Hessian is the host's).
  if (!with_contact)
    sim_options_.stiffness_external = [](const SoftBodySimulator& sim) { return makeStiffnessCuda(sim); };
  std::ostringstream said;
  said << "backend " << toString(backend_requested_) << ": ";
  if (refused.empty()) {
    // A factor applied more often than the break-even of its float32 inverse factor (~48 applications
    // for the finger, whose start design's solve and gradient take ~230) is inverted then and applied
    // at half the bytes of a float64 inverse (a finger evaluation ~40 % faster, bench/gpu/README.md).
    const long inverse_after = denseCholeskyInverseFactorBreakEven(unknowns);
    sim_options_.cholesky_external = [inverse_after] {
      return makeDenseCholeskyCuda(0.0, DenseCholeskyApply::Triangular, inverse_after,
                                   DenseCholeskyApply::InverseFactorFloat32);
    };
    // One design after another of this body: an earlier design's GPU factor preconditions the next
    // until a new one costs less than the extra iterations (rest_factor_reuse.h). On the GPU a factor
    // costs ~400 applications, so keeping it makes the finger inference about three times faster. Not on
    // the host: there an application costs more against a factor, and keeping it measured slower. One kept
    // factor for all tasks of the process: no more GPU memory held than without keeping it.
    sim_options_.rest_factor_reuse = RestFactorReuse::gpuShared();
    said << "the rest stiffness's Cholesky factor on the GPU (dense, " << unknowns << " unknowns, "
         << numberText(denseCholeskyBytes(unknowns) / 1e9, 3) << " GB; applied as its inverse factor in float32, "
         << numberText(denseCholeskyBytes(unknowns) / 2e9, 3) << " GB, from " << inverse_after
         << " applications where the GPU has room to make it; kept from one design to the next while it pays)";
  } else {
    notes_.push_back("backend auto: the rest stiffness's Cholesky factor on the host, not the GPU: " + refused);
    said << "the rest stiffness's Cholesky factor on the host (" << refused << ")";
  }
  said << (with_contact ? "; the stiffness products on the host (the body has contact)"
                        : " and the stiffness products of the linear solves on the GPU")
       << "; the forces and energies on the host";
  std::cerr << "[" << name_ << "] " << said.str() << "\n";
}

void SoftTask::notePreconditioner(const SoftBodySimulator& sim) const {
  const std::string& note = sim.preconditionerNote();
  if (note.empty()) return;
  // once per kind: the text before its first ':' (the numbers after it, e.g. the GPU's free MiB, vary)
  const std::string kind = note.substr(0, note.find(':'));
  for (const std::string& n : notes_)
    if (n.compare(0, kind.size(), kind) == 0) return;
  notes_.push_back(note);
  std::cerr << "[" << name_ << "] warning: " << note
            << (note.rfind("Jacobi", 0) == 0
                    ? " (the linear solves run on Jacobi instead: thousands of CG iterations a "
                      "Newton step)\n"
                    : "\n");
}

void SoftTask::chain(const Materials& m, const SoftDesignGradient& g, bool with_chamber,
                     std::vector<double>* dL_dr) const {
  const std::size_t n = m.mass.size();
  dL_dr->assign(n, 0.0);
  for (std::size_t i = 0; i < n; ++i) {
    double d = g.mass[i] * m.dmass_dr[i] + g.mu[i] * m.dmu_dr[i] + g.lambda[i] * m.dlambda_dr[i];
    if (with_chamber && !g.chamber.empty()) d -= g.chamber[i];
    (*dL_dr)[i] = d;
  }
}

}  // namespace topo_gaussian::inference
