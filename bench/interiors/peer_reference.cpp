#include "peer_reference.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <random>

#include "peer_world/bullet_rocking.h"
#include "peer_world/exact_mass.h"
#include "peer_world/mesh_renderer.h"
#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/number_text.h"
#include "topo_gaussian/inference/motion_targets.h"
#include "topo_gaussian/inference/oscillation.h"
#include "topo_gaussian/inference/task.h"
#include "topo_gaussian/vision/motion_features.h"
#include "topo_gaussian/vision/motion_tracker.h"

namespace topo_gaussian::bench {

using Eigen::Vector3d;

namespace {

MassProperties toMassProperties(const peer::MassMoments& m) {
  MassProperties p;
  p.mass = m.mass_kg;
  p.com = m.com_m;
  p.inertia = m.inertia_com_kg_m2;
  return p;
}

peer::MassMoments toMoments(const MassProperties& p) {
  peer::MassMoments m;
  m.mass_kg = p.mass;
  m.com_m = p.com;
  m.inertia_com_kg_m2 = p.inertia;
  return m;
}

/// Points on the region's surface (sphere, ellipsoid, box), to check that it lies inside the mesh.
std::vector<Vector3d> surfaceSamples(const PeerRegion& R) {
  std::vector<Vector3d> out;
  const int n = 400;
  const double golden = M_PI * (3.0 - std::sqrt(5.0));
  for (int k = 0; k < n; ++k) {  // a Fibonacci sphere, mapped onto the region
    const double z = 1.0 - 2.0 * (k + 0.5) / n, r = std::sqrt(1.0 - z * z);
    Vector3d u(r * std::cos(golden * k), r * std::sin(golden * k), z);
    if (R.kind == PeerRegion::Box) u /= u.cwiseAbs().maxCoeff();  // onto the cube's faces
    const bool round = R.kind == PeerRegion::Sphere || R.kind == PeerRegion::SphereBelow;
    const Vector3d scale = round ? Vector3d::Constant(R.half.x()) : R.half;
    Vector3d x = R.centre + u.cwiseProduct(scale);
    if (R.kind == PeerRegion::SphereBelow) x.z() = std::min(x.z(), R.cut_z_m);  // onto the flat face
    out.push_back(x);
  }
  return out;
}

/// The rig's camera, level, 1.5 m along −x from `target`, 8° across 640 × 480 px, with a mild barrel lens.
peer::PeerCamera rigCamera(const Vector3d& target) {
  return peer::lookAtCamera(target - Vector3d(1.5, 0, 0), target, Vector3d::UnitZ(), 8.0, 640, 480,
                            {-0.08, 0.02, 0.0005, -0.0003});
}

peer::RockingOptions rockingOptions(const inference::TaskConfig& c, double duration_s) {
  peer::RockingOptions o;
  o.rocking_axis_body = c.vector3("rocking_axis").normalized();
  o.up_axis_body = c.vector3("up_axis").normalized();
  o.initial_tilt_deg = c.number("initial_tilt_deg");
  o.duration_s = duration_s;
  o.gravity_m_s2 = c.vector3("gravity").norm();
  return o;
}

}  // namespace

bool PeerRegion::inside(const Vector3d& x) const {
  const Vector3d d = x - centre;
  switch (kind) {
    case Sphere:
      return d.norm() < half.x();
    case SphereBelow:
      return d.norm() < half.x() && x.z() < cut_z_m;
    case Ellipsoid:
      return d.cwiseQuotient(half).squaredNorm() < 1.0;
    case Box:
      return (d.cwiseAbs() - half).maxCoeff() < 0.0;
    case HalfSpace:
      return normal.dot(d) > 0.0;
  }
  return false;
}

MassProperties sphereBelowMoments(const Vector3d& c, double R, double cut_z, double rho) {
  if (!(R > 0) || !std::isfinite(R))
    throw TopoError("sphere below a plane: radius_m", "is " + numberText(R) + ", not a positive length", "give r > 0");
  const double z0 = c.z() - R, z1 = std::min(cut_z, c.z() + R);
  if (!(z1 > z0))
    throw TopoError("sphere below a plane: cut_z_m " + numberText(cut_z), "lies below the sphere",
                    "cut it above its lowest point");
  // ∫ f(z) dz over [z0, z1] by 5-point Gauss–Legendre (exact for degree ≤ 9); a²(z) = R² − (z − c_z)².
  static const double xg[5] = {0.0, -0.5384693101056831, 0.5384693101056831, -0.9061798459386640,
                                0.9061798459386640};
  static const double wg[5] = {0.5688888888888889, 0.4786286704993665, 0.4786286704993665, 0.2369268850561891,
                               0.2369268850561891};
  auto integral = [&](auto f) {
    double s = 0;
    for (int k = 0; k < 5; ++k) s += wg[k] * f(0.5 * (z0 + z1) + 0.5 * (z1 - z0) * xg[k]);
    return 0.5 * (z1 - z0) * s;
  };
  auto a2 = [&](double z) { return R * R - (z - c.z()) * (z - c.z()); };
  const double V = integral([&](double z) { return M_PI * a2(z); });
  const double zc = integral([&](double z) { return z * M_PI * a2(z); }) / V;
  const double Iz = integral([&](double z) { return 0.5 * M_PI * a2(z) * a2(z); });
  const double Ix = integral([&](double z) { return 0.25 * M_PI * a2(z) * a2(z) + (z - zc) * (z - zc) * M_PI * a2(z); });
  MassProperties p;
  p.mass = rho * V;
  p.com = Vector3d(c.x(), c.y(), zc);
  p.inertia = (rho * Eigen::Vector3d(Ix, Ix, Iz)).asDiagonal();
  return p;
}

PeerObject makePeerObject(const geometry::SurfaceData& mesh, const PeerRegion& R, double density_body,
                          double density_region) {
  PeerObject o;
  o.vertices = mesh.points;
  o.triangles = mesh.triangles;
  const peer::MassMoments body = peer::meshMoments(o.vertices, o.triangles, density_body);
  const double d = density_region - density_body;
  peer::MassMoments region;
  if (R.kind == PeerRegion::HalfSpace) {
    region = peer::clippedMeshMoments(o.vertices, o.triangles, R.centre, R.normal, d);
  } else {
    for (const Vector3d& x : surfaceSamples(R))
      if (!peer::insideMesh(o.vertices, o.triangles, x))
        throw TopoError("peer world region at (" + numberText(R.centre.x()) + ", " + numberText(R.centre.y()) + ", " +
                            numberText(R.centre.z()) + ") m",
                        "reaches outside the object's mesh " + mesh.source,
                        "choose a region inside the object (its moments are exact only there)");
    region = R.kind == PeerRegion::SphereBelow ? toMoments(sphereBelowMoments(R.centre, R.half.x(), R.cut_z_m, d))
             : R.kind == PeerRegion::Sphere    ? peer::sphereMoments(R.centre, R.half.x(), d)
             : R.kind == PeerRegion::Ellipsoid ? peer::ellipsoidMoments(R.centre, R.half, d)
                                               : peer::boxMoments(R.centre, R.half, d);
  }
  o.plain = toMassProperties(body);
  o.truth = toMassProperties(peer::combine({body, region}));
  return o;
}

double axleSwingPeriod(const MassProperties& m, const Vector3d& point, const Vector3d& a, double amplitude_deg,
                       double g) {
  const Vector3d s = m.com - point;
  const Vector3d s_perp = s - a.dot(s) * a;
  const double d = s_perp.norm();
  if (!(d > 0)) return NAN;
  const double I_a = a.dot(m.inertia * a) + m.mass * d * d;
  return 4.0 * std::sqrt(I_a / (m.mass * g * d)) * std::comp_ellint_1(std::sin(0.5 * amplitude_deg * M_PI / 180.0));
}

PeerRockingVideo observeRockingThroughPeerVideo(inference::TaskConfig& c, const PeerObject& object, double duration_s,
                                                double fps, double noise_scale, const std::string& frames_dir) {
  PeerRockingVideo v;
  const peer::RockingRun run = peer::rockOnGround(object.vertices, toMoments(object.truth), rockingOptions(c, duration_s));
  const double dt = run.time_s.size() > 1 ? run.time_s[1] - run.time_s[0] : 0.0;
  const int cycles = c.integer("measured_cycles");
  const auto bullet = inference::analyseOscillation(run.tilt_deg, 0.0, dt, cycles, true);
  if (bullet.valid) v.bullet_period_s = bullet.period, v.bullet_max_tilt_deg = bullet.max_abs;

  // The pose at t, interpolated between Bullet's samples (slerp).
  const auto pose_at = [&](double t) {
    const double u = std::clamp(t / dt, 0.0, double(run.time_s.size() - 1));
    const std::size_t j = std::min<std::size_t>(static_cast<std::size_t>(u), run.time_s.size() - 2);
    const double w = u - j;
    const Eigen::Quaterniond q0(run.world_from_body[j].rotation()), q1(run.world_from_body[j + 1].rotation());
    Eigen::Isometry3d p = Eigen::Isometry3d::Identity();
    p.linear() = q0.slerp(w, q1).toRotationMatrix();
    p.translation() = (1 - w) * run.world_from_body[j].translation() + w * run.world_from_body[j + 1].translation();
    return p;
  };
  const Vector3d target = run.world_from_body.front() * object.truth.com;
  const peer::PeerCamera camera = rigCamera(Vector3d(target.x(), target.y(), target.z()));
  peer::RenderStyle style;
  style.noise_sigma = 2.0 * noise_scale;
  style.exposure_s = 1.0 / (2.0 * fps);  // half the frame interval: a little motion blur
  style.sub_samples = 2;
  style.readout_s = 0.5 / fps;  // a rolling shutter reading out over half a frame, in 12 bands
  style.readout_bands = 12;
  style.supersample = 2;
  vision::TrackOptions t;
  t.kind = "tilt";
  t.tracker.method = "silhouette";
  t.fps = fps;
  vision::MotionTracker tracker(t);
  if (!frames_dir.empty()) std::filesystem::create_directories(frames_dir);
  const int frames = static_cast<int>(fps * duration_s);
  double render_s = 0;
  for (int k = 0; k < frames; ++k) {
    const auto t0 = std::chrono::steady_clock::now();
    const cv::Mat img = peer::renderMeshFrame(object.vertices, object.triangles, pose_at, k / fps, k, camera, style);
    render_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (!frames_dir.empty()) {
      char name[64];
      std::snprintf(name, sizeof name, "/frame_%04d.png", k);
      cv::imwrite(frames_dir + name, img);
    }
    tracker.addFrame(img, k / fps);
  }
  v.frames = frames;
  v.render_ms = frames > 0 ? 1e3 * render_s / frames : 0.0;
  const vision::TrackResult track = tracker.finish();
  v.tracker_message = track.message;
  const motion::MotionFeatures f = vision::toMotionFeatures(track);
  v.tracked_period_s = f.period_s;
  v.tracked_max_tilt_deg = f.max_tilt_deg;
  double sum = 0;
  int count = 0;
  for (std::size_t k = 0; k < f.time_s.size(); ++k) {
    const double u = f.time_s[k] / dt;
    const std::size_t j = static_cast<std::size_t>(u);
    if (j + 1 >= run.tilt_deg.size()) break;
    const double y = run.tilt_deg[j] + (u - j) * (run.tilt_deg[j + 1] - run.tilt_deg[j]);
    const double e = std::abs(f.angle_deg[k]) - std::abs(y);
    sum += e;
    ++count;
    v.tilt_error_max_deg = std::max(std::isfinite(v.tilt_error_max_deg) ? v.tilt_error_max_deg : 0.0, std::abs(e));
  }
  if (count > 0) v.tilt_error_mean_deg = sum / count;
  const inference::MotionTargets mt = inference::targetsFromMotion(c, f);
  for (const auto& [name, value] : mt.targets) c.setNumber(name, value);
  v.targets = mt.targets;
  v.note = mt.note;
  if (mt.targets.empty())
    throw TopoError("peer-world video of experiment (" + c.task() + ")",
                    "gave no targets: " + mt.note + " " + track.message, "check the peer camera and the clip");
  return v;
}

PeerHang peerHang(const inference::TaskConfig& c, const PeerObject& object) {
  PeerHang h;
  const Vector3d p = c.vector3("hanging_point");
  const inference::RollPitch rest = inference::hangingRestPose(object.truth.com, p);
  h.roll_deg = rest.roll_deg;
  h.pitch_deg = rest.pitch_deg;
  const Eigen::Matrix3d R = inference::targetRotation(rest.roll_deg, rest.pitch_deg);
  const double g = c.vector3("gravity").norm(), amplitude = c.number("axle_swing_amplitude_deg");
  for (int k = 0; k < 2; ++k) {
    const double psi = (c.number("axle_heading_deg") + 90.0 * k) * M_PI / 180.0;
    const Vector3d axle = R.transpose() * Vector3d(std::cos(psi), std::sin(psi), 0.0);
    (k == 0 ? h.axle_swing_period_s : h.cross_axle_swing_period_s) = axleSwingPeriod(object.truth, p, axle, amplitude, g);
  }
  return h;
}

PeerRocking peerRocking(const inference::TaskConfig& c, const PeerObject& object) {
  const peer::RockingRun run =
      peer::rockOnGround(object.vertices, toMoments(object.truth), rockingOptions(c, c.number("duration_s")));
  const double dt = run.time_s.size() > 1 ? run.time_s[1] - run.time_s[0] : 0.0;
  const auto f = inference::analyseOscillation(run.tilt_deg, 0.0, dt, c.integer("measured_cycles"), true);
  if (!f.valid) throw TopoError("peer-world rocking (Bullet)", "shows no full period: " + f.message, "rock it longer");
  PeerRocking out;
  out.period_s = f.period;
  out.max_tilt_deg = f.max_abs;
  return out;
}

double peerRockingPeriod(const inference::TaskConfig& c, const PeerObject& object) {
  return peerRocking(c, object).period_s;
}

}  // namespace topo_gaussian::bench
