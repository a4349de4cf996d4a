// The peer world's mesh renderer against closed forms and OpenCV's own projection: silhouette area
// and centroid of a cube (projected square; convex hull of cv::projectPoints when tilted), a sphere's
// perspective image (an ellipse of area π f² sin²α cos α / (cos²θ − sin²α)^{3/2}), a lens that puts
// a blob where cv::projectPoints does, Lambert's ratio, rolling shutter and exposure in pixels, the
// near-plane clip, seeded noise, a tilt from second moments, and bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "peer_world/mesh_renderer.h"
#include "topo_gaussian/common/error.h"

using namespace topo_gaussian::peer;
using topo_gaussian::TopoError;

namespace {

struct Mesh {
  std::vector<Eigen::Vector3d> vertices;
  std::vector<Eigen::Vector3i> triangles;
};

// An axis-aligned box of half sizes h [m] centred at the origin, triangles outward (counter-clockwise
// seen from outside).
Mesh box(const Eigen::Vector3d& h) {
  Mesh m;
  for (int i = 0; i < 8; ++i)
    m.vertices.emplace_back((i & 1 ? 1 : -1) * h.x(), (i & 2 ? 1 : -1) * h.y(), (i & 4 ? 1 : -1) * h.z());
  const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : quads) {
    m.triangles.emplace_back(q[0], q[1], q[2]);
    m.triangles.emplace_back(q[0], q[2], q[3]);
  }
  return m;
}

// A UV sphere of radius r [m]: `segments` around the z axis, `stacks` from pole to pole, outward.
Mesh uvSphere(double r, int segments, int stacks) {
  Mesh m;
  m.vertices.emplace_back(0, 0, r);
  for (int i = 1; i < stacks; ++i) {
    const double th = M_PI * i / stacks;
    for (int j = 0; j < segments; ++j) {
      const double ph = 2 * M_PI * j / segments;
      m.vertices.emplace_back(r * std::sin(th) * std::cos(ph), r * std::sin(th) * std::sin(ph), r * std::cos(th));
    }
  }
  m.vertices.emplace_back(0, 0, -r);
  const int south = static_cast<int>(m.vertices.size()) - 1;
  const auto ring = [&](int i, int j) { return 1 + (i - 1) * segments + (j % segments); };
  for (int j = 0; j < segments; ++j) {
    m.triangles.emplace_back(0, ring(1, j), ring(1, j + 1));
    m.triangles.emplace_back(south, ring(stacks - 1, j + 1), ring(stacks - 1, j));
    for (int i = 1; i + 1 < stacks; ++i) {
      m.triangles.emplace_back(ring(i, j), ring(i + 1, j), ring(i + 1, j + 1));
      m.triangles.emplace_back(ring(i, j), ring(i + 1, j + 1), ring(i, j + 1));
    }
  }
  return m;
}

// A rectangle of half sizes (hx, hy) [m] in the body's z = 0 plane.
Mesh rectangle(double hx, double hy) {
  Mesh m;
  m.vertices = {{-hx, -hy, 0}, {hx, -hy, 0}, {hx, hy, 0}, {-hx, hy, 0}};
  m.triangles = {{0, 1, 2}, {0, 2, 3}};
  return m;
}

PeerCamera pinhole(double f, double cx, double cy, std::vector<double> distortion = {}) {
  PeerCamera c;
  c.K = cv::Matx33d(f, 0, cx, 0, f, cy, 0, 0, 1);
  c.distortion = std::move(distortion);
  return c;
}

// White object, full ambient, black backdrop, no blur or noise: grey/255 is the coverage.
RenderStyle silhouetteStyle(const PeerCamera& c) {
  RenderStyle s;
  s.object_bgr = cv::Vec3b(255, 255, 255);
  s.ambient = 1.0;
  s.background = cv::Mat(c.height_px, c.width_px, CV_8UC3, cv::Scalar::all(0));
  s.noise_sigma = 0.0;
  s.blur_px = 0.0;
  return s;
}

std::function<Eigen::Isometry3d(double)> fixedPose(const Eigen::Isometry3d& T) {
  return [T](double) { return T; };
}

Eigen::Isometry3d at(const Eigen::Vector3d& p, const Eigen::Matrix3d& R = Eigen::Matrix3d::Identity()) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R;
  T.translation() = p;
  return T;
}

cv::Mat coverage(const cv::Mat& bgr) {
  cv::Mat g;
  cv::extractChannel(bgr, g, 1);
  g.convertTo(g, CV_64F, 1.0 / 255.0);
  return g;
}

struct Blob {
  double area_px, x, y;
};

Blob blob(const cv::Mat& cov) {
  const cv::Moments m = cv::moments(cov);
  return {m.m00, m.m10 / m.m00, m.m01 / m.m00};
}

// Coverage-weighted centre of row r, and its coverage sum (the width in pixels).
std::pair<double, double> rowCentre(const cv::Mat& cov, int r) {
  double s = 0, sx = 0;
  for (int x = 0; x < cov.cols; ++x) s += cov.at<double>(r, x), sx += x * cov.at<double>(r, x);
  return {sx / s, s};
}

}  // namespace

TEST(PeerRenderer, CubeOnAxisIsItsFrontSquare) {
  // Unit cube 3 m ahead of a camera whose principal point is off the image centre: the front face
  // (z = 2.5 m) is a square of side f/2.5 px centred on the principal point.
  const double f = 600.0, cx = 310.3, cy = 247.6;
  const PeerCamera cam = pinhole(f, cx, cy);
  const Mesh cube = box(Eigen::Vector3d::Constant(0.5));
  const Blob b = blob(coverage(
      renderMeshFrame(cube.vertices, cube.triangles, fixedPose(at({0, 0, 3})), 0.0, 0, cam, silhouetteStyle(cam))));
  const double side = f / 2.5;
  EXPECT_NEAR(b.area_px / (side * side), 1.0, 0.01) << "area " << b.area_px << " vs " << side * side;
  EXPECT_NEAR(b.x, cx, 0.3);
  EXPECT_NEAR(b.y, cy, 0.3);
  std::cout << "[cube on axis] area " << b.area_px << " px² vs " << side * side << ", centroid (" << b.x << ", " << b.y
            << ") vs (" << cx << ", " << cy << ")\n";
}

TEST(PeerRenderer, TiltedCubeIsTheHullOfItsProjectedCorners) {
  // A rotated cube seen obliquely: the silhouette of a convex body is the convex hull of its projected
  // corners (cv::projectPoints), whose area and centroid are cv::moments of the polygon.
  const PeerCamera cam = lookAtCamera({2.2, -1.6, 1.3}, {0.1, 0.05, -0.05}, {0, 0, 1}, 60.0, 640, 480);
  const Eigen::Isometry3d pose =
      at({0.1, 0.0, 0.0}, Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.3, 0.8, 0.5).normalized()).toRotationMatrix());
  const Mesh cube = box(Eigen::Vector3d(0.5, 0.35, 0.25));
  const Blob b = blob(
      coverage(renderMeshFrame(cube.vertices, cube.triangles, fixedPose(pose), 0.0, 0, cam, silhouetteStyle(cam))));
  const Eigen::Isometry3d camera_from_body = cam.world_from_camera.inverse() * pose;
  std::vector<cv::Point3d> corners;
  for (const auto& v : cube.vertices) {
    const Eigen::Vector3d p = camera_from_body * v;
    corners.emplace_back(p.x(), p.y(), p.z());
  }
  std::vector<cv::Point2d> px;
  cv::projectPoints(corners, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), cam.K, cv::noArray(), px);
  std::vector<cv::Point2f> pxf(px.begin(), px.end()), hull;
  cv::convexHull(pxf, hull);
  const cv::Moments m = cv::moments(hull);
  // Tighter than the on-axis cube: no edge here is aligned with the sample grid.
  EXPECT_NEAR(b.area_px / m.m00, 1.0, 0.002) << "area " << b.area_px << " vs " << m.m00;
  EXPECT_NEAR(b.x, m.m10 / m.m00, 0.05);
  EXPECT_NEAR(b.y, m.m01 / m.m00, 0.05);
  std::cout << "[tilted cube] area " << b.area_px << " px² vs hull " << m.m00 << ", centroid (" << b.x << ", " << b.y
            << ") vs (" << m.m10 / m.m00 << ", " << m.m01 / m.m00 << ")\n";
}

TEST(PeerRenderer, SphereImageIsThePerspectiveEllipse) {
  // A sphere of radius R whose centre is at distance D, θ off the optical axis: its image is the
  // section of the tangent cone (half angle α = asin(R/D)) by the image plane, an ellipse of area
  // π f² sin²α cos α / (cos²θ − sin²α)^{3/2} (on the axis a circle of radius f R / √(D² − R²)).
  const double f = 500.0, R = 0.25;
  const PeerCamera cam = pinhole(f, 319.5, 239.5);
  const Mesh sphere = uvSphere(R, 128, 64);
  for (const Eigen::Vector3d& c : {Eigen::Vector3d(0, 0, 2), Eigen::Vector3d(0.6, 0.35, 2.0)}) {
    const Blob b = blob(coverage(
        renderMeshFrame(sphere.vertices, sphere.triangles, fixedPose(at(c)), 0.0, 0, cam, silhouetteStyle(cam))));
    const double D = c.norm(), alpha = std::asin(R / D), theta = std::acos(c.z() / D);
    const double expected = M_PI * f * f * std::pow(std::sin(alpha), 2) * std::cos(alpha) /
                            std::pow(std::pow(std::cos(theta), 2) - std::pow(std::sin(alpha), 2), 1.5);
    EXPECT_NEAR(b.area_px / expected, 1.0, 0.005) << "centre " << c.transpose();  // the 128-gon is inscribed
    std::cout << "[sphere at " << c.transpose() << "] area " << b.area_px << " px² vs " << expected << " ("
              << 100.0 * (b.area_px / expected - 1.0) << " %)\n";
  }
}

TEST(PeerRenderer, LensPutsABlobWhereProjectPointsDoes) {
  // A 10 px square off axis: through the lens its centroid is at cv::projectPoints of its centre (same
  // K and distortion), and far from where the ideal pinhole puts it.
  const std::vector<double> dist{-0.25, 0.08, 0.001, -0.0005};
  const PeerCamera ideal = pinhole(500.0, 319.5, 239.5), lens = pinhole(500.0, 319.5, 239.5, dist);
  const Mesh square = rectangle(0.01, 0.01);
  const cv::Point3d centre(0.4, 0.28, 1.0);
  const auto pose = fixedPose(at({centre.x, centre.y, centre.z}));
  const Blob b_ideal =
      blob(coverage(renderMeshFrame(square.vertices, square.triangles, pose, 0.0, 0, ideal, silhouetteStyle(ideal))));
  const Blob b_lens =
      blob(coverage(renderMeshFrame(square.vertices, square.triangles, pose, 0.0, 0, lens, silhouetteStyle(lens))));
  std::vector<cv::Point2d> px;
  cv::projectPoints(std::vector<cv::Point3d>{centre}, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), lens.K, dist, px);
  EXPECT_NEAR(b_lens.x, px[0].x, 0.1);
  EXPECT_NEAR(b_lens.y, px[0].y, 0.1);
  EXPECT_NEAR(b_ideal.x, 519.5, 0.3);
  EXPECT_NEAR(b_ideal.y, 379.5, 0.3);
  const double shift = std::hypot(b_lens.x - b_ideal.x, b_lens.y - b_ideal.y);
  EXPECT_GT(shift, 2.0);
  std::cout << "[lens] blob (" << b_lens.x << ", " << b_lens.y << ") vs projectPoints (" << px[0].x << ", " << px[0].y
            << "); pinhole blob (" << b_ideal.x << ", " << b_ideal.y << "), moved " << shift << " px\n";
}

TEST(PeerRenderer, LambertRatioOfATiltedPlane) {
  // Light from the camera: a plane facing it is lit fully, one turned 60° by ambient + (1 − ambient) cos 60°.
  const PeerCamera cam = pinhole(500.0, 319.5, 239.5);
  RenderStyle s = silhouetteStyle(cam);
  s.object_bgr = cv::Vec3b(60, 120, 200);
  s.ambient = 0.35;
  s.light_towards_world = Eigen::Vector3d(0, 0, -1);
  const Mesh plane = rectangle(0.2, 0.2);
  const auto centreMean = [&](const Eigen::Matrix3d& R) {
    const cv::Mat img = renderMeshFrame(plane.vertices, plane.triangles, fixedPose(at({0, 0, 2}, R)), 0.0, 0, cam, s);
    return cv::mean(img(cv::Rect(315, 235, 10, 10)));
  };
  const cv::Scalar facing = centreMean(Eigen::Matrix3d::Identity());
  const cv::Scalar turned = centreMean(Eigen::AngleAxisd(M_PI / 3, Eigen::Vector3d::UnitY()).toRotationMatrix());
  const double ratio = 0.35 + 0.65 * 0.5;
  for (int ch = 0; ch < 3; ++ch) {
    EXPECT_NEAR(facing[ch], s.object_bgr[ch], 1.0) << "channel " << ch;
    EXPECT_NEAR(turned[ch], facing[ch] * ratio, 2.0) << "channel " << ch;
  }
  std::cout << "[lambert] facing " << facing << ", turned 60° " << turned << ", expected " << facing * ratio << "\n";
}

TEST(PeerRenderer, RollingShutterShearsAMovingSquare) {
  // A 100 × 360 px rectangle moving right at v = f V / z = 500 px/s; row r is taken at t + r/H · readout,
  // so the rectangle's bottom row is v · readout · (r_bottom − r_top)/H right of its top row.
  const double f = 500.0, cx = 319.5, z = 2.0, V = 2.0, readout = 0.05, t0 = 0.1;
  const PeerCamera cam = pinhole(f, cx, 239.5);
  const Mesh rect = rectangle(0.2, 0.72);
  const auto moving = [&](double t) { return at({-0.2 + V * t, 0, z}); };
  const double v = f * V / z;
  const auto shear = [&](int bands, double readout_s, double* top_error_px) {
    RenderStyle s = silhouetteStyle(cam);
    s.readout_s = readout_s;
    s.readout_bands = bands;
    const cv::Mat cov = coverage(renderMeshFrame(rect.vertices, rect.triangles, moving, t0, 0, cam, s));
    int top = -1, bottom = -1;
    for (int r = 0; r < cov.rows; ++r)
      if (rowCentre(cov, r).second > 99.0) bottom = r, top = top < 0 ? r : top;
    const double expected_top = cx + f * (-0.2 + V * (t0 + top * readout_s / cam.height_px)) / z;
    if (top_error_px) *top_error_px = rowCentre(cov, top).first - expected_top;
    const double measured = rowCentre(cov, bottom).first - rowCentre(cov, top).first;
    return std::make_pair(measured, v * readout_s * (bottom - top) / cam.height_px);
  };
  double top_error = 0;
  const auto [exact, expected] = shear(0, readout, &top_error);
  const auto [banded, expected_banded] = shear(8, readout, nullptr);
  const auto [global, none] = shear(0, 0.0, nullptr);
  EXPECT_GT(expected, 15.0);
  EXPECT_NEAR(exact, expected, 1.0);
  EXPECT_NEAR(top_error, 0.0, 0.3);
  EXPECT_NEAR(banded, expected_banded, v * readout / 8 + 0.25);  // each row at most half a band off
  EXPECT_NEAR(global, 0.0, 0.1);
  std::cout << "[rolling shutter] shear " << exact << " px vs " << expected << " (8 bands: " << banded
            << "; global shutter: " << global << "), top row off by " << top_error << " px\n";
}

TEST(PeerRenderer, ExposureSmearsAtTheMidExposurePosition) {
  // Motion blur over [t, t + e]: each row keeps its coverage (the width) and its centre is the
  // position at t + e/2.
  const double f = 500.0, cx = 319.5, z = 2.0, V = 2.0, e = 0.02, t0 = 0.1;
  const PeerCamera cam = pinhole(f, cx, 239.5);
  const Mesh rect = rectangle(0.1, 0.2);
  RenderStyle s = silhouetteStyle(cam);
  s.exposure_s = e;
  s.sub_samples = 16;
  const cv::Mat cov = coverage(renderMeshFrame(
      rect.vertices, rect.triangles,
      [&](double t) {
        return at({V * t, 0, z});
      },
      t0, 0, cam, s));
  const auto [centre, width] = rowCentre(cov, 240);
  EXPECT_NEAR(centre, cx + f * V * (t0 + 0.5 * e) / z, 0.3);
  EXPECT_NEAR(width, f * 0.2 / z, 0.5);
  int partial = 0;  // pixels between 5 % and 95 % coverage: the smear of v e = 10 px on each edge
  for (int x = 0; x < cov.cols; ++x) partial += cov.at<double>(240, x) > 0.05 && cov.at<double>(240, x) < 0.95;
  EXPECT_GE(partial, 16);
  std::cout << "[exposure] row centre " << centre << " vs " << cx + f * V * (t0 + 0.5 * e) / z << ", width " << width
            << " px, " << partial << " partly covered pixels\n";
}

TEST(PeerRenderer, FloorThroughTheCameraIsClippedAtTheNearPlane) {
  // An 80 m floor 0.5 m below a level camera, reaching behind it: nothing above the horizon (row cy),
  // and floor everywhere below its far edge (z = 40 m, row cy + f 0.5/40).
  const PeerCamera cam = pinhole(500.0, 319.5, 239.5);
  const Mesh floor = rectangle(40.0, 40.0);
  const Eigen::Matrix3d lay = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitX()).toRotationMatrix();
  const cv::Mat cov = coverage(renderMeshFrame(floor.vertices, floor.triangles, fixedPose(at({0, 0.5, 0}, lay)), 0.0, 0,
                                               cam, silhouetteStyle(cam)));
  double above = 0, below_missing = 0;
  for (int r = 0; r < cov.rows; ++r)
    for (int x = 0; x < cov.cols; ++x) {
      if (r <= 237) above += cov.at<double>(r, x);
      if (r >= 248) below_missing += 1.0 - cov.at<double>(r, x);
    }
  EXPECT_LT(above, 1.0);
  EXPECT_LT(below_missing, 1.0);
  std::cout << "[near clip] coverage above the horizon " << above << " px, missing below the far edge " << below_missing
            << " px\n";
}

TEST(PeerRenderer, NoiseIsSeededPerFrame) {
  // Same frame index: the same image; the next index: independent noise of σ each, so the difference
  // has standard deviation √2 σ.
  const PeerCamera cam = pinhole(500.0, 319.5, 239.5);
  RenderStyle s;
  s.noise_sigma = 3.0;
  const Mesh cube = box(Eigen::Vector3d::Constant(0.2));
  const auto frame = [&](int i) {
    cv::Mat f;
    renderMeshFrame(cube.vertices, cube.triangles, fixedPose(at({0, 0, 2})), 0.0, i, cam, s).convertTo(f, CV_64F);
    return f;
  };
  const cv::Mat a = frame(3), b = frame(3), c = frame(4);
  EXPECT_EQ(cv::norm(a - b, cv::NORM_INF), 0.0);
  cv::Scalar mean, sd;
  const cv::Mat difference = a - c;
  cv::meanStdDev(difference.reshape(1), mean, sd);
  EXPECT_NEAR(sd[0], std::sqrt(2.0) * 3.0, 0.2);
  EXPECT_NEAR(mean[0], 0.0, 0.05);
  std::cout << "[noise] σ 3: difference of frames 3 and 4 has sd " << sd[0] << " vs " << std::sqrt(2.0) * 3.0 << "\n";
}

TEST(PeerRenderer, SecondMomentsGiveTheTilt) {
  // A long bar turned 25° about the optical axis: the silhouette's principal axis,
  // ½ atan2(2 μ11, μ20 − μ02), is at 25° in the image.
  const PeerCamera cam = pinhole(500.0, 319.5, 239.5);
  const Mesh bar = box(Eigen::Vector3d(0.4, 0.05, 0.05));
  const double tilt = 25.0 * M_PI / 180.0;
  const cv::Mat cov = coverage(
      renderMeshFrame(bar.vertices, bar.triangles,
                      fixedPose(at({0, 0, 3}, Eigen::AngleAxisd(tilt, Eigen::Vector3d::UnitZ()).toRotationMatrix())),
                      0.0, 0, cam, silhouetteStyle(cam)));
  const cv::Moments m = cv::moments(cov);
  const double angle = 0.5 * std::atan2(2 * m.mu11, m.mu20 - m.mu02);
  EXPECT_NEAR(angle * 180.0 / M_PI, 25.0, 0.1);
  std::cout << "[tilt] second moments " << angle * 180.0 / M_PI << "° vs 25°\n";
}

TEST(PeerRenderer, BadInputIsRefused) {
  const PeerCamera cam = pinhole(500.0, 319.5, 239.5);
  const RenderStyle s;
  const Mesh cube = box(Eigen::Vector3d::Constant(0.2));
  const auto pose = fixedPose(at({0, 0, 2}));
  EXPECT_THROW(renderMeshFrame({}, cube.triangles, pose, 0, 0, cam, s), TopoError);
  EXPECT_THROW(renderMeshFrame(cube.vertices, {}, pose, 0, 0, cam, s), TopoError);
  auto bad = cube.triangles;
  bad[5] = Eigen::Vector3i(0, 1, 8);
  EXPECT_THROW(renderMeshFrame(cube.vertices, bad, pose, 0, 0, cam, s), TopoError);
  bad[5] = Eigen::Vector3i(-1, 1, 2);
  EXPECT_THROW(renderMeshFrame(cube.vertices, bad, pose, 0, 0, cam, s), TopoError);
  PeerCamera empty = cam;
  empty.width_px = 0;
  EXPECT_THROW(renderMeshFrame(cube.vertices, cube.triangles, pose, 0, 0, empty, s), TopoError);
  const auto nan_pose = fixedPose(at({0, std::nan(""), 2}));
  EXPECT_THROW(renderMeshFrame(cube.vertices, cube.triangles, nan_pose, 0, 0, cam, s), TopoError);
  EXPECT_THROW(lookAtCamera({0, 0, 1}, {0, 0, 0}, {0, 0, 1}, 60, 640, 480), TopoError);
  try {
    renderMeshFrame(cube.vertices, std::vector<Eigen::Vector3i>{{0, 1, 8}}, pose, 0, 0, cam, s);
  } catch (const TopoError& e) {
    EXPECT_NE(std::string(e.what()).find("triangle 0"), std::string::npos) << e.what();
  }
}
