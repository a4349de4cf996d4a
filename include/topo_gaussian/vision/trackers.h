// Per-frame object trackers on BGR frames inside a region of interest:
//  - marker:     HSV colour range(s) (default red, two hue bands for the wrap-around), morphological
//                opening, the blob above a minimum area that continues the last one (nearest the
//                constant-velocity prediction, similar area; the largest at the start or after a loss) → centroid, and
//                the blob as a colour-mask silhouette (principal axis, mask) for the finger kind;
//  - silhouette: foreground by background subtraction (MOG2) or an Otsu threshold whose object side is
//                chosen by `polarity` (darker / brighter than the background, or auto: the side that
//                touches the frame border less), the contour chosen as for the marker → image moments →
//                centroid and principal-axis angle;
//  - klt:        Shi–Tomasi corners in the ROI of the first frame, pyramidal Lucas–Kanade flow with a
//                forward–backward check, re-seeded when too few points survive.
// Coordinates in a Measurement are full-frame pixels. Every measurement also describes the mask it
// came from (how much of the region it covers, in how many pieces, how convex the chosen blob is,
// its colour), so the object checks (vision/object_checks.h) can tell one object from a texture.
#pragma once

#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace topo_gaussian::vision {

struct HsvRange {
  cv::Scalar lower, upper;  ///< OpenCV HSV: H 0..180, S and V 0..255 (inclusive)
};

/// Red in two hue bands (0..10 and 170..180), saturation ≥ 90, value ≥ 60.
std::vector<HsvRange> defaultRedRanges();

/// Throws TopoError naming `option` (e.g. "--hsv-lower/--hsv-upper") for a range outside OpenCV's HSV
/// (H 0..180, S and V 0..255) or with a lower bound above the upper one.
void validateHsvRange(const HsvRange& range, const std::string& option);

struct TrackerOptions {
  std::string method = "marker";  ///< marker | silhouette | klt
  cv::Rect roi;                   ///< empty and not roi_given: the whole frame
  bool roi_given = false;         ///< an explicitly empty ROI is then an error
  std::vector<HsvRange> hsv;      ///< marker colour; empty = defaultRedRanges()
  double min_area_px = 30.0;      ///< smallest blob / contour accepted
  int morph_kernel_px = 5;        ///< opening kernel (0 = none)
  /// silhouette: mog2 | otsu | auto. auto = otsu for MotionTracker kinds tilt and finger (an object
  /// that rocks or bends in place stays where it was, so a background model would absorb it), mog2
  /// otherwise; finger always uses otsu.
  std::string foreground = "auto";
  /// silhouette by Otsu: the object is darker | brighter than its background, or auto (the side that
  /// touches the frame border less is the object; the smaller side when both touch it as much).
  std::string polarity = "auto";
  bool keep_mask = false;  ///< fill Measurement::mask (the finger kind needs it; MotionTracker sets it)
  int klt_max_points = 40;
  int klt_min_points = 8;      ///< re-seed below this
  double klt_fb_max_px = 1.0;  ///< forward–backward error limit
};

struct Measurement {
  bool found = false;
  cv::Point2d centroid;  ///< marker / silhouette centroid / mean of the KLT points
  double area_px = 0.0;
  double axis_angle_deg = 0.0;  ///< silhouette: principal axis (pointing image-up) from image-up, + towards image-right
  double elongation = 0.0;      ///< silhouette: sqrt(λmax/λmin) of the moments (1 = round)
  std::vector<cv::Point> contour;  ///< marker blob / silhouette outline (full-frame pixels)
  cv::Mat mask;                    ///< marker / silhouette: the chosen blob (ROI-sized, CV_8U), else empty
  // what the mask looked like (marker / silhouette; klt leaves the defaults)
  double mask_fraction = 0.0;       ///< all mask pixels / region pixels (after the opening)
  double largest_share = 1.0;       ///< the chosen blob's pixels / all mask pixels
  int pieces = 1;                   ///< blobs of at least min_area_px in the mask
  double solidity = 1.0;            ///< chosen blob area / its convex hull's area
  bool touches_border = false;      ///< the chosen blob touches the region's border
  cv::Vec3d mean_bgr;               ///< mean colour of the chosen blob
  std::vector<cv::Point2f> points;  ///< klt: current points
  std::vector<int> point_ids;       ///< klt: stable id of each point (re-seeded points get new ids)
};

class Tracker {
 public:
  virtual ~Tracker() = default;
  virtual Measurement track(const cv::Mat& bgr) = 0;
  virtual std::string name() const = 0;
};

/// Throws TopoError for an unknown method, or an ROI that is empty or outside `frame_size`
/// (message names --roi and the frame size).
std::unique_ptr<Tracker> makeTracker(const TrackerOptions& options, const cv::Size& frame_size);

/// The ROI clipped/validated against the frame (empty ROI → whole frame); throws as above.
cv::Rect validRoi(const cv::Rect& roi, const cv::Size& frame_size, bool roi_given);

}  // namespace topo_gaussian::vision
