#include "topo_gaussian/ros/motion_features_msg.h"

namespace topo_gaussian::topo_ros {

namespace {

// The scalar fields, in the order of MotionFeatures.msg; F(name) expands for each.
#define TOPO_MOTION_FEATURE_FIELDS(F)                                                                              \
  F(kind)                                                                                                          \
  F(method)                                                                                                        \
  F(source)                                                                                                        \
  F(message) F(experiment) F(oscillation_found) F(period_s) F(amplitude_deg) F(max_tilt_deg) F(equilibrium_deg)    \
      F(log_decrement) F(damping_ratio) F(bending_angle_deg) F(bend_profile_deg) F(profile_segments)               \
          F(period_confidence) F(amplitude_confidence) F(equilibrium_confidence) F(bending_confidence)             \
              F(bend_profile_confidence) F(start_time_s) F(end_time_s) F(first_frame) F(last_frame) F(frames_used) \
                  F(frames_lost) F(time_s) F(angle_deg)

template <typename To, typename From>
void copyScalars(To& to, const From& from) {
#define TOPO_COPY_FIELD(name) to.name = from.name;
  TOPO_MOTION_FEATURE_FIELDS(TOPO_COPY_FIELD)
#undef TOPO_COPY_FIELD
}

}  // namespace

topo_gaussian::MotionFeatures toMotionFeaturesMsg(const motion::MotionFeatures& f) {
  topo_gaussian::MotionFeatures m;
  copyScalars(m, f);
  for (const auto& tr : f.trajectories) {
    topo_gaussian::PixelTrajectory t;
    t.name = tr.name;
    t.time_s = tr.time_s;
    t.x_px = tr.x_px;
    t.y_px = tr.y_px;
    for (const auto& q : tr.points_on_plane) {
      geometry_msgs::Point p;
      p.x = q[0];
      p.y = q[1];
      p.z = q[2];
      t.points_on_plane.push_back(p);
    }
    m.trajectories.push_back(std::move(t));
  }
  return m;
}

motion::MotionFeatures fromMotionFeaturesMsg(const topo_gaussian::MotionFeatures& m) {
  motion::MotionFeatures f;
  copyScalars(f, m);
  for (const auto& t : m.trajectories) {
    motion::PixelTrajectory tr;
    tr.name = t.name;
    tr.time_s = t.time_s;
    tr.x_px = t.x_px;
    tr.y_px = t.y_px;
    for (const auto& p : t.points_on_plane) tr.points_on_plane.push_back({p.x, p.y, p.z});
    f.trajectories.push_back(std::move(tr));
  }
  return f;
}

}  // namespace topo_gaussian::topo_ros
