// TrackResult → motion::MotionFeatures (vision/motion_features.h).
#include "topo_gaussian/vision/motion_features.h"

namespace topo_gaussian::vision {

motion::MotionFeatures toMotionFeatures(const TrackResult& r) {
  motion::MotionFeatures m;
  m.kind = r.kind;
  m.method = r.method;
  m.source = r.source;
  m.message = r.message;
  m.oscillation_found = r.signal.oscillation_found;
  m.period_s = r.signal.period_s;
  m.amplitude_deg = r.signal.amplitude_deg;
  m.max_tilt_deg = r.signal.max_tilt_deg;
  m.equilibrium_deg = r.signal.oscillation_found ? r.signal.equilibrium_deg : r.static_pose.angle_deg;
  m.log_decrement = r.signal.log_decrement;
  m.damping_ratio = r.signal.damping_ratio;
  m.bending_angle_deg = r.bend_held_deg;  // the bend at the full pressure (the held plateau)
  m.bend_profile_deg = r.bend_profile_deg;  // at the same held frames
  m.profile_segments = r.profile_segments;
  auto conf = [&](const char* k) {
    const auto it = r.confidence.find(k);
    return it == r.confidence.end() ? 0.0 : it->second;
  };
  m.period_confidence = conf("period_s");
  m.amplitude_confidence = conf("amplitude_deg");
  // The tracker's confidence keys (motion_tracker.cpp): "equilibrium_deg" (tilt; 0 when the axis is
  // ambiguous), else the oscillation's centre (as sure as the period) or the static pose; the bend is
  // "bend_deg", the profile "bend_profile_deg".
  m.equilibrium_confidence = r.confidence.count("equilibrium_deg") ? conf("equilibrium_deg")
                             : r.signal.oscillation_found          ? conf("period_s")
                                                                   : conf("static_angle_deg");
  m.bending_confidence = conf("bend_deg");
  m.bend_profile_confidence = m.bend_profile_deg.empty() ? 0.0 : conf("bend_profile_deg");
  m.start_time_s = r.t_start_s;
  m.end_time_s = r.t_end_s;
  m.first_frame = r.first_frame;
  m.last_frame = r.last_frame;
  m.frames_used = r.frames_used;
  m.frames_lost = r.lost_frames;
  m.time_s = r.t;
  m.angle_deg = r.angle_deg;
  for (std::size_t k = 0; k < r.trajectories.size(); ++k) {
    motion::PixelTrajectory tr;
    tr.name = "point_" + std::to_string(k);
    for (const auto& s : r.trajectories[k]) {
      tr.time_s.push_back(s.t);
      tr.x_px.push_back(s.x);
      tr.y_px.push_back(s.y);
    }
    if (k < r.points_on_plane.size())
      for (const auto& q : r.points_on_plane[k]) tr.points_on_plane.push_back({q[0], q[1], q[2]});
    m.trajectories.push_back(std::move(tr));
  }
  return m;
}

}  // namespace topo_gaussian::vision
