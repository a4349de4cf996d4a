// CalculiX's pneumatic finger and its side view (calculix_finger.h).
#include "peer_world/calculix_finger.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <sstream>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/number_text.h"

namespace topo_gaussian::peer {
namespace {

/// Local corner indices of C3D10 face f (calculix_peer.h's order) and the mid-edge node of a corner pair.
constexpr int kFaces[4][3] = {{0, 1, 2}, {0, 3, 1}, {1, 3, 2}, {2, 3, 0}};
int midEdge(int a, int b) {
  if (a > b) std::swap(a, b);
  if (a == 0) return b == 1 ? 4 : b == 2 ? 6 : 7;
  if (a == 1) return b == 2 ? 5 : 8;
  return 9;  // 2-3
}

}  // namespace

bool calculixAvailable(std::string* why) { return calculix_peer::available(why); }

CalculixFinger::CalculixFinger(const CalculixFingerOptions& o) : options_(o) {
  const std::string input = "CalculiX finger";
  if (!(o.size_m.minCoeff() > 0)) throw TopoError(input, "has a size ≤ 0", "give L, W, H > 0 [m]");
  const Eigen::Vector3d lo(0, -0.5 * o.size_m.y(), -0.5 * o.size_m.z()), hi(o.size_m.x(), 0.5 * o.size_m.y(),
                                                                          0.5 * o.size_m.z());
  for (int a = 0; a < 3; ++a)
    if (!(o.chamber_lo_m[a] > lo[a] && o.chamber_hi_m[a] < hi[a] && o.chamber_lo_m[a] < o.chamber_hi_m[a]))
      throw TopoError(input + " chamber", "is not strictly inside the finger's box",
                      "give lo < hi inside x ∈ (0, L), |y| < W/2, |z| < H/2");
  if (std::abs(o.chamber_lo_m.y() + o.chamber_hi_m.y()) > 1e-12)
    throw TopoError(input + " chamber", "is not centred in y (the peer is a half model, symmetric about y = 0)",
                    "give chamber_lo_m.y = −chamber_hi_m.y");
  const double L = o.size_m.x(), f = o.tip_fraction;
  if (!(o.clamp_length_m > 0 && o.clamp_length_m < o.chamber_lo_m.x() && o.clamp_length_m < L * (1 - 2 * f)))
    throw TopoError(input + " clamp_length_m", "must lie between the base and the chamber and the bend segments",
                    "give 0 < clamp < chamber x and < L (1 − 2 tip_fraction)");
  if (!(o.cell_m > 0) || o.increments < 1 || !(f > 0 && f < 0.45))
    throw TopoError(input, "has a cell ≤ 0, increments < 1 or a tip_fraction outside (0, 0.45)",
                    "give cell_m > 0, increments ≥ 1, tip_fraction in (0, 0.45)");
  using calculix_peer::VoxelGeometry;
  const auto xs = VoxelGeometry::axis(0.0, L, o.cell_m,
                                      {o.clamp_length_m, o.chamber_lo_m.x(), o.chamber_hi_m.x(), L * (1 - 2 * f),
                                       L * (1 - f)});
  const auto ys = VoxelGeometry::axis(0.0, hi.y(), o.cell_m, {o.chamber_hi_m.y()});
  const auto zs = VoxelGeometry::axis(lo.z(), hi.z(), o.cell_m, {o.chamber_lo_m.z(), o.chamber_hi_m.z()});
  VoxelGeometry g = VoxelGeometry::rectilinear(xs, ys, zs);
  g.carve({o.chamber_lo_m.x(), o.chamber_lo_m.y(), o.chamber_lo_m.z()},
          {o.chamber_hi_m.x(), o.chamber_hi_m.y(), o.chamber_hi_m.z()}, 0);
  mesh_ = calculix_peer::meshVoxels(g);

  // The deck's fixed part: mesh, clamp, symmetry plane, material (no gravity: the finger task's default).
  std::ostringstream d;
  calculix_peer::detail::writeMesh(d, mesh_);
  calculix_peer::detail::writeNset(d, "CLAMP", calculix_peer::nodesBelowX(mesh_, o.clamp_length_m));
  std::vector<int> sym;
  for (std::size_t i = 0; i < mesh_.nodes.size(); ++i)
    if (std::abs(mesh_.nodes[i][1]) < 1e-12) sym.push_back(static_cast<int>(i));
  calculix_peer::detail::writeNset(d, "SYM", sym);
  calculix_peer::Material mat;
  mat.youngs_modulus_pa = o.youngs_modulus_pa;
  mat.poisson_ratio = o.poisson_ratio;
  d << calculix_peer::materialDeck(mat) << "*BOUNDARY\nCLAMP, 1, 3\n*BOUNDARY\nSYM, 2, 2\n";
  deck_mesh_ = d.str();

  // The outer surface: faces of exactly one tet, all corners on one outer plane (not y = 0).
  std::map<std::array<int, 3>, int> count;
  for (const auto& t : mesh_.tets)
    for (const auto& f3 : kFaces) {
      std::array<int, 3> key{t[f3[0]], t[f3[1]], t[f3[2]]};
      std::sort(key.begin(), key.end());
      ++count[key];
    }
  auto onOuterPlane = [&](const std::array<int, 3>& c) {
    const double planes[5][2] = {{0, 0}, {0, L}, {1, hi.y()}, {2, lo.z()}, {2, hi.z()}};
    for (const auto& p : planes) {
      bool all = true;
      for (int k : c) all = all && std::abs(mesh_.nodes[k][static_cast<int>(p[0])] - p[1]) < 1e-12;
      if (all) return true;
    }
    return false;
  };
  // Surface vertices: a half-model node, or its mirror image (y → −y) unless it lies on y = 0.
  std::map<int, int> vertex_of[2];
  auto vertex = [&](int node, bool mirror) {
    mirror = mirror && std::abs(mesh_.nodes[node][1]) >= 1e-12;
    const auto it = vertex_of[mirror].find(node);
    if (it != vertex_of[mirror].end()) return it->second;
    const int v = static_cast<int>(surface_node_.size());
    surface_node_.push_back(node);
    mirrored_.push_back(mirror);
    vertex_of[mirror][node] = v;
    return v;
  };
  std::vector<std::array<int, 6>> faces;  // corners a b c, mids ab bc ca (node ids), outward
  for (const auto& t : mesh_.tets) {
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    for (int a = 0; a < 4; ++a) centre += 0.25 * Eigen::Vector3d(mesh_.nodes[t[a]].data());
    for (const auto& f3 : kFaces) {
      std::array<int, 3> key{t[f3[0]], t[f3[1]], t[f3[2]]};
      std::sort(key.begin(), key.end());
      if (count[key] != 1 || !onOuterPlane(key)) continue;
      int a = f3[0], b = f3[1], c = f3[2];
      const Eigen::Vector3d pa(mesh_.nodes[t[a]].data()), pb(mesh_.nodes[t[b]].data()), pc(mesh_.nodes[t[c]].data());
      if ((pb - pa).cross(pc - pa).dot((pa + pb + pc) / 3.0 - centre) < 0) std::swap(b, c);
      faces.push_back({t[a], t[b], t[c], t[midEdge(a, b)], t[midEdge(b, c)], t[midEdge(c, a)]});
    }
  }
  // Each quadratic face as 4 triangles at its mid-edge nodes; the mirror half with the orientation reversed.
  for (const bool mirror : {false, true})
    for (const auto& n : faces) {
      int q[6];
      for (int k = 0; k < 6; ++k) q[k] = vertex(n[k], mirror);
      const int a = q[0], b = q[1], c = q[2], ab = q[3], bc = q[4], ca = q[5];
      for (Eigen::Vector3i t : {Eigen::Vector3i(a, ab, ca), Eigen::Vector3i(ab, b, bc), Eigen::Vector3i(ca, bc, c),
                                Eigen::Vector3i(ab, bc, ca)}) {
        if (mirror) std::swap(t[1], t[2]);
        triangles_.push_back(t);
      }
    }
  for (std::size_t v = 0; v < surface_node_.size(); ++v) {
    const auto& x = mesh_.nodes[surface_node_[v]];
    rest_surface_.emplace_back(x[0], mirrored_[v] ? -x[1] : x[1], x[2]);
  }
}

double CalculixFinger::chamberVolumeM3() const { return (options_.chamber_hi_m - options_.chamber_lo_m).prod(); }
double CalculixFinger::solidVolumeM3() const { return options_.size_m.prod() - chamberVolumeM3(); }
bool CalculixFinger::inChamber(const Eigen::Vector3d& x) const {
  return (x.array() > options_.chamber_lo_m.array()).all() && (x.array() < options_.chamber_hi_m.array()).all();
}

std::vector<CalculixFingerState> CalculixFinger::solve(const std::vector<double>& pressures_pa,
                                                       double* seconds) const {
  std::string why;
  if (!calculixAvailable(&why)) throw TopoError(why);
  for (std::size_t k = 0; k < pressures_pa.size(); ++k)
    if (!(pressures_pa[k] > 0) || (k > 0 && !(pressures_pa[k] > pressures_pa[k - 1])))
      throw TopoError("CalculiX finger pressures", "must be > 0 and increasing", "give e.g. 1.67e5 3.33e5 5e5 [Pa]");
  std::ostringstream d;
  d.precision(17);
  d << deck_mesh_;
  const double inc = 1.0 / options_.increments;
  for (double p : pressures_pa) {
    d << "*STEP, NLGEOM, INC=1000\n*STATIC\n" << inc << ", 1.0, 1e-6, " << inc << "\n*DLOAD\n";
    for (const auto& f : mesh_.void_faces) d << f[0] + 1 << ", P" << f[1] << ", " << p << "\n";
    d << "*NODE PRINT, NSET=NALL\nU\n*END STEP\n";
  }
  const auto t0 = std::chrono::steady_clock::now();
  calculix_peer::Result r;
  try {
    r = calculix_peer::detail::run(d.str(), "finger, NLGEOM pressure steps");
  } catch (const std::exception& e) {
    throw TopoError("CalculiX finger", std::string("ccx failed: ") + e.what(),
                    "check the chamber's walls (at least one cell) and the pressure; more increments help NLGEOM");
  }
  if (seconds) *seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  // The end of each step: the blocks printed at a whole time (ccx's step or total time, both whole there).
  std::vector<const std::vector<calculix_peer::Vec3>*> ends;
  for (std::size_t b = 0; b < r.blocks.size(); ++b) {
    const double t = r.block_times[b];
    if (std::isfinite(t) && t > 0.5 && std::abs(t - std::round(t)) < 1e-6 &&
        r.blocks[b].size() == mesh_.nodes.size())
      ends.push_back(&r.blocks[b]);
  }
  if (ends.size() != pressures_pa.size())
    throw TopoError("CalculiX finger", "ccx printed " + std::to_string(ends.size()) + " step ends for " +
                                           std::to_string(pressures_pa.size()) + " pressures",
                    "check the .dat output of the deck (its steps did not all converge)");
  const double L = options_.size_m.x(), f = options_.tip_fraction;
  std::vector<CalculixFingerState> out;
  for (std::size_t k = 0; k < ends.size(); ++k) {
    calculix_peer::Result one;
    one.displacement = *ends[k];
    CalculixFingerState s;
    s.pressure_pa = pressures_pa[k];
    const auto ct = calculix_peer::deformedCentroid(mesh_, one, L * (1 - f), 1e9);
    const auto cp = calculix_peer::deformedCentroid(mesh_, one, L * (1 - 2 * f), L * (1 - f));
    s.bend_deg = std::atan2(ct[2] - cp[2], ct[0] - cp[0]) * 180.0 / M_PI;
    for (std::size_t v = 0; v < surface_node_.size(); ++v) {
      const auto& u = one.displacement[surface_node_[v]];
      s.surface_m.push_back(rest_surface_[v] + Eigen::Vector3d(u[0], mirrored_[v] ? -u[1] : u[1], u[2]));
    }
    if (!std::isfinite(s.bend_deg))
      throw TopoError("CalculiX finger", "gave a non-finite bend at " + numberText(s.pressure_pa) + " Pa", "check the deck");
    out.push_back(std::move(s));
  }
  return out;
}

PeerCamera fingerRigCamera() {
  return lookAtCamera(Eigen::Vector3d(0.05, -0.5, 0), Eigen::Vector3d(0.05, 0, 0), Eigen::Vector3d::UnitZ(), 16.0,
                      640, 480);
}

RenderStyle fingerRigStyle(unsigned seed) {
  RenderStyle s;
  s.object_bgr = cv::Vec3b(60, 60, 60);
  s.background = cv::Mat(480, 640, CV_8UC3, cv::Scalar(235, 235, 235));
  s.noise_sigma = 2.0;
  s.blur_px = 0.7;
  s.seed = seed;
  return s;
}

std::vector<cv::Mat> renderPressureWindow(const CalculixFinger& finger, const CalculixFingerState& state,
                                          const PeerCamera& camera, const RenderStyle& style, int rest_frames,
                                          int held_frames) {
  const auto still = [](double) { return Eigen::Isometry3d::Identity(); };
  std::vector<cv::Mat> frames;
  for (int k = 0; k < rest_frames + held_frames; ++k)
    frames.push_back(renderMeshFrame(k < rest_frames ? finger.restSurface() : state.surface_m, finger.triangles(),
                                     still, k / 30.0, k, camera, style));
  return frames;
}

}  // namespace topo_gaussian::peer
