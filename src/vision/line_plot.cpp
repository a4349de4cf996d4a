#include "topo_gaussian/vision/line_plot.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/number_text.h"
#include "topo_gaussian/vision/figure.h"

namespace topo_gaussian::vision {

namespace {

const cv::Scalar kInk(20, 20, 20);
const cv::Scalar kGrid(225, 225, 225);

bool usable(double x, double y, bool log_y) { return std::isfinite(x) && std::isfinite(y) && (!log_y || y > 0.0); }

}  // namespace

cv::Mat drawLinePlot(const LinePlot& p) {
  double x0 = std::numeric_limits<double>::infinity(), x1 = -x0, y0 = x0, y1 = -x0;
  std::size_t points = 0, skipped = 0;
  for (const PlotSeries& s : p.series) {
    if (s.x.size() != s.y.size())
      throw TopoError("plot '" + p.title + "'",
                      "series '" + s.label + "' has " + std::to_string(s.x.size()) + " x values and " +
                          std::to_string(s.y.size()) + " y values",
                      "give one y per x");
    for (std::size_t i = 0; i < s.x.size(); ++i) {
      if (!usable(s.x[i], s.y[i], p.log_y)) {
        ++skipped;
        continue;
      }
      const double y = p.log_y ? std::log10(s.y[i]) : s.y[i];
      x0 = std::min(x0, s.x[i]), x1 = std::max(x1, s.x[i]);
      y0 = std::min(y0, y), y1 = std::max(y1, y);
      ++points;
    }
  }
  if (points == 0)
    throw TopoError("plot '" + p.title + "'",
                    p.log_y ? "has no finite positive value to plot on a log axis" : "has no finite point",
                    "check the input data");
  if (x1 - x0 <= 0.0) x0 -= 0.5, x1 += 0.5;
  if (p.log_y) {
    y0 = std::floor(y0 + 1e-9);
    y1 = std::ceil(y1 - 1e-9);
    if (y1 <= y0) y1 = y0 + 1;
  } else {
    if (y1 - y0 <= 0.0) {
      const double d = std::max(1e-12, 0.1 * std::abs(y0));
      y0 -= d, y1 += d;
    }
    const double pad = 0.06 * (y1 - y0);
    y0 -= pad, y1 += pad;
  }

  std::vector<std::string> notes = p.notes;
  if (skipped && p.log_y) notes.push_back(std::to_string(skipped) + " points <= 0 or not finite are not shown");
  const int W = std::max(300, p.width), H = std::max(200, p.height);
  const int L = 90, R = 30, T = 66 + 20 * int(notes.size()), B = 58;
  cv::Mat img(H, W, CV_8UC3, cv::Scalar(255, 255, 255));
  auto px = [&](double x) { return L + int(std::lround((x - x0) / (x1 - x0) * (W - L - R))); };
  auto py = [&](double y) { return H - B - int(std::lround((y - y0) / (y1 - y0) * (H - T - B))); };

  // Grid and ticks.
  const double xs = niceStepAbove((x1 - x0) / 8.0);
  for (double x = std::ceil(x0 / xs - 1e-9) * xs; x <= x1 + 1e-9 * xs; x += xs) {
    cv::line(img, cv::Point(px(x), T), cv::Point(px(x), H - B), kGrid, 1);
    const std::string t = numberText(std::abs(x) < 1e-12 * xs ? 0.0 : x);
    drawText(img, t, cv::Point(px(x) - 4 * int(t.size()), H - B + 20), 0.45, kInk);
  }
  if (p.log_y) {
    const int decades = int(std::lround(y1 - y0));
    const int every = std::max(1, decades / 8);
    for (int k = int(y0); k <= int(y1); ++k) {
      if (decades <= 2)
        for (double m : {2.0, 5.0})
          if (k + std::log10(m) < y1)
            cv::line(img, cv::Point(L, py(k + std::log10(m))), cv::Point(W - R, py(k + std::log10(m))), kGrid, 1);
      if ((k - int(y0)) % every) continue;
      cv::line(img, cv::Point(L, py(k)), cv::Point(W - R, py(k)), kGrid, 1);
      drawText(img, numberText(std::pow(10.0, k), 3), cv::Point(8, py(k) + 5), 0.45, kInk);
    }
  } else {
    const double ys = niceStepAbove((y1 - y0) / 6.0);
    for (double y = std::ceil(y0 / ys - 1e-9) * ys; y <= y1 + 1e-9 * ys; y += ys) {
      cv::line(img, cv::Point(L, py(y)), cv::Point(W - R, py(y)), kGrid, 1);
      drawText(img, numberText(std::abs(y) < 1e-12 * ys ? 0.0 : y), cv::Point(8, py(y) + 5), 0.45, kInk);
    }
  }
  cv::rectangle(img, cv::Point(L, T), cv::Point(W - R, H - B), kInk, 1);

  // Series.
  for (const PlotSeries& s : p.series) {
    bool have = false;
    cv::Point last;
    for (std::size_t i = 0; i < s.x.size(); ++i) {
      if (!usable(s.x[i], s.y[i], p.log_y)) {
        have = false;
        continue;
      }
      const cv::Point q(px(s.x[i]), py(p.log_y ? std::log10(s.y[i]) : s.y[i]));
      if (have) cv::line(img, last, q, s.bgr, 2, cv::LINE_AA);
      if (s.markers) cv::circle(img, q, 3, s.bgr, cv::FILLED, cv::LINE_AA);
      last = q;
      have = true;
    }
  }

  // Labels, title, notes, legend.
  drawText(img, p.title, cv::Point(L, 26), 0.65, kInk, 2);
  for (std::size_t k = 0; k < notes.size(); ++k) drawText(img, notes[k], cv::Point(L, 48 + 20 * int(k)), 0.48, kInk);
  drawText(img, p.y_label + (p.log_y ? " (log scale)" : ""), cv::Point(L, T - 8), 0.5, kInk);
  const int xl = int(p.x_label.size()) * 9;
  drawText(img, p.x_label, cv::Point((L + W - R) / 2 - xl / 2, H - 16), 0.5, kInk);
  int ly = T + 22;
  for (const PlotSeries& s : p.series) {
    if (s.label.empty()) continue;
    const int lx = W - R - 20 - 9 * int(s.label.size()) - 40;
    cv::line(img, cv::Point(lx, ly - 5), cv::Point(lx + 30, ly - 5), s.bgr, 3, cv::LINE_AA);
    drawText(img, s.label, cv::Point(lx + 38, ly), 0.5, kInk);
    ly += 22;
  }
  return img;
}

}  // namespace topo_gaussian::vision
