// Synthetic scenes with known motion, rendered with OpenCV, for tests and benchmarks: a pendulum
// or tumbler swinging with a known period, amplitude, equilibrium and damping, and a two-segment
// soft finger bending to a known angle; with noise, blur and a moving background on request.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace topo_gaussian::vision {

struct PendulumScene {
  int width = 640, height = 480;
  double fps = 30.0;
  double duration_s = 6.0;
  double period_s = 1.2;
  double amplitude_deg = 15.0;               ///< initial swing about the equilibrium
  double equilibrium_deg = 0.0;              ///< 0 = hanging straight down (image +y)
  double damping_ratio = 0.0;                ///< exponential decay of the amplitude
  cv::Point2d pivot = cv::Point2d(320, 60);  ///< pixels
  double length_px = 300.0;                  ///< pivot → bob centre
  double bob_radius_px = 25.0;
  cv::Scalar bob_bgr = cv::Scalar(0, 0, 230);  ///< red bob (the marker)
  double rod_width_px = 6.0;                   ///< a dark rod from the pivot to the bob (the silhouette)
  double noise_sigma = 0.0;                    ///< Gaussian pixel noise (grey levels)
  double blur_px = 0.0;                        ///< Gaussian blur sigma
  bool moving_background = false;              ///< a drifting texture behind the pendulum
  unsigned seed = 1;
};

/// Angle (degrees) of the pendulum at time t: equilibrium + A e^{−ζωt} cos(ωt'), measured from
/// image-down towards image-right.
double pendulumAngleDeg(const PendulumScene& scene, double t);
std::vector<cv::Mat> renderPendulum(const PendulumScene& scene);

struct FingerScene {
  int width = 640, height = 480;
  double fps = 30.0;
  double duration_s = 2.0;
  cv::Point2d base = cv::Point2d(120, 240);
  double base_angle_deg = 0.0;   ///< direction of the base segment (0 = image +x)
  double final_bend_deg = 40.0;  ///< tip direction minus base direction at the end
  double segment_px = 180.0;     ///< length of each of the two segments
  double width_px = 40.0;
  cv::Scalar body_bgr = cv::Scalar(40, 160, 40);
  double noise_sigma = 0.0;
  unsigned seed = 1;
};

/// Bend (degrees) at time t: ramps smoothly from 0 to final_bend_deg over the first 70 % of the clip.
double fingerBendDeg(const FingerScene& scene, double t);
std::vector<cv::Mat> renderFinger(const FingerScene& scene);

/// Writes frames with OpenCV's VideoWriter (".avi": MJPG, ".mp4": mp4v). Throws TopoError naming
/// the path when the writer cannot open it.
void writeVideo(const std::vector<cv::Mat>& frames, double fps, const std::string& path);

}  // namespace topo_gaussian::vision
