// The peer world's z-buffer rasteriser (see mesh_renderer.h): pinhole raster per row band and time,
// lens by remap through cv::undistortPoints, then backdrop, blur and noise.
#include "peer_world/mesh_renderer.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <memory>
#include <mutex>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <string>

#include "topo_gaussian/common/error.h"

namespace topo_gaussian::peer {
namespace {

constexpr double kNearZ_m = 1e-4;               // faces are clipped to z ≥ this in the camera frame
constexpr double kLensResidualLimit_px = 0.05;  // |project(undistort(p)) − p| allowed for the lens map
constexpr double kRigidTolerance = 1e-6;        // |RᵀR − I| allowed for a pose

std::string str(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

void checkRigid(const Eigen::Isometry3d& T, const std::string& input, const std::string& fix) {
  const Eigen::Matrix<double, 3, 4> m = T.matrix().topRows<3>();
  if (!m.allFinite()) throw TopoError(input, "the pose has a non-finite entry", fix);
  const double err = (T.linear().transpose() * T.linear() - Eigen::Matrix3d::Identity()).norm();
  if (err > kRigidTolerance)
    throw TopoError(input, "the pose's rotation is not orthonormal (|RᵀR − I| = " + str(err) + ")", fix);
}

// For each output (distorted) pixel, the ideal pinhole pixel it sees; the part of the ideal image
// that is read (the canvas) and, per output row, the ideal rows it reads.
struct LensMap {
  bool identity = true;
  cv::Mat ideal_px;  // CV_32FC2, absolute ideal pixel coordinates per output pixel
  cv::Rect canvas;   // ideal pixels rendered (absolute coordinates)
  std::vector<float> row_min_y, row_max_y;
};

std::shared_ptr<const LensMap> computeLensMap(const PeerCamera& cam) {
  auto lens = std::make_shared<LensMap>();
  const int W = cam.width_px, H = cam.height_px;
  lens->canvas = cv::Rect(0, 0, W, H);
  if (std::all_of(cam.distortion.begin(), cam.distortion.end(), [](double d) { return d == 0.0; })) return lens;
  lens->identity = false;
  std::vector<cv::Point2d> grid(static_cast<std::size_t>(W) * H), ideal;
  for (int v = 0; v < H; ++v)
    for (int u = 0; u < W; ++u) grid[static_cast<std::size_t>(v) * W + u] = cv::Point2d(u, v);
  const cv::Mat K(cam.K), D(cam.distortion);
  cv::undistortPoints(grid, ideal, K, D, cv::noArray(), K, cv::TermCriteria(cv::TermCriteria::COUNT, 40, 0.0));
  // Check the inversion by distorting back (cv::projectPoints of the normalised rays).
  const cv::Matx33d Kinv = cam.K.inv();
  std::vector<cv::Point3d> rays(ideal.size());
  for (std::size_t i = 0; i < ideal.size(); ++i) {
    const cv::Vec3d r = Kinv * cv::Vec3d(ideal[i].x, ideal[i].y, 1.0);
    rays[i] = cv::Point3d(r[0] / r[2], r[1] / r[2], 1.0);
  }
  std::vector<cv::Point2d> back;
  cv::projectPoints(rays, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, D, back);
  double worst = 0.0;
  std::size_t worst_i = 0;
  for (std::size_t i = 0; i < grid.size(); ++i) {
    const double e = cv::norm(back[i] - grid[i]);
    if (!(e <= worst)) worst = e, worst_i = i;  // also catches NaN
  }
  if (!(worst <= kLensResidualLimit_px))
    throw TopoError("peer camera distortion",
                    "the lens cannot be inverted over the image: pixel (" + str(grid[worst_i].x) + ", " +
                        str(grid[worst_i].y) + ") is missed by " + str(worst) + " px",
                    "use milder distortion coefficients or a smaller image");
  lens->ideal_px.create(H, W, CV_32FC2);
  lens->row_min_y.assign(H, 0.f);
  lens->row_max_y.assign(H, 0.f);
  double x_lo = 1e300, x_hi = -1e300, y_lo = 1e300, y_hi = -1e300;
  for (int v = 0; v < H; ++v) {
    float lo = 1e30f, hi = -1e30f;
    for (int u = 0; u < W; ++u) {
      const cv::Point2d& p = ideal[static_cast<std::size_t>(v) * W + u];
      lens->ideal_px.at<cv::Vec2f>(v, u) = cv::Vec2f(static_cast<float>(p.x), static_cast<float>(p.y));
      lo = std::min(lo, static_cast<float>(p.y)), hi = std::max(hi, static_cast<float>(p.y));
      x_lo = std::min(x_lo, p.x), x_hi = std::max(x_hi, p.x);
    }
    lens->row_min_y[v] = lo, lens->row_max_y[v] = hi;
    y_lo = std::min(y_lo, static_cast<double>(lo)), y_hi = std::max(y_hi, static_cast<double>(hi));
  }
  // One pixel of margin for the bilinear lookup; at most one image size beyond each side.
  const int x0 = std::max(-W, static_cast<int>(std::floor(x_lo)) - 1),
            x1 = std::min(2 * W, static_cast<int>(std::ceil(x_hi)) + 2);
  const int y0 = std::max(-H, static_cast<int>(std::floor(y_lo)) - 1),
            y1 = std::min(2 * H, static_cast<int>(std::ceil(y_hi)) + 2);
  lens->canvas = cv::Rect(x0, y0, x1 - x0, y1 - y0);
  return lens;
}

// The lens map of the last camera seen (benches render many frames through one camera).
std::shared_ptr<const LensMap> lensMap(const PeerCamera& cam) {
  static std::mutex mutex;
  static cv::Matx33d key_K;
  static std::vector<double> key_distortion;
  static int key_w = -1, key_h = -1;
  static std::shared_ptr<const LensMap> cached;
  std::lock_guard<std::mutex> lock(mutex);
  if (!cached || key_K != cam.K || key_distortion != cam.distortion || key_w != cam.width_px ||
      key_h != cam.height_px) {
    cached = computeLensMap(cam);
    key_K = cam.K, key_distortion = cam.distortion, key_w = cam.width_px, key_h = cam.height_px;
  }
  return cached;
}

// A seeded light-grey texture: three octaves of smooth uniform noise (cells of 64, 16, 4 px).
cv::Mat proceduralBackdrop(int W, int H, unsigned seed) {
  cv::RNG rng(0x9E3779B97F4A7C15ULL ^ seed);
  cv::Mat grey(H, W, CV_32F, cv::Scalar(185.0));
  const std::array<std::pair<int, double>, 3> octaves{{{64, 22.0}, {16, 10.0}, {4, 4.0}}};
  for (const auto& [cell_px, amplitude] : octaves) {
    cv::Mat coarse(H / cell_px + 2, W / cell_px + 2, CV_32F), fine;
    rng.fill(coarse, cv::RNG::UNIFORM, -amplitude, amplitude);
    cv::resize(coarse, fine, cv::Size(W, H), 0, 0, cv::INTER_CUBIC);
    grey += fine;
  }
  cv::Mat bgr;
  cv::merge(std::vector<cv::Mat>{grey * 1.0, grey * 0.99, grey * 0.97}, bgr);
  return bgr;
}

cv::Mat backdrop(const RenderStyle& style, int W, int H) {
  if (style.background.empty()) return proceduralBackdrop(W, H, style.seed);
  cv::Mat bg = style.background;
  if (bg.type() == CV_8UC1) cv::cvtColor(bg, bg, cv::COLOR_GRAY2BGR);
  if (bg.type() != CV_8UC3)
    throw TopoError("render style background", "the image is not 8-bit BGR or grey",
                    "pass a CV_8UC3 or CV_8UC1 image, or leave it empty for the textured backdrop");
  if (bg.cols != W || bg.rows != H) cv::resize(bg, bg, cv::Size(W, H), 0, 0, cv::INTER_LINEAR);
  cv::Mat f;
  bg.convertTo(f, CV_32FC3);
  return f;
}

// A vertex in supersampled pixel coordinates with its inverse depth.
struct ScreenVertex {
  double u, v, inv_z;
};

// The pinhole image of the mesh over `rect` (ideal pixels), rasterised at `s` samples per pixel
// along each axis and box-averaged: premultiplied colour and coverage.
struct Patch {
  cv::Rect rect;   // empty: nothing of the mesh there
  cv::Mat colour;  // CV_32FC3
  cv::Mat alpha;   // CV_32F in [0, 1]
};

class Rasteriser {
 public:
  Rasteriser(const PeerCamera& cam, const cv::Rect& rect, int s)
      : rect_(rect), width_(s * rect.width), height_(s * rect.height), s_(s) {
    // Sample i of ideal pixel x: x = x0 + (i + ½)/s − ½, so i = s (x − x0) + (s − 1)/2.
    su_ = s * cam.K(0, 0), sk_ = s * cam.K(0, 1), ou_ = s * (cam.K(0, 2) - rect.x) + 0.5 * (s - 1);
    sv_ = s * cam.K(1, 1), ov_ = s * (cam.K(1, 2) - rect.y) + 0.5 * (s - 1);
    colour_ = cv::Mat(height_, width_, CV_32FC3, cv::Scalar::all(0));
    inv_z_ = cv::Mat(height_, width_, CV_32F, cv::Scalar(0));
  }

  ScreenVertex project(const Eigen::Vector3d& p) const {
    const double x = p.x() / p.z(), y = p.y() / p.z();
    return {su_ * x + sk_ * y + ou_, sv_ * y + ov_, 1.0 / p.z()};
  }

  // A face (camera frame) that crosses the near plane: clipped to z ≥ near, then rasterised.
  void face(const std::array<Eigen::Vector3d, 3>& p, const cv::Vec3f& bgr) {
    std::array<Eigen::Vector3d, 4> poly;
    int n = 0;
    for (int i = 0; i < 3; ++i) {  // Sutherland–Hodgman against the near plane
      const Eigen::Vector3d& a = p[i];
      const Eigen::Vector3d& b = p[(i + 1) % 3];
      const bool a_in = a.z() >= kNearZ_m, b_in = b.z() >= kNearZ_m;
      if (a_in) poly[n++] = a;
      if (a_in != b_in) poly[n++] = a + (b - a) * ((kNearZ_m - a.z()) / (b.z() - a.z()));
    }
    if (n < 3) return;
    std::array<ScreenVertex, 4> q;
    for (int i = 0; i < n; ++i) q[i] = project(poly[i]);
    for (int i = 1; i + 1 < n; ++i) triangle(q[0], q[i], q[i + 1], bgr);
  }

  bool outside(const std::array<ScreenVertex, 3>& q) const {
    const auto lo_v = std::min({q[0].v, q[1].v, q[2].v}), hi_v = std::max({q[0].v, q[1].v, q[2].v});
    const auto lo_u = std::min({q[0].u, q[1].u, q[2].u}), hi_u = std::max({q[0].u, q[1].u, q[2].u});
    return hi_v < 0.0 || lo_v > height_ - 1.0 || hi_u < 0.0 || lo_u > width_ - 1.0;
  }

  Patch result() const {
    Patch p{rect_, colour_, cv::Mat()};
    cv::Mat(inv_z_ > 0.f).convertTo(p.alpha, CV_32F, 1.0 / 255.0);
    if (s_ == 1) return p;
    cv::resize(colour_, p.colour, rect_.size(), 0, 0, cv::INTER_AREA);
    cv::resize(p.alpha, p.alpha, rect_.size(), 0, 0, cv::INTER_AREA);
    return p;
  }

  // Edge functions over the bounding box; a sample is inside when all barycentrics are ≥ 0.
  void triangle(const ScreenVertex& a, const ScreenVertex& b, const ScreenVertex& c, const cv::Vec3f& bgr) {
    const double area = (b.u - a.u) * (c.v - a.v) - (b.v - a.v) * (c.u - a.u);
    if (!(std::abs(area) > 1e-12)) return;
    const auto clampTo = [](double x, int hi) {
      return static_cast<int>(std::clamp(x, -1.0, static_cast<double>(hi)));
    };
    const int x0 = std::max(0, clampTo(std::ceil(std::min({a.u, b.u, c.u})), width_));
    const int x1 = std::min(width_ - 1, clampTo(std::floor(std::max({a.u, b.u, c.u})), width_));
    const int y0 = std::max(0, clampTo(std::ceil(std::min({a.v, b.v, c.v})), height_));
    const int y1 = std::min(height_ - 1, clampTo(std::floor(std::max({a.v, b.v, c.v})), height_));
    const double inv_area = 1.0 / area;
    for (int y = y0; y <= y1; ++y) {
      float* zrow = inv_z_.ptr<float>(y);
      cv::Vec3f* crow = colour_.ptr<cv::Vec3f>(y);
      for (int x = x0; x <= x1; ++x) {
        const double l0 = ((c.u - b.u) * (y - b.v) - (c.v - b.v) * (x - b.u)) * inv_area;
        const double l1 = ((a.u - c.u) * (y - c.v) - (a.v - c.v) * (x - c.u)) * inv_area;
        const double l2 = 1.0 - l0 - l1;
        if (l0 < 0.0 || l1 < 0.0 || l2 < 0.0) continue;
        const float inv_z = static_cast<float>(l0 * a.inv_z + l1 * b.inv_z + l2 * c.inv_z);
        if (inv_z > zrow[x]) zrow[x] = inv_z, crow[x] = bgr;
      }
    }
  }

 private:
  cv::Rect rect_;
  int width_, height_, s_;
  double su_, sk_, ou_, sv_, ov_;
  cv::Mat colour_, inv_z_;
};

struct Scene {
  const std::vector<Eigen::Vector3d>& vertices;
  const std::vector<Eigen::Vector3i>& triangles;
  const PeerCamera& camera;
  const RenderStyle& style;
  Eigen::Vector3d light_world;  // unit
};

// The mesh's pinhole image within `region` (ideal pixels), rasterised only over the projected
// vertices' bounding box when the whole mesh lies beyond the near plane.
Patch renderPinhole(const Scene& scene, const Eigen::Isometry3d& camera_from_body, const cv::Rect& region) {
  std::vector<Eigen::Vector3d> pc(scene.vertices.size());
  for (std::size_t i = 0; i < pc.size(); ++i) pc[i] = camera_from_body * scene.vertices[i];
  cv::Rect rect = region;
  if (std::all_of(pc.begin(), pc.end(), [](const Eigen::Vector3d& p) { return p.z() >= kNearZ_m; })) {
    const cv::Matx33d& K = scene.camera.K;
    double u_lo = 1e300, u_hi = -1e300, v_lo = 1e300, v_hi = -1e300;
    for (const Eigen::Vector3d& p : pc) {
      const double u = K(0, 0) * p.x() / p.z() + K(0, 1) * p.y() / p.z() + K(0, 2),
                   v = K(1, 1) * p.y() / p.z() + K(1, 2);
      u_lo = std::min(u_lo, u), u_hi = std::max(u_hi, u), v_lo = std::min(v_lo, v), v_hi = std::max(v_hi, v);
    }
    const auto inRegion = [](double x, int lo, int hi) {
      return static_cast<int>(std::clamp(x, double(lo), double(hi)));
    };
    const int x0 = inRegion(std::floor(u_lo) - 1, region.x, region.x + region.width);
    const int x1 = inRegion(std::ceil(u_hi) + 2, region.x, region.x + region.width);
    const int y0 = inRegion(std::floor(v_lo) - 1, region.y, region.y + region.height);
    const int y1 = inRegion(std::ceil(v_hi) + 2, region.y, region.y + region.height);
    rect = cv::Rect(x0, y0, x1 - x0, y1 - y0);
  }
  if (rect.empty()) return Patch{};
  Rasteriser raster(scene.camera, rect, scene.style.supersample);
  const Eigen::Vector3d light = scene.camera.world_from_camera.linear().transpose() * scene.light_world;
  const cv::Vec3f albedo(scene.style.object_bgr[0], scene.style.object_bgr[1], scene.style.object_bgr[2]);
  const double ambient = scene.style.ambient;
  std::vector<ScreenVertex> screen(pc.size());
  for (std::size_t i = 0; i < pc.size(); ++i)
    if (pc[i].z() >= kNearZ_m) screen[i] = raster.project(pc[i]);
  for (const Eigen::Vector3i& t : scene.triangles) {
    const std::array<Eigen::Vector3d, 3> p{pc[t[0]], pc[t[1]], pc[t[2]]};
    const int in_front = (p[0].z() >= kNearZ_m) + (p[1].z() >= kNearZ_m) + (p[2].z() >= kNearZ_m);
    if (in_front == 0) continue;
    const std::array<ScreenVertex, 3> q{screen[t[0]], screen[t[1]], screen[t[2]]};
    if (in_front == 3 && raster.outside(q)) continue;
    Eigen::Vector3d n = (p[1] - p[0]).cross(p[2] - p[0]);
    const double len = n.norm();
    if (!(len > 0.0)) continue;
    n /= len;
    if (n.dot(p[0]) > 0.0) n = -n;  // the side that faces the camera (outward for a closed mesh)
    const cv::Vec3f bgr = albedo * static_cast<float>(ambient + (1.0 - ambient) * std::max(0.0, n.dot(light)));
    if (in_front == 3)
      raster.triangle(q[0], q[1], q[2], bgr);
    else
      raster.face(p, bgr);
  }
  return raster.result();
}

void checkInputs(const std::vector<Eigen::Vector3d>& vertices, const std::vector<Eigen::Vector3i>& triangles,
                 const PeerCamera& cam, const RenderStyle& style) {
  if (vertices.empty() || triangles.empty())
    throw TopoError("peer mesh",
                    "it is empty (" + std::to_string(vertices.size()) + " vertices, " +
                        std::to_string(triangles.size()) + " triangles)",
                    "pass a closed triangle mesh with at least one triangle");
  for (std::size_t i = 0; i < vertices.size(); ++i)
    if (!vertices[i].allFinite())
      throw TopoError("peer mesh", "vertex " + std::to_string(i) + " is not finite", "remove NaN/inf vertices");
  const int n = static_cast<int>(vertices.size());
  for (std::size_t i = 0; i < triangles.size(); ++i)
    for (int k = 0; k < 3; ++k)
      if (triangles[i][k] < 0 || triangles[i][k] >= n)
        throw TopoError("peer mesh",
                        "triangle " + std::to_string(i) + " names vertex " + std::to_string(triangles[i][k]) +
                            ", outside [0, " + std::to_string(n) + ")",
                        "index the vertex list from 0");
  if (cam.width_px <= 0 || cam.height_px <= 0)
    throw TopoError(
        "peer camera",
        "the image size " + std::to_string(cam.width_px) + "×" + std::to_string(cam.height_px) + " is not positive",
        "set width_px and height_px ≥ 1");
  const cv::Matx33d& K = cam.K;
  if (!(K(0, 0) > 0.0 && K(1, 1) > 0.0 && std::isfinite(K(0, 0)) && std::isfinite(K(1, 1)) && std::isfinite(K(0, 1)) &&
        std::isfinite(K(0, 2)) && std::isfinite(K(1, 2)) && K(1, 0) == 0.0 && K(2, 0) == 0.0 && K(2, 1) == 0.0 &&
        K(2, 2) == 1.0))
    throw TopoError("peer camera K", "not an intrinsic matrix with finite positive focal lengths",
                    "use [fx s cx; 0 fy cy; 0 0 1] with fx, fy > 0");
  const std::size_t nd = cam.distortion.size();
  if (!(nd == 0 || nd == 4 || nd == 5 || nd == 8) ||
      !std::all_of(cam.distortion.begin(), cam.distortion.end(), [](double d) { return std::isfinite(d); }))
    throw TopoError("peer camera distortion", std::to_string(nd) + " coefficients (or a non-finite one)",
                    "give 0, 4, 5 or 8 finite OpenCV coefficients k1 k2 p1 p2 [k3 [k4 k5 k6]]");
  checkRigid(cam.world_from_camera, "peer camera world_from_camera", "pass a rigid camera pose");
  if (!(style.ambient >= 0.0 && style.ambient <= 1.0) || !(style.noise_sigma >= 0.0) || !(style.blur_px >= 0.0) ||
      !(style.exposure_s >= 0.0) || !(style.readout_s >= 0.0) || style.sub_samples < 1 || style.readout_bands < 0 ||
      style.supersample < 1 || style.supersample > 8 || !std::isfinite(style.exposure_s) ||
      !std::isfinite(style.readout_s) || !std::isfinite(style.noise_sigma) || !std::isfinite(style.blur_px))
    throw TopoError("render style", "a value is out of range",
                    "ambient in [0, 1]; noise, blur, exposure, readout ≥ 0 and finite; sub_samples ≥ 1; "
                    "readout_bands ≥ 0; supersample in 1..8");
  if (!(style.light_towards_world.allFinite() && style.light_towards_world.norm() > 1e-12))
    throw TopoError("render style light_towards_world", "not a finite non-zero direction",
                    "give the direction towards the light");
}

}  // namespace

PeerCamera lookAtCamera(const Eigen::Vector3d& eye, const Eigen::Vector3d& target, const Eigen::Vector3d& up,
                        double horizontal_fov_deg, int width_px, int height_px, std::vector<double> distortion) {
  if (width_px <= 0 || height_px <= 0)
    throw TopoError("lookAtCamera", "the image size is not positive", "set width and height ≥ 1");
  if (!(horizontal_fov_deg > 0.0 && horizontal_fov_deg < 180.0))
    throw TopoError("lookAtCamera", "horizontal fov " + str(horizontal_fov_deg) + "° is outside (0°, 180°)",
                    "give the field of view in degrees");
  const Eigen::Vector3d view = target - eye;
  if (!(eye.allFinite() && target.allFinite() && up.allFinite()) || !(view.norm() > 1e-12))
    throw TopoError("lookAtCamera", "the eye and the target coincide (or are not finite)",
                    "place the eye away from the target");
  const Eigen::Vector3d z = view.normalized();
  const Eigen::Vector3d x_raw = z.cross(up);  // right = forward × up
  if (!(x_raw.norm() > 1e-9 * up.norm()) || !(up.norm() > 1e-12))
    throw TopoError("lookAtCamera", "the view direction is parallel to up", "choose another up vector");
  const Eigen::Vector3d x = x_raw.normalized();
  const Eigen::Vector3d y = z.cross(x);  // down
  PeerCamera cam;
  const double f = 0.5 * width_px / std::tan(0.5 * horizontal_fov_deg * M_PI / 180.0);
  cam.K = cv::Matx33d(f, 0, 0.5 * (width_px - 1), 0, f, 0.5 * (height_px - 1), 0, 0, 1);
  cam.distortion = std::move(distortion);
  cam.world_from_camera.linear().col(0) = x;
  cam.world_from_camera.linear().col(1) = y;
  cam.world_from_camera.linear().col(2) = z;
  cam.world_from_camera.translation() = eye;
  cam.width_px = width_px, cam.height_px = height_px;
  return cam;
}

cv::Mat renderMeshFrame(const std::vector<Eigen::Vector3d>& vertices_body,
                        const std::vector<Eigen::Vector3i>& triangles,
                        const std::function<Eigen::Isometry3d(double)>& world_from_body, double t_s, int frame_index,
                        const PeerCamera& camera, const RenderStyle& style) {
  checkInputs(vertices_body, triangles, camera, style);
  if (!world_from_body) throw TopoError("peer world_from_body", "no pose function", "pass the body's pose over time");
  const int W = camera.width_px, H = camera.height_px;
  const std::shared_ptr<const LensMap> lens = lensMap(camera);
  const Scene scene{vertices_body, triangles, camera, style, style.light_towards_world.normalized()};
  const Eigen::Isometry3d camera_from_world = camera.world_from_camera.inverse();

  const int bands = style.readout_s > 0.0 ? (style.readout_bands > 0 ? std::min(style.readout_bands, H) : H) : 1;
  const int exposures = style.exposure_s > 0.0 ? style.sub_samples : 1;
  const double weight = 1.0 / exposures;
  cv::Mat colour(H, W, CV_32FC3, cv::Scalar::all(0)), alpha(H, W, CV_32F, cv::Scalar(0));
  for (int b = 0; b < bands; ++b) {
    const int r0 = static_cast<int>(static_cast<long>(b) * H / bands);
    const int r1 = static_cast<int>(static_cast<long>(b + 1) * H / bands);
    if (r1 <= r0) continue;
    const double t_band = t_s + 0.5 * (r0 + r1 - 1) / H * style.readout_s;
    // The ideal rows these output rows read (one more each side for the bilinear lookup).
    int y0 = r0, y1 = r1;
    if (!lens->identity) {
      const float lo = *std::min_element(lens->row_min_y.begin() + r0, lens->row_min_y.begin() + r1);
      const float hi = *std::max_element(lens->row_max_y.begin() + r0, lens->row_max_y.begin() + r1);
      y0 = std::max(lens->canvas.y, static_cast<int>(std::floor(lo)) - 1);
      y1 = std::min(lens->canvas.y + lens->canvas.height, static_cast<int>(std::ceil(hi)) + 2);
      if (y1 <= y0) continue;  // these rows see only what lies outside the rendered canvas
    }
    const cv::Rect region(lens->canvas.x, y0, lens->canvas.width, y1 - y0);
    for (int k = 0; k < exposures; ++k) {
      const double t = t_band + (style.exposure_s > 0.0 ? (k + 0.5) / exposures * style.exposure_s : 0.0);
      const Eigen::Isometry3d pose = world_from_body(t);
      checkRigid(pose, "peer world_from_body(" + str(t) + " s)", "return a finite rigid pose for every time");
      Patch patch = renderPinhole(scene, camera_from_world * pose, region);
      if (patch.rect.empty()) continue;
      cv::Mat colour_out = colour(patch.rect), alpha_out = alpha(patch.rect);  // ideal = output pixels
      if (!lens->identity) {
        cv::Mat map, c, a;
        cv::subtract(lens->ideal_px.rowRange(r0, r1), cv::Scalar(patch.rect.x, patch.rect.y), map);
        cv::remap(patch.colour, c, map, cv::noArray(), cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar::all(0));
        cv::remap(patch.alpha, a, map, cv::noArray(), cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(0));
        patch.colour = c, patch.alpha = a;
        colour_out = colour.rowRange(r0, r1), alpha_out = alpha.rowRange(r0, r1);
      }
      cv::scaleAdd(patch.colour, weight, colour_out, colour_out);
      cv::scaleAdd(patch.alpha, weight, alpha_out, alpha_out);
    }
  }

  // Over the backdrop: out = colour + (1 − α) · background (colour is premultiplied by coverage).
  const cv::Mat bg = backdrop(style, W, H);
  cv::Mat alpha3, image;
  cv::merge(std::vector<cv::Mat>{alpha, alpha, alpha}, alpha3);
  image = colour + bg - bg.mul(alpha3);
  if (style.blur_px > 0.0)
    cv::GaussianBlur(image, image, cv::Size(0, 0), style.blur_px, style.blur_px, cv::BORDER_REFLECT101);
  if (style.noise_sigma > 0.0) {
    cv::RNG rng(static_cast<std::uint64_t>(style.seed) * 100003ULL + static_cast<std::uint64_t>(frame_index));
    cv::Mat noise(H, W, CV_32FC3);
    rng.fill(noise, cv::RNG::NORMAL, 0.0, style.noise_sigma);
    image += noise;
  }
  cv::Mat out;
  image.convertTo(out, CV_8UC3);  // rounds and saturates to [0, 255]
  return out;
}

}  // namespace topo_gaussian::peer
