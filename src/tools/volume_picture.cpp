#include "volume_picture.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numeric>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/vision/figure.h"

namespace topo_gaussian::tools {

namespace {

const cv::Scalar kSurface(40, 120, 230);  // BGR orange
const cv::Scalar kInterior(70, 70, 70);
const cv::Scalar kText(20, 20, 20);

void drawCutaway(cv::Mat& img, const cv::Rect& box, const VolumeCloud& c) {
  const Eigen::Vector3d mid = c.centroid();
  const double az = 35.0 * M_PI / 180.0, el = 25.0 * M_PI / 180.0;
  // camera basis: view direction d, right r, up u (world z up)
  const Eigen::Vector3d d(-std::cos(el) * std::cos(az), -std::cos(el) * std::sin(az), -std::sin(el));
  const Eigen::Vector3d r = d.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d u = r.cross(d);
  std::vector<std::size_t> idx;
  for (std::size_t i = 0; i < c.size(); ++i)
    if ((c.X[i] - mid).dot(-d.cwiseProduct(Eigen::Vector3d(1, 1, 0)).normalized()) <= 0.0)
      idx.push_back(i);  // cut the near half
  double lo_x = 1e300, hi_x = -1e300, lo_y = 1e300, hi_y = -1e300;
  for (std::size_t i = 0; i < c.size(); ++i) {
    const Eigen::Vector3d q = c.X[i] - mid;
    lo_x = std::min(lo_x, q.dot(r)), hi_x = std::max(hi_x, q.dot(r));
    lo_y = std::min(lo_y, q.dot(u)), hi_y = std::max(hi_y, q.dot(u));
  }
  const double scale =
      0.9 * std::min(box.width / std::max(hi_x - lo_x, 1e-12), box.height / std::max(hi_y - lo_y, 1e-12));
  std::sort(idx.begin(), idx.end(),
            [&](std::size_t a, std::size_t b) { return (c.X[a] - mid).dot(d) > (c.X[b] - mid).dot(d); });
  const int radius = std::max(1, int(std::lround(0.6 * c.spacing * scale)));
  const double depth_range = std::max(1e-12, (hi_x - lo_x));
  for (std::size_t i : idx) {
    const Eigen::Vector3d q = c.X[i] - mid;
    const cv::Point p(box.x + box.width / 2 + int(std::lround(q.dot(r) * scale)),
                      box.y + box.height / 2 - int(std::lround(q.dot(u) * scale)));
    const double shade = std::clamp(0.65 + 0.35 * (-q.dot(d)) / depth_range, 0.3, 1.0);
    const cv::Scalar base = c.surface[i] ? kSurface : kInterior;
    cv::circle(img, p, radius, base * shade, cv::FILLED, cv::LINE_AA);
  }
}

void drawSlice(cv::Mat& img, const cv::Rect& box, const VolumeCloud& c) {
  const Eigen::Vector3d mid = c.centroid();
  Eigen::Vector3d lo, hi;
  c.bounds(&lo, &hi);
  const double scale =
      0.9 * std::min(box.width / std::max(hi.x() - lo.x(), 1e-12), box.height / std::max(hi.y() - lo.y(), 1e-12));
  const int half = std::max(1, int(std::ceil(0.5 * c.spacing * scale)));
  cv::rectangle(img, box, cv::Scalar(235, 235, 235), cv::FILLED);
  for (std::size_t i = 0; i < c.size(); ++i) {
    if (std::abs(c.X[i].z() - mid.z()) > 0.5 * c.spacing) continue;
    const cv::Point p(box.x + box.width / 2 + int(std::lround((c.X[i].x() - 0.5 * (lo.x() + hi.x())) * scale)),
                      box.y + box.height / 2 - int(std::lround((c.X[i].y() - 0.5 * (lo.y() + hi.y())) * scale)));
    cv::rectangle(img, p - cv::Point(half, half), p + cv::Point(half, half), c.surface[i] ? kSurface : kInterior,
                  cv::FILLED);
  }
}

}  // namespace

void writeVolumePicture(const VolumeCloud& c, const std::string& title, const std::string& path) {
  cv::Mat img(660, 1280, CV_8UC3, cv::Scalar(255, 255, 255));
  drawCutaway(img, cv::Rect(20, 70, 600, 570), c);
  drawSlice(img, cv::Rect(660, 70, 600, 570), c);
  std::ostringstream s;
  s.precision(4);
  s << c.size() << " particles, " << c.surfaceCount() << " on the surface, volume " << c.totalVolume() * 1e6
    << " cm^3, spacing " << c.spacing * 1000 << " mm";
  cv::putText(img, title, cv::Point(20, 30), cv::FONT_HERSHEY_SIMPLEX, 0.8, kText, 2, cv::LINE_AA);
  cv::putText(img, s.str(), cv::Point(20, 58), cv::FONT_HERSHEY_SIMPLEX, 0.6, kText, 1, cv::LINE_AA);
  cv::putText(img, "cut-away view (orange: surface particles, grey: interior)", cv::Point(20, 652),
              cv::FONT_HERSHEY_SIMPLEX, 0.5, kText, 1, cv::LINE_AA);
  cv::putText(img, "slice z = centroid (top view)", cv::Point(660, 652), cv::FONT_HERSHEY_SIMPLEX, 0.5, kText, 1,
              cv::LINE_AA);
  vision::writePng(img, path);
}

}  // namespace topo_gaussian::tools
