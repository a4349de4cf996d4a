#include "topo_gaussian/inference/task.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/number_text.h"
#include "topo_gaussian/inference/task_registry.h"

namespace topo_gaussian::inference {

bool Feature::reached() const {
  if (!has_target) return true;
  return std::abs(value - target) <= tolerance * std::max(std::abs(target), scale);
}

Eigen::Matrix3d targetRotation(double roll_deg, double pitch_deg) {
  const double d = M_PI / 180.0;
  return (Eigen::AngleAxisd(pitch_deg * d, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(roll_deg * d, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

RollPitch hangingRestPose(const Eigen::Vector3d& com_m, const Eigen::Vector3d& point_m) {
  const Eigen::Vector3d d = com_m - point_m;
  if (!(d.norm() > 0) || !d.allFinite())
    throw TopoError("hanging point (" + numberText(point_m.x()) + ", " + numberText(point_m.y()) + ", " +
                        numberText(point_m.z()) + ") m",
                    "is at the centre of mass: the object rests in any pose", "hang it from a point away from it");
  RollPitch rp;
  rp.roll_deg = std::atan2(-d.y(), -d.z()) * 180.0 / M_PI;
  rp.pitch_deg = std::atan2(d.x(), std::hypot(d.y(), d.z())) * 180.0 / M_PI;
  return rp;
}

Task::Task(const TaskConfig& config, const VolumeCloud& cloud, bool require_gravity)
    : name_(config.task()), cloud_(cloud) {
  cloud.validate("volume cloud for task '" + config.task() + "'");
  if (cloud.size() < kMinTaskParticles)
    throw TopoError("volume cloud for task '" + config.task() + "'",
                    "has " + std::to_string(cloud.size()) + " particle" + (cloud.size() == 1 ? "" : "s") +
                        ", too few to infer an interior (at least " + std::to_string(kMinTaskParticles) + ")",
                    "fill the surface with a smaller spacing (topo fill --spacing), e.g. spacing <= size / 10");
  density_.value_r0 = config.number("density_hollow");
  density_.value_r1 = config.number("density_solid");
  density_.power = config.number("density_power");
  density_.floor = config.number("density_floor");
  density_.continuous = config.boolean("continuous_material");
  if (density_.value_r0 > density_.value_r1) {
    throw TopoError("density_hollow",
                    "is larger than density_solid (" + std::to_string(density_.value_r0) + " > " +
                        std::to_string(density_.value_r1) + " kg/m^3)",
                    "the solid material (r = 1) must be the denser one");
  }
  density_.validate("density");
  cloud.bounds(&lo_, &hi_);
  size_ = std::max((hi_ - lo_).norm(), 1e-9);
  geometry_.gravity = config.vector3("gravity");
  if (require_gravity && geometry_.gravity.norm() <= 0.0)
    throw TopoError("gravity", "is zero", "give a gravity vector such as 0,0,-9.81");
}

void Task::masses(const std::vector<double>& r, std::vector<double>* m, std::vector<double>* dm_dr) const {
  if (r.size() != cloud_.size()) {
    throw TopoError("indicator r",
                    "has " + std::to_string(r.size()) + " values for " + std::to_string(cloud_.size()) + " particles",
                    "evaluate the representation on the same volume cloud");
  }
  density_.apply(r, m, dm_dr);
  for (std::size_t i = 0; i < r.size(); ++i) {
    (*m)[i] *= cloud_.V[i];
    if (dm_dr) (*dm_dr)[i] *= cloud_.V[i];
  }
}

Task::RigidMass Task::rigidMass(const std::vector<double>& r, bool with_gradient) const {
  RigidMass out;
  std::vector<double> m;
  masses(r, &m, with_gradient ? &out.dm_dr : nullptr);
  // Each particle stands for its cell: its own second moment m_i h²/12 makes a filled box exact.
  out.moments = computeMassMoments(cloud_.X, m, cubeCellVariance(cloud_.spacing));
  out.props = massPropertiesFromMoments(out.moments);
  return out;
}

void Task::chainToIndicator(const RigidMass& mass, const Eigen::Matrix<double, 10, 1>& dL_dprops,
                            std::vector<double>* dL_dr) const {
  std::vector<double> dL_dm;
  massPropertiesGradientToParticles(cloud_.X, mass.moments, dL_dprops, &dL_dm, cubeCellVariance(cloud_.spacing));
  dL_dr->resize(dL_dm.size());
  for (std::size_t i = 0; i < dL_dm.size(); ++i) (*dL_dr)[i] = dL_dm[i] * mass.dm_dr[i];
}

std::string pointOutsideObjectNote(const TaskGeometry& geometry, const VolumeCloud& cloud) {
  if (!geometry.has_point || cloud.empty()) return "";
  Eigen::Vector3d lo, hi;
  cloud.bounds(&lo, &hi);
  const double h = cloud.spacing;  // carried by every volume (the task validated it)
  const Eigen::Vector3d& p = geometry.point;
  double nearest = std::numeric_limits<double>::infinity();
  for (const auto& x : cloud.X) nearest = std::min(nearest, (x - p).squaredNorm());
  nearest = std::sqrt(nearest);
  const bool outside_box = ((p.array() < lo.array() - h) || (p.array() > hi.array() + h)).any();
  if (!outside_box && nearest <= 2.0 * h) return "";
  std::ostringstream os;
  os << geometry.point_name << " (" << numberText(p.x()) << ", " << numberText(p.y()) << ", " << numberText(p.z())
     << ") m lies outside the object: " << numberText(nearest) << " m from the nearest particle (spacing "
     << numberText(h) << " m), the particles span (" << numberText(lo.x()) << ".." << numberText(hi.x()) << ", "
     << numberText(lo.y()) << ".." << numberText(hi.y()) << ", " << numberText(lo.z()) << ".." << numberText(hi.z())
     << ") m; fine for a hook, otherwise check its units and frame (body frame, metres)";
  return os.str();
}

std::unique_ptr<Task> makeTask(const TaskConfig& config, const VolumeCloud& cloud) {
  return taskDefinition(config.task()).make(config, cloud);  // unknown: lists the registered tasks
}

}  // namespace topo_gaussian::inference
