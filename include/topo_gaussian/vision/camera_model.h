// Pinhole camera with lens distortion: pixels → normalised rays, the intersection of a pixel's ray
// with a known world plane (camera pose R, t: world ← camera), and the projection of world points into
// pixels. The distortion is OpenCV's model (k1 k2 p1 p2 [k3 [k4 k5 k6]]), evaluated here (same
// formulas as cv::projectPoints / iterative cv::undistortPoints) because topo_vision does not link
// opencv_calib3d. Used to turn tracked pixels into
// metric positions on a table or wall plane.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

namespace topo_gaussian::vision {

class CameraModel {
 public:
  CameraModel() = default;
  /// K: 3x3 intrinsics; dist: 0, 4, 5 or 8 OpenCV distortion coefficients (may be empty);
  /// R_wc, t_wc: pose of the camera in the world (x_world = R_wc x_cam + t_wc). Throws TopoError for
  /// malformed matrices.
  CameraModel(const cv::Matx33d& K, const std::vector<double>& dist, const cv::Matx33d& R_wc = cv::Matx33d::eye(),
              const cv::Vec3d& t_wc = cv::Vec3d(0, 0, 0));

  const cv::Matx33d& K() const { return K_; }
  const std::vector<double>& distortion() const { return dist_; }
  cv::Matx33d rotationWorldFromCamera() const { return R_wc_; }
  cv::Vec3d cameraCentreWorld() const { return t_wc_; }

  /// Undistorted normalised image coordinates (x/z, y/z) in the camera frame.
  cv::Point2d normalised(const cv::Point2d& pixel) const;
  /// Unit ray direction in the camera frame and in the world frame.
  cv::Vec3d rayCamera(const cv::Point2d& pixel) const;
  cv::Vec3d rayWorld(const cv::Point2d& pixel) const;
  /// Intersection of the pixel's ray with the plane n·x = d (world). Throws TopoError when the ray is
  /// parallel to the plane or the plane lies behind the camera.
  cv::Vec3d intersectPlane(const cv::Point2d& pixel, const cv::Vec3d& plane_normal, double plane_d) const;
  /// Pixel of a world point (with distortion). Throws TopoError for points behind the camera.
  cv::Point2d project(const cv::Vec3d& world) const;
  std::vector<cv::Point2d> project(const std::vector<cv::Vec3d>& world) const;

 private:
  cv::Matx33d K_ = cv::Matx33d::eye();
  std::vector<double> dist_;
  cv::Matx33d R_wc_ = cv::Matx33d::eye();
  cv::Vec3d t_wc_{0, 0, 0};
};

/// A camera looking at an object whose axis moves in a known plane (a tumbler rocking about one
/// horizontal axis, a pendulum's swing plane): the camera (pose in the plane's frame), the plane
/// n·x = d and the frame's up (−gravity), all in the same frame.
struct PlaneView {
  CameraModel camera;
  cv::Vec4d plane{1, 0, 0, 0};  ///< [nx, ny, nz, d]
  cv::Vec3d up{0, 0, 1};
};

/// The tilt in the plane of a line seen in the image: the line through `pixel` at `image_axis_deg`
/// (from image-up, + towards image-right) is cast through the camera onto view.plane (two pixels
/// 10 px either side of `pixel`), and its angle there measured from `up` projected into the plane,
/// + towards the side that images to the right [deg]. Perspective, not orthographic: a camera
/// tilted towards the plane or off its centre reads the plane's angle, not the image's. Throws
/// TopoError when the rays miss the plane or `up` is along its normal.
double tiltInPlaneDeg(const PlaneView& view, const cv::Point2d& pixel, double image_axis_deg);

}  // namespace topo_gaussian::vision
