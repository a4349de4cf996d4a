// TaskConfig: the common parameters every task has, parsing, validation, YAML files.
#include "topo_gaussian/inference/task_config.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/inference/task_registry.h"

namespace topo_gaussian::inference {

namespace {

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

/// Levenshtein distance of a and b, or limit + 1 as soon as it must exceed limit (every entry of a
/// row above it).
std::size_t editDistance(const std::string& a, const std::string& b, std::size_t limit) {
  const std::size_t longer = std::max(a.size(), b.size()), shorter = std::min(a.size(), b.size());
  if (longer - shorter > limit) return limit + 1;  // at least the length difference
  std::vector<std::size_t> d(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) d[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t prev = d[0];
    d[0] = i;
    std::size_t row_min = d[0];
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t cur = d[j];
      d[j] = std::min({d[j] + 1, d[j - 1] + 1, prev + (a[i - 1] == b[j - 1] ? 0 : 1)});
      row_min = std::min(row_min, d[j]);
      prev = cur;
    }
    if (row_min > limit) return limit + 1;
  }
  return d[b.size()];
}

/// A value as text ("1200", "true", "0,0,0.1", "(unset)"), as valueText shows it.
std::string formatValue(const ParamSpec& s, const ParamValue& v) {
  if (!v.set) return "(unset)";
  std::ostringstream os;
  os.precision(10);
  switch (s.type) {
    case ParamType::Number:
    case ParamType::Integer:
      os << v.number;
      break;
    case ParamType::Boolean:
      os << (v.number != 0 ? "true" : "false");
      break;
    case ParamType::Text:
      os << v.text;
      break;
    case ParamType::Vector3:
      os << v.vec[0] << "," << v.vec[1] << "," << v.vec[2];
      break;
    case ParamType::List:
      for (std::size_t i = 0; i < v.list.size(); ++i) os << (i ? "," : "") << v.list[i];
      break;
  }
  return os.str();
}

}  // namespace

void TaskConfig::declare(const ParamSpec& spec, const ParamValue& value) {
  specs_.push_back(spec);
  values_[spec.name] = value;
}

std::vector<std::string> TaskConfig::taskNames() {
  std::vector<std::string> names;
  for (const auto& t : taskDefinitions()) names.push_back(t.name);
  return names;
}

namespace {

/// The parameters every task has: representation, materials, regularisers, optimiser, gravity.
void declareCommonParameters(TaskParameters& p) {
  const Eigen::Vector3d g(0, 0, -9.81);
  // representation and materials (paper §5, table 2)
  p.text("representation", "quadric", "topology representation: point | quadric | neural",
         {"point", "quadric", "neural"});
  p.number("epsilon", 0.05, "unitless",
           "sigmoid width eps of r = sigmoid(s/eps), unitless (field units of the normalised coordinates)", 0, 1e300,
           true);
  p.number("initial_field", 0.3, "unitless", "initial field value s (> 0: fully solid start), unitless");
  p.list("initial_parameters", {}, "unitless",
         "starting parameters theta0 (unitless) of the representation, overriding initial_field (quadric: the 10 "
         "coefficients a,b,c,d,e,f,g,h,i,j of a x^2+b y^2+c z^2+2(d xy+e xz+f yz)+g x+h y+i z+j in the "
         "normalised frame; s < 0 is hollow); empty: initial_field everywhere");
  p.number("point_bound", 1.0, "unitless", "point representation: bound of each variable t_i, unitless", 0, 1e300,
           true);
  p.integer("neural_depth", 8, "unitless", "neural SDF: number of linear layers, unitless (paper: 8)", 2, 64)
      .paper("8");
  p.integer("neural_width", 512, "unitless", "neural SDF: hidden width, unitless (paper: 512)", 1, 8192).paper("512");
  p.integer("neural_seed", 1, "unitless", "neural SDF: weight initialisation seed, unitless", 0, 1e9);
  p.number("density_solid", 1000.0, "kg/m^3", "density of the solid material [kg/m^3] (paper: 1e3 synthetic, 5e3 real)",
           0, 1e300, true)
      .paper("1e3 synthetic, 5e3 real");
  p.number("density_hollow", 0.0, "kg/m^3", "density of the hollow material [kg/m^3]", 0);
  p.number("density_power", 1.0, "unitless",
           "SIMP power p in rho = rho_hollow + r^p (rho_solid - rho_hollow), unitless", 1, 10);
  p.number("density_floor", 1.0, "kg/m^3", "smallest particle density [kg/m^3] so nothing is massless", 0, 1e300, true);
  p.flag("continuous_material", false, "use r as a density fraction (no binarisation), the paper's ablation");
  p.flag("pin_shell", true, "pin the boundary shell solid (the paper fixes surface particles)").paper("true");
  p.number("shell_thickness_m", 0.0, "m", "pinned shell thickness [m]; 0 = the surface particles only", 0);
  p.text("weighed_start", "ellipsoid",
         "quadric with a mass_kg target: the start's region of the other material, centred on the volume's "
         "centroid with the reading's mass: sphere | ellipsoid (the volume's equivalent ellipsoid, scaled: a shell's "
         "own shape)",
         {"sphere", "ellipsoid"});
  p.text("quadric_field", "auto",
         "quadric: the field whose sign is the material: algebraic (s = u'Au + b'u + c, the paper's) | distance "
         "(s / |grad s|, the distance to the quadric's surface: binary beyond quadric_boundary_m, no grey spread) | "
         "auto (distance when a mass_kg target weighs the object and the weighed start is made, algebraic "
         "otherwise); distance needs a start with a surface (not the constant solid start)",
         {"auto", "algebraic", "distance"});
  p.number("quadric_boundary_m", 0.0, "m",
           "quadric_field distance: the boundary's width w [m], r = sigmoid(d / w) for the distance d to the surface "
           "(0.12 to 0.88 across 4 w); 0 = half the particle spacing",
           0);
  // regularisers
  p.number(
      "weight_volume", 0.0, "unitless",
      "weight of the material-volume regulariser (solid fraction, or its distance to target_solid_fraction), unitless",
      0);
  p.number("target_solid_fraction", -1.0, "unitless",
           "target solid volume fraction for weight_volume, unitless; < 0: minimise material", -1, 1);
  p.number("weight_smoothness", 0.0, "unitless",
           "weight of the smoothness regulariser (mean (r_i - r_j)^2 over neighbours), unitless", 0);
  p.number("smoothness_radius_m", 0.0, "m", "neighbour radius of the smoothness regulariser [m]; 0 = 1.5 x spacing", 0);
  // optimiser
  p.text("optimizer", "lbfgs", "lbfgs (NLopt LD_LBFGS, bounded) | adam", {"lbfgs", "adam"});
  p.integer("max_evaluations", 200, "unitless",
            "limit on the objective evaluations: loss and gradient computations (each simulates the design once), "
            "line-search trials included, not optimiser iterations (an L-BFGS iteration may use several), unitless",
            1, 1e7);
  p.alias("max_iterations", "max_evaluations", "it always counted evaluations");
  p.number("learning_rate", 0.02, "unitless", "Adam step size, unitless", 0, 1e300, true);
  p.number("loss_tolerance", 1e-12, "unitless", "stop when the loss is below this, unitless", 0);
  p.number("relative_tolerance", 1e-10, "unitless",
           "stop when the relative loss change is below this (L-BFGS), unitless", 0);
  p.number("gradient_tolerance", 1e-14, "unitless", "stop when the gradient norm is below this, unitless", 0);
  p.integer("stall_evaluations", 30, "unitless",
            "stop when the best loss fell by less than 0.01 % over this many evaluations, unitless (0 = never)", 0,
            1e7);
  p.text("backend", "auto",
         "where the particle kernels run: auto (a CUDA GPU when this build has the CUDA backend and the driver "
         "reports one, else the CPU) | cpu | cuda (refused without a GPU, with the reason). On the GPU now: the "
         "pear's explicit rollout and its gradient (contact included), the neural representation, and the Cholesky "
         "factor that preconditions the finger's and cantilever's Newton solves with the Hessian products of those "
         "solves (their forces on the host; auto keeps the factor on the host when the GPU lacks the memory); the "
         "rigid tasks' physics runs on the CPU",
         {"auto", "cpu", "cuda"});
  p.vector3("gravity", &g, "m/s^2",
            "gravity in the world frame [m/s^2], each component within [-1000, 1000] (about 100 g)", -1000, 1000);
  // how sure is the interior (inference/design_spread.h)
  p.integer("restarts", 2, "unitless",
            "further optimisations after the best design, pulled to other solid fractions, that look for designs "
            "fitting as well (per-particle solid/hollow confidence, spread of mass and solid fraction), unitless; "
            "each costs about as many evaluations as the main run (at least 20); 0: none",
            0, 1000);
}

}  // namespace

TaskConfig TaskConfig::common() {
  TaskConfig c;
  TaskParameters p(c);
  declareCommonParameters(p);
  return c;
}

TaskConfig TaskConfig::defaults(const std::string& task) {
  const TaskDefinition& definition = taskDefinition(task);  // unknown: lists the registered tasks
  TaskConfig c;
  c.task_ = task;
  TaskParameters p(c);
  declareCommonParameters(p);
  definition.declare_parameters(p);
  return c;
}

const ParamSpec* TaskConfig::spec(const std::string& key_in) const {
  const std::string& key = canonicalName(key_in);
  for (const auto& s : specs_)
    if (s.name == key) return &s;
  return nullptr;
}

const std::string& TaskConfig::canonicalName(const std::string& key) const {
  for (const auto& a : aliases_)
    if (a.name == key) return a.parameter;
  return key;
}

std::string TaskConfig::aliasText(const std::string& name) const {
  for (const auto& a : aliases_)
    if (a.name == name) return a.name + ": alias of " + a.parameter + (a.note.empty() ? "" : " (" + a.note + ")");
  return "";
}

bool TaskConfig::has(const std::string& key) const {
  const auto it = values_.find(canonicalName(key));
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
      for (int i = 0; i < 3; ++i)
        if (v.vec[i] < s.min || v.vec[i] > s.max) {
          std::ostringstream os;
          os << "component " << "xyz"[i] << " = " << v.vec[i] << " is outside [" << s.min << ", " << s.max << "]";
          throw TopoError(who, os.str(), s.doc);
        }
      break;
    case ParamType::Text:
      if (!s.choices.empty() && std::find(s.choices.begin(), s.choices.end(), v.text) == s.choices.end())
        throw TopoError(who, "'" + v.text + "' is not allowed", "use one of: " + joinNames(s.choices));
      break;
    case ParamType::Boolean:
      break;
  }
}

namespace {
const TaskConfig& sharedParameters() {
  static const TaskConfig shared = TaskConfig::common();
  return shared;
}
}  // namespace

bool TaskConfig::isShared(const std::string& key) { return sharedParameters().spec(key) != nullptr; }  // aliases too

std::vector<Experiment> TaskConfig::experimentList() const {
  if (!experiments_.empty()) return experiments_;
  return {Experiment{task_, 1.0, *this}};
}

void TaskConfig::addExperiment(const std::string& name, double weight, const TaskConfig& experiment) {
  const std::string who = "experiment '" + name + "'";
  if (name.empty()) throw TopoError("experiment", "has no name", "give every experiment a name (e.g. `name: rock_x`)");
  if (name.find(kExperimentKeySeparator) != std::string::npos || name.find('/') != std::string::npos)
    throw TopoError(who, "contains '.' or '/'", "use letters, digits and '_' (e.g. rock_x)");
  for (const auto& e : experiments_)
    if (e.name == name) throw TopoError(who, "is named twice", "give each experiment its own name");
  if (!(weight > 0) || !std::isfinite(weight))
    throw TopoError(who + " weight", "must be a positive number", "give a weight > 0 (default 1)");
  if (experiment.hasExperiments())
    throw TopoError(who, "holds experiments itself", "list every experiment in one `experiments:` list");
  if (experiment.task().empty()) throw TopoError(who, "has no task", "give it `task: NAME`");
  // One object, one material and one representation: the shared parameters agree.
  for (const auto& key : experiment.explicit_) {
    if (!isShared(key)) continue;
    const std::string mine = valueText(key), theirs = experiment.valueText(key);
    if (explicit_.count(key)) {
      if (mine != theirs)
        throw TopoError(who + " " + key,
                        "is " + theirs + " but the object's shared value is " + mine +
                            " (one object has one material, representation and optimiser)",
                        "set " + key + " once, at the top of the experiments file, or give it the same value");
      continue;
    }
    values_[key] = experiment.values_.at(key);  // the first experiment to say it sets it for all
    explicit_.insert(key);
    for (auto& e : experiments_) e.config.values_[key] = values_[key];
  }
  if (experiments_.empty()) {
    // The object's config takes the first experiment's task and defaults, keeping its shared values.
    TaskConfig top = experiment;
    for (const auto& key : explicit_) top.values_[key] = values_.at(key);
    top.explicit_.insert(explicit_.begin(), explicit_.end());
    top.source_ = source_;
    *this = std::move(top);
  }
  Experiment e{name, weight, experiment};
  for (const auto& spec : sharedParameters().specs()) e.config.values_[spec.name] = values_.at(spec.name);
  experiments_.push_back(std::move(e));
}

void TaskConfig::removeExperiment(const std::string& name) {
  auto it = std::find_if(experiments_.begin(), experiments_.end(), [&](const Experiment& e) { return e.name == name; });
  if (it == experiments_.end()) throw TopoError("experiment '" + name + "'", "does not exist", "name one of the list");
  if (experiments_.size() == 1)
    throw TopoError("experiment '" + name + "'", "is the only one left", "an inference needs one experiment at least");
  const bool first = it == experiments_.begin();
  experiments_.erase(it);
  if (!first) return;
  // The object's config is the new first experiment's, with the shared values and the list kept.
  std::vector<Experiment> list = std::move(experiments_);
  TaskConfig top = list.front().config;
  top.source_ = source_;
  top.explicit_ = explicit_;
  for (const auto& spec : sharedParameters().specs()) top.values_[spec.name] = values_.at(spec.name);
  top.experiments_ = std::move(list);
  *this = std::move(top);
}

void TaskConfig::set(const std::string& key_in, const std::string& value_in, const std::string& origin) {
  if (experiments_.empty()) {
    setOwn(key_in, value_in, origin);
    return;
  }
  const std::string key = trim(key_in);
  std::vector<std::string> names;
  for (const auto& e : experiments_) names.push_back(e.name);
  const auto dot = key.find(kExperimentKeySeparator);
  if (dot != std::string::npos) {
    const std::string name = key.substr(0, dot), k = key.substr(dot + 1);
    auto it =
        std::find_if(experiments_.begin(), experiments_.end(), [&](const Experiment& e) { return e.name == name; });
    if (it == experiments_.end())
      throw TopoError(origin + " " + key, "names no experiment '" + name + "'",
                      "the experiments are " + joinNames(names));
    if (isShared(k))
      throw TopoError(origin + " " + key, k + " is shared by all experiments of the object",
                      "set it without the experiment name: " + k + "=VALUE");
    it->config.set(k, value_in, origin);
    if (it == experiments_.begin()) setOwn(k, value_in, origin);
    return;
  }
  if (isShared(key)) {
    setOwn(key, value_in, origin);
    for (auto& e : experiments_) e.config.setOwn(key, value_in, origin);
    return;
  }
  std::vector<Experiment*> having;
  for (auto& e : experiments_)
    if (e.config.spec(key) || e.config.shorthands_.count(key)) having.push_back(&e);
  if (having.empty())
    throw TopoError(origin + " " + key, "is a parameter of none of the experiments (" + joinNames(names) + ")",
                    "`topo infer --task TASK --list-params` lists a task's parameters");
  const ParamSpec* s = having.front()->config.spec(key);
  if (s && s->is_target && having.size() > 1)
    throw TopoError(origin + " " + key, "is a target of " + std::to_string(having.size()) + " experiments",
                    "name the experiment: e.g. " + having.back()->name + kExperimentKeySeparator + key + "=VALUE");
  for (auto* e : having) {
    e->config.setOwn(key, value_in, origin);
    if (e == &experiments_.front()) setOwn(key, value_in, origin);
  }
}

void TaskConfig::setOwn(const std::string& key_in, const std::string& value_in, const std::string& origin) {
  const std::string given = trim(key_in), value = trim(value_in);
  const std::string key = canonicalName(given);  // an alias sets its parameter
  // A task's shorthand (e.g. one value for both materials): each listed parameter in turn, the key
  // itself last when it is one of them.
  const auto shorthand = shorthands_.find(key);
  if (shorthand != shorthands_.end()) {
    bool itself = false;
    for (const auto& p : shorthand->second) {
      if (p == key)
        itself = true;
      else
        setOwn(p, value, origin + " " + key + " ->");
    }
    if (!itself) return;
  }
  const ParamSpec* s = spec(key);
  if (!s) {
    std::string nearest;
    std::size_t best = 1000;
    for (const auto& sp : specs_) {
      // Only names within 4 edits are suggested: the distance stops counting above that (a long
      // garbage key took milliseconds per name).
      const std::size_t d = editDistance(key, sp.name, 4);
      if (d < best) best = d, nearest = sp.name;
    }
    throw TopoError(origin + " " + key, "unknown parameter of task '" + task_ + "'",
                    (best <= 4 ? "did you mean '" + nearest + "'? " : std::string()) + "`topo infer --task " + task_ +
                        " --list-params` lists all");
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
      if (l == "true" || l == "1" || l == "yes" || l == "on")
        v.number = 1;
      else if (l == "false" || l == "0" || l == "no" || l == "off")
        v.number = 0;
      else
        throw TopoError(origin + " " + key, "'" + value + "' is not a boolean", "use true or false");
      break;
    }
    case ParamType::Text:
      v.text = value;
      break;
    case ParamType::Vector3: {
      const auto n = parseNumbers(key, value, origin);
      if (n.size() != 3)
        throw TopoError(origin + " " + key, "expects three numbers x,y,z, got '" + value + "'", s->doc);
      v.vec = Eigen::Vector3d(n[0], n[1], n[2]);
      break;
    }
    case ParamType::List:
      v.list = parseNumbers(key, value, origin);
      break;
  }
  v.set = !(s->type == ParamType::Text && v.text.empty());
  check(*s, v, origin);
  const bool aliased =
      std::any_of(aliases_.begin(), aliases_.end(), [&](const ParamAlias& a) { return a.parameter == key; });
  if (aliased) {
    // One origin (a file, the --set list, a goal's overrides) naming a parameter twice, once by its
    // alias, must mean one value; a later origin overrides an earlier one as for any parameter.
    const std::string text = formatValue(*s, v);
    const auto last = alias_changes_.find(key);
    if (last != alias_changes_.end() && last->second.origin == origin && last->second.name != given &&
        last->second.value != text) {
      const std::string alias_name = given == key ? last->second.name : given;
      std::string why;
      for (const auto& a : aliases_)
        if (a.name == alias_name) why = a.note.empty() ? "" : " (" + a.note + ")";
      throw TopoError(origin + " " + last->second.name + " and " + given,
                      "name one parameter twice with different values (" + last->second.value + " and " + text + "); " +
                          alias_name + " is an alias of " + key + why,
                      "give only " + key + "=VALUE");
    }
    alias_changes_[key] = {origin, given, text};
  }
  values_[key] = v;
  explicit_.insert(key);
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
  if (!c.spec(key))
    throw TopoError("parameter " + key, "not a parameter of task '" + c.task() + "'", "see --list-params");
}
}  // namespace

double TaskConfig::number(const std::string& key) const {
  requireKnown(*this, key);
  if (!has(key)) throw TopoError("parameter " + key, "has no value", "set it with --set/--target " + key + "=VALUE");
  return values_.at(canonicalName(key)).number;
}

const std::string& TaskConfig::text(const std::string& key) const {
  requireKnown(*this, key);
  return values_.at(canonicalName(key)).text;
}

Eigen::Vector3d TaskConfig::vector3(const std::string& key) const {
  requireKnown(*this, key);
  if (!has(key)) throw TopoError("parameter " + key, "has no value", "set it with --set " + key + "=x,y,z");
  return values_.at(canonicalName(key)).vec;
}

const std::vector<double>& TaskConfig::list(const std::string& key) const {
  requireKnown(*this, key);
  return values_.at(canonicalName(key)).list;
}

std::string TaskConfig::valueText(const std::string& key) const {
  const ParamSpec* s = spec(key);
  if (!s) return "";
  return formatValue(*s, values_.at(s->name));
}

std::string TaskConfig::help() const {
  std::ostringstream os;
  os << "task " << task_ << " (" << source_ << "):\n";
  for (const auto& s : specs_) {
    os << "  " << (s.is_target ? "--target " : "--set ") << s.name << "=" << valueText(s.name);
    if (!s.unit.empty() && s.unit != "unitless") os << " [" << s.unit << "]";
    os << "\n      " << s.doc << "\n";
    if (!s.paper_value.empty() && s.doc.find("paper: " + s.paper_value) == std::string::npos)
      os << "      paper: " << s.paper_value << "\n";
  }
  if (!aliases_.empty()) {
    os << "old names, still accepted:\n";
    for (const auto& a : aliases_) os << "  " << aliasText(a.name) << "\n";
  }
  return os.str();
}

namespace {

/// The value of a key as text: a scalar, or a flat list of scalars joined by commas. Anything else
/// (a map, a nested list, no value) is refused naming `where` (the file and the key).
std::string nodeText(const YAML::Node& n, const std::string& where) {
  if (n.IsScalar()) return n.Scalar();
  if (n.IsSequence()) {
    std::string s;
    for (const auto& e : n) {
      if (!e.IsScalar())
        throw TopoError(where, "holds a nested list or map", "write a flat list of numbers such as [0, 0, -9.81]");
      s += (s.empty() ? "" : ",") + e.Scalar();
    }
    return s;
  }
  if (n.IsMap()) throw TopoError(where, "is a map, not a value", "write `key: value` (a number, a word or a list)");
  throw TopoError(where, "has no value", "write a value after the colon, or remove the key");
}

}  // namespace

namespace {

YAML::Node loadYaml(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw TopoError(
        path, "is a directory, not a task file",
        "give a task YAML file (e.g. " + path + "/tumbler.yaml) or a task name: " + joinNames(TaskConfig::taskNames()));
  try {
    return YAML::LoadFile(path);
  } catch (const YAML::BadFile&) {
    throw TopoError(path, "cannot open the task file",
                    "check the path (or give a task name: " + joinNames(TaskConfig::taskNames()) + ")");
  } catch (const YAML::Exception& e) {
    throw TopoError(path, std::string("is not valid YAML: ") + e.what(), "fix the syntax at the reported line");
  } catch (const std::exception& e) {  // e.g. an unreadable file: iostream errors carry no path
    throw TopoError(path, std::string("cannot be read as a task file: ") + e.what(), "check that it is a text file");
  }
}

/// Throws TopoError when a map names one key twice: YAML parsers keep both and the later value would
/// silently win (`density_solid` written twice), where an unknown key is refused.
void refuseDuplicateKeys(const YAML::Node& map, const std::string& where) {
  std::set<std::string> seen;
  for (const auto& kv : map) {
    if (!kv.first.IsScalar()) continue;
    if (!seen.insert(kv.first.Scalar()).second)
      throw TopoError(where + " " + kv.first.Scalar(), "is given twice (the second value would silently win)",
                      "keep one " + kv.first.Scalar() + " line");
  }
}

/// Sets every `key: value` of a map (and its `targets:` map) on c, skipping the keys in `skip`.
void applyYamlMap(TaskConfig& c, const YAML::Node& map, const std::string& where, const std::string& origin,
                  const std::vector<std::string>& skip) {
  std::string key;
  try {
    refuseDuplicateKeys(map, where);
    for (const auto& kv : map) {
      if (!kv.first.IsScalar())
        throw TopoError(where, "has a key that is not a name (a list or map as a key)", "write `name: value` lines");
      key = kv.first.Scalar();
      if (std::find(skip.begin(), skip.end(), key) != skip.end()) continue;
      if (key == "targets") {
        if (!kv.second.IsMap())
          throw TopoError(where + " targets", "is not a map", "write `targets:` followed by `name: value` lines");
        refuseDuplicateKeys(kv.second, where + " targets");
        for (const auto& t : kv.second) {
          if (!t.first.IsScalar())
            throw TopoError(where + " targets", "has a key that is not a name", "write `name: value` lines");
          key = "targets " + t.first.Scalar();
          c.set(t.first.Scalar(), nodeText(t.second, where + " " + key), origin);
        }
        continue;
      }
      c.set(key, nodeText(kv.second, where + " " + key), origin);
    }
  } catch (const YAML::Exception& e) {
    throw TopoError(where + " " + key, std::string("cannot be read: ") + e.what(), "write `name: value` lines");
  }
}

/// A task config from a map with `task: NAME` (a file's root, or an item of `experiments:`).
TaskConfig taskFromYamlMap(const YAML::Node& map, const std::string& where, const std::string& origin,
                           const std::vector<std::string>& skip) {
  if (!map.IsMap() || !map["task"])
    throw TopoError(where, "has no `task:` key",
                    "start it with `task: NAME` (" + joinNames(TaskConfig::taskNames()) + ")");
  const std::string task = nodeText(map["task"], where + " task");
  TaskConfig c;
  try {
    c = TaskConfig::defaults(task);
  } catch (const TopoError& e) {
    throw TopoError(where + " task: " + e.what());
  }
  std::vector<std::string> all = skip;
  all.push_back("task");
  all.push_back("description");
  applyYamlMap(c, map, where, origin, all);
  return c;
}

}  // namespace

namespace {

/// The task files being read on this thread, outermost first (as given, and canonical): an
/// `experiments:` item whose `file:` leads back to one of them is a cycle, refused before it recurses.
struct OpenTaskFile {
  std::string given, canonical;
};
thread_local std::vector<OpenTaskFile> t_open_task_files;

/// Holds `path` open for the time of one fromYamlFile; throws TopoError naming the chain of files when
/// `path` is already open (a file whose experiments name itself, or a → b → a).
class TaskFileGuard {
 public:
  explicit TaskFileGuard(const std::string& path) {
    std::error_code ec;
    std::string canonical = std::filesystem::weakly_canonical(path, ec).string();
    if (ec) canonical = path;
    const auto it = std::find_if(t_open_task_files.begin(), t_open_task_files.end(),
                                 [&](const OpenTaskFile& f) { return f.canonical == canonical; });
    if (it != t_open_task_files.end()) {
      std::string chain;
      for (auto f = it; f != t_open_task_files.end(); ++f) chain += f->given + " -> ";
      throw TopoError(it->given, "refers to itself through its experiments' files (" + chain + path + ")",
                      "an experiment's `file:` must hold one experiment (`task:` and its parameters), not an "
                      "`experiments:` list; list every experiment of the object in one `experiments:` list");
    }
    t_open_task_files.push_back({path, canonical});
  }
  ~TaskFileGuard() { t_open_task_files.pop_back(); }
  TaskFileGuard(const TaskFileGuard&) = delete;
  TaskFileGuard& operator=(const TaskFileGuard&) = delete;
};

}  // namespace

TaskConfig TaskConfig::fromYamlFile(const std::string& path) {
  const TaskFileGuard open(path);
  const YAML::Node root = loadYaml(path);
  if (root.IsMap() && root["experiments"]) {
    // Several experiments of one object: shared parameters at the top, one map per experiment.
    if (root["task"])
      throw TopoError(path, "has both `task:` and `experiments:`",
                      "give each experiment its own `task:` inside the `experiments:` list");
    if (root["targets"]) throw TopoError(path, "has `targets:` at the top", "give each experiment its own `targets:`");
    TaskConfig top = common();
    top.source_ = path;
    refuseDuplicateKeys(root, path);
    for (const auto& kv : root) {
      const std::string key = kv.first.IsScalar() ? kv.first.Scalar() : std::string();
      if (key == "experiments" || key == "description") continue;
      if (!isShared(key))
        throw TopoError(path + " " + key,
                        "is not a parameter shared by the experiments (only the representation, materials, "
                        "regularisers, optimiser and gravity are)",
                        "move " + key + " into the experiment(s) it belongs to");
      top.set(key, nodeText(kv.second, path + " " + key), path);
    }
    const YAML::Node list = root["experiments"];
    if (!list.IsSequence() || list.size() == 0)
      throw TopoError(path + " experiments", "is not a non-empty list",
                      "write `experiments:` followed by `- name: ...` items, each with a task or a file");
    const std::filesystem::path dir = std::filesystem::path(path).parent_path();
    for (std::size_t i = 0; i < list.size(); ++i) {
      const YAML::Node item = list[i];
      std::string where = path + " experiments[" + std::to_string(i) + "]";
      if (!item.IsMap())
        throw TopoError(where, "is not a map", "write `- name: NAME` then `task: TASK` (or `file: FILE.yaml`)");
      const std::string name =
          item["name"] ? nodeText(item["name"], where + " name") : "experiment" + std::to_string(i + 1);
      where += " (" + name + ")";
      double weight = 1.0;
      if (item["weight"]) {
        const std::string w = nodeText(item["weight"], where + " weight");
        char* end = nullptr;
        weight = std::strtod(w.c_str(), &end);
        if (end == w.c_str() || *end != '\0')
          throw TopoError(where + " weight", "'" + w + "' is not a number", "give a weight > 0 (default 1)");
      }
      TaskConfig exp;
      if (item["file"]) {
        if (item["task"]) throw TopoError(where, "has both `file:` and `task:`", "give one: the file holds the task");
        std::filesystem::path f = nodeText(item["file"], where + " file");
        if (f.is_relative()) f = dir / f;
        exp = fromYamlFile(f.string());
        if (exp.hasExperiments())
          throw TopoError(f.string(), "holds experiments itself", "list every experiment in one `experiments:` list");
        applyYamlMap(exp, item, where, path, {"name", "weight", "file", "description"});
      } else {
        exp = taskFromYamlMap(item, where, path, {"name", "weight"});
      }
      top.addExperiment(name, weight, exp);
    }
    return top;
  }
  TaskConfig c = taskFromYamlMap(root, path, path, {});
  c.source_ = path;
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

namespace {

/// "dir/rock_x.yaml" → "rock_x"; a task name stays.
std::string experimentStem(const std::string& path) {
  std::string stem = std::filesystem::path(path).filename().string();
  if (stem.size() > 5 && stem.substr(stem.size() - 5) == ".yaml") stem.resize(stem.size() - 5);
  return stem;
}

}  // namespace

std::pair<std::string, std::string> TaskConfig::splitNamedValue(const std::string& s) {
  const auto eq = s.find('=');
  if (eq == std::string::npos || s.find('/') < eq) return {"", s};
  return {s.substr(0, eq), s.substr(eq + 1)};
}

TaskConfig TaskConfig::loadWithExperiments(const std::string& task, const std::vector<std::string>& experiments,
                                           const std::string& task_dir, const std::vector<std::string>& assignments) {
  if (task.empty() && experiments.empty())
    throw TopoError("task", "is empty and no experiment is given",
                    "name a task (" + joinNames(taskNames()) + "), a task YAML file or experiments");
  std::vector<std::string> shared;  // the user's shared values, "KEY=VALUE"
  for (const auto& a : assignments) {
    const auto eq = a.find('=');
    if (eq != std::string::npos && isShared(trim(a.substr(0, eq)))) shared.push_back(a);
  }
  const auto loadOne = [&](const std::string& file) {
    TaskConfig one = load(file, task_dir);
    if (!experiments.empty() && !one.hasExperiments())
      for (const auto& a : shared) one.setAssignment(a, "shared value");
    return one;
  };
  std::size_t next = 0;
  TaskConfig c = loadOne(task.empty() ? TaskConfig::splitNamedValue(experiments[0]).second : task);
  if (experiments.empty()) return c;
  if (!c.hasExperiments()) {  // the task (or the first experiment) becomes the first experiment
    const auto [name, file] =
        task.empty() ? TaskConfig::splitNamedValue(experiments[0]) : std::make_pair(std::string(), task);
    TaskConfig top = common();
    top.addExperiment(name.empty() ? experimentStem(file) : name, 1.0, c);
    c = std::move(top);
    if (task.empty()) next = 1;
  }
  for (std::size_t i = next; i < experiments.size(); ++i) {
    const auto [name, file] = TaskConfig::splitNamedValue(experiments[i]);
    c.addExperiment(name.empty() ? experimentStem(file) : name, 1.0, loadOne(file));
  }
  return c;
}

}  // namespace topo_gaussian::inference
