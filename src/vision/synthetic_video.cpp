// Synthetic scenes with known motion (pendulum, two-segment finger), rendered with OpenCV.
#include "topo_gaussian/vision/synthetic_video.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "topo_gaussian/common/error.h"

namespace topo_gaussian::vision {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr int kShift = 4;  // sub-pixel bits for cv drawing
constexpr double kScale = 1 << kShift;

cv::Point fixedPoint(const cv::Point2d& p) {
  return cv::Point(static_cast<int>(std::lround(p.x * kScale)), static_cast<int>(std::lround(p.y * kScale)));
}

int frameCount(double fps, double duration_s) {
  if (!(fps > 0.0) || !std::isfinite(fps))
    throw TopoError("synthetic scene fps", "must be positive and finite (got " + std::to_string(fps) + ")",
                    "set fps > 0");
  if (!(duration_s > 0.0) || !std::isfinite(duration_s))
    throw TopoError("synthetic scene duration_s",
                    "must be positive and finite (got " + std::to_string(duration_s) + ")", "set duration_s > 0");
  return static_cast<int>(std::lround(fps * duration_s));
}

void checkSize(int width, int height) {
  if (width <= 0 || height <= 0)
    throw TopoError(
        "synthetic scene size",
        "width and height must be positive (got " + std::to_string(width) + "x" + std::to_string(height) + ")",
        "set width, height > 0");
}

/// A smooth random texture (low-frequency noise), twice the image size, to be shifted over time.
cv::Mat makeTexture(int width, int height, cv::RNG& rng) {
  cv::Mat small(std::max(4, height / 16), std::max(4, width / 16), CV_8UC3);
  rng.fill(small, cv::RNG::UNIFORM, cv::Scalar(150, 150, 150), cv::Scalar(235, 235, 235));
  cv::Mat big;
  cv::resize(small, big, cv::Size(2 * width, 2 * height), 0, 0, cv::INTER_CUBIC);
  return big;
}

void addNoiseAndBlur(cv::Mat& img, double noise_sigma, double blur_px, cv::RNG& rng) {
  if (blur_px > 0.0) cv::GaussianBlur(img, img, cv::Size(0, 0), blur_px);
  if (noise_sigma > 0.0) {
    cv::Mat noise(img.size(), CV_16SC3);
    rng.fill(noise, cv::RNG::NORMAL, cv::Scalar::all(0), cv::Scalar::all(noise_sigma));
    cv::Mat tmp;
    img.convertTo(tmp, CV_16SC3);
    tmp += noise;
    tmp.convertTo(img, CV_8UC3);  // saturating
  }
}

double smoothstep(double x) {
  x = std::min(1.0, std::max(0.0, x));
  return x * x * (3.0 - 2.0 * x);
}

/// A thick segment as a filled rotated rectangle (anti-aliased).
void drawBar(cv::Mat& img, const cv::Point2d& a, const cv::Point2d& b, double width, const cv::Scalar& colour) {
  const cv::Point2d d = b - a;
  const double len = std::hypot(d.x, d.y);
  if (len <= 0.0) return;
  const cv::Point2d n(-d.y / len * width / 2.0, d.x / len * width / 2.0);
  std::vector<cv::Point> poly = {fixedPoint(a + n), fixedPoint(b + n), fixedPoint(b - n), fixedPoint(a - n)};
  cv::fillConvexPoly(img, poly, colour, cv::LINE_AA, kShift);
}

}  // namespace

// period_s is the damped period: ω_d = 2π / period_s, ω = ω_d / sqrt(1 − ζ²) is the natural
// angular frequency used in the decay envelope e^{−ζωt}.
double pendulumAngleDeg(const PendulumScene& scene, double t) {
  const double zeta = std::min(std::max(scene.damping_ratio, 0.0), 0.999);
  const double wd = 2.0 * kPi / scene.period_s;
  const double w = wd / std::sqrt(1.0 - zeta * zeta);
  return scene.equilibrium_deg + scene.amplitude_deg * std::exp(-zeta * w * t) * std::cos(wd * t);
}

std::vector<cv::Mat> renderPendulum(const PendulumScene& scene) {
  checkSize(scene.width, scene.height);
  if (!(scene.period_s > 0.0)) throw TopoError("pendulum scene period_s", "must be positive", "set period_s > 0");
  const int n = frameCount(scene.fps, scene.duration_s);
  cv::RNG rng(scene.seed);
  cv::Mat texture;
  if (scene.moving_background) texture = makeTexture(scene.width, scene.height, rng);
  const cv::Scalar wall(235, 238, 240);
  const cv::Scalar rod(40, 40, 40);
  std::vector<cv::Mat> frames;
  frames.reserve(n);
  for (int k = 0; k < n; ++k) {
    const double t = k / scene.fps;
    cv::Mat img;
    if (scene.moving_background) {
      const int dx = static_cast<int>(std::lround(0.25 * scene.width * (1.0 + std::sin(0.7 * t))));
      const int dy = static_cast<int>(std::lround(0.25 * scene.height * (1.0 + std::cos(0.5 * t))));
      texture(cv::Rect(dx, dy, scene.width, scene.height)).copyTo(img);
    } else {
      img = cv::Mat(scene.height, scene.width, CV_8UC3, wall);
    }
    const double th = pendulumAngleDeg(scene, t) * kPi / 180.0;
    const cv::Point2d bob = scene.pivot + scene.length_px * cv::Point2d(std::sin(th), std::cos(th));
    drawBar(img, scene.pivot, bob, scene.rod_width_px, rod);
    cv::circle(img, fixedPoint(scene.pivot), static_cast<int>(std::lround(0.8 * scene.rod_width_px * kScale)),
               cv::Scalar(20, 20, 20), cv::FILLED, cv::LINE_AA, kShift);
    cv::circle(img, fixedPoint(bob), static_cast<int>(std::lround(scene.bob_radius_px * kScale)), scene.bob_bgr,
               cv::FILLED, cv::LINE_AA, kShift);
    addNoiseAndBlur(img, scene.noise_sigma, scene.blur_px, rng);
    frames.push_back(img);
  }
  return frames;
}

double fingerBendDeg(const FingerScene& scene, double t) {
  const double ramp = 0.7 * scene.duration_s;
  if (!(ramp > 0.0)) return scene.final_bend_deg;
  return scene.final_bend_deg * smoothstep(t / ramp);
}

std::vector<cv::Mat> renderFinger(const FingerScene& scene) {
  checkSize(scene.width, scene.height);
  const int n = frameCount(scene.fps, scene.duration_s);
  cv::RNG rng(scene.seed);
  const cv::Scalar background(225, 230, 232);
  std::vector<cv::Mat> frames;
  frames.reserve(n);
  const double a0 = scene.base_angle_deg * kPi / 180.0;
  const cv::Point2d joint = scene.base + scene.segment_px * cv::Point2d(std::cos(a0), std::sin(a0));
  for (int k = 0; k < n; ++k) {
    const double t = k / scene.fps;
    cv::Mat img(scene.height, scene.width, CV_8UC3, background);
    const double a1 = a0 + fingerBendDeg(scene, t) * kPi / 180.0;
    const cv::Point2d tip = joint + scene.segment_px * cv::Point2d(std::cos(a1), std::sin(a1));
    drawBar(img, scene.base, joint, scene.width_px, scene.body_bgr);
    drawBar(img, joint, tip, scene.width_px, scene.body_bgr);
    // rounded joint and tip so the silhouette is continuous
    cv::circle(img, fixedPoint(joint), static_cast<int>(std::lround(scene.width_px / 2.0 * kScale)), scene.body_bgr,
               cv::FILLED, cv::LINE_AA, kShift);
    cv::circle(img, fixedPoint(tip), static_cast<int>(std::lround(scene.width_px / 2.0 * kScale)), scene.body_bgr,
               cv::FILLED, cv::LINE_AA, kShift);
    addNoiseAndBlur(img, scene.noise_sigma, 0.0, rng);
    frames.push_back(img);
  }
  return frames;
}

void writeVideo(const std::vector<cv::Mat>& frames, double fps, const std::string& path) {
  if (frames.empty()) throw TopoError(path, "no frames to write", "render at least one frame");
  if (!(fps > 0.0) || !std::isfinite(fps))
    throw TopoError(path, "fps must be positive (got " + std::to_string(fps) + ")", "pass fps > 0");
  std::string ext;
  const auto dot = path.find_last_of('.');
  if (dot != std::string::npos) ext = path.substr(dot);
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  int fourcc;
  if (ext == ".avi")
    fourcc = cv::VideoWriter::fourcc('M', 'J', 'P', 'G');
  else if (ext == ".mp4")
    fourcc = cv::VideoWriter::fourcc('m', 'p', '4', 'v');
  else
    throw TopoError(path, "unsupported video extension '" + ext + "'", "use a .avi or .mp4 path");
  const cv::Size size = frames.front().size();
  for (size_t i = 0; i < frames.size(); ++i) {
    if (frames[i].empty() || frames[i].size() != size)
      throw TopoError(path,
                      "frame " + std::to_string(i) + " is " + std::to_string(frames[i].cols) + "x" +
                          std::to_string(frames[i].rows) + ", frame 0 is " + std::to_string(size.width) + "x" +
                          std::to_string(size.height),
                      "render all frames at the same size");
    if (frames[i].type() != CV_8UC3 && frames[i].type() != CV_8UC1)
      throw TopoError(path, "frame " + std::to_string(i) + " is not 8-bit grey or BGR", "convert frames to CV_8UC3");
  }
  {
    std::error_code ec;
    const std::filesystem::path parent = std::filesystem::path(path).parent_path();
    if (!parent.empty() && !std::filesystem::is_directory(parent, ec))
      throw TopoError(path, "cannot open video for writing: directory '" + parent.string() + "' does not exist",
                      "create the directory first or choose another output path");
  }
  cv::VideoWriter writer;
  try {
    writer.open(path, fourcc, fps, size, true);
  } catch (const cv::Exception& e) {
    throw TopoError(path, std::string("cannot open video for writing (") + e.what() + ")",
                    "check that the directory exists and is writable");
  }
  if (!writer.isOpened())
    throw TopoError(path, "cannot open video for writing",
                    "check that the directory exists and is writable and that OpenCV has a " + ext + " encoder");
  cv::Mat bgr;
  for (const cv::Mat& f : frames) {
    if (f.channels() == 1)
      cv::cvtColor(f, bgr, cv::COLOR_GRAY2BGR);
    else
      bgr = f;
    writer.write(bgr);
  }
  writer.release();
}

}  // namespace topo_gaussian::vision
