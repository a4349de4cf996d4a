// ParamReader's checks (ros/param_reader.h) through their XmlRpcValue seam, without a ROS master:
// a good value, a wrong type, a value out of range, ints where numbers are expected, lists given as
// one string. (Absent → default is ParamReader's `hasParam` branch, exercised by every node's
// rostest with its defaults.) Then param_doc, the descriptions every read appends to the file named
// by TOPO_DESCRIBE_PARAMS (docs/nodes.md is rendered from them by test/ros/node_interfaces.test).
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/ros/param_reader.h"

using namespace topo_gaussian;
using namespace topo_gaussian::topo_ros;
using XmlRpc::XmlRpcValue;

namespace {

const std::string kName = "~replay_rate_hz (/rig/replay_rate_hz)";

template <typename F>
std::string errorOf(F&& f) {
  try {
    f();
  } catch (const TopoError& e) {
    return e.what();
  }
  return "(no error)";
}

XmlRpcValue list(std::initializer_list<double> v) {
  XmlRpcValue a;
  a.setSize(static_cast<int>(v.size()));
  int i = 0;
  for (double x : v) a[i++] = x;
  return a;
}

}  // namespace

TEST(ParamReader, NumberGoodValueAndIntAccepted) {
  EXPECT_EQ(param_check::number(XmlRpcValue(30.5), kName, "Hz", Range::above(0), "30"), 30.5);
  EXPECT_EQ(param_check::number(XmlRpcValue(30), kName, "Hz", Range::above(0), "30"), 30.0);
}

TEST(ParamReader, NumberWrongTypeNamesParameterTypesAndExample) {
  const std::string e = errorOf([] { param_check::number(XmlRpcValue("fast"), kName, "Hz", Range::above(0), "30"); });
  EXPECT_NE(e.find(kName), std::string::npos) << e;
  EXPECT_NE(e.find("a string (\"fast\")"), std::string::npos) << e;
  EXPECT_NE(e.find("not a number [Hz]"), std::string::npos) << e;
  EXPECT_NE(e.find("_replay_rate_hz:=30"), std::string::npos) << e;
  EXPECT_NE(errorOf([] { param_check::number(XmlRpcValue(true), kName, "", Range(), "1"); }).find("a boolean"),
            std::string::npos);
}

TEST(ParamReader, NumberOutOfRangeGivesRangeAndUnit) {
  const std::string e = errorOf([] { param_check::number(XmlRpcValue(0.0), kName, "Hz", Range::above(0), "30"); });
  EXPECT_NE(e.find("is 0 Hz, outside (0, inf) Hz"), std::string::npos) << e;
  const std::string h =
      errorOf([] { param_check::number(XmlRpcValue(5000.0), kName, "s", Range::between(0, 3600), "20"); });
  EXPECT_NE(h.find("outside [0, 3600] s"), std::string::npos) << h;
  const Range open{0, 1, true, true};
  EXPECT_TRUE(open.contains(0.5));
  EXPECT_FALSE(open.contains(1.0));
  EXPECT_EQ(open.text(""), "(0, 1)");
}

TEST(ParamReader, IntegerRefusesFractionsAndStrings) {
  EXPECT_EQ(param_check::integer(XmlRpcValue(5), kName, "", Range::atLeast(1), "1"), 5);
  EXPECT_EQ(param_check::integer(XmlRpcValue(5e4), kName, "", Range::atLeast(1), "1"), 50000);  // YAML's 5e4
  EXPECT_NE(errorOf([] { param_check::integer(XmlRpcValue(2.5), kName, "", Range(), "1"); }).find("not a whole number"),
            std::string::npos);
  EXPECT_NE(errorOf([] { param_check::integer(XmlRpcValue("2"), kName, "", Range(), "1"); }).find("a string"),
            std::string::npos);
  EXPECT_NE(
      errorOf([] { param_check::integer(XmlRpcValue(0), kName, "", Range::atLeast(1), "1"); }).find("outside [1, inf)"),
      std::string::npos);
}

TEST(ParamReader, FlagTextAndChoices) {
  EXPECT_TRUE(param_check::flag(XmlRpcValue(true), kName));
  EXPECT_NE(errorOf([] { param_check::flag(XmlRpcValue(1), kName); }).find("not true or false"), std::string::npos);
  EXPECT_EQ(param_check::text(XmlRpcValue("klt"), kName, {"marker", "klt"}, "marker"), "klt");
  const std::string e = errorOf([] { param_check::text(XmlRpcValue("blob"), kName, {"marker", "klt"}, "marker"); });
  EXPECT_NE(e.find("marker | klt"), std::string::npos) << e;
  EXPECT_NE(errorOf([] { param_check::text(XmlRpcValue(3), kName, {}, "x"); }).find("an integer, not a string"),
            std::string::npos);
}

TEST(ParamReader, NumberListsFromListsOrOneString) {
  EXPECT_EQ(param_check::numbers(list({1, 2, 3}), kName, 3, "", "[1, 2, 3]"), (std::vector<double>{1, 2, 3}));
  XmlRpcValue mixed;
  mixed[0] = 1;
  mixed[1] = 2.5;
  EXPECT_EQ(param_check::numbers(mixed, kName, 2, "px", "[1, 2]"), (std::vector<double>{1, 2.5}));
  EXPECT_EQ(param_check::numbers(XmlRpcValue("[4, 5.5]"), kName, 2, "", "[1, 2]"), (std::vector<double>{4, 5.5}));
  EXPECT_NE(errorOf([&] {
              param_check::numbers(list({1, 2}), kName, 3, "", "[1, 2, 3]");
            }).find("has 2 entries, not 3"),
            std::string::npos);
  EXPECT_NE(errorOf([] { param_check::numbers(XmlRpcValue("one, two"), kName, 0, "", "[1]"); }).find("a string"),
            std::string::npos);
  XmlRpcValue bad;
  bad[0] = 1;
  bad[1] = "x";
  EXPECT_NE(errorOf([&] { param_check::numbers(bad, kName, 0, "", "[1]"); }).find("entry 1 is a string"),
            std::string::npos);
}

TEST(ParamReader, TextListsFromListsOrOneString) {
  XmlRpcValue l;
  l[0] = "a=1";
  l[1] = "hanging_point=0.01,0.005,0.05";
  EXPECT_EQ(param_check::texts(l, kName, "", ";"), (std::vector<std::string>{"a=1", "hanging_point=0.01,0.005,0.05"}));
  EXPECT_EQ(param_check::texts(XmlRpcValue("a=1; b=0.1,0.2"), kName, "", ";"),
            (std::vector<std::string>{"a=1", "b=0.1,0.2"}));
  EXPECT_EQ(param_check::texts(XmlRpcValue("['a=1', 'b=2']"), kName, "", "; \t"),
            (std::vector<std::string>{"a=1", "b=2"}));
  EXPECT_NE(errorOf([] { param_check::texts(XmlRpcValue(2.0), kName, "", ";"); }).find("not a list of strings"),
            std::string::npos);
}

// The descriptions docs/nodes.md is rendered from (param_doc; written by every ParamReader read when
// TOPO_DESCRIBE_PARAMS names a file, test/ros/node_interfaces.test).
TEST(ParamDoc, DefaultsAsAUserWritesThem) {
  EXPECT_EQ(param_doc::numberDefault(20.0), "20");
  EXPECT_EQ(param_doc::numberDefault(0.02), "0.02");
  EXPECT_EQ(param_doc::numberDefault(5e4), "50000");
  EXPECT_EQ(param_doc::numbersDefault({1, 0, 0}), "[1, 0, 0]");
  EXPECT_EQ(param_doc::numbersDefault({}), "[]");
  EXPECT_EQ(param_doc::textDefault("marker"), "marker");
  EXPECT_EQ(param_doc::textDefault(""), "\"\"");
  EXPECT_EQ(param_doc::textsDefault({"a=1", "b=2"}), "['a=1', 'b=2']");
  EXPECT_EQ(param_doc::textsDefault({}), "[]");
  EXPECT_EQ(param_doc::rangeText(Range()), "");
  EXPECT_EQ(param_doc::rangeText(Range::above(0)), "(0, inf)");
  EXPECT_EQ(param_doc::rangeText(Range::between(0, 3600)), "[0, 3600]");
}

TEST(ParamDoc, JsonLineHoldsEveryField) {
  param_doc::Entry e;
  e.node = "motion_tracker";
  e.ns = "/motion_tracker";
  e.name = "method";
  e.type = "text";
  e.default_value = "marker";
  e.choices = {"marker", "klt"};
  const std::string line = param_doc::jsonLine(e);
  EXPECT_EQ(line.find('\n'), std::string::npos) << line;
  const auto j = nlohmann::json::parse(line);
  EXPECT_EQ(j.at("node"), "motion_tracker");
  EXPECT_EQ(j.at("ns"), "/motion_tracker");
  EXPECT_EQ(j.at("name"), "method");
  EXPECT_EQ(j.at("type"), "text");
  EXPECT_EQ(j.at("default"), "marker");
  EXPECT_EQ(j.at("unit"), "");
  EXPECT_EQ(j.at("range"), "");
  EXPECT_EQ(j.at("choices"), (std::vector<std::string>{"marker", "klt"}));
  EXPECT_EQ(j.at("size"), 0);
  EXPECT_EQ(j.at("example"), "");
}

TEST(ParamDoc, AppendWritesEachDistinctLineOnceFromManyThreads) {
  char dir[] = "/tmp/topo_param_doc_XXXXXX";
  ASSERT_NE(mkdtemp(dir), nullptr);
  const std::string path = std::string(dir) + "/params.jsonl";
  param_doc::Entry window;
  window.node = "motion_tracker";
  window.ns = "/motion_tracker";
  window.name = "window_s";
  window.type = "number";
  window.default_value = "20";
  window.unit = "s";
  window.range = "(0, inf)";
  param_doc::Entry other = window;
  other.name = "publish_period_s";
  std::vector<std::thread> threads;
  for (int t = 0; t < 8; ++t)
    threads.emplace_back([&] {
      for (int k = 0; k < 50; ++k) param_doc::append(path, k % 2 ? window : other);
    });
  for (auto& t : threads) t.join();
  param_doc::Entry changed = window;  // the same parameter with another default: described too
  changed.default_value = "30";
  param_doc::append(path, changed);
  std::ifstream in(path);
  std::vector<std::string> names, defaults;
  for (std::string line; std::getline(in, line);) {
    const auto j = nlohmann::json::parse(line);  // whole lines only
    names.push_back(j.at("name"));
    defaults.push_back(j.at("default"));
  }
  ASSERT_EQ(names.size(), 3u);
  EXPECT_EQ(std::count(names.begin(), names.end(), "window_s"), 2);
  EXPECT_EQ(std::count(names.begin(), names.end(), "publish_period_s"), 1);
  EXPECT_EQ(defaults.back(), "30");
  std::remove(path.c_str());
  rmdir(dir);
}

TEST(ParamDoc, NothingRecordedWithoutTheVariable) {
  if (std::getenv("TOPO_DESCRIBE_PARAMS")) GTEST_SKIP() << "TOPO_DESCRIBE_PARAMS is set in this environment";
  EXPECT_EQ(param_doc::targetFile(), "");
}
