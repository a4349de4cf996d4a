#include "topo_gaussian/vision/figure.h"

#include <unistd.h>
#include <cmath>

#include <cstdio>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/number_text.h"

namespace topo_gaussian::vision {

void writePng(const cv::Mat& img, const std::string& path) {
  // Encoded in memory, written to a temporary file beside the target and renamed over it, so an
  // interrupted write never leaves a truncated picture where a good one was.
  const auto dot = path.find_last_of('.');
  const std::string ext =
      dot == std::string::npos || path.find('/', dot) != std::string::npos ? ".png" : path.substr(dot);
  std::vector<unsigned char> bytes;
  bool ok = false;
  try {
    ok = !img.empty() && cv::imencode(ext, img, bytes);
  } catch (const cv::Exception& e) {
    throw TopoError(path, std::string("cannot be encoded as a picture: ") + e.what(), "give a path ending in .png");
  }
  if (!ok) throw TopoError(path, "cannot be encoded as a picture", "give a path ending in .png");
  const std::string tmp = path + ".tmp" + std::to_string(::getpid());
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
    if (!out) {
      std::remove(tmp.c_str());
      throw TopoError(path, "cannot be written", "give a writable path in an existing directory (and free disk space)");
    }
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    std::remove(tmp.c_str());
    throw TopoError(path, "cannot be replaced", "check the permissions of the file and its directory");
  }
}

double niceStepBelow(double limit) {
  if (!(limit > 0.0) || !std::isfinite(limit)) return 1.0;
  const double p = std::pow(10.0, std::floor(std::log10(limit)));
  for (double m : {5.0, 2.0, 1.0})
    if (m * p <= limit * (1 + 1e-12)) return m * p;
  return p;
}

double niceStepAbove(double limit) {
  if (!(limit > 0.0) || !std::isfinite(limit)) return 1.0;
  const double p = std::pow(10.0, std::floor(std::log10(limit)));
  for (double m : {1.0, 2.0, 5.0, 10.0})
    if (m * p >= limit * (1 - 1e-12)) return m * p;
  return 10 * p;
}

std::string lengthText(double m) {
  const double a = std::abs(m);
  if (a >= 1.0) return numberText(m, 3) + " m";
  if (a >= 0.01) return numberText(m * 100, 3) + " cm";
  if (a >= 1e-3) return numberText(m * 1e3, 3) + " mm";
  return numberText(m * 1e6, 3) + " um";
}

void drawText(cv::Mat& img, const std::string& text, cv::Point at, double scale, const cv::Scalar& bgr, int thickness) {
  cv::putText(img, text, at, cv::FONT_HERSHEY_SIMPLEX, scale, bgr, thickness, cv::LINE_AA);
}

}  // namespace topo_gaussian::vision
