// Shared soft-task machinery; see soft_task.h.
#include "soft_task.h"

#include <cmath>

#include "topo_gaussian/common/error.h"

namespace topo_gaussian::inference {

CorotatedSphOptions sphOptionsFromConfig(const TaskConfig& c, double spacing) {
  CorotatedSphOptions o;
  o.spacing = spacing;
  o.smoothing_factor = c.number("smoothing_factor");
  o.hourglass_alpha = c.number("hourglass_alpha");
  o.gradient_order = c.integer("gradient_order");
  o.density = c.number("density_solid");
  o.model = c.text("energy_model") == "stvk" ? SphEnergyModel::StVK : SphEnergyModel::CorotatedLinear;
  // Rotations from the corrected gradient: the forces are then the exact gradient of the energy,
  // which Newton's line search and the adjoints need.
  o.rotation = SphRotationSource::CorrectedGradient;
  return o;
}

namespace {

double cloudSpacing(const VolumeCloud& cloud) {
  if (cloud.spacing > 0.0) return cloud.spacing;
  double v = 0.0;
  for (double x : cloud.V) v += x;
  return std::cbrt(v / static_cast<double>(cloud.size()));
}

}  // namespace

SoftTask::SoftTask(const TaskConfig& c, const VolumeCloud& cloud)
    : Task(c, cloud, false),
      sph_(cloud.X, cloud.V, lameFromYoung(c.number("youngs_modulus_solid"), c.number("poisson_ratio")),
           sphOptionsFromConfig(c, cloudSpacing(cloud))) {
  const LameParameters solid = lameFromYoung(c.number("youngs_modulus_solid"), c.number("poisson_ratio"));
  const LameParameters hollow = lameFromYoung(c.number("youngs_modulus_hollow"), c.number("poisson_ratio_hollow"));
  E_solid_ = c.number("youngs_modulus_solid");
  rho_solid_ = c.number("density_solid");
  for (auto* m : {&mu_interp_, &lambda_interp_}) {
    m->power = c.number("stiffness_power");
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
  sim_options_.damping = c.number("damping_per_s");
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
  auto sim = std::make_unique<SoftBodySimulator>(std::move(sph), sim_options_);
  sim->setMasses(m.mass);
  return sim;
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
