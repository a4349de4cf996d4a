// TrackResult (what the tracker measured, with its tracker-only details) → motion::MotionFeatures
// (common/motion_features.h, the library type that `topo track --json`, the motion_tracker node's
// message and the inference share). The one place that decides which tracker number becomes which
// feature.
#pragma once

#include "topo_gaussian/common/motion_features.h"
#include "topo_gaussian/vision/motion_tracker.h"

namespace topo_gaussian::vision {

/// Features of a tracking result: the signal's period, amplitude, max tilt, damping; the
/// equilibrium is the oscillation centre, or the static pose when no oscillation was found; the
/// bending angle and the bend profile (finger); a confidence per feature from result.confidence (absent → 0, "not
/// measured"; the equilibrium's is the period's, or the static pose's when no oscillation); frame and time range; the
/// sampled signal; one PixelTrajectory "point_<k>" per tracked point, with its points_on_plane when placeOnPlane was
/// called.
motion::MotionFeatures toMotionFeatures(const TrackResult& result);

}  // namespace topo_gaussian::vision
