// Helpers shared by the figures topo_gaussian draws for people (interior slices, loss and signal
// plots): writing a PNG with an error that names the file, "nice" steps for ticks and scale bars
// (1, 2 or 5 × 10^k) and a length with its unit.
#pragma once

#include <opencv2/core.hpp>
#include <string>

namespace topo_gaussian::vision {

/// Writes img as PNG. Throws TopoError naming the path when it cannot be written.
void writePng(const cv::Mat& img, const std::string& path);

/// The largest 1, 2 or 5 × 10^k that is ≤ limit (limit > 0).
double niceStepBelow(double limit);
/// The smallest 1, 2 or 5 × 10^k that is ≥ limit (limit > 0).
double niceStepAbove(double limit);

/// A length in metres as people read it: "5 mm", "2 cm", "0.5 m".
std::string lengthText(double metres);

/// putText with the figures' font (Hershey simplex, anti-aliased); scale 0.5 ≈ 11 px high.
void drawText(cv::Mat& img, const std::string& text, cv::Point at, double scale = 0.5,
              const cv::Scalar& bgr = cv::Scalar(20, 20, 20), int thickness = 1);

}  // namespace topo_gaussian::vision
