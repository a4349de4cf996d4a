// The peer world's pneumatic finger: CalculiX (not this package's soft simulator) bends a box finger
// with a true void chamber under a follower pressure, and the independent rasteriser
// (peer_world/mesh_renderer.h) films its deformed surface from the side, as the finger rig's camera.
//
// Body: the box x ∈ [0, L], |y| ≤ W/2, |z| ≤ H/2 [m] (base at x = 0, as `topo shape finger` lies)
// minus the chamber, an axis-aligned box [lo, hi] (void: no material, no mass). Material: linear
// elastic E, ν under NLGEOM (Green strain, St. Venant–Kirchhoff: the finger task's default energy).
// Mesh: C3D10 on a rectilinear grid of cells ≤ cell_m with nodes on the chamber's, the clamp's and the
// bend segments' planes (peer_world/calculix_peer.h), half model y ≥ 0 (symmetry plane y = 0; the
// chamber must be centred in y), nodes with x ≤ clamp_length_m fixed.
// Load: one ccx run, one NLGEOM *STATIC step per pressure in increasing order, each ramping the
// chamber walls' face pressure *DLOAD P (a follower load under NLGEOM: it acts on the deformed faces)
// from the step before's to its own, `increments` initial increments per step.
// Bend (CalculiX's own, as finger_task.cpp defines it on a continuum): d = c_tip − c_pre, the
// deformed centroids of the material with rest x in [L (1 − f), L] (tip) and [L (1 − 2f), L (1 − f)]
// (the segment before), integrated exactly over the quadratic tetrahedra; θ = atan2(d_z, d_x) [deg],
// + towards +z, f = tip_fraction.
// Surface for the camera: the outer faces of the solid tetrahedra (the chamber's walls and the
// symmetry plane left out), each quadratic face split at its mid-edge nodes into 4 triangles, the half
// mirrored in y: a closed, outward triangle mesh of the full finger whose vertices move with the nodes.
#pragma once

#include <Eigen/Core>
#include <array>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "peer_world/calculix_peer.h"
#include "peer_world/mesh_renderer.h"

namespace topo_gaussian::peer {

struct CalculixFingerOptions {
  Eigen::Vector3d size_m{0.1, 0.02, 0.015};  ///< L × W × H [m] (the default finger's box)
  Eigen::Vector3d chamber_lo_m{0.015, -0.006, -0.0045}, chamber_hi_m{0.065, 0.006, 0.0005};  ///< the void [m]
  double youngs_modulus_pa = 2e6;  ///< the rig's elastomer (config/rigs/finger_twin.yaml)
  double poisson_ratio = 0.45;     ///< the finger task's default
  double clamp_length_m = 0.01;    ///< nodes with x ≤ this are fixed [m]
  double cell_m = 0.0025;          ///< largest grid cell [m]
  int increments = 5;              ///< initial increments per pressure step (NLGEOM)
  double tip_fraction = 0.15;      ///< the bend's segments (finger_task.cpp's tip_fraction)
};

/// The finger at one pressure, as CalculiX solved it.
struct CalculixFingerState {
  double pressure_pa = 0.0;
  double bend_deg = 0.0;                    ///< CalculiX's own (header), + towards +z
  std::vector<Eigen::Vector3d> surface_m;  ///< the surface's vertices, deformed [m] (CalculixFinger::triangles())
};

class CalculixFinger {
 public:
  /// Meshes the finger. Throws TopoError for a size ≤ 0, a chamber not strictly inside the box or not
  /// centred in y, a clamp that reaches the chamber or the bend segments, a cell ≤ 0, increments < 1.
  explicit CalculixFinger(const CalculixFingerOptions& options);

  const CalculixFingerOptions& options() const { return options_; }
  double chamberVolumeM3() const;  ///< exact: the chamber box
  double solidVolumeM3() const;    ///< exact: box − chamber
  bool inChamber(const Eigen::Vector3d& x_m) const;
  const calculix_peer::TetMesh& mesh() const { return mesh_; }  ///< the half model's C3D10 mesh

  /// The surface: rest vertices [m] and triangles (closed, outward), shared by every state.
  const std::vector<Eigen::Vector3d>& restSurface() const { return rest_surface_; }
  const std::vector<Eigen::Vector3i>& triangles() const { return triangles_; }

  /// One ccx run (header): the states at `pressures_pa` (each > 0, increasing). Throws TopoError when ccx
  /// is missing or fails (its log's start in the message), or prints fewer steps than asked.
  std::vector<CalculixFingerState> solve(const std::vector<double>& pressures_pa, double* seconds = nullptr) const;

 private:
  CalculixFingerOptions options_;
  calculix_peer::TetMesh mesh_;
  std::vector<Eigen::Vector3d> rest_surface_;
  std::vector<Eigen::Vector3i> triangles_;
  std::vector<int> surface_node_;  ///< per surface vertex: its half-model node
  std::vector<char> mirrored_;     ///< per surface vertex: the node's mirror image (y → −y)
  std::string deck_mesh_;          ///< the deck up to the steps (mesh, sets, material, boundary)
};

/// True when `ccx` is on PATH; otherwise *why says what is missing and how to install it.
bool calculixAvailable(std::string* why);

/// The finger rig's side camera (launch/soft_finger_rig.launch, config/rigs/finger_twin.yaml): 0.5 m
/// along −y from (0.05, 0, 0), looking along +y, world +z up (image right = +x), 16° across 640 × 480 px.
PeerCamera fingerRigCamera();

/// The rig's look: a dark grey elastomer (60, 60, 60) on a light uniform backdrop (235), Gaussian pixel
/// noise σ 2 grey levels, optics blur σ 0.7 px.
RenderStyle fingerRigStyle(unsigned seed = 1);

/// One pressure window as the rig films it: `rest_frames` of the rest surface, then `held_frames` of
/// `state`'s, frame k carrying time k / fps (the static shapes: the regulator changes the pressure slowly
/// against the finger's first mode). Frames BGR (CV_8UC3).
std::vector<cv::Mat> renderPressureWindow(const CalculixFinger& finger, const CalculixFingerState& state,
                                          const PeerCamera& camera, const RenderStyle& style, int rest_frames = 10,
                                          int held_frames = 20);

}  // namespace topo_gaussian::peer
