// motion::MotionFeatures <-> its JSON document (io/motion_features_json.h), through nlohmann::json.
#include "topo_gaussian/io/motion_features_json.h"

#include <array>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/io/text_file.h"

namespace topo_gaussian::io {

namespace {

using nlohmann::json;

constexpr const char* kFormat = "topo_gaussian.motion_features";
constexpr int kVersion = 1;
constexpr double kNotMeasured = std::numeric_limits<double>::quiet_NaN();

/// NaN and ±Inf become null (nlohmann writes them as null anyway; explicit for the reader's sake).
json number(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

json numbers(const std::vector<double>& v) {
  json a = json::array();
  for (double x : v) a.push_back(number(x));
  return a;
}

const char* typeName(const json& v) {
  if (v.is_number_integer()) return "an integer";
  if (v.is_number_float()) return "a floating-point number";
  if (v.is_string()) return "a string";
  if (v.is_boolean()) return "a boolean";
  if (v.is_array()) return "an array";
  if (v.is_object()) return "an object";
  return "null";
}

/// Reads keys of one object, naming the file and the dotted key in every error.
class Reader {
 public:
  Reader(const std::string& origin, const json& object, const std::string& prefix)
      : origin_(origin), o_(object), prefix_(prefix) {}

  const json* find(const std::string& key) const {
    const auto it = o_.find(key);
    return it == o_.end() || it->is_null() ? nullptr : &*it;
  }
  std::string name(const std::string& key) const { return prefix_ + key; }

  [[noreturn]] void wrongType(const std::string& key, const json& v, const std::string& expected,
                              const std::string& example) const {
    throw TopoError(origin_, "key '" + name(key) + "' is " + typeName(v) + ", expected " + expected,
                    "write e.g. \"" + key + "\": " + example +
                        " (or null / leave it out when not measured), or "
                        "write the file again with `topo track --json`");
  }

  /// NaN when absent or null.
  double number(const std::string& key) const {
    const json* v = find(key);
    if (!v) return kNotMeasured;
    if (!v->is_number()) wrongType(key, *v, "a number", "1.25");
    return v->get<double>();
  }
  int integer(const std::string& key, int fallback) const {
    const json* v = find(key);
    if (!v) return fallback;
    if (!v->is_number_integer()) wrongType(key, *v, "an integer", "42");
    return v->get<int>();
  }
  bool flag(const std::string& key) const {
    const json* v = find(key);
    if (!v) return false;
    if (!v->is_boolean()) wrongType(key, *v, "true or false", "true");
    return v->get<bool>();
  }
  std::string text(const std::string& key) const {
    const json* v = find(key);
    if (!v) return {};
    if (!v->is_string()) wrongType(key, *v, "a string", "\"pendulum\"");
    return v->get<std::string>();
  }
  std::vector<double> series(const std::string& key) const {
    std::vector<double> out;
    const json* v = find(key);
    if (!v) return out;
    if (!v->is_array()) wrongType(key, *v, "an array of numbers", "[0.0, 0.033]");
    for (std::size_t i = 0; i < v->size(); ++i) {
      const json& x = (*v)[i];
      if (x.is_null())
        out.push_back(kNotMeasured);
      else if (x.is_number())
        out.push_back(x.get<double>());
      else
        wrongType(key + "[" + std::to_string(i) + "]", x, "a number", "0.5");
    }
    return out;
  }
  /// The sub-object, or an empty one when absent.
  Reader object(const std::string& key) const {
    static const json empty = json::object();
    const json* v = find(key);
    if (!v) return Reader(origin_, empty, prefix_ + key + ".");
    if (!v->is_object()) wrongType(key, *v, "an object", "{...}");
    return Reader(origin_, *v, prefix_ + key + ".");
  }
  const std::string& origin() const { return origin_; }

 private:
  const std::string& origin_;
  const json& o_;
  std::string prefix_;
};

/// A measured value and its confidence; NaN (null/absent) → not measured: 0 and confidence 0.
void measured(double value, double confidence, const Reader& conf, const std::string& key, double& out_value,
              double& out_confidence) {
  if (std::isfinite(confidence) && (confidence < 0.0 || confidence > 1.0))
    throw TopoError(conf.origin(), "key '" + conf.name(key) + "' is " + std::to_string(confidence) + ", outside 0..1",
                    "a confidence is between 0 (not measured) and 1");
  if (!std::isfinite(value)) {
    out_value = 0.0;
    out_confidence = 0.0;
    return;
  }
  out_value = value;
  out_confidence = std::isfinite(confidence) ? confidence : 0.0;
}

double orZero(double v) { return std::isfinite(v) ? v : 0.0; }

}  // namespace

std::string motionFeaturesJson(const motion::MotionFeatures& f, bool with_series) {
  json doc;
  doc["format"] = kFormat;
  doc["version"] = kVersion;
  doc["kind"] = f.kind;
  doc["method"] = f.method;
  doc["source"] = f.source;
  doc["message"] = f.message;
  if (!f.experiment.empty()) doc["experiment"] = f.experiment;
  if (!f.side_data.empty()) {
    json side = json::object();
    for (const auto& [name, value] : f.side_data) side[name] = number(value);
    doc["side_data"] = side;
  }
  doc["features"] = {{"oscillation_found", f.oscillation_found},
                     {"period_s", number(f.period_s)},
                     {"amplitude_deg", number(f.amplitude_deg)},
                     {"max_tilt_deg", number(f.max_tilt_deg)},
                     {"equilibrium_deg", number(f.equilibrium_deg)},
                     {"log_decrement", number(f.log_decrement)},
                     {"damping_ratio", number(f.damping_ratio)},
                     {"bending_angle_deg", number(f.bending_angle_deg)},
                     {"bend_profile_deg", f.bend_profile_deg.empty() ? json(nullptr) : numbers(f.bend_profile_deg)},
                     {"profile_segments", f.profile_segments}};
  doc["confidence"] = {{"period_s", number(f.period_confidence)},
                       {"amplitude_deg", number(f.amplitude_confidence)},
                       {"equilibrium_deg", number(f.equilibrium_confidence)},
                       {"bending_angle_deg", number(f.bending_confidence)},
                       {"bend_profile_deg", number(f.bend_profile_confidence)}};
  doc["range"] = {{"start_time_s", number(f.start_time_s)}, {"end_time_s", number(f.end_time_s)},
                  {"first_frame", f.first_frame},           {"last_frame", f.last_frame},
                  {"frames_used", f.frames_used},           {"frames_lost", f.frames_lost}};
  if (with_series) doc["series"] = {{"time_s", numbers(f.time_s)}, {"angle_deg", numbers(f.angle_deg)}};
  bool on_plane = false;
  for (const auto& t : f.trajectories) on_plane = on_plane || !t.points_on_plane.empty();
  if (!f.trajectories.empty() && (with_series || on_plane || f.kind == "trajectory")) {
    json trajectories = json::array();
    for (const auto& t : f.trajectories) {
      json points = json::array();
      for (const auto& p : t.points_on_plane) points.push_back({number(p[0]), number(p[1]), number(p[2])});
      trajectories.push_back({{"name", t.name},
                              {"time_s", numbers(t.time_s)},
                              {"x_px", numbers(t.x_px)},
                              {"y_px", numbers(t.y_px)},
                              {"points_on_plane", points}});
    }
    doc["trajectories"] = trajectories;
  }
  return doc.dump();
}

motion::MotionFeatures parseMotionFeaturesJson(const std::string& text, const std::string& origin) {
  json doc;
  try {
    doc = json::parse(text);
  } catch (const json::parse_error& e) {
    throw TopoError(origin, std::string("is not valid JSON (") + e.what() + ")",
                    "give the file that `topo track --video VIDEO --json > FILE` wrote");
  }
  if (!doc.is_object())
    throw TopoError(origin, std::string("holds ") + typeName(doc) + ", not a motion-features object",
                    "give the file that `topo track --video VIDEO --json > FILE` wrote");
  const Reader root(origin, doc, "");
  const std::string format = root.text("format");
  if (!format.empty() && format != kFormat)
    throw TopoError(origin, "key 'format' is \"" + format + "\", not \"" + kFormat + "\"",
                    "give a motion-features file (`topo track --json`), not another JSON document");
  const int version = root.integer("version", kVersion);
  if (version > kVersion)
    throw TopoError(
        origin,
        "key 'version' is " + std::to_string(version) + ", newer than this reader (" + std::to_string(kVersion) + ")",
        "read it with the topo_gaussian that wrote it, or write it again with this `topo track`");

  motion::MotionFeatures f;
  f.kind = root.text("kind");
  if (f.kind.empty())
    throw TopoError(origin, "key 'kind' is missing", "add \"kind\": \"pendulum\" (or tilt, trajectory, finger)");
  if (f.kind != "pendulum" && f.kind != "tilt" && f.kind != "trajectory" && f.kind != "finger")
    throw TopoError(origin, "key 'kind' is \"" + f.kind + "\", which is not a kind of motion features",
                    "use pendulum, tilt, trajectory or finger");
  f.method = root.text("method");
  f.source = root.text("source");
  f.message = root.text("message");
  f.experiment = root.text("experiment");
  if (const json* side = root.find("side_data")) {
    if (!side->is_object()) root.wrongType("side_data", *side, "an object of numbers", "{\"pressure_pa\": 3.3e5}");
    const Reader values(origin, *side, "side_data.");
    for (const auto& item : side->items()) f.side_data[item.key()] = values.number(item.key());
  }

  const Reader feat = root.object("features");
  const Reader conf = root.object("confidence");
  f.oscillation_found = feat.flag("oscillation_found");
  const double period_s = feat.number("period_s");
  measured(period_s, conf.number("period_s"), conf, "period_s", f.period_s, f.period_confidence);
  measured(feat.number("amplitude_deg"), conf.number("amplitude_deg"), conf, "amplitude_deg", f.amplitude_deg,
           f.amplitude_confidence);
  measured(feat.number("equilibrium_deg"), conf.number("equilibrium_deg"), conf, "equilibrium_deg", f.equilibrium_deg,
           f.equilibrium_confidence);
  measured(feat.number("bending_angle_deg"), conf.number("bending_angle_deg"), conf, "bending_angle_deg",
           f.bending_angle_deg, f.bending_confidence);
  if (!std::isfinite(period_s)) f.oscillation_found = false;  // a period that was not measured is no oscillation
  // the bend profile: a list, null or absent when not measured; any null angle leaves it unmeasured
  f.bend_profile_deg = feat.series("bend_profile_deg");
  f.profile_segments = feat.integer("profile_segments", static_cast<int>(f.bend_profile_deg.size()));
  if (!f.bend_profile_deg.empty() && f.profile_segments != static_cast<int>(f.bend_profile_deg.size()))
    throw TopoError(origin,
                    "'features.bend_profile_deg' has " + std::to_string(f.bend_profile_deg.size()) +
                        " angles but 'features.profile_segments' is " + std::to_string(f.profile_segments),
                    "give one chord angle per segment, or write the file again with `topo track --json`");
  bool profile_known = !f.bend_profile_deg.empty();
  for (double v : f.bend_profile_deg) profile_known = profile_known && std::isfinite(v);
  double profile_flag = 0.0;  // measured() takes one number: the profile's being known stands for it
  measured(profile_known ? 0.0 : kNotMeasured, conf.number("bend_profile_deg"), conf, "bend_profile_deg", profile_flag,
           f.bend_profile_confidence);
  if (!profile_known) f.bend_profile_deg.clear();
  f.max_tilt_deg = orZero(feat.number("max_tilt_deg"));
  f.log_decrement = orZero(feat.number("log_decrement"));
  f.damping_ratio = orZero(feat.number("damping_ratio"));

  const Reader range = root.object("range");
  f.start_time_s = orZero(range.number("start_time_s"));
  f.end_time_s = orZero(range.number("end_time_s"));
  f.first_frame = range.integer("first_frame", 0);
  f.last_frame = range.integer("last_frame", -1);
  f.frames_used = range.integer("frames_used", 0);
  f.frames_lost = range.integer("frames_lost", 0);

  const Reader series = root.object("series");
  f.time_s = series.series("time_s");
  f.angle_deg = series.series("angle_deg");
  if (f.time_s.size() != f.angle_deg.size())
    throw TopoError(origin,
                    "'series.time_s' has " + std::to_string(f.time_s.size()) + " samples but 'series.angle_deg' " +
                        std::to_string(f.angle_deg.size()),
                    "give one angle per time stamp");

  if (const json* tr = root.find("trajectories")) {
    if (!tr->is_array()) root.wrongType("trajectories", *tr, "an array of objects", "[{\"name\": \"point_0\", ...}]");
    for (std::size_t k = 0; k < tr->size(); ++k) {
      const std::string key = "trajectories[" + std::to_string(k) + "]";
      const json& item = (*tr)[k];
      if (!item.is_object()) root.wrongType(key, item, "an object", "{\"name\": \"point_0\", ...}");
      const Reader t(origin, item, key + ".");
      motion::PixelTrajectory p;
      p.name = t.text("name");
      p.time_s = t.series("time_s");
      p.x_px = t.series("x_px");
      p.y_px = t.series("y_px");
      if (p.x_px.size() != p.time_s.size() || p.y_px.size() != p.time_s.size())
        throw TopoError(origin,
                        "'" + key + "' has " + std::to_string(p.time_s.size()) + " times, " +
                            std::to_string(p.x_px.size()) + " x_px and " + std::to_string(p.y_px.size()) + " y_px",
                        "give one pixel position per time stamp");
      if (const json* pts = t.find("points_on_plane")) {
        if (!pts->is_array()) t.wrongType("points_on_plane", *pts, "an array of [x, y, z]", "[[0.1, 0.0, 2.0]]");
        for (std::size_t j = 0; j < pts->size(); ++j) {
          const json& q = (*pts)[j];
          const std::string qk = "points_on_plane[" + std::to_string(j) + "]";
          if (!q.is_array() || q.size() != 3)
            t.wrongType(qk, q, "an array of three numbers [x, y, z] (m)", "[0.1, 0.0, 2.0]");
          std::array<double, 3> xyz{};
          for (int c = 0; c < 3; ++c) {
            if (q[c].is_null())
              xyz[c] = kNotMeasured;  // the ray missed the plane
            else if (q[c].is_number())
              xyz[c] = q[c].get<double>();
            else
              t.wrongType(qk, q, "an array of three numbers [x, y, z] (m)", "[0.1, 0.0, 2.0]");
          }
          p.points_on_plane.push_back(xyz);
        }
      }
      f.trajectories.push_back(std::move(p));
    }
  }
  return f;
}

motion::MotionFeatures readMotionFeaturesJson(const std::string& path) {
  return parseMotionFeaturesJson(readTextFile(path), path);
}

}  // namespace topo_gaussian::io
