// The interior_inference node's library pieces without a ROS master: the interior cloud layout and
// its colours, the markers of a result, and the replay's pose interpolation. (The targets taken from
// motion features are a library rule: test/unit/inference_motion_targets.cpp.)
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>

#include "test_clouds.h"
#include "test_util.h"
#include "topo_gaussian/inference/body_motion.h"
#include "topo_gaussian/inference/pipeline.h"
#include "topo_gaussian/ros/conversions.h"
#include "topo_gaussian/ros/interior_markers.h"

using namespace topo_gaussian;
using topo_test::errorOf;

namespace {

std::uint32_t rgbAt(const sensor_msgs::PointCloud2& m, std::size_t i) {
  int off = -1;
  for (const auto& f : m.fields)
    if (f.name == "rgb") off = int(f.offset);
  std::uint32_t v = 0;
  std::memcpy(&v, m.data.data() + i * m.point_step + std::size_t(off), 4);
  return v;
}

}  // namespace

TEST(InteriorCloud, LayoutColoursAndRoundTrip) {
  const VolumeCloud cloud = topo_test::boxCloud(0.04, 0.04, 0.04, 0.01);
  std::vector<double> r(cloud.size()), rho(cloud.size()), e;
  for (std::size_t i = 0; i < r.size(); ++i) {
    r[i] = double(i % 5) / 4.0;
    rho[i] = 1 + 999 * r[i];
  }
  const auto msg = topo_ros::toInteriorCloud(cloud, r, rho, e, "object_simulated", ros::Time(3.0));
  EXPECT_EQ(msg.width, cloud.size());
  EXPECT_EQ(msg.header.frame_id, "object_simulated");
  for (const char* f : {"x", "y", "z", "solid", "density", "stiffness", "rgb"})
    EXPECT_TRUE(topo_ros::hasField(msg, f)) << f;
  EXPECT_EQ(rgbAt(msg, 0), topo_ros::kHollowRgb);                                              // r = 0
  EXPECT_EQ(rgbAt(msg, 4), topo_ros::kSolidRgb);                                               // r = 1
  EXPECT_EQ(topo_ros::interiorRgb(0.5), 0x824682u) << std::hex << topo_ros::interiorRgb(0.5);  // midway per channel
  const auto back = topo_ros::fromInteriorCloud(msg, "test");
  ASSERT_EQ(back.r.size(), r.size());
  for (std::size_t i = 0; i < r.size(); ++i) {
    EXPECT_NEAR(back.r[i], r[i], 1e-7);
    EXPECT_NEAR((back.X[i] - cloud.X[i]).norm(), 0.0, 1e-8);
  }
  // wrong sizes and bad values are named
  EXPECT_NE(errorOf([&] { topo_ros::toInteriorCloud(cloud, {0.5}, rho, e, "o", ros::Time()); }).find("1 indicator"),
            std::string::npos);
  auto bad = msg;
  float nan = std::nanf("");
  int off = 0;
  for (const auto& f : bad.fields)
    if (f.name == "solid") off = int(f.offset);
  std::memcpy(bad.data.data() + 2 * bad.point_step + off, &nan, 4);
  EXPECT_NE(errorOf([&] { topo_ros::fromInteriorCloud(bad, "~simulate interior"); }).find("point 2 has solid"),
            std::string::npos);
  auto none = topo_ros::toPointCloud2(cloud, "object", ros::Time());
  EXPECT_NE(errorOf([&] { topo_ros::fromInteriorCloud(none, "goal"); }).find("no field 'solid'"), std::string::npos);
}

TEST(InteriorMarkers, CentreOfMassSolidCubesGravityAndText) {
  const VolumeCloud cloud = topo_test::boxCloud(0.1, 0.1, 0.1, 0.01);
  std::vector<double> r(cloud.size());
  std::size_t solid = 0;
  for (std::size_t i = 0; i < r.size(); ++i) solid += (r[i] = cloud.X[i].z() < 0 ? 1.0 : 0.1) >= 0.5;
  topo_ros::InteriorMarkerInput in;
  in.cloud = &cloud;
  in.r = &r;
  in.mass.mass = 2.0;
  in.mass.com = Eigen::Vector3d(0, 0, -0.02);
  in.mass.inertia = Eigen::Vector3d(1, 2, 3).asDiagonal();
  in.geometry.has_point = true;
  in.geometry.point = Eigen::Vector3d(0, 0, 0.05);
  in.features = {inference::Feature{"period_s", 0.3, "s", true, 0.31}};
  in.object_in_world = Eigen::Translation3d(0, 0, 1.0) * Eigen::Quaterniond::Identity();
  in.cut_away = false;  // every particle (the cut-away has its own test)
  const auto arr = topo_ros::makeInteriorMarkers(in, ros::Time(1.0));
  ASSERT_GE(arr.markers.size(), 8u);
  EXPECT_EQ(arr.markers[0].action, visualization_msgs::Marker::DELETEALL);
  const visualization_msgs::Marker* cubes = nullptr;
  const visualization_msgs::Marker* gravity = nullptr;
  const visualization_msgs::Marker* text = nullptr;
  for (const auto& m : arr.markers) {
    if (m.type == visualization_msgs::Marker::CUBE_LIST && m.id == 7) cubes = &m;
    if (m.type == visualization_msgs::Marker::ARROW && m.header.frame_id == "world") gravity = &m;
    if (m.type == visualization_msgs::Marker::TEXT_VIEW_FACING) text = &m;
    if (m.id == 1) EXPECT_NEAR(m.pose.position.z, -0.02, 1e-12);  // com sphere
    if (m.id == 2) EXPECT_NEAR(m.pose.position.z, 0.05, 1e-12);   // hanging point
  }
  ASSERT_TRUE(cubes && gravity && text);
  EXPECT_EQ(cubes->points.size(), solid);
  EXPECT_NEAR(cubes->scale.x, 0.01, 1e-12);
  EXPECT_NEAR(gravity->points[0].z, 1.0 - 0.02, 1e-12) << "starts at the com placed in the world";
  EXPECT_LT(gravity->points[1].z, gravity->points[0].z) << "points down";
  EXPECT_EQ(text->text, "period_s = 0.3 s (target 0.31)");
  // The experiment count and the uncertain share (confidence < 0.95) head the text: a quarter of the
  // particles (equal volumes) uncertain.
  std::vector<double> confidence(cloud.size(), 1.0);
  for (std::size_t i = 0; i < confidence.size(); i += 4) confidence[i] = 0.6;
  const double share = 100.0 * ((confidence.size() + 3) / 4) / double(confidence.size());
  in.experiments = 3;
  in.confidence = &confidence;
  std::string head;
  for (const auto& m : topo_ros::makeInteriorMarkers(in, ros::Time(1.0)).markers)
    if (m.type == visualization_msgs::Marker::TEXT_VIEW_FACING) head = m.text.substr(0, m.text.find('\n'));
  char want[80];
  std::snprintf(want, sizeof want, "from 3 experiments; %.3g %% of the volume uncertain", share);
  EXPECT_EQ(head, want);
  in.experiments = 0;
  in.confidence = nullptr;
  std::vector<double> short_r(3, 1.0);
  in.r = &short_r;
  EXPECT_NE(errorOf([&] { topo_ros::makeInteriorMarkers(in, ros::Time()); }).find("one indicator value"),
            std::string::npos);
}

TEST(BodyMotion, PoseInterpolationAndClamping) {
  std::vector<inference::BodyPose> m(3);
  for (int k = 0; k < 3; ++k) {
    m[k].t = 0.1 * k;
    m[k].translation = Eigen::Vector3d(k, 0, 0);
    m[k].rotation = Eigen::Quaterniond(Eigen::AngleAxisd(0.2 * k, Eigen::Vector3d::UnitX()));
  }
  const auto p = inference::poseAt(m, 0.15);
  EXPECT_NEAR(p.translation.x(), 1.5, 1e-12);
  EXPECT_NEAR(Eigen::AngleAxisd(p.rotation).angle(), 0.3, 1e-12);
  EXPECT_NEAR(inference::poseAt(m, -1).translation.x(), 0.0, 0.0);
  EXPECT_NEAR(inference::poseAt(m, 9).translation.x(), 2.0, 0.0);
  EXPECT_NE(errorOf([] { inference::poseAt({}, 0.0); }).find("no samples"), std::string::npos);
}

TEST(BodyMotion, TumblerMotionPlacesTheComAtTheSimulatedState) {
  // The reported pose maps the body-frame centre of mass onto the rigid state's position, and the
  // lowest surface particle of the resting start touches the ground (z ≈ 0).
  const VolumeCloud cloud = topo_test::tumblerCloud(0.05, 0.4, 0.006);
  const inference::TaskConfig c = inference::TaskConfig::defaults("tumbler");
  const inference::ProblemEvaluation ev = inference::simulateInterior(c, cloud, {});
  ASSERT_EQ(ev.task.motion.size(), ev.task.signal.size());
  double zmin = 1e9;
  const auto& p0 = ev.task.motion.front();
  for (const auto& x : cloud.X) zmin = std::min(zmin, (p0.rotation * x + p0.translation).z());
  EXPECT_NEAR(zmin, 0.0, 0.006) << "rests on the ground within a spacing";
  // the tilt of the pose about the rocking axis (x) equals the task's signal
  for (std::size_t k = 0; k < ev.task.motion.size(); k += 37) {
    const Eigen::Vector3d up = ev.task.motion[k].rotation * Eigen::Vector3d::UnitZ();
    const double tilt = std::atan2(-up.y(), up.z()) * 180 / M_PI;
    EXPECT_NEAR(std::abs(tilt), std::abs(ev.task.signal[k]), 1e-6) << k;
  }
}

// contact_samples (the volume's true surface, published by cloud_ingest): the layout round trip with
// the samples' spacing, an older cloud without it (derived from the areas), and a cloud without the
// normals named.
TEST(ContactCloud, LayoutRoundTripAndMissingFields) {
  ContactSamples c;
  c.spacing = 0.002;
  for (int k = 0; k < 50; ++k) {
    const double a = 0.1 * k;
    c.X.emplace_back(0.05 * std::cos(a), 0.05 * std::sin(a), 0.001 * k);
    c.normal.emplace_back(std::cos(a), std::sin(a), 0.0);
    c.area.push_back(4e-6 * (1.0 + 0.01 * (k % 3)));
  }
  const sensor_msgs::PointCloud2 msg = topo_ros::toContactCloud(c, "object", ::ros::Time(3.0));
  EXPECT_EQ(msg.header.frame_id, "object");
  EXPECT_EQ(msg.width, 50u);
  const ContactSamples back = topo_ros::fromContactCloud(msg, "/contact_samples");
  ASSERT_EQ(back.size(), c.size());
  for (std::size_t k = 0; k < c.size(); ++k) {
    EXPECT_LT((back.X[k] - c.X[k]).norm(), 1e-7);
    EXPECT_LT((back.normal[k] - c.normal[k]).norm(), 1e-6);
    EXPECT_NEAR(back.area[k], c.area[k], 1e-12);
  }
  EXPECT_EQ(back.spacing, c.spacing);  // carried (field spacing), not derived from the areas
  // A contact cloud recorded before the field: the square root of the median area, with a warning.
  sensor_msgs::PointCloud2 old = msg;
  old.fields.erase(std::remove_if(old.fields.begin(), old.fields.end(), [](const auto& f) { return f.name == "spacing"; }),
                   old.fields.end());
  std::string warning;
  EXPECT_NEAR(topo_ros::fromContactCloud(old, "/contact_samples", &warning).spacing, std::sqrt(4.04e-6), 1e-9);  // areas via float32
  EXPECT_NE(warning.find("derived"), std::string::npos) << warning;
  VolumeCloud v = topo_test::tumblerCloud(0.05, 0.4, 0.01);
  v.contact = back;
  EXPECT_NO_THROW(v.validate("volume with contact samples"));
  sensor_msgs::PointCloud2 bare = topo_ros::toPointCloud2(v, "object", ::ros::Time(3.0));
  try {
    topo_ros::fromContactCloud(bare, "/contact_samples");
    FAIL() << "expected TopoError";
  } catch (const TopoError& e) {
    EXPECT_NE(std::string(e.what()).find("normal_x"), std::string::npos) << e.what();
  }
}

// `volume` carries the spacing the volume was filled at (field spacing, FLOAT64, the same in every
// point), so the round trip keeps it exactly. A small object has more partial boundary particles than
// whole cells, so the cube root of the median volume (what the message gave before the field, and
// what a cloud from an older bag still gets, with a warning) is not the spacing: 0.80 h here.
TEST(VolumeMessage, CarriesTheSpacingExactly) {
  const VolumeCloud cloud = topo_test::smallBallCloud(0.004);
  const double derived = spacingFromVolumes(cloud.V);
  EXPECT_NEAR(derived / cloud.spacing, 0.7984, 1e-3);

  const sensor_msgs::PointCloud2 msg = topo_ros::toPointCloud2(cloud, "object", ros::Time(2.0));
  for (const char* f : {"x", "y", "z", "volume", "surface", "spacing"}) EXPECT_TRUE(topo_ros::hasField(msg, f)) << f;
  std::string warning = "not set";
  const VolumeCloud back = topo_ros::fromPointCloud2(msg, "/volume", &warning);
  EXPECT_EQ(back.spacing, cloud.spacing);
  EXPECT_EQ(warning, "");
  ASSERT_EQ(back.size(), cloud.size());

  sensor_msgs::PointCloud2 old = msg;  // as recorded before the field
  old.fields.erase(std::remove_if(old.fields.begin(), old.fields.end(), [](const auto& f) { return f.name == "spacing"; }),
                   old.fields.end());
  const VolumeCloud guessed = topo_ros::fromPointCloud2(old, "/volume (2025 bag)", &warning);
  EXPECT_NEAR(guessed.spacing, derived, 1e-6 * derived);  // the volumes went through float32
  EXPECT_NE(guessed.spacing, cloud.spacing);
  EXPECT_NE(warning.find("/volume (2025 bag)"), std::string::npos) << warning;
  EXPECT_NE(warning.find("derived"), std::string::npos) << warning;
}

// The cut-away: of a box with a spherical cavity, the markers keep the half away from the viewer
// (x·n ≤ c·n + h/2), so the cavity's section shows as hollow-coloured cubes, and the solid region's
// surface is cut the same way; colour_by confidence fades uncertain cubes to grey.
TEST(InteriorMarkers, CutAwayShowsTheCavity) {
  const VolumeCloud cloud = topo_test::boxCloud(0.1, 0.1, 0.1, 0.01);
  std::vector<double> r(cloud.size()), confidence(cloud.size());
  for (std::size_t i = 0; i < r.size(); ++i) {
    r[i] = cloud.X[i].norm() < 0.03 ? 0.0 : 1.0;  // a cavity of radius 3 cm in the middle
    confidence[i] = cloud.X[i].y() > 0 ? 1.0 : 0.0;
  }
  topo_ros::InteriorMarkerInput in;
  in.cloud = &cloud;
  in.r = &r;
  in.mass.mass = 1.0;
  in.cut_normal = Eigen::Vector3d(1, 0, 0);  // the +x half is cut away
  auto find = [](const visualization_msgs::MarkerArray& a, int id) -> const visualization_msgs::Marker* {
    for (const auto& m : a.markers)
      if (m.id == id && m.action == visualization_msgs::Marker::ADD) return &m;
    return nullptr;
  };
  const auto arr = topo_ros::makeInteriorMarkers(in, ros::Time(1.0));
  const visualization_msgs::Marker* solid = find(arr, 7);
  const visualization_msgs::Marker* hollow = find(arr, 9);
  const visualization_msgs::Marker* surface = find(arr, 10);
  ASSERT_TRUE(solid && hollow && surface);
  std::size_t kept_hollow = 0, kept_solid = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i)
    if (cloud.X[i].x() <= 0.005 + 1e-12) (r[i] < 0.5 ? kept_hollow : kept_solid)++;
  EXPECT_GT(kept_hollow, 40u);
  EXPECT_EQ(hollow->points.size(), kept_hollow);
  EXPECT_EQ(solid->points.size(), kept_solid);
  for (const auto& p : hollow->points) EXPECT_LE(p.x, 0.005 + 1e-12);
  EXPECT_EQ(hollow->color.a, 1.0f);  // the cavity opaque, the solid translucent
  EXPECT_LT(solid->color.a, 0.5f);
  EXPECT_GT(hollow->color.b, hollow->color.r);  // hollow blue
  ASSERT_EQ(surface->type, visualization_msgs::Marker::TRIANGLE_LIST);
  ASSERT_EQ(surface->points.size() % 3, 0u);
  for (std::size_t k = 0; k < surface->points.size(); k += 3)
    EXPECT_LE((surface->points[k].x + surface->points[k + 1].x + surface->points[k + 2].x) / 3.0, 0.005 + 1e-9);
  // without the cut every hollow particle is drawn
  in.cut_away = false;
  const auto all = topo_ros::makeInteriorMarkers(in, ros::Time(1.0));
  std::size_t hollow_all = 0;
  for (double v : r) hollow_all += v < 0.5;
  ASSERT_TRUE(find(all, 9));
  EXPECT_EQ(find(all, 9)->points.size(), hollow_all);
  // colour by confidence: a cube with confidence 0 is grey, one with confidence 1 keeps its colour
  in.colour_by = "confidence";
  in.confidence = &confidence;
  const auto faded = topo_ros::makeInteriorMarkers(in, ros::Time(1.0));
  const visualization_msgs::Marker* fs = find(faded, 7);
  ASSERT_TRUE(fs);
  ASSERT_EQ(fs->colors.size(), fs->points.size());
  for (std::size_t k = 0; k < fs->points.size(); ++k) {
    if (fs->points[k].y > 0) EXPECT_NEAR(fs->colors[k].r, 0xDC / 255.0, 1e-6);
    if (fs->points[k].y < 0) EXPECT_NEAR(fs->colors[k].r, 0.6, 1e-6);
  }
  in.colour_by = "rainbow";
  EXPECT_NE(errorOf([&] { topo_ros::makeInteriorMarkers(in, ros::Time()); }).find("colour_by"), std::string::npos);
}
