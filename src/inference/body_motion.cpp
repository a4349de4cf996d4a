#include "topo_gaussian/inference/body_motion.h"

#include <algorithm>

#include "topo_gaussian/common/error.h"

namespace topo_gaussian::inference {

BodyPose poseAt(const std::vector<BodyPose>& motion, double t) {
  if (motion.empty()) throw TopoError("body motion", "has no samples", "simulate a rigid task with a motion first");
  if (t <= motion.front().t) return motion.front();
  if (t >= motion.back().t) return motion.back();
  const auto hi =
      std::upper_bound(motion.begin(), motion.end(), t, [](double v, const BodyPose& p) { return v < p.t; });
  const BodyPose& b = *hi;
  const BodyPose& a = *(hi - 1);
  const double span = b.t - a.t;
  const double w = span > 0 ? (t - a.t) / span : 0.0;
  BodyPose p;
  p.t = t;
  p.translation = (1 - w) * a.translation + w * b.translation;
  p.rotation = a.rotation.slerp(w, b.rotation).normalized();
  return p;
}

}  // namespace topo_gaussian::inference
