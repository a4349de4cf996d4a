// ColourSurvey: what colour is the thing that moves? Used when the marker tracker's default colour
// (red) finds no object, so the refusal can say which colour range or method would.
//
//   background B(x)  = per-pixel median of the sampled frames (the object moves, the scene does not)
//   foreground F_k   = { x : max_c |I_k(x)_c − B(x)_c| > τ }  (τ = 30 grey levels), opened
//   hue histogram    = OpenCV hues (0..180) of the foreground pixels with S ≥ 45 and V ≥ 40
//   dominant hue h*  = the 21-bin circular window with the most pixels; the suggested range is that
//                      window with S and V from their 10th percentiles inside it
// When fewer than a quarter of the foreground pixels are coloured (a grey or metal object), the
// suggestion is the silhouette method, with the polarity the foreground's brightness against the
// background gives. Every suggestion is tried on the sampled frames (the marker tracker with the
// suggested range, or an Otsu silhouette): the survey reports in how many it finds a blob.
//
// The frames are kept downscaled (at most 320 px wide) and thinned to at most 48, evenly spread over
// the clip, so the survey costs little memory and a small fraction of the tracking time.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "topo_gaussian/vision/trackers.h"

namespace topo_gaussian::vision {

struct ColourSuggestion {
  bool available = false;      ///< false: too few frames or nothing moved; `text` says which
  std::string method;          ///< "marker" or "silhouette"
  HsvRange range;              ///< marker: the suggested HSV range (OpenCV units)
  std::string polarity;        ///< silhouette: "darker" | "brighter"
  std::string args;            ///< the options to give `topo track`, e.g. "--hsv-lower 30,80,90 --hsv-upper 50,255,255"
  double moving_fraction = 0;  ///< foreground pixels / pixels, averaged over the sampled frames
  double coloured_share = 0;   ///< of the foreground pixels, the share with S ≥ 45 and V ≥ 40
  double hue_share = 0;        ///< of the coloured foreground pixels, the share inside the suggested hue band
  int frames_tried = 0;        ///< sampled frames the suggestion was tried on
  int frames_found = 0;        ///< ... in which it found a blob of at least min_area_px
  std::string text;            ///< one line for a person (what moved, the suggestion, how it did)
};

class ColourSurvey {
 public:
  /// `roi` (full-frame pixels; empty = the whole frame) limits the survey to the tracker's region;
  /// `min_area_px` is the tracker's smallest blob at full resolution.
  ColourSurvey(cv::Rect roi, double min_area_px);
  /// Offer one BGR frame (every frame of the clip, in order); a few are kept.
  void addFrame(const cv::Mat& bgr);
  int framesKept() const { return static_cast<int>(frames_.size()); }
  /// The suggestion from the frames kept so far (at least 4 needed). Computed again only when a frame
  /// was kept since the last call (a live tracker asks at every publication of a refused window).
  ColourSuggestion suggest() const;

 private:
  cv::Rect roi_;
  double min_area_px_;
  double scale_ = 1.0;
  long offered_ = 0;
  long stride_ = 1;
  std::vector<cv::Mat> frames_;  ///< downscaled BGR crops of the region
  long kept_ = 0;                 ///< frames kept so far (the cache's key)
  mutable long suggested_at_ = -1;
  mutable ColourSuggestion suggestion_;
  ColourSuggestion compute() const;
};

}  // namespace topo_gaussian::vision
