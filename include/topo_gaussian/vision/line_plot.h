// Line plots for people (the loss history of an inference run on a log axis; an observed signal
// against the simulated one): axes with ticks at 1/2/5 × 10^k (decades on a log axis), grid, axis
// labels, a title and a legend. OpenCV drawing only.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace topo_gaussian::vision {

struct PlotSeries {
  std::string label;
  std::vector<double> x, y;  ///< same size; non-finite points (and y ≤ 0 on a log axis) are skipped
  cv::Scalar bgr = cv::Scalar(160, 60, 0);
  bool markers = false;  ///< a small circle at every point
};

struct LinePlot {
  std::string title, x_label, y_label;
  bool log_y = false;
  std::vector<PlotSeries> series;
  std::vector<std::string> notes;  ///< extra lines printed under the title (e.g. "RMS difference 0.3 deg")
  int width = 1000, height = 560;
};

/// Throws TopoError when a series' x and y differ in size or nothing is plottable (no finite point;
/// on a log axis no positive y).
cv::Mat drawLinePlot(const LinePlot& plot);

}  // namespace topo_gaussian::vision
