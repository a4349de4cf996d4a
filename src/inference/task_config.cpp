#include "topo_gaussian/inference/task_config.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include "topo_gaussian/common/error.h"

namespace topo_gaussian::inference {

struct TaskConfigBuilder {
  TaskConfig& c;
  void num(const std::string& n, double def, const std::string& doc, double lo = -1e300, double hi = 1e300,
           bool lo_excl = false) {
    ParamSpec s{n, ParamType::Number, doc, lo, hi, lo_excl, {}, false};
    ParamValue v;
    v.number = def;
    v.set = true;
    c.declare(s, v);
  }
  void integer(const std::string& n, int def, const std::string& doc, double lo, double hi) {
    ParamSpec s{n, ParamType::Integer, doc, lo, hi, false, {}, false};
    ParamValue v;
    v.number = def;
    v.set = true;
    c.declare(s, v);
  }
  void flag(const std::string& n, bool def, const std::string& doc) {
    ParamSpec s{n, ParamType::Boolean, doc, 0, 1, false, {}, false};
    ParamValue v;
    v.number = def ? 1.0 : 0.0;
    v.set = true;
    c.declare(s, v);
  }
  void text(const std::string& n, const std::string& def, const std::string& doc, std::vector<std::string> choices = {}) {
    ParamSpec s{n, ParamType::Text, doc, -1e300, 1e300, false, std::move(choices), false};
    ParamValue v;
    v.text = def;
    v.set = !def.empty();
    c.declare(s, v);
  }
  void vec(const std::string& n, const Eigen::Vector3d* def, const std::string& doc) {
    ParamSpec s{n, ParamType::Vector3, doc, -1e300, 1e300, false, {}, false};
    ParamValue v;
    if (def) {
      v.vec = *def;
      v.set = true;
    }
    c.declare(s, v);
  }
  void list(const std::string& n, std::vector<double> def, const std::string& doc, double lo = -1e300, double hi = 1e300) {
    ParamSpec s{n, ParamType::List, doc, lo, hi, false, {}, false};
    ParamValue v;
    v.list = std::move(def);
    v.set = !v.list.empty();
    c.declare(s, v);
  }
  void target(const std::string& n, ParamType type, const std::string& doc, double lo = -1e300, double hi = 1e300,
              bool lo_excl = false) {
    ParamSpec s{n, type, doc, lo, hi, lo_excl, {}, true};
    c.declare(s, ParamValue());
  }
};

namespace {

const std::vector<std::string>& knownTasks() {
  static const std::vector<std::string> k = {"hanging", "balance", "stand", "tumbler", "qiqi", "ball",
                                                      "finger", "pear", "cantilever"};
  return k;
}

std::string joinNames(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& x : v) s += (s.empty() ? "" : ", ") + x;
  return s;
}

std::string trim(std::string s) {
  const auto b = s.find_first_not_of(" \t\r\n");
  const auto e = s.find_last_not_of(" \t\r\n");
  return b == std::string::npos ? std::string() : s.substr(b, e - b + 1);
}

std::vector<double> parseNumbers(const std::string& key, std::string text, const std::string& origin) {
  for (char& ch : text)
    if (ch == '[' || ch == ']' || ch == ',' || ch == ';') ch = ' ';
  std::istringstream in(text);
  std::vector<double> out;
  std::string tok;
  while (in >> tok) {
    char* end = nullptr;
    const double v = std::strtod(tok.c_str(), &end);
    if (end == tok.c_str() || *end != '\0') {
      throw TopoError(origin + " " + key, "'" + tok + "' is not a number", "write numbers such as 0.1 or 1e-3");
    }
    out.push_back(v);
  }
  return out;
}

std::size_t editDistance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> d(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) d[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t prev = d[0];
    d[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t cur = d[j];
      d[j] = std::min({d[j] + 1, d[j - 1] + 1, prev + (a[i - 1] == b[j - 1] ? 0 : 1)});
      prev = cur;
    }
  }
  return d[b.size()];
}

}  // namespace

void TaskConfig::declare(const ParamSpec& spec, const ParamValue& value) {
  specs_.push_back(spec);
  values_[spec.name] = value;
}

std::vector<std::string> TaskConfig::taskNames() { return knownTasks(); }

TaskConfig TaskConfig::defaults(const std::string& task) {
  const auto& known = knownTasks();
  if (std::find(known.begin(), known.end(), task) == known.end()) {
    throw TopoError("task '" + task + "'", "unknown task", "use one of: " + joinNames(known) +
                                                               " (or a YAML file with `task: NAME`)");
  }
  TaskConfig c;
  c.task_ = task;
  TaskConfigBuilder b{c};
  const Eigen::Vector3d g(0, 0, -9.81), ex(1, 0, 0), ez(0, 0, 1), zero(0, 0, 0);
  // representation and materials (paper §5, table 2)
  b.text("representation", "quadric", "topology representation: point | quadric | neural", {"point", "quadric", "neural"});
  b.num("epsilon", 0.05, "sigmoid width eps of r = sigmoid(s/eps), field units (normalised coordinates)", 0, 1e300, true);
  b.num("initial_field", 0.3, "initial field value s (> 0: fully solid start)");
  b.list("initial_parameters", {},
         "starting parameters theta0 of the representation, overriding initial_field (quadric: the 10 "
         "coefficients a,b,c,d,e,f,g,h,i,j of a x^2+b y^2+c z^2+2(d xy+e xz+f yz)+g x+h y+i z+j in the "
         "normalised frame; s < 0 is hollow); empty: initial_field everywhere");
  b.num("point_bound", 1.0, "point representation: bound of each variable t_i", 0, 1e300, true);
  b.integer("neural_depth", 8, "neural SDF: number of linear layers (paper: 8)", 2, 64);
  b.integer("neural_width", 512, "neural SDF: hidden width (paper: 512)", 1, 8192);
  b.integer("neural_seed", 1, "neural SDF: weight initialisation seed", 0, 1e9);
  b.num("density_solid", 1000.0, "density of the solid material [kg/m^3] (paper: 1e3 synthetic, 5e3 real)", 0, 1e300, true);
  b.num("density_hollow", 0.0, "density of the hollow material [kg/m^3]", 0);
  b.num("density_power", 1.0, "SIMP power p in rho = rho_hollow + r^p (rho_solid - rho_hollow)", 1, 10);
  b.num("density_floor", 1.0, "smallest particle density [kg/m^3] so nothing is massless", 0, 1e300, true);
  b.flag("continuous_material", false, "use r as a density fraction (no binarisation), the paper's ablation");
  b.flag("pin_shell", true, "pin the boundary shell solid (the paper fixes surface particles)");
  b.num("shell_thickness_m", 0.0, "pinned shell thickness [m]; 0 = the surface particles only", 0);
  // regularisers
  b.num("weight_volume", 0.0, "weight of the material-volume regulariser (solid fraction, or its distance to target_solid_fraction)", 0);
  b.num("target_solid_fraction", -1.0, "target solid volume fraction for weight_volume; < 0: minimise material", -1, 1);
  b.num("weight_smoothness", 0.0, "weight of the smoothness regulariser (mean (r_i - r_j)^2 over neighbours)", 0);
  b.num("smoothness_radius_m", 0.0, "neighbour radius of the smoothness regulariser [m]; 0 = 1.5 x spacing", 0);
  // optimiser
  b.text("optimizer", "lbfgs", "lbfgs (NLopt LD_LBFGS, bounded) | adam", {"lbfgs", "adam"});
  b.integer("max_iterations", 200, "iteration limit", 1, 1e7);
  b.num("learning_rate", 0.02, "Adam step size", 0, 1e300, true);
  b.num("loss_tolerance", 1e-12, "stop when the loss is below this", 0);
  b.num("relative_tolerance", 1e-10, "stop when the relative loss change is below this (L-BFGS)", 0);
  b.num("gradient_tolerance", 1e-14, "stop when the gradient norm is below this", 0);
  b.vec("gravity", &g, "gravity in the world frame [m/s^2]");

  if (task == "hanging" || task == "balance" || task == "stand") {
    if (task == "hanging") {
      b.vec("hanging_point", nullptr, "hanging point in the body frame [m]; default: top centre of the bounds");
      b.num("swing_duration_s", 0.0, "also simulate the design swinging on the hanging point for this long [s] (0 = off)", 0);
      b.num("swing_tilt_deg", 3.0, "release angle of that swing about world x [deg]", -80, 80);
    }
    if (task == "balance") {
      b.vec("support_point", nullptr, "support point in the body frame [m]; default: top centre of the bounds");
      b.flag("require_stable", true, "the centre of mass must lie below the support point");
      b.num("stability_margin_m", 0.0, "required depth of the centre of mass below the support point [m]", 0);
    }
    if (task == "stand") b.num("base_tolerance_m", 0.0, "particles this close to the lowest point form the base [m]; 0 = 1.5 x spacing", 0);
    b.target("target_roll_deg", ParamType::Number, "target orientation: roll about world x [deg] (default 0: the rest pose)");
    b.target("target_pitch_deg", ParamType::Number, "target orientation: pitch about world y [deg] (default 0)");
  }
  if (task == "tumbler" || task == "ball") {
    b.num("duration_s", task == "tumbler" ? 2.0 : 1.0, "simulated time [s]", 0, 1e300, true);
    b.num("dt_s", 5e-3, "sampling step of the simulated motion [s] (paper: 5e-3)", 0, 1e300, true);
    b.num("max_substep_s", 0.0, "integration step limit [s]; 0 = automatic from the contact stiffness", 0);
    b.num("contact_stiffness_n_per_m", 0.0, "penalty stiffness per contact particle [N/m]; 0 = automatic", 0);
    b.num("contact_offset_m", 0.0, "penalty offset delta [m]", 0);
    b.num("contact_damping_ratio", task == "tumbler" ? 0.1 : 0.3, "normal contact damping, fraction of critical", 0, 10);
    b.num("friction_mu", 1.0, "Coulomb friction coefficient", 0);
    b.num("linear_damping_per_s", 0.0, "linear velocity damping [1/s]", 0);
    b.num("angular_damping_per_s", 0.0, "angular velocity damping [1/s]", 0);
  }
  if (task == "tumbler") {
    b.num("initial_tilt_deg", 10.0, "release tilt about rocking_axis [deg]", -89, 89);
    b.num("initial_angular_velocity_rad_s", 0.0, "initial angular velocity about rocking_axis [rad/s]");
    b.vec("rocking_axis", &ex, "rocking axis in the body frame (horizontal at rest)");
    b.vec("up_axis", &ez, "the body's up direction (the tilt is measured from it)");
    c.values_["loss_tolerance"].number = 1e-8;  // relative feature errors of 1e-4 are plenty
    b.integer("measured_cycles", 2, "period and equilibrium from the first N full cycles (0 = all in duration_s)", 0, 1000);
    b.num("weight_period", 1.0, "loss weight of ((T - T*)/T*)^2", 0);
    b.num("weight_tilt", 1.0, "loss weight of ((tilt - tilt*)/tilt*)^2", 0);
    b.target("period_s", ParamType::Number, "observed rocking period [s]", 0, 1e300, true);
    b.target("max_tilt_deg", ParamType::Number, "observed maximum tilt [deg]", 0, 90, true);
  }
  if (task == "qiqi") {
    b.vec("pivot_point", nullptr, "hinge pivot in the body frame [m]; default: bounds centre, 1/4 of the height above it");
    b.vec("hinge_axis", &ex, "hinge axis (body = world at zero tilt)");
    b.list("fill_levels", {0.0, 0.5, 0.95}, "water volume as fractions of the cavity volume, one per pose", 0, 1);
    b.num("water_density", 1000.0, "[kg/m^3]", 0, 1e300, true);
    b.num("water_smoothing", 0.01, "width of the water surface as a fraction of the object size", 0, 1, true);
    b.target("target_tilts_deg", ParamType::List, "observed tilt at each fill level [deg]");
  }
  if (task == "finger" || task == "pear" || task == "cantilever") {
    // Soft bodies (paper §6.1 soft, table 2): Young's modulus interpolated by r like the density.
    const bool finger = task == "finger", pear = task == "pear";
    b.num("youngs_modulus_solid", finger ? 1e7 : (pear ? 1e6 : 1e7),
          "Young's modulus of the r = 1 material [Pa] (paper: stiff 3e7, real finger 1e7)", 0, 1e300, true);
    b.num("youngs_modulus_hollow", finger ? 1e6 : (pear ? 1e5 : 1e7),
          finger ? "Young's modulus of the chamber (r = 0) [Pa]" : "Young's modulus of the r = 0 material [Pa] (paper: soft 1.5e5)",
          0, 1e300, true);
    b.num("poisson_ratio", finger ? 0.45 : 0.3, "Poisson ratio nu of the r = 1 material (paper: 0.4; real finger 0.49)", -0.99, 0.499);
    b.num("poisson_ratio_hollow", finger ? 0.0 : 0.3,
          finger ? "Poisson ratio of the chamber (0: the air offers no bulk stiffness)" : "Poisson ratio of the r = 0 material",
          -0.99, 0.499);
    b.num("stiffness_power", finger ? 3.0 : 1.0, "SIMP power of the Young's modulus interpolation", 1, 10);
    b.text("energy_model", "corotated_linear", "corotated_linear (Cauchy strain) | stvk (Green strain)",
           {"corotated_linear", "stvk"});
    b.integer("gradient_order", task == "cantilever" ? 2 : 1,
              "SPH kernel gradient: 1 corrected (paper), 2 quadratic MLS (exact in bending)", 1, 2);
    b.num("smoothing_factor", 1.5, "SPH smoothing length h as a multiple of the particle spacing", 0.8, 3);
    b.num("hourglass_alpha", 0.1, "zero-energy-mode penalty relative to mu", 0);
    b.num("damping_per_s", pear ? 0.0 : 0.0, "mass-proportional damping c [1/s]", 0);
    b.num("newton_tolerance", 1e-8, "Newton convergence: max residual force / load scale", 0, 1, true);
    b.num("default_spacing_m", finger ? 0.0025 : (pear ? 0.008 : 0.004),
          "particle spacing of the generated default shape when no volume is given [m]", 0, 1e300, true);
    c.values_["density_hollow"].number = finger ? 1.0 : (pear ? 1000.0 : 1000.0);
    c.values_["density_solid"].number = 1000.0;
    c.values_["pin_shell"].number = finger ? 1.0 : 0.0;
  }
  if (task == "finger") {
    b.num("pressure_pa", 5e5, "chamber gauge pressure at the end of the ramp [Pa] (paper: 5e5)");
    b.num("clamp_length_m", 0.01, "particles within this distance of the base (min x) are clamped [m]", 0, 1e300, true);
    b.text("mode", "static", "static (quasi-static equilibrium at the full pressure) | implicit (implicit Euler over the ramp)",
           {"static", "implicit"});
    b.integer("load_steps", 2, "static mode: pressure increments of the Newton solve", 1, 100);
    b.num("duration_s", 0.2, "implicit mode: simulated time; the pressure ramps over it [s]", 0, 1e300, true);
    b.num("dt_s", 0.01, "implicit mode: time step [s]", 0, 1e300, true);
    b.vec("finger_axis", &ex, "the finger's long axis from base to tip (rest state)");
    b.vec("bend_normal", &ez, "positive bending angle = tip turning towards this direction");
    b.num("tip_fraction", 0.15, "the tip segment: the last fraction of the length; the segment before it has the same length", 0.02, 0.45);
    c.values_["gravity"].vec = zero;  // the paper's finger task: actuation only
    c.values_["loss_tolerance"].number = 1e-8;
    b.target("bend_angle_deg", ParamType::Number, "observed bending angle of the tip at the full pressure [deg]", -180, 180);
  }
  if (task == "pear") {
    b.num("duration_s", 0.12, "simulated time [s]", 0, 1e300, true);
    b.num("dt_s", 0.0, "integration step [s]; 0 = 0.9 x the explicit stability limit", 0);
    b.num("sample_dt_s", 0.005, "spacing of the compared trajectory samples [s]", 0, 1e300, true);
    b.num("initial_height_m", 0.01, "gap between the lowest point and the ground at release [m]", 0);
    b.vec("initial_velocity", &zero, "initial velocity [m/s]");
    b.num("initial_tilt_deg", 15.0, "release tilt about world x [deg]", -89, 89);
    b.num("contact_stiffness_n_per_m", 0.0, "ground penalty stiffness per particle [N/m]; 0 = automatic", 0);
    b.num("friction_mu", 0.5, "Coulomb friction coefficient", 0);
    b.list("pivot_points", {}, "tracked body points x,y,z,... [m]; default: top, bottom and two side points");
    b.target("target_trajectory_file", ParamType::Text, "CSV: t, then x y z of each pivot point [s, m]");
  }
  if (task == "cantilever") {
    b.num("clamp_length_m", 0.0, "particles with x < min x + this are clamped [m]; 0 = 3 spacings", 0);
    b.flag("vibration", true, "also release the static shape without gravity and measure the first frequency");
    b.num("vibration_periods", 1.0, "free vibration: full periods to measure", 0.5, 20);
    c.values_["pin_shell"].number = 0.0;
  }
  if (task == "ball") {
    b.num("initial_height_m", 0.3, "drop height of the lowest point above the ground [m]", 0);
    b.vec("initial_velocity", &zero, "initial velocity [m/s]");
    b.vec("initial_angular_velocity", &zero, "initial angular velocity, world frame [rad/s]");
    b.list("pivot_points", {}, "tracked body points x,y,z,... [m]; default: centroid and two surface points");
    b.target("target_trajectory_file", ParamType::Text, "CSV: t, then x y z of each pivot point [s, m]");
  }
  return c;
}

const ParamSpec* TaskConfig::spec(const std::string& key) const {
  for (const auto& s : specs_)
    if (s.name == key) return &s;
  return nullptr;
}

bool TaskConfig::has(const std::string& key) const {
  const auto it = values_.find(key);
  return it != values_.end() && it->second.set;
}

void TaskConfig::check(const ParamSpec& s, const ParamValue& v, const std::string& origin) const {
  const std::string who = origin + " " + s.name;
  auto range = [&](double x) {
    if (!std::isfinite(x)) throw TopoError(who, "value is not finite", "give a finite number");
    const bool low = s.min_exclusive ? x <= s.min : x < s.min;
    if (low || x > s.max) {
      std::ostringstream os;
      os << "value " << x << " is outside " << (s.min_exclusive ? "(" : "[") << s.min << ", " << s.max << "]";
      throw TopoError(who, os.str(), s.doc);
    }
  };
  switch (s.type) {
    case ParamType::Number:
    case ParamType::Integer:
      range(v.number);
      if (s.type == ParamType::Integer && v.number != std::floor(v.number))
        throw TopoError(who, "value must be a whole number", s.doc);
      break;
    case ParamType::List:
      for (double x : v.list) range(x);
      break;
    case ParamType::Vector3:
      if (!v.vec.allFinite()) throw TopoError(who, "vector is not finite", "give three finite numbers x,y,z");
      break;
    case ParamType::Text:
      if (!s.choices.empty() && std::find(s.choices.begin(), s.choices.end(), v.text) == s.choices.end())
        throw TopoError(who, "'" + v.text + "' is not allowed", "use one of: " + joinNames(s.choices));
      break;
    case ParamType::Boolean:
      break;
  }
}

void TaskConfig::set(const std::string& key_in, const std::string& value_in, const std::string& origin) {
  const std::string key = trim(key_in), value = trim(value_in);
  // Uniform-material shorthands (the cantilever): one value for both materials.
  if (task_ == "cantilever" && (key == "youngs_modulus" || key == "density")) {
    const std::string base = key == "density" ? "density" : "youngs_modulus";
    set(base + "_solid", value, origin + " " + key + " ->");
    set(base + "_hollow", value, origin + " " + key + " ->");
    return;
  }
  if (task_ == "cantilever" && key == "poisson_ratio") {
    set("poisson_ratio_hollow", value, origin + " " + key + " ->");  // and fall through for poisson_ratio
  }
  const ParamSpec* s = spec(key);
  if (!s) {
    std::string nearest;
    std::size_t best = 1000;
    for (const auto& sp : specs_) {
      const std::size_t d = editDistance(key, sp.name);
      if (d < best) best = d, nearest = sp.name;
    }
    throw TopoError(origin + " " + key, "unknown parameter of task '" + task_ + "'",
                    (best <= 4 ? "did you mean '" + nearest + "'? " : std::string()) +
                        "`topo infer --task " + task_ + " --list-params` lists all");
  }
  ParamValue v = values_[key];
  switch (s->type) {
    case ParamType::Number:
    case ParamType::Integer: {
      const auto n = parseNumbers(key, value, origin);
      if (n.size() != 1) throw TopoError(origin + " " + key, "expects one number, got '" + value + "'", s->doc);
      v.number = n[0];
      break;
    }
    case ParamType::Boolean: {
      std::string l = value;
      std::transform(l.begin(), l.end(), l.begin(), ::tolower);
      if (l == "true" || l == "1" || l == "yes" || l == "on") v.number = 1;
      else if (l == "false" || l == "0" || l == "no" || l == "off") v.number = 0;
      else throw TopoError(origin + " " + key, "'" + value + "' is not a boolean", "use true or false");
      break;
    }
    case ParamType::Text:
      v.text = value;
      break;
    case ParamType::Vector3: {
      const auto n = parseNumbers(key, value, origin);
      if (n.size() != 3) throw TopoError(origin + " " + key, "expects three numbers x,y,z, got '" + value + "'", s->doc);
      v.vec = Eigen::Vector3d(n[0], n[1], n[2]);
      break;
    }
    case ParamType::List:
      v.list = parseNumbers(key, value, origin);
      break;
  }
  v.set = !(s->type == ParamType::Text && v.text.empty());
  check(*s, v, origin);
  values_[key] = v;
}

void TaskConfig::setAssignment(const std::string& a, const std::string& origin) {
  const auto eq = a.find('=');
  if (eq == std::string::npos || eq == 0)
    throw TopoError(origin + " '" + a + "'", "not of the form KEY=VALUE", "write e.g. density_solid=1200");
  set(a.substr(0, eq), a.substr(eq + 1), origin);
}

void TaskConfig::setNumber(const std::string& key, double value) {
  std::ostringstream os;
  os.precision(17);
  os << value;
  set(key, os.str(), "parameter");
}

void TaskConfig::setVector(const std::string& key, const Eigen::Vector3d& v) {
  std::ostringstream os;
  os.precision(17);
  os << v[0] << "," << v[1] << "," << v[2];
  set(key, os.str(), "parameter");
}

void TaskConfig::setList(const std::string& key, const std::vector<double>& l) {
  std::ostringstream os;
  os.precision(17);
  for (std::size_t i = 0; i < l.size(); ++i) os << (i ? "," : "") << l[i];
  set(key, os.str(), "parameter");
}

namespace {
void requireKnown(const TaskConfig& c, const std::string& key) {
  if (!c.spec(key)) throw TopoError("parameter " + key, "not a parameter of task '" + c.task() + "'", "see --list-params");
}
}  // namespace

double TaskConfig::number(const std::string& key) const {
  requireKnown(*this, key);
  if (!has(key)) throw TopoError("parameter " + key, "has no value", "set it with --set/--target " + key + "=VALUE");
  return values_.at(key).number;
}

const std::string& TaskConfig::text(const std::string& key) const {
  requireKnown(*this, key);
  return values_.at(key).text;
}

Eigen::Vector3d TaskConfig::vector3(const std::string& key) const {
  requireKnown(*this, key);
  if (!has(key)) throw TopoError("parameter " + key, "has no value", "set it with --set " + key + "=x,y,z");
  return values_.at(key).vec;
}

const std::vector<double>& TaskConfig::list(const std::string& key) const {
  requireKnown(*this, key);
  return values_.at(key).list;
}

std::string TaskConfig::valueText(const std::string& key) const {
  const ParamSpec* s = spec(key);
  if (!s) return "";
  const ParamValue& v = values_.at(key);
  if (!v.set) return "(unset)";
  std::ostringstream os;
  os.precision(10);
  switch (s->type) {
    case ParamType::Number: case ParamType::Integer: os << v.number; break;
    case ParamType::Boolean: os << (v.number != 0 ? "true" : "false"); break;
    case ParamType::Text: os << v.text; break;
    case ParamType::Vector3: os << v.vec[0] << "," << v.vec[1] << "," << v.vec[2]; break;
    case ParamType::List:
      for (std::size_t i = 0; i < v.list.size(); ++i) os << (i ? "," : "") << v.list[i];
      break;
  }
  return os.str();
}

std::string TaskConfig::help() const {
  std::ostringstream os;
  os << "task " << task_ << " (" << source_ << "):\n";
  for (const auto& s : specs_) {
    os << "  " << (s.is_target ? "--target " : "--set ") << s.name << "=" << valueText(s.name) << "\n      " << s.doc << "\n";
  }
  return os.str();
}

namespace {
std::string nodeText(const YAML::Node& n) {
  if (n.IsSequence()) {
    std::string s;
    for (const auto& e : n) s += (s.empty() ? "" : ",") + e.as<std::string>();
    return s;
  }
  return n.as<std::string>();
}
}  // namespace

TaskConfig TaskConfig::fromYamlFile(const std::string& path) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::BadFile&) {
    throw TopoError(path, "cannot open the task file", "check the path (or give a task name: " + joinNames(knownTasks()) + ")");
  } catch (const YAML::Exception& e) {
    throw TopoError(path, std::string("is not valid YAML: ") + e.what(), "fix the syntax at the reported line");
  }
  if (!root.IsMap() || !root["task"]) throw TopoError(path, "has no `task:` key", "start the file with `task: NAME` (" + joinNames(knownTasks()) + ")");
  TaskConfig c = defaults(root["task"].as<std::string>());
  c.source_ = path;
  for (const auto& kv : root) {
    const std::string key = kv.first.as<std::string>();
    if (key == "task" || key == "description") continue;
    if (key == "targets") {
      if (!kv.second.IsMap()) throw TopoError(path + " targets", "is not a map", "write `targets:` followed by `name: value` lines");
      for (const auto& t : kv.second) c.set(t.first.as<std::string>(), nodeText(t.second), path);
      continue;
    }
    c.set(key, nodeText(kv.second), path);
  }
  return c;
}

TaskConfig TaskConfig::load(const std::string& name_or_path, const std::string& task_dir) {
  const bool looks_like_file = name_or_path.find('/') != std::string::npos ||
                               (name_or_path.size() > 5 && name_or_path.substr(name_or_path.size() - 5) == ".yaml");
  if (looks_like_file) return fromYamlFile(name_or_path);
  if (!task_dir.empty()) {
    const std::string p = task_dir + "/" + name_or_path + ".yaml";
    if (std::ifstream(p).good()) return fromYamlFile(p);
  }
  return defaults(name_or_path);
}

}  // namespace topo_gaussian::inference
