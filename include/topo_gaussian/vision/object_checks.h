// Is what the tracker followed one rigid object? A tracked blob/silhouette must behave like one rigid
// object: compact, of consistent size and colour, moving continuously. From the per-frame
// measurements (vision/trackers.h) of the frames where something was found:
//  - frame filling:  the chosen blob covers > max_blob_fraction of the region, or the whole mask
//                    > max_mask_fraction of it (the background, a wall, a floor);
//  - texture:        the mask falls into ≥ texture_min_pieces blobs and the chosen one holds less than
//                    texture_max_share of it, in most frames (bricks, parquet, foliage);
//  - size:           robust spread of the area, s_A = 1.4826·MAD(A)/median(A), above max_area_spread;
//  - jumps:          a frame whose velocity changes by more than max(jump_sizes · √median(A), 20 px)
//                    per frame, |c₊ − 2c + c₋|, is a jump (a fast object keeps its velocity, a bounce
//                    reverses it once; a tracker switching between regions jumps there and back);
//                    more than max_jump_fraction of the frames are jumps;
//  - colour:         robust spread of the blob's mean colour above max_colour_spread (0..255 units).
// Each failing check is a reason to refuse; the score (0..1) multiplies every feature's confidence:
//   score = 1/(1 + (s_A/0.5)²) · (1 − 3·jump_fraction)₊ · min(1, solidity/0.6) · 1/(1 + (s_c/40)²).
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "topo_gaussian/vision/trackers.h"

namespace topo_gaussian::vision {

struct ObjectCheckOptions {
  double max_blob_fraction = 0.5;
  double max_mask_fraction = 0.6;
  int texture_min_pieces = 6;
  double texture_max_share = 0.5;
  double max_area_spread = 0.6;
  double jump_sizes = 4.0;
  double max_jump_fraction = 0.12;
  double max_colour_spread = 45.0;
};

struct ObjectCheck {
  bool valid = false;   ///< behaves like one object (false also when nothing was found)
  double score = 0.0;   ///< 0..1, multiplies the features' confidences
  std::string problem;  ///< for a person: what was seen instead, and the fix (empty when valid)
  int frames = 0;       ///< frames with a measurement
  double median_area_px = 0.0, area_spread = 0.0, jump_fraction = 0.0, median_mask_fraction = 0.0,
         median_solidity = 1.0, colour_spread = 0.0;
};

/// `measurements` in frame order (found or not); `method` names the tracker for the advice.
ObjectCheck checkOneObject(const std::vector<Measurement>& measurements, const std::string& method,
                           const ObjectCheckOptions& options = ObjectCheckOptions());

}  // namespace topo_gaussian::vision
