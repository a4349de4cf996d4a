// The peer world's camera: an independent z-buffer rasteriser of a triangle mesh. A pixel's colour is
// albedo · (ambient + (1 − ambient) · max(0, n·l)) for the nearest face whose projection
// u = fx x/z + cx, v = fy y/z + cy covers it (flat shading, n the face normal turned towards the
// camera, depth by 1/z interpolated in screen space), supersampled and box-averaged for antialiased
// edges; then a real lens (OpenCV's k1 k2 p1 p2 [k3 [k4 k5 k6]] model: each output pixel samples the
// ideal image where cv::undistortPoints puts it), a backdrop, Gaussian optics blur and Gaussian pixel
// noise. Exposure (motion blur) and rolling-shutter readout are rendered from the mesh at their times.
// It is the ground truth our tracker is tested against, so it uses nothing of this package's
// vision code: OpenCV (core, imgproc, calib3d) and Eigen only. Pixel centres are integer coordinates.
#pragma once

#include <Eigen/Geometry>
#include <functional>
#include <opencv2/core.hpp>
#include <vector>

namespace topo_gaussian::peer {

/// A perspective camera. Camera frame: x right, y down, z forward (OpenCV's optical frame).
struct PeerCamera {
  cv::Matx33d K = cv::Matx33d::eye();  ///< intrinsics [px]: fx 0 cx; 0 fy cy; 0 0 1
  std::vector<double> distortion;      ///< OpenCV k1 k2 p1 p2 [k3 [k4 k5 k6]]: 0, 4, 5 or 8 values
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();  ///< x_world = T x_camera [m]
  int width_px = 640, height_px = 480;
};

/// A camera at `eye` [m] looking at `target` [m] with the world's `up` appearing upwards (image −y),
/// fx = fy = (width/2) / tan(fov/2), principal point at the image centre ((w−1)/2, (h−1)/2).
/// Throws TopoError when eye = target, the view is parallel to up, fov ∉ (0°, 180°) or a size ≤ 0.
PeerCamera lookAtCamera(const Eigen::Vector3d& eye, const Eigen::Vector3d& target, const Eigen::Vector3d& up,
                        double horizontal_fov_deg, int width_px, int height_px, std::vector<double> distortion = {});

struct RenderStyle {
  cv::Vec3b object_bgr{40, 40, 150};                     ///< albedo of the object
  Eigen::Vector3d light_towards_world{0.3, -0.4, 0.85};  ///< direction towards the light (world; normalised here)
  double ambient = 0.35;                                 ///< shade = ambient + (1 − ambient) max(0, n·l), in [0, 1]
  cv::Mat background;        ///< BGR (or grey) image, resized to the output; empty: a seeded textured backdrop
  double noise_sigma = 2.0;  ///< Gaussian pixel noise [grey levels], seeded by seed·100003 + frame index
  double blur_px = 0.7;      ///< Gaussian blur sigma [px] of the optics, 0 = none
  double exposure_s = 0.0;   ///< row r integrates over [t_r, t_r + exposure_s] (motion blur); 0 = instantaneous
  double readout_s = 0.0;    ///< rolling shutter: row r starts its exposure at t_r = t + r/height · readout_s
  int sub_samples = 4;       ///< sub-frames averaged over the exposure, at t_r + (k + ½)/n · exposure_s
  int readout_bands = 0;     ///< rows rendered at one shared time (their middle row's); 0 = every row its own
  int supersample = 4;       ///< samples per pixel along each axis (antialiasing), 1..8
  unsigned seed = 1;         ///< backdrop texture and noise
};

/// Renders the mesh (vertices in the body frame [m], triangles as vertex indices; closed meshes
/// outward-oriented, open ones are shaded two-sided) at the body pose world_from_body(time) for the
/// frame whose row 0 starts its exposure at t_s; frame_index seeds the noise. Returns CV_8UC3 BGR.
/// Throws TopoError for an empty mesh, indices out of range, non-finite vertices or poses, a camera
/// with a non-positive size or focal length or an uninvertible lens, or a style out of range.
cv::Mat renderMeshFrame(const std::vector<Eigen::Vector3d>& vertices_body,
                        const std::vector<Eigen::Vector3i>& triangles,
                        const std::function<Eigen::Isometry3d(double)>& world_from_body, double t_s, int frame_index,
                        const PeerCamera& camera, const RenderStyle& style);

}  // namespace topo_gaussian::peer
