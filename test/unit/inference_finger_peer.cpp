// Pneumatic finger held to CalculiX (issue 15 §3).
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "calculix_peer.h"
#include "topo_gaussian/geometry/interior_fill.h"
#include "topo_gaussian/geometry/shape_generator.h"
#include "topo_gaussian/inference/task.h"
#include "topo_gaussian/inference/task_config.h"

using namespace topo_gaussian;
using namespace topo_gaussian::inference;

namespace {

double feature(const TaskEvaluation& ev, const std::string& name) {
  for (const auto& f : ev.features)
    if (f.name == name) return f.value;
  ADD_FAILURE() << "no feature " << name;
  return NAN;
}

struct Finger {
  double length = 0.1, width = 0.02, height = 0.02;  // x ∈ [0, L], y, z centred
  calculix_peer::Vec3 ch_lo{0.015, -0.005, -0.005}, ch_hi{0.065, 0.005, 0.0};
  double E = 1e7, nu = 0.49, E_ch = 1e6, nu_ch = 0.0, p = 5e5, clamp = 0.01;
};

struct Ours {
  double angle = NAN, seconds = 0;
  std::size_t n = 0;
  double tip_lo = NAN, pre_lo = NAN;
};

Ours ours(const Finger& f, double h, bool void_chamber, double E_void, const std::string& extra = "") {
  geometry::SurfaceData box = geometry::makeBox(Eigen::Vector3d(f.length, f.width, f.height));
  for (auto& p : box.points) p.x() += 0.5 * f.length;
  geometry::FillOptions fo;
  fo.spacing_m = h;
  const VolumeCloud cloud = geometry::fillInterior(box, fo);
  TaskConfig c = TaskConfig::defaults("finger");
  c.setNumber("youngs_modulus_solid", f.E);
  c.setNumber("poisson_ratio", f.nu);
  c.setNumber("youngs_modulus_hollow", void_chamber ? E_void : f.E_ch);
  c.setNumber("poisson_ratio_hollow", f.nu_ch);
  c.setNumber("pressure_pa", f.p);
  c.setNumber("clamp_length_m", f.clamp);
  if (!extra.empty()) c.setAssignment(extra);
  std::vector<double> r(cloud.size(), 1.0);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    bool in = true;
    for (int a = 0; a < 3; ++a) in = in && cloud.X[i][a] > f.ch_lo[a] && cloud.X[i][a] < f.ch_hi[a];
    if (in) r[i] = 0.0;
  }
  const auto t0 = std::chrono::steady_clock::now();
  const auto task = makeTask(c, cloud);
  const TaskEvaluation ev = task->evaluate(r, nullptr);
  Ours o;
  o.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  o.angle = feature(ev, "bend_angle_deg");
  o.n = cloud.size();
  double xmin = 1e9, xmax = -1e9;
  for (auto& x : cloud.X) xmin = std::min(xmin, x.x()), xmax = std::max(xmax, x.x());
  return o;
}

/// Tip and pre segments of the finger task for lattice spacing h: cells whose centres have
/// u = X − X_min > 0.85 len (tip), > 0.7 len (pre), len = L − h.
void segments(const Finger& f, double h, double* tip_lo, double* pre_lo) {
  const double len = f.length - h;
  auto first_cell_face = [&](double frac) {
    // cell centres at h/2 + k h; first k with k h > frac * len
    const int k = static_cast<int>(std::floor(frac * len / h + 1e-9)) + 1;
    return k * h;
  };
  *tip_lo = first_cell_face(0.85);
  *pre_lo = first_cell_face(0.70);
}

double calculix(const Finger& f, double h, bool void_chamber, double cell, bool nlgeom, double* seconds) {
  using namespace calculix_peer;
  double tip_lo, pre_lo;
  segments(f, h, &tip_lo, &pre_lo);
  const auto xs = VoxelGeometry::axis(0.0, f.length, cell, {f.clamp, f.ch_lo[0], f.ch_hi[0], tip_lo, pre_lo});
  const auto ys = VoxelGeometry::axis(0.0, 0.5 * f.width, cell, {f.ch_hi[1]});
  const auto zs = VoxelGeometry::axis(-0.5 * f.height, 0.5 * f.height, cell, {f.ch_lo[2], f.ch_hi[2]});
  VoxelGeometry g = VoxelGeometry::rectilinear(xs, ys, zs);
  g.carve(f.ch_lo, f.ch_hi, void_chamber ? 0 : 2);
  const TetMesh m = meshVoxels(g);
  Material wall, ch;
  wall.youngs_modulus_pa = f.E;
  wall.poisson_ratio = f.nu;
  ch.youngs_modulus_pa = f.E_ch;
  ch.poisson_ratio = f.nu_ch;
  Load load;
  load.gravity_m_s2 = {0, 0, 0};
  load.void_pressure_pa = f.p;
  load.nlgeom = nlgeom;
  load.increments = 5;
  load.symmetry_y_m = 0.0;
  const auto t0 = std::chrono::steady_clock::now();
  const Result r = staticSolve(m, wall, f.clamp, load, &ch);
  *seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const calculix_peer::Vec3 ct = deformedCentroid(m, r, tip_lo, 1e9), cp = deformedCentroid(m, r, pre_lo, tip_lo);
  std::fprintf(stderr, "  ccx cell %.4g: %zu nodes %zu tets %zu pressure faces, %.1f s\n", cell, m.nodes.size(),
               m.tets.size(), m.void_faces.size(), *seconds);
  return std::atan2(ct[2] - cp[2], ct[0] - cp[0]) * 180.0 / M_PI;
}

}  // namespace

TEST(FingerPeer, Explore) {
  const char* what = std::getenv("FINGER_EXPLORE");
  if (!what) GTEST_SKIP();
  Finger f;
  const std::string w = what;
  const double h = std::getenv("FINGER_H") ? std::atof(std::getenv("FINGER_H")) : 0.0025;
  if (w.find("ours") != std::string::npos) {
    const bool v = w.find("void") != std::string::npos;
    const double Ev = std::getenv("FINGER_EVOID") ? std::atof(std::getenv("FINGER_EVOID")) : 1e4;
    const char* extra = std::getenv("FINGER_SET");
    const Ours o = ours(f, h, v, Ev, extra ? extra : "");
    std::printf("ours h %.4g void %d Evoid %.3g: %zu particles, angle %.5f deg, %.1f s\n", h, v, Ev, o.n, o.angle,
                o.seconds);
  }
  if (w.find("ccx") != std::string::npos) {
    const bool v = w.find("void") != std::string::npos;
    const double cell = std::getenv("FINGER_CELL") ? std::atof(std::getenv("FINGER_CELL")) : 0.0025;
    double s;
    const double a = calculix(f, h, v, cell, w.find("lin") == std::string::npos, &s);
    std::printf("ccx h %.4g void %d cell %.4g: angle %.5f deg, %.1f s\n", h, v, cell, a, s);
  }
}
