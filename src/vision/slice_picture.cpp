#include "topo_gaussian/vision/slice_picture.h"

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
const cv::Scalar kFrame(190, 190, 190);
const char* const kAxisName[3] = {"x", "y", "z"};

/// In-plane axes (u, v) of a slice normal to `axis`: z → (x, y), y → (x, z), x → (y, z).
void planeAxes(int axis, int* u, int* v) {
  *u = axis == 0 ? 1 : 0;
  *v = axis == 2 ? 1 : 2;
}

struct Lattice {
  Eigen::Vector3d lo, hi;
  double h;
  int layer(const Eigen::Vector3d& x, int axis) const { return int(std::lround((x[axis] - lo[axis]) / h)); }
  int layers(int axis) const { return layer(hi, axis) + 1; }
};

struct Panel {
  int axis = 2;   ///< slice normal
  int layer = 0;  ///< lattice layer along the normal
  std::string caption;
  cv::Rect rect;  ///< whole panel (caption, drawing, scale strip)
};

constexpr int kCaption = 24, kStrip = 34, kMargin = 10;

/// Pixels per metre that fit every panel's (u, v) extent into its drawing area.
double fitScale(const std::vector<Panel>& panels, const Lattice& L) {
  double s = std::numeric_limits<double>::infinity();
  for (const Panel& p : panels) {
    int u, v;
    planeAxes(p.axis, &u, &v);
    const double du = L.hi[u] - L.lo[u] + L.h, dv = L.hi[v] - L.lo[v] + L.h;
    s = std::min({s, (p.rect.width - 2.0 * kMargin) / du, (p.rect.height - kCaption - kStrip - 2.0 * kMargin) / dv});
  }
  return std::max(s, 1e-9);
}

constexpr int kHatchPeriod = 5;  ///< pixels between the hatching's diagonal lines

void drawPanel(cv::Mat& img, const Panel& p, double s, const Lattice& L, const std::vector<Eigen::Vector3d>& X,
               const std::vector<double>& r, double iso, const std::vector<double>& confidence) {
  int u, v;
  planeAxes(p.axis, &u, &v);
  const int w = int(std::ceil((L.hi[u] - L.lo[u] + L.h) * s)), hgt = int(std::ceil((L.hi[v] - L.lo[v] + L.h) * s));
  const int ox = p.rect.x + (p.rect.width - w) / 2;
  const int oy = p.rect.y + kCaption + kMargin + (p.rect.height - kCaption - kStrip - 2 * kMargin - hgt) / 2;
  drawText(img, p.caption, cv::Point(p.rect.x + 6, p.rect.y + 17), 0.5, kInk);
  cv::rectangle(img, cv::Rect(ox - 1, oy - 1, w + 2, hgt + 2), kFrame, 1);
  for (std::size_t i = 0; i < X.size(); ++i) {
    if (L.layer(X[i], p.axis) != p.layer) continue;
    // Cell edges from whole lattice indices, so neighbouring cells share an edge pixel exactly (from
    // snapped coordinates a rounding of cu + h/2 against cu' − h/2 left a white column between them).
    const int ku = L.layer(X[i], u), kv = L.layers(v) - 1 - L.layer(X[i], v);
    const int x0 = ox + int(std::floor(ku * L.h * s));
    const int x1 = std::max(x0, ox + int(std::floor((ku + 1) * L.h * s)) - 1);
    const int y0 = oy + int(std::floor(kv * L.h * s));
    const int y1 = std::max(y0, oy + int(std::floor((kv + 1) * L.h * s)) - 1);
    cv::rectangle(img, cv::Point(x0, y0), cv::Point(x1, y1), r[i] >= iso ? kSliceSolidBgr : kSliceHollowBgr,
                  cv::FILLED);
    if (!confidence.empty() && confidence[i] < 1.0) {  // hatched in image coordinates: lines run on across cells
      const cv::Vec3b ink(static_cast<uchar>(kSliceUncertainBgr[0]), static_cast<uchar>(kSliceUncertainBgr[1]),
                          static_cast<uchar>(kSliceUncertainBgr[2]));
      for (int y = std::max(0, y0); y <= std::min(y1, img.rows - 1); ++y)
        for (int x = std::max(0, x0); x <= std::min(x1, img.cols - 1); ++x)
          if ((x + y) % kHatchPeriod == 0) img.at<cv::Vec3b>(y, x) = ink;
    }
  }
  // Axis arrows (lower left) and a scale bar (lower right) in the strip under the drawing.
  const int base = p.rect.y + p.rect.height - 8;
  const cv::Point o(p.rect.x + 14, base);
  cv::arrowedLine(img, o, o + cv::Point(30, 0), kInk, 1, cv::LINE_AA, 0, 0.25);
  cv::arrowedLine(img, o, o + cv::Point(0, -22), kInk, 1, cv::LINE_AA, 0, 0.25);
  drawText(img, kAxisName[u], o + cv::Point(34, 4), 0.45, kInk);
  drawText(img, kAxisName[v], o + cv::Point(-4, -26), 0.45, kInk);
  const double bar = niceStepBelow(0.3 * (L.hi[u] - L.lo[u] + L.h));
  const int bar_px = std::max(1, int(std::lround(bar * s)));
  const int bx1 = p.rect.x + p.rect.width - 14, bx0 = bx1 - bar_px;
  cv::line(img, cv::Point(bx0, base - 4), cv::Point(bx1, base - 4), kInk, 2);
  cv::line(img, cv::Point(bx0, base - 9), cv::Point(bx0, base + 1), kInk, 1);
  cv::line(img, cv::Point(bx1, base - 9), cv::Point(bx1, base + 1), kInk, 1);
  const std::string label = lengthText(bar);
  drawText(img, label, cv::Point(bx0 - 8 - 9 * int(label.size()), base), 0.45, kInk);
}

/// "xy slice, z = 12.5 mm": positions in mm for objects under 2 m, else m; rounding noise shows as 0.
std::string planeCaption(int axis, double coord, double extent) {
  int u, v;
  planeAxes(axis, &u, &v);
  if (std::abs(coord) < 1e-6 * extent) coord = 0.0;
  const std::string at = extent < 2.0 ? numberText(coord * 1e3, 4) + " mm" : numberText(coord, 4) + " m";
  return std::string(kAxisName[u]) + kAxisName[v] + " slice, " + kAxisName[axis] + " = " + at;
}

}  // namespace

cv::Mat drawInteriorSlices(const std::vector<Eigen::Vector3d>& X, const std::vector<double>& r, double spacing,
                           const std::string& title, const SliceOptions& o) {
  if (X.empty()) throw TopoError("slice picture", "has no particles", "export a non-empty volume");
  if (X.size() != r.size())
    throw TopoError("slice picture",
                    std::to_string(X.size()) + " positions but " + std::to_string(r.size()) + " values of r",
                    "give one indicator value per particle");
  if (!o.confidence.empty() && o.confidence.size() != X.size())
    throw TopoError(
        "slice picture",
        std::to_string(X.size()) + " positions but " + std::to_string(o.confidence.size()) + " confidence values",
        "give one confidence per particle, or none");
  if (!(spacing > 0.0) || !std::isfinite(spacing))
    throw TopoError("slice picture", "spacing " + numberText(spacing) + " is not positive", "give the lattice spacing");
  Lattice L;
  L.h = spacing;
  L.lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  L.hi = -L.lo;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  std::size_t solid = 0;
  for (std::size_t i = 0; i < X.size(); ++i) {
    L.lo = L.lo.cwiseMin(X[i]);
    L.hi = L.hi.cwiseMax(X[i]);
    centroid += X[i];
    solid += r[i] >= o.iso ? 1 : 0;
  }
  centroid /= double(X.size());
  L.hi = L.lo + spacing * ((L.hi - L.lo) / spacing).array().round().matrix();  // on the lattice

  const int W = std::max(600, o.width), head = o.confidence.empty() ? 70 : 92, row1 = 430,
            row2 = o.along_count > 0 ? 330 : 0;
  cv::Mat img(head + row1 + row2 + 10, W, CV_8UC3, kSliceOutsideBgr);

  std::vector<Panel> top;
  for (int axis : {2, 1, 0}) {
    Panel p;
    p.axis = axis;
    p.layer = L.layer(centroid, axis);
    p.caption = planeCaption(axis, L.lo[axis] + spacing * p.layer, (L.hi - L.lo).maxCoeff()) + " (centroid)";
    const int k = int(top.size());
    p.rect = cv::Rect(k * W / 3, head, W / 3, row1);
    top.push_back(p);
  }
  const double s1 = fitScale(top, L);
  for (const Panel& p : top) drawPanel(img, p, s1, L, X, r, o.iso, o.confidence);

  if (row2 > 0) {
    int longest = 0;
    for (int a = 1; a < 3; ++a)
      if (L.hi[a] - L.lo[a] > L.hi[longest] - L.lo[longest]) longest = a;
    const int layers = L.layers(longest);
    const int n = std::min(o.along_count, layers);
    std::vector<Panel> along;
    for (int k = 0; k < n; ++k) {
      Panel p;
      p.axis = longest;
      p.layer = std::clamp(int(std::lround((k + 0.5) / n * layers - 0.5)), 0, layers - 1);
      p.caption = planeCaption(longest, L.lo[longest] + spacing * p.layer, (L.hi - L.lo).maxCoeff());
      p.rect = cv::Rect(k * W / n, head + row1, W / n, row2);
      along.push_back(p);
    }
    const double s2 = fitScale(along, L);
    for (const Panel& p : along) drawPanel(img, p, s2, L, X, r, o.iso, o.confidence);
    cv::line(img, cv::Point(0, head + row1), cv::Point(W, head + row1), kFrame, 1);
  }

  // Title and legend.
  drawText(img, title, cv::Point(14, 28), 0.7, kInk, 2);
  const std::string counts = std::to_string(X.size()) + " particles, " + std::to_string(solid) + " solid (" +
                             numberText(100.0 * double(solid) / double(X.size()), 3) + " %), spacing " +
                             lengthText(spacing);
  drawText(img, counts, cv::Point(14, 56), 0.5, kInk);
  if (!o.confidence.empty()) {  // a hatched swatch and the count of undetermined particles
    std::size_t n = 0;
    for (double c : o.confidence) n += c < 1.0 ? 1 : 0;
    const cv::Rect swatch(14, 66, 18, 18);
    cv::rectangle(img, swatch, kSliceSolidBgr, cv::FILLED);
    for (int y = swatch.y; y < swatch.y + swatch.height; ++y)
      for (int x = swatch.x; x < swatch.x + swatch.width; ++x)
        if ((x + y) % kHatchPeriod == 0)
          img.at<cv::Vec3b>(y, x) =
              cv::Vec3b(static_cast<uchar>(kSliceUncertainBgr[0]), static_cast<uchar>(kSliceUncertainBgr[1]),
                        static_cast<uchar>(kSliceUncertainBgr[2]));
    cv::rectangle(img, swatch, kInk, 1);
    drawText(img,
             "hatched: undetermined, designs that fit as well disagree (" + std::to_string(n) + " particles, " +
                 numberText(100.0 * double(n) / double(X.size()), 3) + " %)",
             cv::Point(40, 81), 0.5, kInk);
  }
  int x = W - 520;
  for (const auto& [colour, label] :
       std::vector<std::pair<cv::Scalar, std::string>>{{kSliceSolidBgr, "solid (r >= " + numberText(o.iso) + ")"},
                                                       {kSliceHollowBgr, "hollow (r < " + numberText(o.iso) + ")"},
                                                       {kSliceOutsideBgr, "outside"}}) {
    cv::rectangle(img, cv::Rect(x, 40, 18, 18), colour, cv::FILLED);
    cv::rectangle(img, cv::Rect(x, 40, 18, 18), kInk, 1);
    drawText(img, label, cv::Point(x + 24, 55), 0.5, kInk);
    x += 175;
  }
  return img;
}

}  // namespace topo_gaussian::vision
