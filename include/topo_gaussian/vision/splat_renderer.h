// Splat renderer: world-frame particles drawn as shaded discs into a BGR image for a pinhole camera,
// as a camera would see the opaque object (the rig twin's "camera driver"). OpenCV + Eigen only.
//
// Conventions: the camera is an ideal pinhole (no distortion) with intrinsics fx fy cx cy, integer
// pixel coordinates at pixel centres (OpenCV, ROS CameraInfo: u = fx x/z + cx). Its pose is that of
// the optical frame in the world (x right, y down, z forward): x_world = R_wc x_cam + t_wc.
// Each splat is a sphere of radius `radius_m` around its particle, seen from the camera: a disc of
// radius fx·r/z × fy·r/z pixels, with the sphere's depth per pixel in a z-buffer (the nearest wins),
// shaded once per splat with Lambert + ambient light from its outward normal:
//   colour · (ambient + diffuse · max(0, n · l)),  l the unit direction towards the light (world),
// then optional Gaussian pixel noise (reproducible from its seed).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <vector>

namespace topo_gaussian::vision {

struct SplatCamera {
  int width = 640, height = 480;
  double fx = 500.0, fy = 500.0, cx = 319.5, cy = 239.5;  ///< [px]
  Eigen::Matrix3d R_wc = Eigen::Matrix3d::Identity();     ///< optical frame → world rotation
  Eigen::Vector3d t_wc = Eigen::Vector3d::Zero();         ///< optical frame origin in the world [m]
  double near_m = 1e-3;                                   ///< splats closer than this are not drawn

  /// Throws TopoError for a non-positive size or focal length, non-finite values or a rotation
  /// that is not orthonormal.
  void validate() const;
  /// Camera-frame coordinates of a world point.
  Eigen::Vector3d toCamera(const Eigen::Vector3d& world) const { return R_wc.transpose() * (world - t_wc); }
};

/// Rotation of an optical frame (x right, y down, z forward) at `eye` looking at `target`, with
/// image-up along the projection of `up` (world). Throws TopoError when eye = target or the view
/// direction is parallel to up.
Eigen::Matrix3d lookAtRotation(const Eigen::Vector3d& eye, const Eigen::Vector3d& target,
                               const Eigen::Vector3d& up = Eigen::Vector3d::UnitZ());

/// Defaults: light from −x and above (the side of the rig twin's default camera), soft shading.
/// Silhouette trackers threshold a blurred image, so an outline whose grey level varies with the
/// shading moves by a fraction of a pixel where it is lit: with ambient 0.35 / diffuse 0.65 the
/// tracked tilt of the twin came out 0.66 % small, with 0.55 / 0.45 and a dark object 0.14 %.
struct SplatShading {
  Eigen::Vector3d light_dir_world = Eigen::Vector3d(-1.0, 0.0, 1.0);  ///< towards the light (normalised here)
  double ambient = 0.55;
  double diffuse = 0.45;
  cv::Scalar background_bgr = cv::Scalar(235, 235, 235);
  double noise_sigma = 0.0;  ///< Gaussian pixel noise, grey levels (0 = none)
  unsigned noise_seed = 1;   ///< the same seed gives the same noise
};

/// Particles to draw, world frame. colours: one per particle, or one for all (BGR 0..255).
struct Splats {
  std::vector<Eigen::Vector3d> positions;  ///< [m]
  std::vector<Eigen::Vector3d> normals;    ///< outward unit normals (zero: shaded with ambient only)
  std::vector<cv::Vec3b> colours;
  double radius_m = 0.002;
};

/// Renders the splats (CV_8UC3, camera.height × camera.width). Throws TopoError for an invalid
/// camera or mismatched array sizes, naming the array. `depth_out` (optional) receives the z-buffer
/// (CV_32F, metres along the optical axis, +inf where nothing was drawn).
cv::Mat renderSplats(const SplatCamera& camera, const Splats& splats, const SplatShading& shading,
                     cv::Mat* depth_out = nullptr);

}  // namespace topo_gaussian::vision
