// Bad input at the ROS boundary, without a ROS master: PointCloud2 position fields that are not
// coordinates, coordinates no surface can have, surface paths that would block the node, stamps that
// jump, and the ASCII text our nodes hand to rosout.
#include <gtest/gtest.h>
#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/PointField.h>
#include <sensor_msgs/point_cloud2_iterator.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <random>
#include <string>

#include "test_util.h"
#include "topo_gaussian/ros/ascii_text.h"
#include "topo_gaussian/ros/cloud_ingest_node.h"
#include "topo_gaussian/ros/conversions.h"
#include "topo_gaussian/ros/motion_tracker_node.h"

using namespace topo_gaussian;
using sensor_msgs::PointCloud2;
using sensor_msgs::PointField;
using topo_test::errorOf;

namespace {

/// `n` points with x y z of `type` (each field as wide as the type), all zero.
PointCloud2 cloudOfType(std::uint8_t type, std::size_t n) {
  PointCloud2 msg;
  msg.height = 1;
  sensor_msgs::PointCloud2Modifier mod(msg);
  mod.setPointCloud2Fields(3, "x", 1, type, "y", 1, type, "z", 1, type);
  mod.resize(n);
  return msg;
}

PointCloud2 floatCloud(const std::vector<Eigen::Vector3f>& points) {
  PointCloud2 msg = cloudOfType(PointField::FLOAT32, points.size());
  sensor_msgs::PointCloud2Iterator<float> x(msg, "x");
  for (const auto& p : points) {
    x[0] = p.x();
    x[1] = p.y();
    x[2] = p.z();
    ++x;
  }
  return msg;
}

}  // namespace

TEST(RosConversions, IntegerPositionFieldsAreRefusedNamingFieldTypeAndFix) {
  // A uint8 'x' was read as metres (a box of 0..255 m filled without a word).
  for (const auto type : {PointField::UINT8, PointField::INT16, PointField::INT32}) {
    const PointCloud2 msg = cloudOfType(type, 10);
    const std::string e = errorOf([&] { topo_ros::toSurfaceData(msg, "/camera/points"); });
    EXPECT_NE(e.find("/camera/points"), std::string::npos) << e;
    EXPECT_NE(e.find("'x'"), std::string::npos) << e;
    EXPECT_NE(e.find(type == PointField::UINT8   ? "UINT8"
                     : type == PointField::INT16 ? "INT16"
                                                 : "INT32"),
              std::string::npos)
        << e;
    EXPECT_NE(e.find("FLOAT32"), std::string::npos) << "names the fix: " << e;
    EXPECT_NE(errorOf([&] { topo_ros::fromPointCloud2(msg, "/volume"); }).find("'x'"), std::string::npos);
    EXPECT_NE(errorOf([&] { topo_ros::fromInteriorCloud(msg, "/interior"); }).find("'x'"), std::string::npos);
  }
  // Only z of the wrong type: named.
  PointCloud2 msg;
  msg.height = 1;
  sensor_msgs::PointCloud2Modifier mod(msg);
  mod.setPointCloud2Fields(3, "x", 1, PointField::FLOAT32, "y", 1, PointField::FLOAT32, "z", 1, PointField::UINT16);
  mod.resize(4);
  const std::string e = errorOf([&] { topo_ros::toSurfaceData(msg, "/scan"); });
  EXPECT_NE(e.find("'z'"), std::string::npos) << e;
  EXPECT_NE(e.find("UINT16"), std::string::npos) << e;
  // FLOAT64 and FLOAT32 are coordinates.
  EXPECT_EQ(topo_ros::toSurfaceData(cloudOfType(PointField::FLOAT64, 5), "/scan").size(), 5u);
  EXPECT_EQ(topo_ros::toSurfaceData(cloudOfType(PointField::FLOAT32, 5), "/scan").size(), 5u);
}

TEST(RosConversions, CoordinatesBeyondAMillionMetresAreRefused) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  // ±3e38 m (near FLT_MAX) overflowed the fill (FLANN aborted the node).
  const PointCloud2 huge = floatCloud({{0.f, 0.f, 0.f}, {1.f, 0.f, 0.f}, {3e38f, -3e38f, 3e38f}});
  const std::string e = errorOf([&] { topo_ros::toSurfaceData(huge, "/surface_cloud"); });
  EXPECT_NE(e.find("/surface_cloud"), std::string::npos) << e;
  EXPECT_NE(e.find("point 2"), std::string::npos) << e;
  EXPECT_NE(e.find("1e+06 m"), std::string::npos) << e;
  const float inf = std::numeric_limits<float>::infinity();
  EXPECT_NE(errorOf([&] {
              topo_ros::toSurfaceData(floatCloud({{0.f, inf, 0.f}}), "/s");
            }).find("y = "),
            std::string::npos);
  EXPECT_NE(errorOf([&] { topo_ros::toSurfaceData(floatCloud({{0.f, 0.f, -2e6f}}), "/s"); }), "");
  // NaN points stay (cleaning drops them), and a 999 km coordinate is still a coordinate.
  const geometry::SurfaceData s = topo_ros::toSurfaceData(floatCloud({{nan, nan, nan}, {9.99e5f, 0.f, 0.f}}), "/s");
  ASSERT_EQ(s.size(), 2u);
  EXPECT_TRUE(std::isnan(s.points[0].x()));
}

TEST(RosConversions, EmptyCloudsConvertBothWays) {
  // Found by fuzz_ros_conversions: the PointCloud2 iterators read data.front() of an empty cloud.
  const VolumeCloud empty;
  const PointCloud2 msg = topo_ros::toPointCloud2(empty, "object", ros::Time(1.0));
  EXPECT_EQ(msg.width * msg.height, 0u);
  EXPECT_TRUE(topo_ros::hasField(msg, "volume"));
  EXPECT_EQ(topo_ros::fromPointCloud2(msg, "/volume").size(), 0u);
  const PointCloud2 interior = topo_ros::toInteriorCloud(empty, {}, {}, {}, "object", ros::Time(1.0));
  EXPECT_EQ(interior.width * interior.height, 0u);
  EXPECT_TRUE(topo_ros::fromInteriorCloud(interior, "/interior").X.empty());
}

// The spacing field is one positive length, the same in every point: anything else is named (a
// cloud without it is an older one and gets the fallback: ros_interior_messages).
TEST(RosConversions, SpacingFieldIsOneLength) {
  VolumeCloud c;
  c.spacing = 0.01;
  c.X = {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(0.01, 0, 0)};
  c.V = {1e-6, 1e-6};
  c.surface = {1, 1};
  const PointCloud2 good = topo_ros::toPointCloud2(c, "object", ros::Time(1.0));
  auto withSpacing = [&](std::size_t point, double h) {
    PointCloud2 m = good;
    std::memcpy(m.data.data() + point * m.point_step + 24, &h, sizeof(h));
    return m;
  };
  EXPECT_NE(errorOf([&] { topo_ros::fromPointCloud2(withSpacing(1, 0.02), "/volume"); }).find("point 1 has spacing"),
            std::string::npos);
  EXPECT_NE(errorOf([&] { topo_ros::fromPointCloud2(withSpacing(0, 0.0), "/volume"); }).find("not a positive"),
            std::string::npos);
  EXPECT_NE(errorOf([&] { topo_ros::fromPointCloud2(withSpacing(0, std::nan("")), "/volume"); }).find("spacing"),
            std::string::npos);
  PointCloud2 integer = good;
  integer.fields[5].datatype = PointField::UINT8;
  EXPECT_NE(errorOf([&] { topo_ros::fromPointCloud2(integer, "/volume"); }).find("UINT8"), std::string::npos);
  // A volume without a spacing is not published with a made-up one.
  c.spacing = 0.0;
  EXPECT_NE(errorOf([&] { topo_ros::toPointCloud2(c, "object", ros::Time(1.0)); }).find("spacing 0"),
            std::string::npos);
}

TEST(RosConversions, DataBeyondWidthTimesHeightIsRefusedWithTheNumbers) {
  // A cloud whose data holds five times the points its width × height declare: was cut to the first
  // fifth without a word, then refused as an open surface.
  std::vector<Eigen::Vector3f> pts;
  for (int i = 0; i < 200; ++i) pts.emplace_back(float(i % 7), float(i % 11), float(i % 13));
  PointCloud2 msg = floatCloud(pts);
  const std::size_t declared = msg.data.size();
  for (int copy = 0; copy < 4; ++copy) msg.data.insert(msg.data.end(), msg.data.begin(), msg.data.begin() + declared);
  const std::string e = errorOf([&] { topo_ros::toSurfaceData(msg, "/camera/points"); });
  EXPECT_NE(e.find("/camera/points"), std::string::npos) << e;
  EXPECT_NE(e.find(std::to_string(msg.data.size()) + " bytes"), std::string::npos) << e;
  EXPECT_NE(e.find(std::to_string(declared)), std::string::npos) << e;
  EXPECT_NE(e.find("row_step"), std::string::npos) << e;
  EXPECT_NE(e.find("1000 points"), std::string::npos) << e;  // what the data would hold
  // The same for a volume cloud; a cloud of the declared size still converts.
  PointCloud2 volume = topo_ros::toPointCloud2(VolumeCloud{}, "object", ros::Time(1.0));
  volume.width = 0;
  volume.data.resize(volume.point_step * 3);
  EXPECT_NE(errorOf([&] { topo_ros::fromPointCloud2(volume, "/volume"); }).find("bytes"), std::string::npos);
  msg.data.resize(declared);
  EXPECT_EQ(topo_ros::toSurfaceData(msg, "/camera/points").size(), pts.size());
}

TEST(RosCloudIngest, TheFillSummarySaysWhatWasRepaired) {
  // A scan with every point written twice: the node's log line and service message said nothing of
  // the merge (nor of any other warning of the fill).
  std::mt19937 rng(7);
  std::normal_distribution<double> g;
  geometry::SurfaceData scan;
  scan.source = "/camera/points";
  for (int i = 0; i < 3000; ++i) scan.points.push_back(0.05 * Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized());
  scan.points.insert(scan.points.end(), scan.points.begin(), scan.points.end());
  geometry::IngestOptions o;
  o.fill.target_count = 2000;
  o.fill.contact.enabled = false;
  const geometry::IngestResult r = geometry::ingestSurface(scan, o);
  ASSERT_FALSE(r.warnings.empty());
  const std::string line = topo_ros::describe(r);
  EXPECT_NE(line.find("merged 3000 exact duplicate"), std::string::npos) << line;
  for (const auto& w : r.warnings) EXPECT_NE(line.find(w), std::string::npos) << w;
}

TEST(RosAsciiText, SymbolsAreSpelledInAscii) {
  EXPECT_EQ(topo_ros::asciiText("0.2 × 0.3 m, N·m"), "0.2 x 0.3 m, N*m");
  EXPECT_EQ(topo_ros::asciiText("depth ≥ 2, r ≤ 1, 45°, −3 → 4"), "depth >= 2, r <= 1, 45 deg, -3 -> 4");
  EXPECT_EQ(topo_ros::asciiText("m³ and m², ±0.5, 5 µm"), "m^3 and m^2, +/-0.5, 5 um");
  EXPECT_EQ(topo_ros::asciiText("plain ASCII stays"), "plain ASCII stays");
  EXPECT_EQ(topo_ros::asciiText("emoji \xF0\x9F\x98\x80 and 中"), "emoji U+1F600 and U+4E2D");
  EXPECT_EQ(topo_ros::asciiText("bad \xFF byte, cut \xE2\x89"), "bad ? byte, cut ??");
  for (const char c : topo_ros::asciiText("ĝ θ ∂ Σ ᵀ x̃ — ‖"))
    EXPECT_LT(static_cast<unsigned char>(c), 128u) << "non-ASCII byte left";
}

TEST(RosCloudIngest, SurfacePathThatWouldBlockIsRefused) {
  const std::string fifo = "/tmp/topo_ros_faults_" + std::to_string(::getpid()) + ".fifo";
  ::unlink(fifo.c_str());
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const std::string e = errorOf([&] { topo_ros::checkSurfaceFile(fifo, "~surface_file"); });
  ::unlink(fifo.c_str());
  EXPECT_NE(e.find("~surface_file"), std::string::npos) << e;
  EXPECT_NE(e.find("FIFO"), std::string::npos) << e;
  EXPECT_NE(e.find("regular file"), std::string::npos) << e;
  EXPECT_NE(errorOf([] { topo_ros::checkSurfaceFile("/tmp", "~surface_file"); }).find("directory"), std::string::npos);
  EXPECT_EQ(errorOf([] { topo_ros::checkSurfaceFile("/nonexistent/x.ply", "~surface_file"); }), "")
      << "a missing file is the reader's to name";
  EXPECT_EQ(errorOf([] { topo_ros::checkSurfaceFile(TOPO_SOURCE_DIR "/README.md", "~surface_file"); }), "");
}

TEST(RosCloudIngest, UpAxisNames) {
  EXPECT_EQ(topo_ros::upAxisVector("z", "~up_axis"), Eigen::Vector3d(0, 0, 1));
  EXPECT_EQ(topo_ros::upAxisVector("-y", "~up_axis"), Eigen::Vector3d(0, -1, 0));
  EXPECT_EQ(topo_ros::upAxisVector("+x", "~up_axis"), Eigen::Vector3d(1, 0, 0));
  const std::string e = errorOf([] { topo_ros::upAxisVector("up", "~up_axis (/cloud_ingest/up_axis)"); });
  EXPECT_NE(e.find("~up_axis"), std::string::npos) << e;
  EXPECT_NE(e.find("-z"), std::string::npos) << "names the choices: " << e;
  EXPECT_NE(errorOf([] { topo_ros::upAxisVector("", "~up_axis"); }), "");
}

TEST(RosMotionTracker, StampJumpsRestartTheWindowAndTheStreamRecovers) {
  using A = topo_ros::StampWindow::Action;
  topo_ros::StampWindow w(/*window_s=*/20.0, /*max_jump_s=*/10.0);
  EXPECT_EQ(w.next(100.0).action, A::Start);
  EXPECT_EQ(w.next(100.0 + 1.0 / 30).action, A::Add);
  // Three frames stamped 1e6 s ahead: the first restarts the window (with a warning naming the jump).
  const auto jump = w.next(1e6 + 100.0);
  EXPECT_EQ(jump.action, A::Restart);
  EXPECT_NE(jump.warning.find("forward"), std::string::npos) << jump.warning;
  EXPECT_NE(jump.warning.find("forward by 999999.967 s"), std::string::npos) << "names the jump: " << jump.warning;
  EXPECT_EQ(w.next(1e6 + 100.0 + 1.0 / 30).action, A::Add);
  EXPECT_EQ(w.next(1e6 + 100.0 + 2.0 / 30).action, A::Add);
  // Then the normal 30 Hz stream: it restarts once, then every frame is used (it used to be dropped forever).
  const auto back = w.next(100.1);
  EXPECT_EQ(back.action, A::Restart);
  EXPECT_NE(back.warning.find("back"), std::string::npos) << back.warning;
  int added = 0;
  for (int k = 1; k <= 150; ++k) {
    const auto d = w.next(100.1 + k / 30.0);
    added += d.action == A::Add;
    EXPECT_TRUE(d.warning.empty()) << d.warning;
  }
  EXPECT_EQ(added, 150);
  // A small step back (a reordered frame) is skipped, not a restart.
  const auto reordered = w.next(100.1 + 149 / 30.0);
  EXPECT_EQ(reordered.action, A::Skip);
  EXPECT_NE(reordered.warning.find("not after"), std::string::npos);
  // A full window restarts silently; the relative time starts again at 0.
  topo_ros::StampWindow v(2.0, 10.0);
  v.next(0.0);
  EXPECT_NEAR(v.next(1.5).t_s, 1.5, 1e-12);
  const auto full = v.next(2.5);
  EXPECT_EQ(full.action, A::Restart);
  EXPECT_TRUE(full.warning.empty());
  EXPECT_NEAR(v.next(2.6).t_s, 0.1, 1e-12);
  v.reset();
  EXPECT_EQ(v.next(-5.0).action, A::Start);
}
