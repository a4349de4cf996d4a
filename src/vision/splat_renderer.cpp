// Splat renderer: particles → shaded, z-buffered discs in a pinhole image.
#include "topo_gaussian/vision/splat_renderer.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "topo_gaussian/common/error.h"

namespace topo_gaussian::vision {

void SplatCamera::validate() const {
  if (width <= 0 || height <= 0)
    throw TopoError("camera size " + std::to_string(width) + "x" + std::to_string(height),
                    "width and height must be positive", "give the image size in pixels, e.g. 640x480");
  if (!(fx > 0) || !(fy > 0) || !std::isfinite(fx) || !std::isfinite(fy))
    throw TopoError(
        "camera focal length",
        "fx and fy must be positive and finite (got " + std::to_string(fx) + ", " + std::to_string(fy) + ")",
        "give the focal length in pixels");
  if (!std::isfinite(cx) || !std::isfinite(cy) || !R_wc.allFinite() || !t_wc.allFinite())
    throw TopoError("camera", "principal point or pose is not finite", "give finite intrinsics and pose");
  if ((R_wc.transpose() * R_wc - Eigen::Matrix3d::Identity()).norm() > 1e-6 || R_wc.determinant() < 0)
    throw TopoError("camera rotation", "is not a rotation matrix (orthonormal, determinant +1)",
                    "normalise the orientation quaternion of the camera pose");
}

Eigen::Matrix3d lookAtRotation(const Eigen::Vector3d& eye, const Eigen::Vector3d& target, const Eigen::Vector3d& up) {
  const Eigen::Vector3d z = target - eye;
  if (!(z.norm() > 0) || !z.allFinite())
    throw TopoError("camera look-at", "the eye and the target coincide", "place the camera away from what it looks at");
  const Eigen::Vector3d zn = z.normalized(), x = zn.cross(up);
  if (!(x.norm() > 1e-9 * up.norm()))
    throw TopoError("camera look-at", "the view direction is parallel to the up direction",
                    "look at the target from the side, or give another up direction");
  const Eigen::Vector3d xn = x.normalized();
  Eigen::Matrix3d R;
  R.col(0) = xn;            // image right
  R.col(1) = zn.cross(xn);  // image down
  R.col(2) = zn;            // forward
  return R;
}

cv::Mat renderSplats(const SplatCamera& cam, const Splats& s, const SplatShading& shading, cv::Mat* depth_out) {
  cam.validate();
  const std::size_t n = s.positions.size();
  if (s.normals.size() != n)
    throw TopoError("splat normals",
                    "has " + std::to_string(s.normals.size()) + " entries for " + std::to_string(n) + " positions",
                    "give one normal per particle");
  if (s.colours.size() != n && s.colours.size() != 1)
    throw TopoError("splat colours",
                    "has " + std::to_string(s.colours.size()) + " entries for " + std::to_string(n) + " positions",
                    "give one colour per particle or a single colour for all");
  if (!(s.radius_m > 0) || !std::isfinite(s.radius_m))
    throw TopoError("splat radius", "must be positive (got " + std::to_string(s.radius_m) + " m)",
                    "use about the particle spacing");
  if (!(shading.noise_sigma >= 0))
    throw TopoError("noise sigma", "must be ≥ 0 (got " + std::to_string(shading.noise_sigma) + ")", "use 0 for none");

  cv::Mat img(cam.height, cam.width, CV_8UC3, shading.background_bgr);
  cv::Mat depth(cam.height, cam.width, CV_32F, cv::Scalar(std::numeric_limits<float>::infinity()));
  Eigen::Vector3d light = shading.light_dir_world;
  if (light.norm() > 0) light.normalize();
  const Eigen::Matrix3d R_cw = cam.R_wc.transpose();
  const double r = s.radius_m;
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d pc = R_cw * (s.positions[i] - cam.t_wc);
    const double z = pc.z();
    if (!(z > cam.near_m + r)) continue;
    const double u = cam.fx * pc.x() / z + cam.cx, v = cam.fy * pc.y() / z + cam.cy;
    const double rx = cam.fx * r / z, ry = cam.fy * r / z;
    const int u0 = std::max(0, static_cast<int>(std::ceil(u - rx))),
              u1 = std::min(cam.width - 1, static_cast<int>(std::floor(u + rx)));
    const int v0 = std::max(0, static_cast<int>(std::ceil(v - ry))),
              v1 = std::min(cam.height - 1, static_cast<int>(std::floor(v + ry)));
    if (u0 > u1 || v0 > v1) continue;
    const double lambert = std::max(0.0, s.normals[i].dot(light));
    const double k = std::min(1.0, shading.ambient + shading.diffuse * lambert);
    const cv::Vec3b& base = s.colours.size() == 1 ? s.colours[0] : s.colours[i];
    const cv::Vec3b c(cv::saturate_cast<uchar>(base[0] * k), cv::saturate_cast<uchar>(base[1] * k),
                      cv::saturate_cast<uchar>(base[2] * k));
    for (int y = v0; y <= v1; ++y) {
      const double dy = (y - v) / ry;
      float* zrow = depth.ptr<float>(y);
      cv::Vec3b* row = img.ptr<cv::Vec3b>(y);
      for (int x = u0; x <= u1; ++x) {
        const double dx = (x - u) / rx, d2 = dx * dx + dy * dy;
        if (d2 > 1.0) continue;
        const float zp = static_cast<float>(z - r * std::sqrt(1.0 - d2));  // the sphere's front surface
        if (zp >= zrow[x]) continue;
        zrow[x] = zp;
        row[x] = c;
      }
    }
  }
  if (shading.noise_sigma > 0) {
    cv::RNG rng(shading.noise_seed);
    cv::Mat noise(img.size(), CV_16SC3), tmp;
    rng.fill(noise, cv::RNG::NORMAL, cv::Scalar::all(0), cv::Scalar::all(shading.noise_sigma));
    img.convertTo(tmp, CV_16SC3);
    tmp += noise;
    tmp.convertTo(img, CV_8UC3);  // saturating
  }
  if (depth_out) *depth_out = depth;
  return img;
}

}  // namespace topo_gaussian::vision
