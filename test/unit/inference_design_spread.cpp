// How sure is the interior (inference/design_spread.h): the designs that fit as well as the best.
//  - A box hung from a point off its centre line: the observation fixes only the horizontal centre of
//    mass, so designs of many solid fractions fit. Checked against the closed form: a design hangs
//    level iff Σ m_i (x_i − d) = 0 and Σ m_i y_i = 0 (c on the vertical through the point), and a
//    box of edge a keeps c at x = d only with a solid (mass) fraction f ≤ 1 − 2d/a (the removed
//    material's centroid lies at most at the far face's slab).
//  - The same box hung from a point the centre of mass cannot reach: the nearest design is the
//    extreme one, the shell plus the interior beyond a plane x = t (closed form: the t maximising c_x),
//    and only designs near it fit as well: confidence near 1.
//  - interior.ply keeps the confidence column (and reads files without it), the interior
//    PointCloud2 carries it, slices.png hatches the undetermined particles.
#include <gtest/gtest.h>
#include <sensor_msgs/point_cloud2_iterator.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "test_clouds.h"
#include "test_util.h"
#include "topo_gaussian/inference/design_spread.h"
#include "topo_gaussian/inference/pipeline.h"
#include "topo_gaussian/io/interior_ply.h"
#include "topo_gaussian/ros/conversions.h"
#include "topo_gaussian/topology/indicator.h"
#include "topo_gaussian/vision/slice_picture.h"

using namespace topo_gaussian;
using topo_test::errorOf;

namespace {

constexpr double kEdge = 0.1;  // box edge [m]
constexpr double kH = kEdge / 16;

VolumeCloud box() { return topo_test::boxCloud(kEdge, kEdge, kEdge, kH); }

inference::TaskConfig hangingConfig(double d_m, int restarts) {
  inference::TaskConfig c = inference::TaskConfig::defaults("hanging");
  c.setVector("hanging_point", Eigen::Vector3d(d_m, 0, kEdge / 2));
  c.set("target_roll_deg", "0", "--target");
  c.set("target_pitch_deg", "0", "--target");
  c.setNumber("restarts", restarts);
  return c;
}

/// Particle masses m_i = V_i max(floor, ρ_s r_i) (the stated interpolation, ρ_hollow = 0, p = 1).
std::vector<double> masses(const VolumeCloud& cloud, const std::vector<double>& r) {
  std::vector<double> m(r.size());
  for (std::size_t i = 0; i < r.size(); ++i) m[i] = cloud.V[i] * std::max(1.0, 1000.0 * r[i]);
  return m;
}

Eigen::Vector3d centreOfMass(const VolumeCloud& cloud, const std::vector<double>& r) {
  const std::vector<double> m = masses(cloud, r);
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  double total = 0;
  for (std::size_t i = 0; i < r.size(); ++i) {
    sum += m[i] * cloud.X[i];
    total += m[i];
  }
  return sum / total;
}

double massFraction(const VolumeCloud& cloud, const std::vector<double>& r) {
  double m = 0;
  for (double x : masses(cloud, r)) m += x;
  return m / (1000.0 * cloud.totalVolume());
}

}  // namespace

TEST(DesignSpread, HangingFixesOnlyTheHorizontalCentreOfMassSoManySolidFractionsFit) {
  const VolumeCloud cloud = box();
  const double d = 0.01;
  const inference::TaskConfig config = hangingConfig(d, 4);
  const inference::InferenceResult res = inference::runInference(config, cloud);
  ASSERT_TRUE(res.targets_reached) << res.message;
  const inference::DesignSpread& s = res.spread;
  ASSERT_TRUE(s.computed);
  std::printf("[ spread   ] %s\n", s.sentence.c_str());
  EXPECT_EQ(s.tried, 4);
  EXPECT_GE(s.accepted, 3) << res.message;
  ASSERT_EQ(s.confidence.size(), cloud.size());
  // The result's confidence: the lower of the spread's and the linearised region analysis's.
  ASSERT_TRUE(res.region.available) << res.region.note;
  ASSERT_EQ(res.solid_confidence.size(), cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i)
    EXPECT_DOUBLE_EQ(res.solid_confidence[i], std::min(s.confidence[i], res.region.confidence[i])) << i;

  // The designs again, with their indicators, to hold each against the closed form: from the main
  // run's best (the same run without the search; a restart may have found a lower loss, which is then
  // res.theta).
  inference::TaskConfig main_only = config;
  main_only.setNumber("restarts", 0);
  const inference::InferenceResult main = inference::runInference(main_only, cloud);
  std::vector<std::vector<double>> designs;
  inference::DesignSpreadOptions so;
  so.restarts = 4;
  so.max_evaluations = main.optimizer.evaluations;
  const inference::DesignSpread again =
      inference::exploreDesignSpread(config, cloud, main.theta, main.final, so, &designs);
  EXPECT_EQ(again.found_better, s.found_better);
  if (s.found_better) EXPECT_EQ(res.theta, s.better_theta) << "the lowest loss found is the result";
  EXPECT_EQ(again.confidence, s.confidence) << "the search is seeded: the same designs every time";
  ASSERT_EQ(int(designs.size()), s.accepted);
  const double size = std::sqrt(3.0) * (kEdge - kH);  // bounding-box diagonal of the particle centres
  double f_min = 1, f_max = 0;
  for (const auto& r : designs) {
    const Eigen::Vector3d c = centreOfMass(cloud, r);
    EXPECT_NEAR(c.x(), d, 1e-3 * size) << "c on the vertical through the hanging point";
    EXPECT_NEAR(c.y(), 0.0, 1e-3 * size);
    const double f = massFraction(cloud, r);
    EXPECT_LE(f, 1.0 - 2.0 * d / kEdge + 1e-3) << "closed-form bound of a box holding c at x = d";
    f_min = std::min(f_min, f);
    f_max = std::max(f_max, f);
  }
  EXPECT_GT(f_max - f_min, 0.2) << "the accepted designs span a range of solid fractions";
  EXPECT_NEAR(s.solid_fraction_max - s.solid_fraction_min, f_max - f_min, 0.01);
  EXPECT_GT(s.mass_max_kg - s.mass_min_kg, 0.2 * 1000.0 * cloud.totalVolume());

  // Undetermined particles have confidence < 1; the pinned shell is solid in every design.
  EXPECT_GT(s.undetermined_fraction, 0.2);
  EXPECT_NE(s.sentence.find("% of the volume is undetermined"), std::string::npos) << s.sentence;
  int uncertain = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    EXPECT_GE(s.confidence[i], 1.0 / s.accepted - 1e-12);
    EXPECT_LE(s.confidence[i], 1.0);
    uncertain += s.confidence[i] < 1.0 ? 1 : 0;
    if (cloud.surface[i]) {
      EXPECT_EQ(s.p_solid[i], 1.0);
      EXPECT_EQ(s.confidence[i], 1.0);
    }
  }
  EXPECT_GT(uncertain, 100);

  // A design with c off the vertical does not fit: refused by the acceptance rule.
  std::vector<double> off(cloud.size(), 1.0);
  for (std::size_t i = 0; i < cloud.size(); ++i)
    if (!cloud.surface[i] && cloud.X[i].x() > 0) off[i] = 0.0;
  EXPECT_LT(centreOfMass(cloud, off).x(), 0.0);
  const inference::ProblemEvaluation off_ev = inference::simulateInterior(config, cloud, off);
  EXPECT_FALSE(inference::acceptedByFit(off_ev, res.final, true));
}

TEST(DesignSpread, AnUnreachableHangingPointLeavesOneExtremeDesignWithConfidenceNearOne) {
  const VolumeCloud cloud = box();
  const double d = 0.04;  // beyond the largest c_x a design with a solid shell can have
  const inference::InferenceResult res = inference::runInference(hangingConfig(d, 4), cloud);
  EXPECT_FALSE(res.targets_reached);
  const inference::DesignSpread& s = res.spread;
  ASSERT_TRUE(s.computed);
  std::printf("[ spread   ] %s\n", s.sentence.c_str());
  EXPECT_NE(s.rule.find("task loss"), std::string::npos) << s.rule;

  // Closed form: the shell plus the interior at x ≥ t, t the lattice plane maximising c_x.
  std::vector<double> best_extreme;
  double best_cx = -1;
  for (int k = 0; k <= 16; ++k) {
    const double t = -kEdge / 2 + k * kH;
    std::vector<double> r(cloud.size(), 0.0);
    for (std::size_t i = 0; i < cloud.size(); ++i) r[i] = cloud.surface[i] || cloud.X[i].x() >= t ? 1.0 : 0.0;
    const double cx = centreOfMass(cloud, r).x();
    if (cx > best_cx) {
      best_cx = cx;
      best_extreme = r;
    }
  }
  ASSERT_LT(best_cx, d) << "the hanging point must be out of reach for this test";
  // No design, binary or not (a linear-fractional programme: its optimum is a vertex), has a larger c_x.
  EXPECT_LE(res.final.task.mass.com.x(), best_cx + 1e-9);
  EXPECT_GT(res.final.task.mass.com.x(), 0.9 * best_cx);
  int both = 0, either = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const bool a = res.r[i] >= 0.5, b = best_extreme[i] >= 0.5;
    both += a && b;
    either += a || b;
  }
  std::printf("[ spread   ] c_x %.6f m, closed-form extreme %.6f m, IoU with it %.3f\n", res.final.task.mass.com.x(),
              best_cx, double(both) / either);
  EXPECT_GE(double(both) / either, 0.9) << "the best design is the closed-form extreme";

  EXPECT_GE(s.accepted, 2);
  EXPECT_LT(s.undetermined_fraction, 0.1) << s.sentence;
  EXPECT_LT(s.solid_fraction_max - s.solid_fraction_min, 0.1);
  double mean = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) mean += cloud.V[i] * s.confidence[i];
  EXPECT_GT(mean / cloud.totalVolume(), 0.95);
}

TEST(DesignSpread, SummaryCountsAgreementWithTheBestDesign) {
  VolumeCloud cloud = box();
  const std::size_t n = cloud.size();
  std::vector<std::vector<double>> designs(4, std::vector<double>(n, 1.0));
  designs[1][0] = 0.2;  // one design of four disagrees on particle 0
  designs[2][1] = 0.4;  // two disagree on particle 1
  designs[3][1] = 0.0;
  designs[0][2] = 0.0;  // the best is hollow at particle 2, the others solid
  cloud.V[0] = 2 * cloud.V[0];
  inference::DesignSpread s;
  inference::summarizeDesigns(designs, cloud, &s);
  EXPECT_DOUBLE_EQ(s.p_solid[0], 0.75);
  EXPECT_DOUBLE_EQ(s.confidence[0], 0.75);
  EXPECT_DOUBLE_EQ(s.confidence[1], 0.5);
  EXPECT_DOUBLE_EQ(s.p_solid[2], 0.75);
  EXPECT_DOUBLE_EQ(s.confidence[2], 0.25) << "agreement with the best design's label, not with the majority";
  EXPECT_DOUBLE_EQ(s.confidence[3], 1.0);
  EXPECT_NEAR(s.undetermined_fraction, (4.0 * cloud.V[1]) / cloud.totalVolume(), 1e-12);
  EXPECT_NE(errorOf([&] { inference::summarizeDesigns({}, cloud, &s); }).find("no design"), std::string::npos);
  EXPECT_NE(errorOf([&] { inference::summarizeDesigns({{1.0}}, cloud, &s); }).find("1 values"), std::string::npos);
}

TEST(DesignSpread, NoRestartsOrACancelledRunExploreNothing) {
  const VolumeCloud cloud = box();
  const inference::InferenceResult none = inference::runInference(hangingConfig(0.01, 0), cloud);
  EXPECT_FALSE(none.spread.computed);
  // No spread: the confidence is the linearised region analysis's alone.
  ASSERT_TRUE(none.region.available) << none.region.note;
  EXPECT_EQ(none.solid_confidence, none.region.confidence);
  const inference::InferenceResult cancelled =
      inference::runInference(hangingConfig(0.01, 4), cloud, [](const inference::IterationInfo&) { return false; });
  EXPECT_TRUE(cancelled.cancelled);
  EXPECT_FALSE(cancelled.spread.computed);
  EXPECT_NE(cancelled.message.find("spread (restarts = 4) was skipped"), std::string::npos) << cancelled.message;
  // Cancelled inside the search: the designs found so far, marked cancelled.
  int calls = 0;
  const inference::InferenceResult partial =
      inference::runInference(hangingConfig(0.01, 4), cloud,
                              [&](const inference::IterationInfo& it) { return ++calls < 25 || it.iteration < 0; });
  if (partial.spread.computed) {
    EXPECT_TRUE(partial.spread.cancelled);
    EXPECT_LT(partial.spread.tried, 4);
    EXPECT_NE(partial.spread.sentence.find("Cancelled"), std::string::npos);
  } else {
    EXPECT_TRUE(partial.cancelled) << "cancelled in the main run instead";
  }
}

TEST(DesignSpread, InteriorPlyKeepsTheConfidenceColumnAndReadsFilesWithoutIt) {
  const VolumeCloud cloud = box();
  const std::string dir =
      (std::filesystem::temp_directory_path() / ("design_spread_" + std::to_string(getpid()))).string();
  std::filesystem::create_directories(dir);
  std::vector<double> r(cloud.size()), rho(cloud.size()), conf(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    r[i] = (i % 7) / 6.0;
    rho[i] = 1000.0 * r[i];
    conf[i] = 0.25 + 0.75 * ((i % 5) / 4.0);
  }
  io::writeInteriorPly(dir + "/with.ply", cloud, r, rho, false, conf);
  const io::InteriorPly with = io::readInteriorPlyData(dir + "/with.ply", cloud.size());
  ASSERT_EQ(with.confidence.size(), cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    EXPECT_NEAR(with.confidence[i], conf[i], 1e-7);
    EXPECT_NEAR(with.r[i], r[i], 1e-7);
    EXPECT_NEAR(with.density[i], rho[i], 1e-4);
    EXPECT_NEAR((with.X[i] - cloud.X[i]).norm(), 0.0, 1e-7);
  }
  io::writeInteriorPly(dir + "/without.ply", cloud, r, rho, false);
  const io::InteriorPly without = io::readInteriorPlyData(dir + "/without.ply", cloud.size());
  EXPECT_TRUE(without.confidence.empty());
  EXPECT_NEAR(without.r[5], r[5], 1e-7);
  EXPECT_NE(
      errorOf([&] { io::writeInteriorPly(dir + "/bad.ply", cloud, r, rho, false, {0.5}); }).find("1 confidence values"),
      std::string::npos);
  conf[3] = 1.5;
  io::writeInteriorPly(dir + "/out_of_range.ply", cloud, r, rho, false, conf);
  EXPECT_NE(errorOf([&] {
              io::readInteriorPlyData(dir + "/out_of_range.ply", cloud.size());
            }).find("particle 3 has confidence"),
            std::string::npos);
  std::filesystem::remove_all(dir);
}

TEST(DesignSpread, InteriorCloudCarriesConfidenceAndSlicesHatchTheUndetermined) {
  const VolumeCloud cloud = box();
  std::vector<double> r(cloud.size(), 1.0), rho(cloud.size(), 1000.0), conf(cloud.size(), 1.0);
  conf[10] = 0.6;
  const auto msg = topo_ros::toInteriorCloud(cloud, r, rho, {}, "object", ::ros::Time(1.0), conf);
  ASSERT_TRUE(topo_ros::hasField(msg, "confidence"));
  sensor_msgs::PointCloud2ConstIterator<float> c(msg, "confidence");
  for (std::size_t i = 0; i < cloud.size(); ++i, ++c) EXPECT_FLOAT_EQ(*c, float(conf[i]));
  const auto plain = topo_ros::toInteriorCloud(cloud, r, rho, {}, "object", ::ros::Time(1.0));
  sensor_msgs::PointCloud2ConstIterator<float> one(plain, "confidence");
  EXPECT_FLOAT_EQ(*one, 1.0f) << "no spread: confidence 1";
  EXPECT_NE(
      errorOf([&] { topo_ros::toInteriorCloud(cloud, r, rho, {}, "o", ::ros::Time(), {0.5}); }).find("1 confidence"),
      std::string::npos);

  const auto hatchPixels = [](const cv::Mat& img) {
    const cv::Vec3b ink(static_cast<uchar>(vision::kSliceUncertainBgr[0]),
                        static_cast<uchar>(vision::kSliceUncertainBgr[1]),
                        static_cast<uchar>(vision::kSliceUncertainBgr[2]));
    int n = 0;
    for (int y = 100; y < img.rows; ++y)  // below the legend
      for (int x = 0; x < img.cols; ++x) n += img.at<cv::Vec3b>(y, x) == ink ? 1 : 0;
    return n;
  };
  vision::SliceOptions so;
  const int plain_ink = hatchPixels(vision::drawInteriorSlices(cloud.X, r, cloud.spacing, "t", so));  // text edges
  // Every particle of the central layers undetermined: the hatching covers part of each cell.
  for (std::size_t i = 0; i < cloud.size(); ++i) conf[i] = cloud.surface[i] ? 1.0 : 0.5;
  so.confidence = conf;
  const cv::Mat hatched = vision::drawInteriorSlices(cloud.X, r, cloud.spacing, "t", so);
  EXPECT_GT(hatchPixels(hatched) - plain_ink, 2000);
  so.confidence = {0.5};
  EXPECT_NE(errorOf([&] { vision::drawInteriorSlices(cloud.X, r, cloud.spacing, "t", so); }).find("confidence"),
            std::string::npos);
}

// A stop is not a proof. The tumbler of bench_infer (a 25 mm cavity above the centre of a 5000 kg/m³
// doll, its period and max tilt simulated on the same lattice, so the truth reaches both targets
// exactly): the quadric search from the default start stalls at a nearly solid design 1.6 % off in
// period (a local minimum; the searches from other solid fractions find nothing better). The message
// used to say that no interior of the representation reaches the target, and that the interior looked
// determined: both false. Now: either unreachable or a local minimum, and the spread's note does not
// call an interior that misses its targets determined.
TEST(DesignSpread, ALocalMinimumThatMissesTheTargetIsNotCalledTheNearestReachable) {
  const VolumeCloud tumbler = topo_test::tumblerCloud(0.05, 0.6, 0.0033);
  inference::TaskConfig c = inference::TaskConfig::defaults("tumbler");
  c.set("density_solid", "5000");
  c.set("duration_s", "2.0");
  std::vector<double> truth(tumbler.size(), 1.0);
  for (std::size_t i = 0; i < tumbler.size(); ++i)
    if (!tumbler.surface[i] && (tumbler.X[i] - Eigen::Vector3d(0, 0.012, 0.008)).norm() < 0.025) truth[i] = 0.0;
  const inference::ProblemEvaluation gt = inference::simulateInterior(c, tumbler, truth);
  c.setNumber("period_s", gt.task.features[0].value);
  c.setNumber("max_tilt_deg", gt.task.features[1].value);
  c.setNumber("restarts", 2);
  c.set("max_evaluations", "60");
  // The truth reaches both targets: a claim that nothing does would be false.
  const inference::ProblemEvaluation at_truth = inference::simulateInterior(c, tumbler, truth);
  ASSERT_TRUE(inference::allTargetsReached(at_truth));
  const inference::InferenceResult res = inference::runInference(c, tumbler);
  std::printf("[ message  ] %s\n", res.message.c_str());
  if (res.targets_reached) {  // a better optimiser escapes the minimum: then the message says so
    EXPECT_NE(res.message.find("All targets reached"), std::string::npos) << res.message;
  } else {
    EXPECT_TRUE(res.optimizer.converged) << res.optimizer.message;  // stalled: counted as converged
    EXPECT_EQ(res.message.find("nearest reachable"), std::string::npos) << res.message;
    EXPECT_EQ(res.message.find("looks determined"), std::string::npos) << res.message;
    EXPECT_NE(res.message.find("local minimum"), std::string::npos) << res.message;
    EXPECT_NE(res.spread.sentence.find("misses its targets"), std::string::npos) << res.spread.sentence;
    EXPECT_FALSE(res.spread.best_reached);
  }

  // More restarts: one finds a design that reaches both targets; it is the result, and the spread is judged
  // against it (it used to say that the best missed its targets, of the design the run started from).
  c.setNumber("restarts", 6);
  const inference::InferenceResult more = inference::runInference(c, tumbler);
  std::printf("[ message  ] %s\n", more.message.c_str());
  // (The main run is the same as above: when it stalled, the result is a restart's.)
  EXPECT_EQ(more.spread.found_better, !res.targets_reached);
  EXPECT_TRUE(more.targets_reached);
  EXPECT_TRUE(more.spread.best_reached);
  EXPECT_EQ(more.spread.sentence.find("misses its targets"), std::string::npos) << more.spread.sentence;
  EXPECT_NE(more.message.find("found a design with a lower loss"), std::string::npos) << more.message;
  // Two rocking features cannot fix a quadric's ten parameters: no sentence calls the interior determined.
  EXPECT_EQ(more.message.find("looks determined"), std::string::npos) << more.message;
}
