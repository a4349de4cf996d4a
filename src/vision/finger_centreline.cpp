// fingerCentreline, equalArcStations (vision/finger_centreline.h).
#include "topo_gaussian/vision/finger_centreline.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <opencv2/imgproc.hpp>
#include <queue>

#include "topo_gaussian/common/number_text.h"
#include "topo_gaussian/common/statistics.h"

namespace topo_gaussian::vision {
namespace {

constexpr double kInside = 0.5;         ///< the outline: the field's half level
constexpr double kCutStep = 0.25;       ///< sampling step along a cut or an end extension [px]
constexpr double kMaxHalfWidth = 24.0;  ///< a wider finger is worked on shrunk to this half-width [px]
/// A cut crosses the finger's sides when the outline's normal is within this of the cut at both
/// crossings, at the outline's own scale or at a third of the half-width (ribs smoothed out) [deg]
constexpr double kSideDeg = 15.0;

/// The outline field (1 inside, 0 outside), sampled bilinearly; 0 outside it.
class EdgeField {
 public:
  explicit EdgeField(const cv::Mat& field) : f_(field) {}
  double at(const cv::Point2d& p) const {
    if (!(p.x >= 0 && p.y >= 0 && p.x <= f_.cols - 1 && p.y <= f_.rows - 1)) return 0.0;
    const int x0 = std::min(static_cast<int>(p.x), f_.cols - 2), y0 = std::min(static_cast<int>(p.y), f_.rows - 2);
    const double ax = p.x - x0, ay = p.y - y0;
    const float* r0 = f_.ptr<float>(y0);
    const float* r1 = f_.ptr<float>(y0 + 1);
    return (1 - ay) * ((1 - ax) * r0[x0] + ax * r0[x0 + 1]) + ay * ((1 - ax) * r1[x0] + ax * r1[x0 + 1]);
  }
  /// The field's gradient (central differences over ±0.5 px).
  cv::Point2d gradient(const cv::Point2d& p) const {
    return cv::Point2d(at(p + cv::Point2d(0.5, 0)) - at(p - cv::Point2d(0.5, 0)),
                       at(p + cv::Point2d(0, 0.5)) - at(p - cv::Point2d(0, 0.5)));
  }

 private:
  cv::Mat f_;
};

/// The largest distance from a blob pixel to the outside (the blob's half-width, about), on the blob
/// shrunk to at most 512 px: only a scale.
double roughHalfWidth(const cv::Mat& blob) {
  const int side = std::max(blob.cols, blob.rows);
  const int s = std::max(1, (side + 511) / 512);
  cv::Mat small = blob;
  if (s > 1) {
    cv::resize(blob, small, cv::Size(std::max(1, blob.cols / s), std::max(1, blob.rows / s)), 0, 0, cv::INTER_AREA);
    small = small >= 128;
  }
  cv::Mat padded, dt;
  cv::copyMakeBorder(small, padded, 1, 1, 1, 1, cv::BORDER_CONSTANT, cv::Scalar(0));
  cv::distanceTransform(padded, dt, cv::DIST_L2, 3);
  double m = 0;
  cv::minMaxLoc(dt, nullptr, &m);
  return m * s;
}

/// Geodesic (chamfer 1, √2) distance from `seed` to every mask pixel; −1 outside the mask.
cv::Mat geodesicDistance(const cv::Mat& mask, const cv::Point& seed) {
  cv::Mat d(mask.size(), CV_64F, cv::Scalar(-1.0));
  using Item = std::pair<double, int>;
  std::priority_queue<Item, std::vector<Item>, std::greater<Item>> q;
  const int w = mask.cols;
  d.at<double>(seed) = 0.0;
  q.push({0.0, seed.y * w + seed.x});
  static const int dx[8] = {1, -1, 0, 0, 1, 1, -1, -1}, dy[8] = {0, 0, 1, -1, 1, -1, 1, -1};
  static const double cost[8] = {1, 1, 1, 1, M_SQRT2, M_SQRT2, M_SQRT2, M_SQRT2};
  while (!q.empty()) {
    const auto [g, idx] = q.top();
    q.pop();
    const int x = idx % w, y = idx / w;
    if (g > d.at<double>(y, x)) continue;
    for (int k = 0; k < 8; ++k) {
      const int nx = x + dx[k], ny = y + dy[k];
      if (nx < 0 || ny < 0 || nx >= w || ny >= mask.rows || !mask.at<uchar>(ny, nx)) continue;
      double& dn = d.at<double>(ny, nx);
      const double gn = g + cost[k];
      if (dn < 0 || gn < dn) {
        dn = gn;
        q.push({gn, ny * w + nx});
      }
    }
  }
  return d;
}

cv::Point farthest(const cv::Mat& geo) {
  double best = -1;
  cv::Point at(0, 0);
  for (int y = 0; y < geo.rows; ++y)
    for (int x = 0; x < geo.cols; ++x)
      if (geo.at<double>(y, x) > best) best = geo.at<double>(y, x), at = cv::Point(x, y);
  return at;
}

double polylineLength(const std::vector<cv::Point2d>& p) {
  double len = 0;
  for (std::size_t i = 1; i < p.size(); ++i) len += cv::norm(p[i] - p[i - 1]);
  return len;
}

/// The polyline resampled every `step` of arc length (its last point kept).
std::vector<cv::Point2d> resample(const std::vector<cv::Point2d>& p, double step) {
  if (p.size() < 2) return p;
  std::vector<cv::Point2d> out{p.front()};
  double carried = 0;  // arc length since the last output point
  for (std::size_t i = 1; i < p.size(); ++i) {
    const cv::Point2d d = p[i] - p[i - 1];
    const double seg = cv::norm(d);
    double at = step - carried;
    while (at <= seg) {
      out.push_back(p[i - 1] + d * (at / seg));
      at += step;
    }
    carried = seg - (at - step);
  }
  if (cv::norm(out.back() - p.back()) > 1e-9 * step) out.push_back(p.back());
  return out;
}

/// Moving average over ±half samples (the window shrinks symmetrically at the ends, which stay put).
std::vector<cv::Point2d> smooth(const std::vector<cv::Point2d>& p, int half) {
  const int n = static_cast<int>(p.size());
  std::vector<cv::Point2d> out(p.size());
  for (int i = 0; i < n; ++i) {
    const int h = std::min({half, i, n - 1 - i});
    cv::Point2d s(0, 0);
    for (int k = -h; k <= h; ++k) s += p[i + k];
    out[i] = s * (1.0 / (2 * h + 1));
  }
  return out;
}

cv::Point2d unit(const cv::Point2d& v) {
  const double n = std::hypot(v.x, v.y);
  return n > 0 ? v * (1.0 / n) : cv::Point2d(0, 0);
}

/// The cut through c along n: the inside run containing (or nearest, within ±near) c, its two 0.5
/// crossings u− < u+ (bracketed in steps of `stride`, the bracket halved to kCutStep, then linearly
/// interpolated). False when there is none, it runs past ±reach, or (with `sides`, the field blurred to
/// the finger's scale) it does not cross the two sides: the outline's normal at a crossing is more
/// than kSideDeg from the cut both in `f` and in `sides` (an end face, a rounded tip's cap, a corner:
/// such a cut is not a cross-section; a rib's flank is one only in `sides`).
bool cutAcross(const EdgeField& f, const EdgeField* sides, const cv::Point2d& c, const cv::Point2d& n, double reach,
               double near, double stride, double* lo, double* hi) {
  auto sample = [&](double u) { return f.at(c + n * u); };
  // the inside sample nearest the centre, within ±near
  double start = 0;
  bool found = false;
  for (double k = 0; k <= near && !found; k += kCutStep)
    for (double u : {k, -k})
      if (sample(u) >= kInside) {
        start = u;
        found = true;
        break;
      }
  if (!found) return false;
  // outwards from it in strides to the first outside sample on either side (within ±reach), then
  // halving the bracket to kCutStep and interpolating linearly
  auto cross = [&](double dir, double* u) {
    double in = start;
    for (double out = start + dir * stride; std::abs(out) <= reach + stride; out += dir * stride) {
      if (sample(out) >= kInside) {
        in = out;
        continue;
      }
      while (std::abs(out - in) > kCutStep) {
        const double mid = 0.5 * (in + out);
        (sample(mid) >= kInside ? in : out) = mid;
      }
      const double vi = sample(in), vo = sample(out);
      *u = in + (out - in) * (vi - kInside) / (vi - vo);
      return std::abs(*u) <= reach;
    }
    return false;
  };
  if (!cross(-1.0, lo) || !cross(1.0, hi)) return false;
  if (!sides) return true;
  auto across = [&](const EdgeField& field, double limit_deg) {  // the outline's normal along the cut at both
    for (double u : {*lo, *hi}) {
      const cv::Point2d g = field.gradient(c + n * u);
      const double norm = std::hypot(g.x, g.y);
      if (!(norm > 0) || std::abs(g.dot(n)) < std::cos(limit_deg * M_PI / 180) * norm) return false;
    }
    return true;
  };
  return across(f, kSideDeg) || across(*sides, kSideDeg);
}

/// The last `count` points of `p` (its end: p.back()) fitted with a parabola y = a + b x + c x² in the
/// frame of their chord (x outwards), robustly: points further from it than max(floor_px, 3 σ) (σ from
/// the median absolute residual) are left out and the fit repeated, so a few bad cuts at an end (a
/// scalloped end face, a corner's bump) do not bend it. Returns the index of the last point kept (the
/// ones after it are dropped by the caller); *end is the fit there, *dir its unit tangent, pointing out.
/// The tangent of the chord itself would lag the curve's by κ·count/2 (3° over 20 px at R = 190 px).
int endTangent(const std::vector<cv::Point2d>& p, int count, double floor_px, cv::Point2d* end, cv::Point2d* dir) {
  const int n = static_cast<int>(p.size());
  count = std::min(count, n);
  const int i0 = n - count;
  const cv::Point2d e = p.back();
  const cv::Point2d u = unit(e - p[i0]), v(-u.y, u.x);
  std::vector<double> x(count), y(count);
  for (int i = 0; i < count; ++i) x[i] = (p[i0 + i] - e).dot(u), y[i] = (p[i0 + i] - e).dot(v);
  std::vector<char> in(count, 1);
  cv::Vec3d abc(0, 0, 0);
  bool fitted = false;
  for (int round = 0; round < 4; ++round) {
    cv::Matx33d A = cv::Matx33d::zeros();
    cv::Vec3d rhs(0, 0, 0);
    int used = 0;
    for (int i = 0; i < count; ++i)
      if (in[i]) {
        const cv::Vec3d row(1, x[i], x[i] * x[i]);
        A += row * row.t();
        rhs += row * y[i];
        ++used;
      }
    if (used < 4 || !cv::solve(A, rhs, abc, cv::DECOMP_CHOLESKY)) break;
    fitted = true;
    std::vector<double> r(count), kept;
    for (int i = 0; i < count; ++i) {
      r[i] = std::abs(y[i] - (abc[0] + abc[1] * x[i] + abc[2] * x[i] * x[i]));
      if (in[i]) kept.push_back(r[i]);
    }
    const double limit = std::max(floor_px, 3.0 * 1.4826 * median(kept));
    bool changed = false;
    for (int i = 0; i < count; ++i) {
      const char now = r[i] <= limit;
      changed = changed || now != in[i];
      in[i] = now;
    }
    if (!changed) break;
  }
  if (!fitted) {
    *end = e;
    *dir = u;
    return n - 1;
  }
  int last = count - 1;
  while (last > 0 && !in[last]) --last;
  const double xl = x[last];
  *end = e + u * xl + v * (abc[0] + abc[1] * xl + abc[2] * xl * xl);
  *dir = unit(u + v * (abc[1] + 2 * abc[2] * xl));
  return i0 + last;
}

/// From `end` outwards along `dir`: the point where the field drops below the outline level.
cv::Point2d extendToOutline(const EdgeField& f, const cv::Point2d& end, const cv::Point2d& dir, double reach) {
  double prev = f.at(end);
  if (prev < kInside) return end;
  for (double u = kCutStep; u <= reach; u += kCutStep) {
    const double v = f.at(end + dir * u);
    if (v < kInside) return end + dir * (u - kCutStep * (kInside - v) / (prev - v));
    prev = v;
  }
  return end + dir * reach;
}

/// 1 inside the blob, 0 outside, with the frame's sub-pixel edges where it is given: each pixel's colour
/// projected on the line from the background's mean colour (a ring 2..5 px outside the blob) to the
/// blob's (its inside, 2 px in), F = (c − c_bg)·(c_fg − c_bg)/|c_fg − c_bg|², clipped to 0..1, kept
/// within 3 px of the blob and at 1 inside it (markings on the finger). An anti-aliased edge's colour
/// is the covered fraction's mix, so F's 0.5 level is the outline to about 0.1 px, where the binary
/// mask's is quantised to a pixel along an edge that runs with the pixel grid. Without a frame, or
/// with less than 20 levels of contrast, the binary mask.
cv::Mat objectField(const cv::Mat& mask, const cv::Mat& bgr) {
  cv::Mat binary;
  mask.convertTo(binary, CV_32F, 1.0 / 255.0);
  if (bgr.empty() || bgr.type() != CV_8UC3) return binary;
  const cv::Mat disc = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(3, 3));
  cv::Mat inner, near, far, ring;
  cv::erode(mask, inner, disc, cv::Point(-1, -1), 2);
  cv::dilate(mask, near, disc, cv::Point(-1, -1), 2);
  cv::dilate(mask, far, disc, cv::Point(-1, -1), 5);
  cv::subtract(far, near, ring);
  if (cv::countNonZero(inner) < 20 || cv::countNonZero(ring) < 20) return binary;
  const cv::Scalar fg = cv::mean(bgr, inner), bg = cv::mean(bgr, ring);
  const cv::Vec3d d(fg[0] - bg[0], fg[1] - bg[1], fg[2] - bg[2]);
  const double d2 = d.dot(d);
  if (d2 < 20.0 * 20.0) return binary;
  cv::Mat keep;
  cv::dilate(mask, keep, disc, cv::Point(-1, -1), 3);
  cv::Mat colour, field;
  bgr.convertTo(colour, CV_32FC3);
  const cv::Matx13f w(static_cast<float>(d[0] / d2), static_cast<float>(d[1] / d2), static_cast<float>(d[2] / d2));
  cv::transform(colour, field, w);  // c·d / |d|², then less c_bg·d / |d|²
  field -= (bg[0] * d[0] + bg[1] * d[1] + bg[2] * d[2]) / d2;
  cv::min(cv::max(field, 0.0), 1.0, field);
  field.setTo(0.0f, keep == 0);
  field.setTo(1.0f, inner);
  return field;
}

}  // namespace

FingerCentreline fingerCentreline(const cv::Mat& mask_in, const cv::Point& offset, const CentrelineOptions& o,
                                  const cv::Mat& bgr) {
  FingerCentreline out;
  cv::Mat bin = mask_in > 0;
  const int area = cv::countNonZero(bin);
  if (area < 50) {
    out.problem = "the silhouette has only " + std::to_string(area) + " pixels";
    return out;
  }
  // Work on the blob's bounding box with a margin for the blur and the background ring, shrunk so that
  // the finger is at most 2 kMaxHalfWidth px wide: the outline's precision is relative to the width,
  // and the work falls with the square of the shrinking (a frame-filling blob at 1080p stays cheap).
  const cv::Rect tight = cv::boundingRect(bin);
  const double q = std::max(1.0, roughHalfWidth(bin(tight)) / kMaxHalfWidth);
  const int margin = static_cast<int>(std::ceil(q * (4 * o.mask_blur_px + 8)));
  const cv::Rect box =
      (tight + cv::Size(2 * margin, 2 * margin) - cv::Point(margin, margin)) & cv::Rect(0, 0, bin.cols, bin.rows);
  cv::Mat crop = bin(box), colour = bgr.empty() ? cv::Mat() : bgr(box);
  double qx = 1.0, qy = 1.0;  // frame pixels per working pixel
  if (q > 1.0) {
    const cv::Size small(std::max(1, static_cast<int>(std::lround(box.width / q))),
                         std::max(1, static_cast<int>(std::lround(box.height / q))));
    qx = static_cast<double>(box.width) / small.width;
    qy = static_cast<double>(box.height) / small.height;
    cv::resize(crop, crop, small, 0, 0, cv::INTER_AREA);
    crop = crop >= 128;
    if (!colour.empty()) cv::resize(colour, colour, small, 0, 0, cv::INTER_AREA);
  }
  cv::Mat field = objectField(crop, colour);
  // replicate: a finger running off the region's edge keeps its width up to the edge
  if (o.mask_blur_px > 0) cv::GaussianBlur(field, field, cv::Size(0, 0), o.mask_blur_px, 0, cv::BORDER_REPLICATE);
  const EdgeField f(field);
  auto toFrame = [&](const cv::Point2d& p) {
    return cv::Point2d((p.x + 0.5) * qx - 0.5 + box.x, (p.y + 0.5) * qy - 0.5 + box.y);
  };
  // within a (working) pixel of the region's border: the finger may run on beyond it
  const double border = std::max(qx, qy);
  auto atBorder = [&](const cv::Point2d& p) {
    const cv::Point2d r = toFrame(p);
    return r.x < border || r.y < border || r.x > bin.cols - 1 - border || r.y > bin.rows - 1 - border;
  };

  cv::Mat dt;
  cv::distanceTransform(crop, dt, cv::DIST_L2, 5);
  double half_width = 0;
  cv::minMaxLoc(dt, nullptr, &half_width);
  // 1. ends and the coarse centreline: band centroids of the geodesic distance from one end, on the
  // mask shrunk to about 4 px per half-width (the cuts below refine it at full resolution)
  const int shrink = std::max(1, static_cast<int>(half_width / 4));
  cv::Mat coarse = crop;
  if (shrink > 1) {
    cv::resize(crop, coarse, cv::Size(), 1.0 / shrink, 1.0 / shrink, cv::INTER_AREA);
    coarse = coarse >= 128;
  }
  cv::Point seed;
  {
    cv::Mat coarse_dt;
    cv::distanceTransform(coarse, coarse_dt, cv::DIST_L2, 3);
    cv::minMaxLoc(coarse_dt, nullptr, nullptr, nullptr, &seed);
  }
  const cv::Point e1 = farthest(geodesicDistance(coarse, seed));
  const cv::Mat geo = geodesicDistance(coarse, e1);
  double reach_max = 0;
  cv::minMaxLoc(geo, nullptr, &reach_max);
  reach_max *= shrink;
  if (reach_max < 4 * half_width) {
    out.problem = "the silhouette is not long and thin (" + fixedText(reach_max, 0) + " px along it, " +
                  fixedText(2 * half_width, 0) + " px across)";
    return out;
  }
  const double band = std::max(2.0, 0.5 * half_width);
  const int bands = static_cast<int>(reach_max / band) + 1;
  std::vector<cv::Point2d> sum(bands, cv::Point2d(0, 0));
  std::vector<int> count(bands, 0);
  for (int y = 0; y < geo.rows; ++y)
    for (int x = 0; x < geo.cols; ++x) {
      const double g = geo.at<double>(y, x) * shrink;
      if (g < 0) continue;
      const int b = std::min(bands - 1, static_cast<int>(g / band));
      sum[b] += cv::Point2d((x + 0.5) * shrink - 0.5, (y + 0.5) * shrink - 0.5);
      ++count[b];
    }
  std::vector<cv::Point2d> line;
  for (int b = 0; b < bands; ++b)
    if (count[b] > 0) line.push_back(sum[b] * (1.0 / count[b]));
  // 2. cut and bisect
  // the outline's direction at the scale of the finger (ribs and scallops smoothed out), to tell its
  // sides from its end faces
  cv::Mat side_field;
  cv::GaussianBlur(field, side_field, cv::Size(0, 0), std::max(1.5, half_width / 3), 0, cv::BORDER_REPLICATE);
  const EdgeField sides(side_field);
  const double reach = 3 * half_width + 4;
  const double stride = std::clamp(0.1 * half_width, kCutStep, 2.0);  // along a cut, before the bracket halving
  const int tangent_half = std::max(2, static_cast<int>(std::lround(0.5 * half_width / o.step_px)));
  const int smooth_half = std::max(0, static_cast<int>(std::lround(o.smooth_px / o.step_px)));
  std::vector<double> widths;
  bool refined = false;  // one cut-and-bisect pass completed
  for (int it = 0; it < std::max(1, o.iterations); ++it) {
    const std::vector<cv::Point2d> c = resample(line, o.step_px);
    const int n = static_cast<int>(c.size());
    if (n < 3) break;
    std::vector<cv::Point2d> mid;
    std::vector<cv::Point2d> tangent;
    widths.clear();
    for (int j = 0; j < n; ++j) {
      const cv::Point2d t = unit(c[std::min(n - 1, j + tangent_half)] - c[std::max(0, j - tangent_half)]);
      const cv::Point2d nrm(-t.y, t.x);
      double lo = 0, hi = 0;
      if (!cutAcross(f, &sides, c[j], nrm, reach, half_width, stride, &lo, &hi)) continue;
      mid.push_back(c[j] + nrm * (0.5 * (lo + hi)));
      tangent.push_back(t);
      widths.push_back(hi - lo);
    }
    if (mid.size() < 3) break;
    const double wmed = median(widths);
    std::vector<cv::Point2d> kept;
    for (std::size_t j = 0; j < mid.size(); ++j) {
      if (widths[j] < 0.5 * wmed) continue;  // a rounded tip's last cuts: the extension below covers it
      if (!kept.empty() && (mid[j] - kept.back()).dot(tangent[j]) < 0.2 * o.step_px) continue;  // no going back
      kept.push_back(mid[j]);
    }
    if (kept.size() < 3) break;
    std::vector<cv::Point2d> body = smooth(resample(kept, o.step_px), smooth_half);
    // the ends: straight on along the end tangent (of a robust parabola over 1.5 widths) to the outline,
    // the points the parabola leaves out at an end dropped
    const int k = std::max(8, static_cast<int>(3 * half_width / o.step_px));
    cv::Point2d tail, tail_dir, head, head_dir;
    const int last = endTangent(body, k, 0.5, &tail, &tail_dir);
    const std::vector<cv::Point2d> reversed(body.rbegin(), body.rend());
    const int first = static_cast<int>(body.size()) - 1 - endTangent(reversed, k, 0.5, &head, &head_dir);
    if (last - first < 2) break;
    body = std::vector<cv::Point2d>(body.begin() + first, body.begin() + last + 1);
    body.front() = head;
    body.back() = tail;
    const cv::Point2d start = extendToOutline(f, head, head_dir, 2 * half_width + 5);
    const cv::Point2d end = extendToOutline(f, tail, tail_dir, 2 * half_width + 5);
    line.assign(1, start);
    line.insert(line.end(), body.begin(), body.end());
    line.push_back(end);
    out.start_at_border = atBorder(start);
    out.end_at_border = atBorder(end);
    out.width_px = median(widths);
    refined = true;
  }
  if (!refined) {
    out.problem = "no cut across the silhouette is bisected by a centreline";
    return out;
  }
  for (auto& p : line) p = toFrame(p) + cv::Point2d(offset);
  out.points = resample(line, o.step_px);
  out.width_px *= 0.5 * (qx + qy);
  out.length_px = polylineLength(out.points);
  if (out.length_px < 2 * out.width_px) {
    out.problem = "the centreline (" + fixedText(out.length_px, 0) + " px) is shorter than twice the width (" +
                  fixedText(out.width_px, 0) + " px)";
    return out;
  }
  out.ok = true;
  return out;
}

std::vector<cv::Point2d> equalArcStations(const std::vector<cv::Point2d>& p, int segments) {
  std::vector<cv::Point2d> st;
  if (p.size() < 2 || segments < 1) return st;
  std::vector<double> s(p.size(), 0.0);
  for (std::size_t i = 1; i < p.size(); ++i) s[i] = s[i - 1] + cv::norm(p[i] - p[i - 1]);
  const double L = s.back();
  std::size_t i = 1;
  for (int k = 0; k <= segments; ++k) {
    const double at = L * k / segments;
    while (i + 1 < p.size() && s[i] < at) ++i;
    const double seg = s[i] - s[i - 1];
    const double t = seg > 0 ? std::clamp((at - s[i - 1]) / seg, 0.0, 1.0) : 0.0;
    st.push_back(p[i - 1] + (p[i] - p[i - 1]) * t);
  }
  return st;
}

}  // namespace topo_gaussian::vision
