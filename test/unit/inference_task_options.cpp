// Typed task options (inference/task_options.h): one list of fields declares the parameters as
// TaskParameters does and reads them back into a struct: defaults, set values, targets only when
// given; every task reads its own parameters this way.
#include <gtest/gtest.h>

#include <optional>

#include "test_clouds.h"
#include "test_util.h"
#include "topo_gaussian/common/error.h"
#include "topo_gaussian/inference/task.h"
#include "topo_gaussian/inference/task_options.h"

using namespace topo_gaussian;
using namespace topo_gaussian::inference;
using topo_test::errorOf;

namespace {

struct ProbeOptions {
  double length_m = 0;
  int count = 0;
  bool enabled = false;
  Eigen::Vector3d axis = Eigen::Vector3d::Zero();
  std::vector<double> points;
  std::optional<double> observed_s;
  std::optional<std::string> observed_file;
};

constexpr auto kProbeFields = [](auto& f) {
  using O = ProbeOptions;
  f.number("probe_length_m", &O::length_m, 0.25, "m", "a length [m]", 0, 10).paper("0.3");
  f.integer("probe_count", &O::count, 3, "unitless", "a count, unitless", 1, 9);
  f.flag("probe_enabled", &O::enabled, true, "a switch");
  f.vector3("probe_axis", &O::axis, Eigen::Vector3d(0, 1, 0), "unitless", "a direction, unitless");
  f.list("probe_points", &O::points, {}, "m", "points x,y,z,... [m]");
  f.target("probe_observed_s", &O::observed_s, "s", "an observed time [s]", 0, 1e300, true);
  f.target("probe_observed_file", &O::observed_file, "", "an observed file");
};

}  // namespace

TEST(TaskOptions, OneListDeclaresAndReadsTypedFields) {
  TaskConfig c = TaskConfig::defaults("hanging");
  TaskParameters p(c);
  declareOptions<ProbeOptions>(p, kProbeFields);
  // declared as TaskParameters declares them, in the list's order
  const ParamSpec* length = c.spec("probe_length_m");
  ASSERT_NE(length, nullptr);
  EXPECT_EQ(length->type, ParamType::Number);
  EXPECT_EQ(length->unit, "m");
  EXPECT_EQ(length->paper_value, "0.3");
  EXPECT_EQ(c.spec("probe_count")->type, ParamType::Integer);
  EXPECT_EQ(c.spec("probe_enabled")->type, ParamType::Boolean);
  EXPECT_EQ(c.spec("probe_axis")->type, ParamType::Vector3);
  EXPECT_EQ(c.spec("probe_points")->type, ParamType::List);
  EXPECT_TRUE(c.spec("probe_observed_s")->is_target);
  EXPECT_EQ(c.spec("probe_observed_file")->type, ParamType::Text);
  EXPECT_TRUE(c.spec("probe_observed_file")->is_target);
  std::vector<std::string> order;
  for (const auto& s : c.specs())
    if (s.name.rfind("probe_", 0) == 0) order.push_back(s.name);
  EXPECT_EQ(order, (std::vector<std::string>{"probe_length_m", "probe_count", "probe_enabled", "probe_axis",
                                             "probe_points", "probe_observed_s", "probe_observed_file"}));
  // the defaults read back; a target only when given
  ProbeOptions o = readOptions<ProbeOptions>(c, kProbeFields);
  EXPECT_DOUBLE_EQ(o.length_m, 0.25);
  EXPECT_EQ(o.count, 3);
  EXPECT_TRUE(o.enabled);
  EXPECT_EQ(o.axis, Eigen::Vector3d(0, 1, 0));
  EXPECT_TRUE(o.points.empty());
  EXPECT_FALSE(o.observed_s.has_value());
  EXPECT_FALSE(o.observed_file.has_value());
  // values set as text (a file, --set, a goal) read back typed; ranges are the declaration's
  c.set("probe_length_m", "1.5", "test");
  c.set("probe_count", "7", "test");
  c.set("probe_enabled", "false", "test");
  c.set("probe_axis", "0,0,1", "test");
  c.set("probe_points", "0,0,0.1,0,0,0.2", "test");
  c.set("probe_observed_s", "0.4", "test");
  c.set("probe_observed_file", "track.csv", "test");
  o = readOptions<ProbeOptions>(c, kProbeFields);
  EXPECT_DOUBLE_EQ(o.length_m, 1.5);
  EXPECT_EQ(o.count, 7);
  EXPECT_FALSE(o.enabled);
  EXPECT_EQ(o.axis, Eigen::Vector3d(0, 0, 1));
  ASSERT_TRUE(o.observed_s.has_value());
  EXPECT_DOUBLE_EQ(*o.observed_s, 0.4);
  EXPECT_EQ(o.points, (std::vector<double>{0, 0, 0.1, 0, 0, 0.2}));
  EXPECT_EQ(o.observed_file, std::optional<std::string>("track.csv"));
  EXPECT_THROW(c.set("probe_count", "12", "test"), TopoError);
}

namespace {

struct ProbeExtraOptions {
  std::string mode;
  std::optional<Eigen::Vector3d> point;
  std::optional<std::vector<double>> observed;
};

constexpr auto kProbeExtraFields = [](auto& f) {
  using O = ProbeExtraOptions;
  f.text("probe_mode", &O::mode, "slow", "slow | fast", {"slow", "fast"});
  f.vector3("probe_point", &O::point, "m", "an optional point [m]");
  f.target("probe_observed_deg", &O::observed, "deg", "observed angles, one per pose [deg]", -90, 90);
};

}  // namespace

// Text with choices, an optional point and an observed list: declared as TaskParameters declares them, the
// point and the list read back only when given.
TEST(TaskOptions, TextOptionalPointAndObservedList) {
  TaskConfig c = TaskConfig::defaults("hanging");
  TaskParameters p(c);
  declareOptions<ProbeExtraOptions>(p, kProbeExtraFields);
  EXPECT_EQ(c.spec("probe_mode")->type, ParamType::Text);
  EXPECT_EQ(c.spec("probe_mode")->choices, (std::vector<std::string>{"slow", "fast"}));
  EXPECT_EQ(c.spec("probe_point")->type, ParamType::Vector3);
  EXPECT_FALSE(c.spec("probe_point")->is_target);
  EXPECT_EQ(c.spec("probe_observed_deg")->type, ParamType::List);
  EXPECT_TRUE(c.spec("probe_observed_deg")->is_target);
  ProbeExtraOptions o = readOptions<ProbeExtraOptions>(c, kProbeExtraFields);
  EXPECT_EQ(o.mode, "slow");
  EXPECT_FALSE(o.point.has_value());
  EXPECT_FALSE(o.observed.has_value());
  c.set("probe_mode", "fast", "test");
  c.set("probe_point", "0,0,0.1", "test");
  c.set("probe_observed_deg", "20,0,-45", "test");
  o = readOptions<ProbeExtraOptions>(c, kProbeExtraFields);
  EXPECT_EQ(o.mode, "fast");
  EXPECT_EQ(o.point, std::optional<Eigen::Vector3d>(Eigen::Vector3d(0, 0, 0.1)));
  EXPECT_EQ(o.observed, std::optional<std::vector<double>>(std::vector<double>{20, 0, -45}));
  EXPECT_THROW(c.set("probe_mode", "medium", "test"), TopoError);
  EXPECT_THROW(c.set("probe_observed_deg", "0,100", "test"), TopoError);
}

// The tumbler reads its own parameters as TumblerOptions: its targets are used only when given, and the
// two equilibrium targets exclude each other.
TEST(TaskOptions, TumblerTakesItsTargetsFromItsTypedOptions) {
  const VolumeCloud cloud = topo_test::tumblerCloud(0.05, 0.5, 0.01);
  TaskConfig c = TaskConfig::defaults("tumbler");
  EXPECT_NO_THROW(makeTask(c, cloud));
  EXPECT_THROW(makeTask(c, cloud)->requireTargets(), TopoError);  // none given
  c.set("period_s", "0.3", "test");
  EXPECT_NO_THROW(makeTask(c, cloud)->requireTargets());
  c.set("equilibrium_tilt_deg", "2", "test");
  EXPECT_NO_THROW(makeTask(c, cloud));
  c.set("equilibrium_from_release_deg", "2", "test");
  const std::string e = errorOf([&] { makeTask(c, cloud); });
  EXPECT_NE(e.find("give both equilibrium_tilt_deg and equilibrium_from_release_deg"), std::string::npos) << e;
}
