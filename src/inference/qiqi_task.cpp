// Tilting vessel (qiqi, paper appendix "Qiqi"): the vessel hangs on a horizontal hinge; water poured
// in fills the cavity (hollow particles, weight 1 − r_i) from the bottom up to the level that holds
// the given fraction of the cavity volume at the current pose. For each fill level the vessel rests
// where the hinge torque of vessel + water vanishes (a stable equilibrium φ*). Loss: Σ_k (φ*_k − φ_k)²
// [rad²]. The equilibrium is differentiated through with the implicit function theorem:
//   water:  G(h, φ, r) = Σ V_i w_i σ_i − f Σ V_i w_i = 0,  σ_i = sigmoid((h − z_i(φ)) / ε_w)
//   torque: τ(φ, h, r) = Σ (m_i + ρ_w V_i w_i σ_i) t_i(φ),  t_i = a · ((x_i − P) × g)
//   dφ*/dr = −(τ_r + τ_h h_r) / (τ_φ + τ_h h_φ),  h_r = −G_r / G_h,  h_φ = −G_φ / G_h.
#include <Eigen/Geometry>
#include <cmath>
#include <optional>
#include <vector>

#include "task_factories.h"
#include "topo_gaussian/common/error.h"
#include "topo_gaussian/inference/task_options.h"
#include "topo_gaussian/topology/indicator.h"

namespace topo_gaussian::inference {
namespace {

constexpr double kDeg = 180.0 / M_PI;

double sigmoid(double x) { return x >= 0 ? 1.0 / (1.0 + std::exp(-x)) : std::exp(x) / (1.0 + std::exp(x)); }

/// The vessel's own parameters, typed.
struct QiqiOptions {
  std::optional<Eigen::Vector3d> pivot_point;
  Eigen::Vector3d hinge_axis = Eigen::Vector3d::UnitX();
  std::vector<double> fill_levels;
  double water_density = 1000, water_smoothing = 0.01;
  std::optional<std::vector<double>> target_tilts_deg;
};

/// Its declaration and reading (inference/task_options.h), in the order `topo tasks` lists them.
constexpr auto kQiqiFields = [](auto& f) {
  using O = QiqiOptions;
  f.vector3("pivot_point", &O::pivot_point, "m",
            "hinge pivot in the body frame [m]; default: bounds centre, 1/4 of the height above it");
  f.vector3("hinge_axis", &O::hinge_axis, Eigen::Vector3d(1, 0, 0), "unitless",
            "hinge axis (body = world at zero tilt), a unitless direction");
  f.list("fill_levels", &O::fill_levels, {0.0, 0.5, 0.95}, "unitless",
         "water volume as fractions of the cavity volume, one per pose, unitless", 0, 1);
  f.number("water_density", &O::water_density, 1000.0, "kg/m^3", "density of the water [kg/m^3]", 0, 1e300, true);
  f.number("water_smoothing", &O::water_smoothing, 0.01, "unitless",
           "width of the water surface as a fraction of the object size, unitless", 0, 1, true);
  f.target("target_tilts_deg", &O::target_tilts_deg, "deg", "observed tilt at each fill level [deg]");
};

class QiqiTask : public Task {
 public:
  QiqiTask(const TaskConfig& c, const VolumeCloud& cloud) : Task(c, cloud) {
    const QiqiOptions o = readOptions<QiqiOptions>(c, kQiqiFields);
    const Eigen::Vector3d centre = 0.5 * (lo_ + hi_);
    pivot_ = o.pivot_point.value_or(Eigen::Vector3d(centre.x(), centre.y(), centre.z() + 0.25 * (hi_.z() - lo_.z())));
    axis_ = o.hinge_axis;
    if (axis_.norm() == 0) throw TopoError("hinge_axis", "is zero", "give a direction such as 1,0,0");
    axis_.normalize();
    if (std::abs(axis_.dot(geometry_.gravity.normalized())) > 1e-6)
      throw TopoError("hinge_axis", "is not horizontal (not perpendicular to gravity)",
                      "give a horizontal axis such as 1,0,0");
    fills_ = o.fill_levels;
    if (fills_.empty()) throw TopoError("fill_levels", "is empty", "give the water fractions, e.g. 0,0.5,0.95");
    if (o.target_tilts_deg) {
      targets_ = *o.target_tilts_deg;
      if (targets_.size() != fills_.size())
        throw TopoError(
            "target_tilts_deg",
            "has " + std::to_string(targets_.size()) + " values for " + std::to_string(fills_.size()) + " fill levels",
            "give one observed tilt per fill level");
    }
    rho_w_ = o.water_density;
    eps_w_ = o.water_smoothing * size_;
    pinned_ = c.boolean("pin_shell") ? boundaryShell(cloud.X, cloud.surface, c.number("shell_thickness_m"))
                                     : std::vector<std::uint8_t>(cloud.size(), 0);
    geometry_.has_point = true;
    geometry_.point_name = "pivot_point";
    geometry_.point = pivot_;
  }

  void requireTargets() const override {
    if (targets_.empty())
      throw TopoError("qiqi targets", "target_tilts_deg is not given",
                      "give one observed tilt per fill level, e.g. --target target_tilts_deg=20,0,-90");
  }

  // Everything at one pose, for given masses and cavity weights.
  struct Pose {
    double tau = 0, h = 0, dtau_dphi = 0;  // total derivative along the water constraint
    bool has_water = false;
    double G_h = 0, tau_h = 0;
  };

  Eigen::Matrix3d rot(double phi) const { return Eigen::AngleAxisd(phi, axis_).toRotationMatrix(); }

  double solveLevel(double phi, const std::vector<double>& w, double f) const {
    const Eigen::Matrix3d R = rot(phi);
    double lo = 1e300, hi = -1e300, cav = 0;
    std::vector<double> z(cloud_.size());
    for (std::size_t i = 0; i < cloud_.size(); ++i) {
      z[i] = (pivot_ + R * (cloud_.X[i] - pivot_)).z();
      lo = std::min(lo, z[i]);
      hi = std::max(hi, z[i]);
      cav += cloud_.V[i] * w[i];
    }
    lo -= 20 * eps_w_;
    hi += 20 * eps_w_;
    const double want = f * cav;
    // Safeguarded Newton on the monotone water volume V(h).
    double h = 0.5 * (lo + hi);
    for (int it = 0; it < 100; ++it) {
      double vol = 0, dvol = 0;
      for (std::size_t i = 0; i < z.size(); ++i) {
        const double s = sigmoid((h - z[i]) / eps_w_);
        vol += cloud_.V[i] * w[i] * s;
        dvol += cloud_.V[i] * w[i] * s * (1 - s) / eps_w_;
      }
      const double res = vol - want;
      if (std::abs(res) <= 1e-13 * cav) break;
      (res < 0 ? lo : hi) = h;
      double next = dvol > 0 ? h - res / dvol : 0.5 * (lo + hi);
      if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
      h = next;
      if (hi - lo < 1e-15 * size_) break;
    }
    return h;
  }

  // Torque and its partial derivatives at (φ, h).
  Pose pose(double phi, const std::vector<double>& m, const std::vector<double>& w, double f,
            std::vector<double>* dtau_dr_m = nullptr) const {
    Pose p;
    p.has_water = f > 0;
    if (p.has_water) p.h = solveLevel(phi, w, f);
    const Eigen::Matrix3d R = rot(phi);
    const Eigen::Vector3d g = geometry_.gravity;
    double tau = 0, tau_phi = 0, tau_h = 0, G_h = 0, G_phi = 0;
    for (std::size_t i = 0; i < cloud_.size(); ++i) {
      const Eigen::Vector3d y = R * (cloud_.X[i] - pivot_);
      const Eigen::Vector3d dy = axis_.cross(y);
      const double t = axis_.dot(y.cross(g)), dt = axis_.dot(dy.cross(g));
      double M = m[i];
      if (p.has_water) {
        const double z = pivot_.z() + y.z();
        const double s = sigmoid((p.h - z) / eps_w_), ds = s * (1 - s) / eps_w_;
        const double mw = rho_w_ * cloud_.V[i] * w[i];
        M += mw * s;
        tau_h += mw * ds * t;
        tau_phi += mw * ds * (-dy.z()) * t;
        G_h += cloud_.V[i] * w[i] * ds;
        G_phi += cloud_.V[i] * w[i] * ds * (-dy.z());
      }
      tau += M * t;
      tau_phi += M * dt;
    }
    p.tau = tau;
    p.G_h = G_h;
    p.tau_h = tau_h;
    p.dtau_dphi = tau_phi + (p.has_water && G_h > 0 ? tau_h * (-G_phi / G_h) : 0.0);
    return p;
  }

  // Stable equilibrium nearest to `reference` (scan, then bisection).
  double equilibrium(const std::vector<double>& m, const std::vector<double>& w, double f, double reference,
                     const std::string& level) const {
    const int n = 72;
    std::vector<double> phis(n + 1), taus(n + 1);
    for (int k = 0; k <= n; ++k) {
      phis[k] = -M_PI + 2 * M_PI * k / n;
      taus[k] = pose(phis[k], m, w, f).tau;
    }
    double best = 0, best_d = 1e300;
    bool found = false;
    for (int k = 0; k < n; ++k) {
      if (!(taus[k] > 0 && taus[k + 1] <= 0)) continue;  // torque decreasing through zero: stable
      double a = phis[k], b = phis[k + 1], ta = taus[k];
      for (int it = 0; it < 45; ++it) {
        const double mid = 0.5 * (a + b), tm = pose(mid, m, w, f).tau;
        if ((tm > 0) == (ta > 0))
          a = mid, ta = tm;
        else
          b = mid;
      }
      const double phi = 0.5 * (a + b);
      double d = std::abs(std::remainder(phi - reference, 2 * M_PI));
      if (d < best_d) best_d = d, best = phi, found = true;
    }
    if (!found)
      throw TopoError("qiqi fill level " + level, "no stable equilibrium about the hinge",
                      "check pivot_point: the vessel must hang below it for some pose");
    return best;
  }

  TaskEvaluation evaluate(const std::vector<double>& r, std::vector<double>* dL_dr) const override {
    std::vector<double> m, dm;
    masses(r, &m, &dm);
    std::vector<double> w(r.size());
    for (std::size_t i = 0; i < r.size(); ++i) w[i] = pinned_[i] ? 0.0 : 1.0 - r[i];
    TaskEvaluation ev;
    ev.mass = computeMassProperties(cloud_.X, m);
    if (dL_dr) dL_dr->assign(r.size(), 0.0);
    double reference = 0.0;
    const Eigen::Vector3d g = geometry_.gravity;
    for (std::size_t k = 0; k < fills_.size(); ++k) {
      const double f = fills_[k];
      const double phi = equilibrium(m, w, f, reference, std::to_string(k));
      reference = phi;
      Feature feat{"tilt_deg_at_fill_" + std::to_string(k), phi * kDeg, "deg", !targets_.empty(),
                   targets_.empty() ? 0.0 : targets_[k],    10.0,       0.01};  // 0.1° near zero, 1 % beyond 10°
      if (targets_.empty()) {
        ev.features.push_back(feat);
        continue;
      }
      // Wrap the error to (−π, π] so an overturned vessel at ±180° compares correctly.
      const double err = std::remainder(phi - targets_[k] / kDeg, 2 * M_PI);
      ev.loss += err * err;
      feat.value = (targets_[k] / kDeg + err) * kDeg;
      ev.features.push_back(feat);
      if (!dL_dr) continue;
      const Pose p = pose(phi, m, w, f);
      if (std::abs(p.dtau_dphi) < 1e-300) continue;
      const Eigen::Matrix3d R = rot(phi);
      for (std::size_t i = 0; i < r.size(); ++i) {
        const Eigen::Vector3d y = R * (cloud_.X[i] - pivot_);
        const double t = axis_.dot(y.cross(g));
        // τ_r = dm/dr t − ρ_w V σ t (water weight w = 1 − r);  G_r = −V σ + f V.
        double tau_r = dm[i] * t, G_r = 0;
        if (p.has_water && !pinned_[i]) {
          const double s = sigmoid((p.h - (pivot_.z() + y.z())) / eps_w_);
          tau_r += -rho_w_ * cloud_.V[i] * s * t;
          G_r = -cloud_.V[i] * s + f * cloud_.V[i];
        }
        const double dT_dr = tau_r + (p.has_water && p.G_h > 0 ? p.tau_h * (-G_r / p.G_h) : 0.0);
        (*dL_dr)[i] += 2.0 * err * (-dT_dr / p.dtau_dphi);
      }
    }
    double cav = 0, tot = 0;
    for (std::size_t i = 0; i < r.size(); ++i) cav += cloud_.V[i] * w[i], tot += cloud_.V[i];
    ev.features.push_back(Feature{"cavity_fraction", cav / tot, ""});
    ev.features.push_back(Feature{"mass_kg", ev.mass.mass, "kg"});
    return ev;
  }

 private:
  Eigen::Vector3d pivot_, axis_;
  std::vector<double> fills_, targets_;
  double rho_w_ = 1000, eps_w_ = 1e-3;
  std::vector<std::uint8_t> pinned_;
};

}  // namespace

void registerQiqiTask(TaskList* tasks) {
  TaskDefinition t;
  t.name = "qiqi";
  t.summary = "a vessel on a hinge tilts as water fills its cavity: equilibrium tilt at each fill level";
  t.declare_parameters = [](TaskParameters& p) { declareOptions<QiqiOptions>(p, kQiqiFields); };
  t.make = [](const TaskConfig& config, const VolumeCloud& cloud) -> std::unique_ptr<Task> {
    return std::make_unique<QiqiTask>(config, cloud);
  };
  tasks->push_back(t);
}

}  // namespace topo_gaussian::inference
