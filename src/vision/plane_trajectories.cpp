// Tracked pixels → 3D points on a known plane through the camera model (trajectories
// "as rays/3D points on a known plane, so the inference can compare simulated points").
#include <cmath>
#include <limits>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/vision/camera_model.h"
#include "topo_gaussian/vision/motion_tracker.h"

namespace topo_gaussian::vision {

void placeOnPlane(const CameraModel& camera, const cv::Vec3d& n, double d, TrackResult& result) {
  if (!(cv::norm(n) > 0) || !std::isfinite(d))
    throw TopoError("plane", "normal is zero or offset not finite",
                    "give n·x = d with a non-zero normal, e.g. 0,0,1,0 for the floor");
  const double nan = std::numeric_limits<double>::quiet_NaN();
  result.points_on_plane.assign(result.trajectories.size(), {});
  for (std::size_t k = 0; k < result.trajectories.size(); ++k) {
    auto& out = result.points_on_plane[k];
    out.reserve(result.trajectories[k].size());
    for (const auto& s : result.trajectories[k]) {
      try {
        out.push_back(camera.intersectPlane(cv::Point2d(s.x, s.y), n, d));
      } catch (const TopoError&) {
        out.push_back(cv::Vec3d(nan, nan, nan));  // ray parallel to or away from the plane
      }
    }
  }
}

}  // namespace topo_gaussian::vision
