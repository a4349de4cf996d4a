// checkOneObject: the rigid-object checks of vision/object_checks.h.
#include "topo_gaussian/vision/object_checks.h"

#include <algorithm>
#include <cmath>

#include "topo_gaussian/common/number_text.h"
#include "topo_gaussian/common/statistics.h"

namespace topo_gaussian::vision {
namespace {

/// 1.4826 · MAD: the standard deviation of normal data, robust to outliers.
double robustSpread(const std::vector<double>& v) {
  if (v.empty()) return 0.0;
  const double m = median(v);
  std::vector<double> d;
  for (double x : v) d.push_back(std::abs(x - m));
  return 1.4826 * median(d);
}

std::string percent(double f) { return fixedText(100.0 * f, f < 0.1 ? 1 : 0) + " %"; }

}  // namespace

ObjectCheck checkOneObject(const std::vector<Measurement>& ms, const std::string& method, const ObjectCheckOptions& o) {
  ObjectCheck c;
  std::vector<double> area, fraction, solidity, b, g, r, share, steps;
  std::vector<int> pieces;
  std::vector<cv::Point2d> path;
  for (const auto& m : ms) {
    if (!m.found) continue;
    area.push_back(m.area_px);
    fraction.push_back(m.mask_fraction);
    solidity.push_back(m.solidity);
    share.push_back(m.largest_share);
    pieces.push_back(m.pieces);
    b.push_back(m.mean_bgr[0]);
    g.push_back(m.mean_bgr[1]);
    r.push_back(m.mean_bgr[2]);
    path.push_back(m.centroid);
  }
  c.frames = static_cast<int>(area.size());
  if (c.frames == 0) {
    c.problem = "nothing was found";
    return c;
  }
  const std::string fix = method == "marker"
                              ? "narrow the colour range (--hsv-lower/--hsv-upper) to the object, give --roi around "
                                "its motion, or use --method silhouette"
                              : "give --roi around the object's motion, set --polarity, or use --method marker with "
                                "the object's colour";
  c.median_area_px = median(area);
  // klt's "area" is its point count and it has no mask: only the jumps apply to it
  const bool klt = method == "klt";
  c.area_spread = c.median_area_px > 0 && !klt ? robustSpread(area) / c.median_area_px : 0.0;
  c.median_mask_fraction = median(fraction);
  c.median_solidity = median(solidity);
  c.colour_spread = klt ? 0.0 : std::max({robustSpread(b), robustSpread(g), robustSpread(r)});
  // blob fraction of the region: area / (mask pixels / mask fraction) = share · mask fraction
  std::vector<double> blob_fraction;
  for (std::size_t i = 0; i < fraction.size(); ++i) blob_fraction.push_back(fraction[i] * share[i]);
  const double median_blob_fraction = median(blob_fraction);
  int texture_frames = 0;
  for (std::size_t i = 0; i < pieces.size(); ++i)
    if (pieces[i] >= o.texture_min_pieces && share[i] < o.texture_max_share) ++texture_frames;
  const double size_px = klt ? 10.0 : std::sqrt(std::max(1.0, c.median_area_px));
  // jumps: the second difference of the position (a change of velocity within one frame); a fast
  // object in flight keeps its velocity, a bounce reverses it once, a tracker that switches between
  // regions jumps there and back
  for (std::size_t i = 1; i + 1 < path.size(); ++i)
    steps.push_back(cv::norm(path[i + 1] - 2.0 * path[i] + path[i - 1]));
  const double jump_px = std::max(o.jump_sizes * size_px, 20.0);
  int jumps = 0;
  for (double s : steps)
    if (s > jump_px) ++jumps;
  c.jump_fraction = steps.empty() ? 0.0 : static_cast<double>(jumps) / steps.size();

  std::vector<std::string> problems;
  if (median_blob_fraction > o.max_blob_fraction || c.median_mask_fraction > o.max_mask_fraction)
    problems.push_back("the tracked region fills " + percent(std::max(median_blob_fraction, c.median_mask_fraction)) +
                       " of the frame (or --roi): the background or a wall/floor, not an object in view");
  if (texture_frames > 0.5 * c.frames)
    problems.push_back("the mask falls into many pieces (median " +
                       fixedText(median(std::vector<double>(pieces.begin(), pieces.end())), 0) +
                       ", the largest holds " + percent(median(share)) + " of it) in " +
                       percent(double(texture_frames) / c.frames) +
                       " of the frames: a texture of that colour (floor, wall, bricks), not one object");
  if (c.area_spread > o.max_area_spread)
    problems.push_back("its size changes from frame to frame by " + percent(c.area_spread) +
                       " (robust spread of the area): not one rigid object");
  if (c.jump_fraction > o.max_jump_fraction)
    problems.push_back("it jumps: its velocity changes by more than " + fixedText(jump_px, 0) +
                       " px within one frame in " + percent(c.jump_fraction) +
                       " of the frames (the tracker switches between regions)");
  if (c.colour_spread > o.max_colour_spread)
    problems.push_back("its colour changes by " + fixedText(c.colour_spread, 0) +
                       " (0..255, robust spread) between frames: different things are being followed");
  c.score = 1.0 / (1.0 + (c.area_spread / 0.5) * (c.area_spread / 0.5));
  c.score *= std::max(0.0, 1.0 - 3.0 * c.jump_fraction);
  c.score *= std::min(1.0, c.median_solidity / 0.6);
  c.score *= 1.0 / (1.0 + (c.colour_spread / 40.0) * (c.colour_spread / 40.0));
  c.valid = problems.empty();
  if (!c.valid) {
    c.score = 0.0;
    for (std::size_t i = 0; i < problems.size(); ++i) c.problem += (i ? "; " : "") + problems[i];
    c.problem = "what was tracked is not one object: " + c.problem + "; " + fix;
  }
  return c;
}

}  // namespace topo_gaussian::vision
