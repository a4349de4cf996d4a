// Motion features as a library type: TrackResult → motion::MotionFeatures (vision::toMotionFeatures)
// and the JSON document of io/motion_features_json.h (write → read gives the same features; null or
// absent features read as not measured; bad documents are refused naming the file and the key).
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <string>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/io/motion_features_json.h"
#include "topo_gaussian/vision/motion_features.h"

using namespace topo_gaussian;

namespace {

motion::MotionFeatures sample() {
  motion::MotionFeatures f;
  f.kind = "pendulum";
  f.method = "marker";
  f.source = "/data/clip \"one\".mp4";
  f.message = "period 1.2 s\nover 4 cycles";
  f.oscillation_found = true;
  f.period_s = 1.2000123456789;
  f.amplitude_deg = 14.94;
  f.max_tilt_deg = 20.1;
  f.equilibrium_deg = -4.95;
  f.log_decrement = 0.188;
  f.damping_ratio = 0.0299;
  f.bending_angle_deg = 0.0;
  f.period_confidence = 0.93;
  f.amplitude_confidence = 0.93;
  f.equilibrium_confidence = 0.9;
  f.bending_confidence = 0.0;
  f.start_time_s = 0.5;
  f.end_time_s = 4.0;
  f.first_frame = 15;
  f.last_frame = 120;
  f.frames_used = 104;
  f.frames_lost = 2;
  for (int i = 0; i < 50; ++i) {
    f.time_s.push_back(0.5 + i / 30.0);
    f.angle_deg.push_back(15.0 * std::sin(i * 0.17) - 4.95);
  }
  motion::PixelTrajectory t;
  t.name = "point_0";
  for (int i = 0; i < 5; ++i) {
    t.time_s.push_back(i / 30.0);
    t.x_px.push_back(320.0 + i);
    t.y_px.push_back(360.25 - i);
    t.points_on_plane.push_back({0.01 * i, -0.2, 2.0});
  }
  f.trajectories.push_back(t);
  return f;
}

std::string writeFile(const std::string& name, const std::string& text) {
  const std::string path = testing::TempDir() + "/" + name;
  std::ofstream(path) << text;
  return path;
}

std::string errorOf(const std::string& path) {
  try {
    io::readMotionFeaturesJson(path);
  } catch (const TopoError& e) {
    return e.what();
  }
  return "(no error)";
}

}  // namespace

TEST(MotionFeaturesJson, RoundTripIsExact) {
  const motion::MotionFeatures f = sample();
  const std::string path = writeFile("features_round_trip.json", io::motionFeaturesJson(f, true));
  const motion::MotionFeatures g = io::readMotionFeaturesJson(path);
  EXPECT_EQ(g.kind, f.kind);
  EXPECT_EQ(g.method, f.method);
  EXPECT_EQ(g.source, f.source);
  EXPECT_EQ(g.message, f.message);
  EXPECT_EQ(g.oscillation_found, f.oscillation_found);
  EXPECT_EQ(g.period_s, f.period_s);
  EXPECT_EQ(g.amplitude_deg, f.amplitude_deg);
  EXPECT_EQ(g.max_tilt_deg, f.max_tilt_deg);
  EXPECT_EQ(g.equilibrium_deg, f.equilibrium_deg);
  EXPECT_EQ(g.log_decrement, f.log_decrement);
  EXPECT_EQ(g.damping_ratio, f.damping_ratio);
  EXPECT_EQ(g.bending_angle_deg, f.bending_angle_deg);
  EXPECT_EQ(g.period_confidence, f.period_confidence);
  EXPECT_EQ(g.amplitude_confidence, f.amplitude_confidence);
  EXPECT_EQ(g.equilibrium_confidence, f.equilibrium_confidence);
  EXPECT_EQ(g.bending_confidence, f.bending_confidence);
  EXPECT_EQ(g.start_time_s, f.start_time_s);
  EXPECT_EQ(g.end_time_s, f.end_time_s);
  EXPECT_EQ(g.first_frame, f.first_frame);
  EXPECT_EQ(g.last_frame, f.last_frame);
  EXPECT_EQ(g.frames_used, f.frames_used);
  EXPECT_EQ(g.frames_lost, f.frames_lost);
  EXPECT_EQ(g.time_s, f.time_s);
  EXPECT_EQ(g.angle_deg, f.angle_deg);
  ASSERT_EQ(g.trajectories.size(), 1u);
  EXPECT_EQ(g.trajectories[0].name, f.trajectories[0].name);
  EXPECT_EQ(g.trajectories[0].time_s, f.trajectories[0].time_s);
  EXPECT_EQ(g.trajectories[0].x_px, f.trajectories[0].x_px);
  EXPECT_EQ(g.trajectories[0].y_px, f.trajectories[0].y_px);
  EXPECT_EQ(g.trajectories[0].points_on_plane, f.trajectories[0].points_on_plane);
  // Without the series the features stay, the series go (the plane points stay: they are a result).
  const motion::MotionFeatures h = io::parseMotionFeaturesJson(io::motionFeaturesJson(f, false), "no series");
  EXPECT_EQ(h.period_s, f.period_s);
  EXPECT_TRUE(h.time_s.empty());
  ASSERT_EQ(h.trajectories.size(), 1u);
  EXPECT_EQ(h.trajectories[0].points_on_plane.size(), 5u);
}

TEST(MotionFeaturesJson, NullOrAbsentIsNotMeasured) {
  motion::MotionFeatures f = sample();
  f.period_s = std::numeric_limits<double>::quiet_NaN();
  f.trajectories[0].points_on_plane[1][0] = std::numeric_limits<double>::quiet_NaN();  // ray missed the plane
  const motion::MotionFeatures g = io::parseMotionFeaturesJson(io::motionFeaturesJson(f, true), "nan period");
  EXPECT_FALSE(g.oscillation_found);
  EXPECT_EQ(g.period_s, 0.0);
  EXPECT_EQ(g.period_confidence, 0.0);
  EXPECT_EQ(g.amplitude_deg, f.amplitude_deg);
  EXPECT_TRUE(std::isnan(g.trajectories[0].points_on_plane[1][0]));

  const motion::MotionFeatures m = io::parseMotionFeaturesJson(
      R"({"kind": "finger", "features": {"bending_angle_deg": 38.5}, "confidence": {"bending_angle_deg": 0.8}})",
      "minimal");
  EXPECT_EQ(m.kind, "finger");
  EXPECT_EQ(m.bending_angle_deg, 38.5);
  EXPECT_EQ(m.bending_confidence, 0.8);
  EXPECT_FALSE(m.oscillation_found);
  EXPECT_EQ(m.period_confidence, 0.0);
  EXPECT_EQ(m.equilibrium_confidence, 0.0);
  EXPECT_EQ(m.last_frame, -1);
}

TEST(MotionFeaturesJson, BadDocumentsNameTheFileAndTheKey) {
  const std::string unknown = writeFile("features_unknown.json", R"({"kind": "wobble"})");
  std::string e = errorOf(unknown);
  EXPECT_NE(e.find(unknown), std::string::npos) << e;
  EXPECT_NE(e.find("'kind'"), std::string::npos) << e;
  EXPECT_NE(e.find("pendulum, tilt, trajectory or finger"), std::string::npos) << e;

  const std::string wrong = writeFile("features_wrong.json", R"({"kind": "tilt", "features": {"period_s": "1.2"}})");
  e = errorOf(wrong);
  EXPECT_NE(e.find(wrong), std::string::npos) << e;
  EXPECT_NE(e.find("'features.period_s' is a string, expected a number"), std::string::npos) << e;
  EXPECT_NE(e.find("Fix:"), std::string::npos) << e;

  e = errorOf(writeFile("features_conf.json", R"({"kind": "tilt", "confidence": {"period_s": 3}})"));
  EXPECT_NE(e.find("'confidence.period_s'"), std::string::npos) << e;
  e = errorOf(writeFile("features_nokind.json", R"({"features": {}})"));
  EXPECT_NE(e.find("'kind' is missing"), std::string::npos) << e;
  e = errorOf(writeFile("features_text.json", "period 1.2 s"));
  EXPECT_NE(e.find("not valid JSON"), std::string::npos) << e;
  e = errorOf(writeFile("features_series.json", R"({"kind": "tilt", "series": {"time_s": [0, 1], "angle_deg": [2]}})"));
  EXPECT_NE(e.find("series.angle_deg"), std::string::npos) << e;
  e = errorOf("/nonexistent/features.json");
  EXPECT_NE(e.find("/nonexistent/features.json"), std::string::npos) << e;
}

TEST(MotionFeaturesJson, TrackResultMapping) {
  vision::TrackResult r;
  r.kind = "tilt";
  r.method = "silhouette";
  r.source = "clip.mp4";
  r.signal.oscillation_found = false;
  r.static_pose.angle_deg = 7.5;
  r.confidence = {{"period_s", 0.0}, {"amplitude_deg", 0.0}, {"static_angle_deg", 0.85}, {"tracking", 1.0}};
  r.t = {0.0, 0.1};
  r.angle_deg = {7.4, 7.6};
  r.lost_frames = 3;
  r.trajectories = {{{0.0, 10.0, 20.0}, {0.1, 11.0, 21.0}}};
  r.points_on_plane = {{cv::Vec3d(1, 2, 3), cv::Vec3d(4, 5, 6)}};
  const motion::MotionFeatures f = vision::toMotionFeatures(r);
  EXPECT_EQ(f.equilibrium_deg, 7.5);  // the static pose when nothing swings
  EXPECT_EQ(f.equilibrium_confidence, 0.85);
  EXPECT_EQ(f.period_confidence, 0.0);
  EXPECT_EQ(f.frames_lost, 3);
  EXPECT_EQ(f.angle_deg, r.angle_deg);
  ASSERT_EQ(f.trajectories.size(), 1u);
  EXPECT_EQ(f.trajectories[0].name, "point_0");
  EXPECT_EQ(f.trajectories[0].y_px, (std::vector<double>{20.0, 21.0}));
  EXPECT_EQ(f.trajectories[0].points_on_plane[1], (std::array<double, 3>{4, 5, 6}));

  r.kind = "finger";
  r.bend_held_deg = 40.25;  // the bend at the full pressure is the feature
  r.bend_final_deg = 39.0;
  r.confidence = {{"bend_deg", 0.7}};
  const motion::MotionFeatures b = vision::toMotionFeatures(r);
  EXPECT_EQ(b.bending_angle_deg, 40.25);
  EXPECT_EQ(b.bending_confidence, 0.7);
}

TEST(MotionFeaturesJson, SideDataRoundTripsAndABadValueIsNamed) {
  motion::MotionFeatures f;
  f.kind = "finger";
  f.side_data["pressure_pa"] = 333300.0;
  f.side_data["gripper/state"] = std::nan("");  // a tag without a sample in force: null
  const std::string text = io::motionFeaturesJson(f, false);
  EXPECT_NE(text.find("\"side_data\":{\"gripper/state\":null,\"pressure_pa\":333300"), std::string::npos) << text;
  const motion::MotionFeatures back = io::parseMotionFeaturesJson(text, "tagged window");
  ASSERT_EQ(back.side_data.size(), 2u);
  EXPECT_EQ(back.side_data.at("pressure_pa"), 333300.0);
  EXPECT_TRUE(std::isnan(back.side_data.at("gripper/state")));
  // an untagged window writes no side_data at all
  f.side_data.clear();
  EXPECT_EQ(io::motionFeaturesJson(f, false).find("side_data"), std::string::npos);

  std::string e = errorOf(writeFile("features_side.json", R"({"kind": "finger", "side_data": {"pressure_pa": "5 bar"}})"));
  EXPECT_NE(e.find("'side_data.pressure_pa' is a string, expected a number"), std::string::npos) << e;
  e = errorOf(writeFile("features_side_list.json", R"({"kind": "finger", "side_data": [3e5]})"));
  EXPECT_NE(e.find("'side_data' is an array, expected an object of numbers"), std::string::npos) << e;
}
