// CameraModel: pinhole + OpenCV distortion model, rays, plane intersection and projection.
#include "topo_gaussian/vision/camera_model.h"

#include <cmath>

#include "topo_gaussian/common/error.h"

namespace topo_gaussian::vision {
namespace {

/// OpenCV's forward distortion of normalised coordinates (k1 k2 p1 p2 k3 k4 k5 k6, missing = 0).
cv::Point2d distort(const cv::Point2d& p, const double* k) {
  const double x = p.x, y = p.y, r2 = x * x + y * y, r4 = r2 * r2, r6 = r4 * r2;
  const double radial = (1 + k[0] * r2 + k[1] * r4 + k[4] * r6) / (1 + k[5] * r2 + k[6] * r4 + k[7] * r6);
  return {x * radial + 2 * k[2] * x * y + k[3] * (r2 + 2 * x * x),
          y * radial + k[2] * (r2 + 2 * y * y) + 2 * k[3] * x * y};
}

std::string pixelText(const cv::Point2d& p) {
  return "pixel (" + std::to_string(p.x) + ", " + std::to_string(p.y) + ")";
}

}  // namespace

CameraModel::CameraModel(const cv::Matx33d& K, const std::vector<double>& dist, const cv::Matx33d& R_wc,
                         const cv::Vec3d& t_wc)
    : K_(K), dist_(dist), R_wc_(R_wc), t_wc_(t_wc) {
  if (!(K(0, 0) > 0) || !(K(1, 1) > 0) || std::abs(K(2, 2) - 1.0) > 1e-9 || K(1, 0) != 0 || K(2, 0) != 0 ||
      K(2, 1) != 0)
    throw TopoError("camera matrix K", "needs positive focal lengths fx, fy, a zero lower triangle and K(2,2) = 1",
                    "give K = [fx s cx; 0 fy cy; 0 0 1] from a calibration");
  const std::size_t n = dist.size();
  if (!(n == 0 || n == 4 || n == 5 || n == 8))
    throw TopoError("distortion coefficients (" + std::to_string(n) + " given)", "have an unsupported count",
                    "give 0, 4, 5 or 8 OpenCV coefficients (k1 k2 p1 p2 [k3 [k4 k5 k6]])");
  const cv::Matx33d RtR = R_wc.t() * R_wc;
  if (cv::norm(RtR - cv::Matx33d::eye()) > 1e-6 || cv::determinant(R_wc) < 0)
    throw TopoError("camera rotation R", "is not a rotation matrix", "give an orthonormal R with det(R) = +1");
}

cv::Point2d CameraModel::normalised(const cv::Point2d& pixel) const {
  // invert K (upper triangular)
  const double fx = K_(0, 0), s = K_(0, 1), cx = K_(0, 2), fy = K_(1, 1), cy = K_(1, 2);
  const double yd = (pixel.y - cy) / fy;
  const double xd = (pixel.x - cx - s * yd) / fx;
  if (dist_.empty()) return {xd, yd};
  double k[8] = {0, 0, 0, 0, 0, 0, 0, 0};
  for (std::size_t i = 0; i < dist_.size(); ++i) k[i] = dist_[i];
  // Newton iterations on distort(p) = (xd, yd) with a numeric Jacobian (converges to ~1e-15)
  cv::Point2d p(xd, yd);
  for (int it = 0; it < 50; ++it) {
    const cv::Point2d f = distort(p, k) - cv::Point2d(xd, yd);
    if (std::hypot(f.x, f.y) < 1e-15) break;
    const double h = 1e-7;
    const cv::Point2d fx1 = distort(p + cv::Point2d(h, 0), k) - cv::Point2d(xd, yd);
    const cv::Point2d fy1 = distort(p + cv::Point2d(0, h), k) - cv::Point2d(xd, yd);
    const double a = (fx1.x - f.x) / h, b = (fy1.x - f.x) / h, c = (fx1.y - f.y) / h, d = (fy1.y - f.y) / h;
    const double det = a * d - b * c;
    if (std::abs(det) < 1e-300) break;
    p.x -= (d * f.x - b * f.y) / det;
    p.y -= (-c * f.x + a * f.y) / det;
  }
  return p;
}

cv::Vec3d CameraModel::rayCamera(const cv::Point2d& pixel) const {
  const cv::Point2d n = normalised(pixel);
  const cv::Vec3d r(n.x, n.y, 1.0);
  return r / cv::norm(r);
}

cv::Vec3d CameraModel::rayWorld(const cv::Point2d& pixel) const { return R_wc_ * rayCamera(pixel); }

cv::Vec3d CameraModel::intersectPlane(const cv::Point2d& pixel, const cv::Vec3d& n, double d) const {
  const cv::Vec3d r = rayWorld(pixel);
  const double denom = n.dot(r);
  if (std::abs(denom) < 1e-12 * cv::norm(n))
    throw TopoError(pixelText(pixel), "its ray is parallel to the plane", "check the plane and the camera pose");
  const double s = (d - n.dot(t_wc_)) / denom;
  if (s <= 0)
    throw TopoError(pixelText(pixel), "the plane lies behind the camera along its ray",
                    "check the plane and the camera pose");
  return t_wc_ + s * r;
}

std::vector<cv::Point2d> CameraModel::project(const std::vector<cv::Vec3d>& world) const {
  const cv::Matx33d R_cw = R_wc_.t();
  double k[8] = {0, 0, 0, 0, 0, 0, 0, 0};
  for (std::size_t i = 0; i < dist_.size(); ++i) k[i] = dist_[i];
  std::vector<cv::Point2d> out;
  out.reserve(world.size());
  for (const auto& w : world) {
    const cv::Vec3d c = R_cw * (w - t_wc_);
    if (!(c[2] > 0))
      throw TopoError(
          "world point (" + std::to_string(w[0]) + ", " + std::to_string(w[1]) + ", " + std::to_string(w[2]) + ")",
          "lies behind the camera", "only project points in front of the camera");
    const cv::Point2d p = distort(cv::Point2d(c[0] / c[2], c[1] / c[2]), k);
    out.emplace_back(K_(0, 0) * p.x + K_(0, 1) * p.y + K_(0, 2), K_(1, 1) * p.y + K_(1, 2));
  }
  return out;
}

cv::Point2d CameraModel::project(const cv::Vec3d& world) const { return project(std::vector<cv::Vec3d>{world})[0]; }

double tiltInPlaneDeg(const PlaneView& view, const cv::Point2d& pixel, double image_axis_deg) {
  const cv::Vec3d n0(view.plane[0], view.plane[1], view.plane[2]);
  const double nn = cv::norm(n0);
  if (!(nn > 0)) throw TopoError("the motion plane", "has a zero normal", "give [nx, ny, nz, d] with a normal");
  const cv::Vec3d n = n0 / nn;
  const double d = view.plane[3] / nn;
  cv::Vec3d u = view.up - view.up.dot(n) * n;
  if (!(cv::norm(u) > 1e-6 * cv::norm(view.up)))
    throw TopoError("the motion plane", "is horizontal (its normal is along up): a tilt in it has no up",
                    "give the vertical plane the object's axis moves in");
  u /= cv::norm(u);
  const double a = image_axis_deg * CV_PI / 180.0, h = 10.0;
  const cv::Point2d along(std::sin(a), -std::cos(a));  // image-up at a = 0
  const auto on = [&](const cv::Point2d& p) { return view.camera.intersectPlane(p, n, d); };
  const cv::Vec3d v = on(pixel + h * along) - on(pixel - h * along);
  const cv::Vec3d right = on(pixel + cv::Point2d(h, 0)) - on(pixel - cv::Point2d(h, 0));
  cv::Vec3d s = n.cross(u);
  if (s.dot(right) < 0) s = -s;
  return std::atan2(v.dot(s), v.dot(u)) * 180.0 / CV_PI;
}

}  // namespace topo_gaussian::vision
