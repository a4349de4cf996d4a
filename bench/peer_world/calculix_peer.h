// CalculiX peer for the soft-body tests and the peer world's finger (calculix_finger.h; DESIGN.md
// "Physics": soft bodies held to a FEM peer). Header-only, standard library only, so any test
// (core_*, inference_*; include dir bench) can use it.
//
// Geometry: a union of axis-aligned boxes ("voxels" of a structured grid, possibly with cells left
// out for a void such as the finger's chamber), meshed here with quadratic tetrahedra C3D10: every
// grid cell is split into 6 tetrahedra around its main diagonal (Kuhn / Freudenthal subdivision,
// conforming across cells because every cell uses the same diagonal), mid-edge nodes shared through
// an edge map. Boxes are meshed exactly, so no mesher (gmsh / tetgen) is needed for them; the peer
// needs only `ccx` (Debian calculix-ccx).
//
// Analyses (one ccx run each, in a fresh temporary directory, removed afterwards):
//  - staticSolve: linear elastic (or NLGEOM) static step under gravity and/or a pressure on the
//    faces of a void, nodes with x ≤ clamp_x fixed; node displacements parsed from the .dat file
//    (*NODE PRINT, U; every printed block is kept with its time, Result::blocks, so a deck of several
//    steps, e.g. a ladder of pressures, reads each step's end);
//  - firstFrequency: *FREQUENCY, lowest eigenfrequency [Hz] from the .dat's eigenvalue table.
// C3D10 node order (CalculiX / Abaqus): corners 1–4 (positive volume), then mid-edges 1-2, 2-3, 3-1,
// 1-4, 2-4, 3-4. Element faces: 1 = 1-2-3, 2 = 1-4-2, 3 = 2-4-3, 4 = 3-4-1; a positive face pressure
// P<k> pushes into the element.
#pragma once

#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace calculix_peer {

using Vec3 = std::array<double, 3>;

/// True when the `ccx` executable is on PATH; otherwise *why says what is missing and how to install it.
inline bool available(std::string* why) {
  if (std::system("command -v ccx >/dev/null 2>&1") == 0) return true;
  if (why)
    *why =
        "CalculiX (ccx) is not installed: the soft-body FEM peer cannot run (install Debian calculix-ccx, e.g. "
        "scripts/install_deps.sh)";
  return false;
}

/// A rectilinear grid of cells [x[0][i], x[0][i+1]] × [x[1][j], x[1][j+1]] × [x[2][k], x[2][k+1]]
/// (node coordinates per axis, increasing; uniform for box()); solid says which cells are material:
/// 1 = the first material, 2 = a second material (e.g. the finger's soft-solid chamber), 0 = void.
struct VoxelGeometry {
  std::vector<double> x[3];  ///< node coordinates per axis [m], n[a] + 1 of them
  int n[3] = {1, 1, 1};
  std::vector<char> solid;  ///< n[0] * n[1] * n[2], x fastest
  bool at(int i, int j, int k) const { return material(i, j, k) != 0; }
  /// Material of cell (i, j, k): 0 (void or outside the grid), 1 or 2.
  int material(int i, int j, int k) const {
    if (i < 0 || j < 0 || k < 0 || i >= n[0] || j >= n[1] || k >= n[2]) return 0;
    return solid[(static_cast<std::size_t>(k) * n[1] + j) * n[0] + i];
  }
  /// Cells with the given node coordinates per axis, all of material 1.
  static VoxelGeometry rectilinear(const std::vector<double>& xs, const std::vector<double>& ys,
                                   const std::vector<double>& zs) {
    VoxelGeometry g;
    g.x[0] = xs;
    g.x[1] = ys;
    g.x[2] = zs;
    for (int a = 0; a < 3; ++a) {
      if (g.x[a].size() < 2) throw std::invalid_argument("calculix_peer: a grid axis needs at least 2 nodes");
      for (std::size_t i = 1; i < g.x[a].size(); ++i)
        if (!(g.x[a][i] > g.x[a][i - 1])) throw std::invalid_argument("calculix_peer: grid nodes must increase");
      g.n[a] = static_cast<int>(g.x[a].size()) - 1;
    }
    g.solid.assign(static_cast<std::size_t>(g.n[0]) * g.n[1] * g.n[2], 1);
    return g;
  }
  /// The box [lo, hi] divided into (nx, ny, nz) equal cells, all solid.
  static VoxelGeometry box(const Vec3& lo, const Vec3& hi, int nx, int ny, int nz) {
    const int n[3] = {nx, ny, nz};
    std::vector<double> xs[3];
    for (int a = 0; a < 3; ++a)
      for (int i = 0; i <= n[a]; ++i) xs[a].push_back(lo[a] + (hi[a] - lo[a]) * i / n[a]);
    return rectilinear(xs[0], xs[1], xs[2]);
  }
  /// Nodes covering [lo, hi] with cells of at most `cell` that put a node on every one of `breaks`
  /// inside (lo, hi) (e.g. a chamber's walls, a clamp's edge).
  static std::vector<double> axis(double lo, double hi, double cell, std::vector<double> breaks) {
    breaks.push_back(lo);
    breaks.push_back(hi);
    std::sort(breaks.begin(), breaks.end());
    std::vector<double> out{lo};
    for (std::size_t b = 1; b < breaks.size(); ++b) {
      const double a0 = breaks[b - 1], a1 = breaks[b];
      if (a0 < lo - 1e-12 || a1 > hi + 1e-12 || a1 - a0 < 1e-12) continue;
      const int k = std::max(1, static_cast<int>(std::ceil((a1 - a0) / cell - 1e-9)));
      for (int i = 1; i <= k; ++i) out.push_back(a0 + (a1 - a0) * i / k);
    }
    return out;
  }
  /// Cells whose centres lie inside [lo, hi] become void, or material `value` (2: a second material).
  void carve(const Vec3& vlo, const Vec3& vhi, char value = 0) {
    for (int k = 0; k < n[2]; ++k)
      for (int j = 0; j < n[1]; ++j)
        for (int i = 0; i < n[0]; ++i) {
          const Vec3 c{0.5 * (x[0][i] + x[0][i + 1]), 0.5 * (x[1][j] + x[1][j + 1]), 0.5 * (x[2][k] + x[2][k + 1])};
          bool in = true;
          for (int a = 0; a < 3; ++a) in = in && c[a] > vlo[a] && c[a] < vhi[a];
          if (in) solid[(static_cast<std::size_t>(k) * n[1] + j) * n[0] + i] = value;
        }
  }
};

struct TetMesh {
  std::vector<Vec3> nodes;                ///< node id = index + 1
  std::vector<std::array<int, 10>> tets;  ///< 0-based node indices, C3D10 order
  std::vector<int> material;              ///< per tet: its cell's material (1 or 2)
  /// (tet index, face 1..4): faces of material-1 tets that face a void or material-2 cell inside
  /// the grid's bounds (the chamber walls: a pressure on them pushes into the material-1 tet).
  std::vector<std::array<int, 2>> void_faces;
};

/// C3D10 mesh of the solid cells (see the header comment).
inline TetMesh meshVoxels(const VoxelGeometry& g) {
  TetMesh m;
  const int nx = g.n[0] + 1, ny = g.n[1] + 1, nz = g.n[2] + 1;
  std::vector<int> corner(static_cast<std::size_t>(nx) * ny * nz, -1);
  std::vector<std::array<int, 3>> grid_index;  // per node id: its grid indices (corner nodes only)
  auto cid = [&](int i, int j, int k) {
    int& id = corner[(static_cast<std::size_t>(k) * ny + j) * nx + i];
    if (id < 0) {
      id = static_cast<int>(m.nodes.size());
      m.nodes.push_back({g.x[0][i], g.x[1][j], g.x[2][k]});
      grid_index.resize(m.nodes.size(), {-1, -1, -1});
      grid_index[id] = {i, j, k};
    }
    return id;
  };
  std::map<std::pair<int, int>, int> mid;
  auto mid_id = [&](int a, int b) {
    const auto key = std::make_pair(std::min(a, b), std::max(a, b));
    auto it = mid.find(key);
    if (it != mid.end()) return it->second;
    const int id = static_cast<int>(m.nodes.size());
    const Vec3 &p = m.nodes[a], &q = m.nodes[b];
    m.nodes.push_back({0.5 * (p[0] + q[0]), 0.5 * (p[1] + q[1]), 0.5 * (p[2] + q[2])});
    mid[key] = id;
    return id;
  };
  std::vector<std::array<int, 3>> cell_of;  // per tet
  // Kuhn subdivision: the 6 monotone paths from corner (0,0,0) to (1,1,1).
  static const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (int k = 0; k < g.n[2]; ++k)
    for (int j = 0; j < g.n[1]; ++j)
      for (int i = 0; i < g.n[0]; ++i) {
        if (!g.at(i, j, k)) continue;
        for (const auto& p : perms) {
          int c[3] = {i, j, k};
          std::array<int, 4> v;
          v[0] = cid(c[0], c[1], c[2]);
          for (int s = 0; s < 3; ++s) {
            ++c[p[s]];
            v[s + 1] = cid(c[0], c[1], c[2]);
          }
          auto vol = [&](const std::array<int, 4>& t) {
            const Vec3 &a = m.nodes[t[0]], &b = m.nodes[t[1]], &cc = m.nodes[t[2]], &d = m.nodes[t[3]];
            const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
            const double w[3] = {cc[0] - a[0], cc[1] - a[1], cc[2] - a[2]};
            const double z[3] = {d[0] - a[0], d[1] - a[1], d[2] - a[2]};
            return (u[1] * w[2] - u[2] * w[1]) * z[0] + (u[2] * w[0] - u[0] * w[2]) * z[1] +
                   (u[0] * w[1] - u[1] * w[0]) * z[2];
          };
          if (vol(v) < 0) std::swap(v[1], v[2]);
          std::array<int, 10> t;
          for (int a = 0; a < 4; ++a) t[a] = v[a];
          t[4] = mid_id(v[0], v[1]);
          t[5] = mid_id(v[1], v[2]);
          t[6] = mid_id(v[2], v[0]);
          t[7] = mid_id(v[0], v[3]);
          t[8] = mid_id(v[1], v[3]);
          t[9] = mid_id(v[2], v[3]);
          m.tets.push_back(t);
          m.material.push_back(g.material(i, j, k));
          cell_of.push_back({i, j, k});
        }
      }
  // Chamber walls: faces of material-1 tets whose three corners lie in one grid plane (so on their
  // cell's boundary) with a void or material-2 cell inside the grid's bounds across it.
  static const int faces[4][3] = {{0, 1, 2}, {0, 3, 1}, {1, 3, 2}, {2, 3, 0}};
  for (std::size_t t = 0; t < m.tets.size(); ++t) {
    for (int f = 0; f < 4; ++f) {
      // The face's plane: the axis along which all three corners share a grid index.
      for (int d = 0; d < 3; ++d) {
        const int q = grid_index[m.tets[t][faces[f][0]]][d];
        if (grid_index[m.tets[t][faces[f][1]]][d] != q || grid_index[m.tets[t][faces[f][2]]][d] != q) continue;
        // The face lies on the plane q of axis d: the neighbour cell is the tet's own cell moved
        // across that plane.
        int nb[3] = {cell_of[t][0], cell_of[t][1], cell_of[t][2]};
        nb[d] = q == cell_of[t][d] ? q - 1 : q;
        const bool in_grid = nb[d] >= 0 && nb[d] < g.n[d];
        if (m.material[t] == 1 && in_grid && g.material(nb[0], nb[1], nb[2]) != 1)
          m.void_faces.push_back({static_cast<int>(t), f + 1});
      }
    }
  }
  return m;
}

struct Material {
  double youngs_modulus_pa = 1e7;
  double poisson_ratio = 0.3;
  double density_kg_m3 = 1000.0;
};

struct Load {
  Vec3 gravity_m_s2{0, 0, -9.81};
  double void_pressure_pa = 0.0;  ///< on the faces of the void cells (pushing the walls outward)
  bool nlgeom = false;            ///< geometric nonlinearity (large rotations)
  int increments = 1;             ///< NLGEOM: initial increment = 1 / increments
  double symmetry_y_m = NAN;      ///< when finite: nodes on the plane y = symmetry_y_m held in y (half model)
};

/// ccx's output of one run.
struct Result {
  std::vector<Vec3> displacement;  ///< per node (static), [m]: the last block printed
  /// every displacement block of the .dat in order, with the time ccx printed on its header
  std::vector<std::vector<Vec3>> blocks;
  std::vector<double> block_times;
  double first_frequency_hz = NAN;
  std::string log;  ///< ccx's output when it failed
};

namespace detail {

inline std::string makeTempDir() {
  char tmpl[] = "/tmp/topo_ccx_XXXXXX";
  const char* d = mkdtemp(tmpl);
  if (!d) throw std::runtime_error("calculix_peer: cannot create a temporary directory");
  return d;
}

inline void writeMesh(std::ostream& o, const TetMesh& m) {
  o.precision(17);
  o << "*NODE, NSET=NALL\n";
  for (std::size_t i = 0; i < m.nodes.size(); ++i)
    o << i + 1 << ", " << m.nodes[i][0] << ", " << m.nodes[i][1] << ", " << m.nodes[i][2] << "\n";
  o << "*ELEMENT, TYPE=C3D10, ELSET=EALL\n";
  for (std::size_t t = 0; t < m.tets.size(); ++t) {
    o << t + 1;
    for (int a = 0; a < 10; ++a) o << ", " << m.tets[t][a] + 1;
    o << "\n";
  }
}

inline void writeNset(std::ostream& o, const std::string& name, const std::vector<int>& ids) {
  o << "*NSET, NSET=" << name << "\n";
  for (std::size_t i = 0; i < ids.size(); ++i) o << ids[i] + 1 << ((i % 10 == 9 || i + 1 == ids.size()) ? "\n" : ", ");
}

inline Result run(const std::string& deck, const std::string& what) {
  Result r;
  const std::string dir = makeTempDir();
  {
    std::ofstream f(dir + "/job.inp");
    f << deck;
  }
  const std::string cmd = "cd " + dir + " && OMP_NUM_THREADS=1 ccx -i job > ccx.log 2>&1";
  const int rc = std::system(cmd.c_str());
  std::ifstream dat(dir + "/job.dat");
  std::stringstream ds;
  ds << dat.rdbuf();
  const std::string text = ds.str();
  std::ifstream lg(dir + "/ccx.log");
  std::stringstream ls;
  ls << lg.rdbuf();
  r.log = ls.str();
  std::system(("rm -rf " + dir).c_str());
  if (rc != 0 || text.empty() || r.log.find("*ERROR") != std::string::npos)
    throw std::runtime_error("calculix_peer: ccx failed (" + what + "):\n" + r.log.substr(0, 4000));
  std::istringstream in(text);
  std::string line;
  bool disp = false, eig = false;
  while (std::getline(in, line)) {
    if (line.find("displacements (vx,vy,vz)") != std::string::npos) {
      if (disp || !r.displacement.empty()) r.blocks.push_back(r.displacement);
      disp = true;
      r.displacement.clear();
      const std::size_t at = line.find(" time");
      r.block_times.push_back(at == std::string::npos ? NAN : std::atof(line.c_str() + at + 5));
      continue;
    }
    if (line.find("E I G E N V A L U E   O U T P U T") != std::string::npos) {
      eig = true;
      continue;
    }
    std::istringstream ls2(line);
    if (disp) {
      long id;
      Vec3 u;
      if (ls2 >> id >> u[0] >> u[1] >> u[2]) {
        if (static_cast<long>(r.displacement.size()) < id) r.displacement.resize(id, Vec3{NAN, NAN, NAN});
        r.displacement[id - 1] = u;
      } else if (!r.displacement.empty() && !line.empty() && line.find_first_not_of(' ') != std::string::npos) {
        disp = false;
      }
    } else if (eig) {
      long mode;
      double ev, rad, cyc;
      if (ls2 >> mode >> ev >> rad >> cyc) {
        if (mode == 1) r.first_frequency_hz = cyc;
        eig = false;
      }
    }
  }
  if (!r.block_times.empty()) r.blocks.push_back(r.displacement);
  return r;
}

}  // namespace detail

/// Nodes with x ≤ clamp_x (within 1e-9 of a cell) are fixed in all directions.
inline std::vector<int> nodesBelowX(const TetMesh& m, double x) {
  std::vector<int> ids;
  for (std::size_t i = 0; i < m.nodes.size(); ++i)
    if (m.nodes[i][0] <= x + 1e-9) ids.push_back(static_cast<int>(i));
  return ids;
}

inline std::string materialDeck(const Material& mat) {
  std::ostringstream o;
  o.precision(17);
  o << "*MATERIAL, NAME=M\n*ELASTIC\n"
    << mat.youngs_modulus_pa << ", " << mat.poisson_ratio << "\n*DENSITY\n"
    << mat.density_kg_m3 << "\n*SOLID SECTION, ELSET=EALL, MATERIAL=M\n";
  return o.str();
}

/// Two materials: the material-1 tets (ELSET E1) get mat, the material-2 tets (E2) mat2.
inline std::string materialDeck(const TetMesh& m, const Material& mat, const Material& mat2) {
  std::ostringstream o;
  o.precision(17);
  for (int k = 1; k <= 2; ++k) {
    std::vector<int> ids;
    for (std::size_t t = 0; t < m.tets.size(); ++t)
      if (m.material[t] == k) ids.push_back(static_cast<int>(t));
    if (ids.empty()) continue;
    const Material& mk = k == 1 ? mat : mat2;
    o << "*ELSET, ELSET=E" << k << "\n";
    for (std::size_t i = 0; i < ids.size(); ++i)
      o << ids[i] + 1 << ((i % 10 == 9 || i + 1 == ids.size()) ? "\n" : ", ");
    o << "*MATERIAL, NAME=M" << k << "\n*ELASTIC\n"
      << mk.youngs_modulus_pa << ", " << mk.poisson_ratio << "\n*DENSITY\n"
      << mk.density_kg_m3 << "\n*SOLID SECTION, ELSET=E" << k << ", MATERIAL=M" << k << "\n";
  }
  return o.str();
}

/// Static solve; displacement per node. clamp_x: nodes with x ≤ clamp_x fixed. mat2: the material
/// of the material-2 cells (required when the mesh has any).
inline Result staticSolve(const TetMesh& m, const Material& mat, double clamp_x, const Load& load,
                          const Material* mat2 = nullptr) {
  std::ostringstream o;
  o.precision(17);
  detail::writeMesh(o, m);
  detail::writeNset(o, "CLAMP", nodesBelowX(m, clamp_x));
  const bool two = std::count(m.material.begin(), m.material.end(), 2) > 0;
  if (two && !mat2) throw std::invalid_argument("calculix_peer: the mesh has material-2 cells but no second material");
  o << (two ? materialDeck(m, mat, *mat2) : materialDeck(mat));
  o << "*BOUNDARY\nCLAMP, 1, 3\n";
  if (std::isfinite(load.symmetry_y_m)) {
    std::vector<int> ids;
    for (std::size_t i = 0; i < m.nodes.size(); ++i)
      if (std::abs(m.nodes[i][1] - load.symmetry_y_m) < 1e-9) ids.push_back(static_cast<int>(i));
    detail::writeNset(o, "SYM", ids);
    o << "*BOUNDARY\nSYM, 2, 2\n";
  }
  if (load.nlgeom)
    o << "*STEP, NLGEOM, INC=1000\n*STATIC\n"
      << 1.0 / load.increments << ", 1.0, 1e-6, " << 1.0 / load.increments << "\n";
  else
    o << "*STEP\n*STATIC\n";
  const double g = std::sqrt(load.gravity_m_s2[0] * load.gravity_m_s2[0] + load.gravity_m_s2[1] * load.gravity_m_s2[1] +
                             load.gravity_m_s2[2] * load.gravity_m_s2[2]);
  if (g > 0)
    o << "*DLOAD\nEALL, GRAV, " << g << ", " << load.gravity_m_s2[0] / g << ", " << load.gravity_m_s2[1] / g << ", "
      << load.gravity_m_s2[2] / g << "\n";
  if (load.void_pressure_pa != 0.0) {
    o << "*DLOAD\n";
    for (const auto& f : m.void_faces) o << f[0] + 1 << ", P" << f[1] << ", " << load.void_pressure_pa << "\n";
  }
  o << "*NODE PRINT, NSET=NALL\nU\n*END STEP\n";
  Result r = detail::run(o.str(), "static");
  if (r.displacement.size() != m.nodes.size())
    throw std::runtime_error("calculix_peer: ccx printed " + std::to_string(r.displacement.size()) +
                             " displacements for " + std::to_string(m.nodes.size()) + " nodes");
  return r;
}

/// Lowest natural frequency [Hz] with nodes x ≤ clamp_x fixed.
inline double firstFrequency(const TetMesh& m, const Material& mat, double clamp_x) {
  std::ostringstream o;
  detail::writeMesh(o, m);
  detail::writeNset(o, "CLAMP", nodesBelowX(m, clamp_x));
  o << materialDeck(mat);
  o << "*BOUNDARY\nCLAMP, 1, 3\n*STEP\n*FREQUENCY\n1\n*END STEP\n";
  const Result r = detail::run(o.str(), "frequency");
  if (!std::isfinite(r.first_frequency_hz))
    throw std::runtime_error("calculix_peer: no eigenfrequency in ccx's output");
  return r.first_frequency_hz;
}

/// Mean of displacement component `axis` over the nodes with x ≥ x_min (e.g. a beam's end face).
inline double meanDisplacement(const TetMesh& m, const Result& r, double x_min, int axis) {
  double s = 0;
  int n = 0;
  for (std::size_t i = 0; i < m.nodes.size(); ++i)
    if (m.nodes[i][0] >= x_min - 1e-9) {
      s += r.displacement[i][axis];
      ++n;
    }
  return n ? s / n : NAN;
}

/// Deformed centroid of the material of the tets whose rest centroids have x in (x_lo, x_hi),
/// volume-weighted: a straight-edged C3D10's volume average of its displacement is
/// Σ_corners (−1/20) u_a + Σ_mid-edges (1/5) u_m (∫N_a dV / V of the quadratic shape functions).
inline Vec3 deformedCentroid(const TetMesh& m, const Result& r, double x_lo, double x_hi) {
  Vec3 c{0, 0, 0};
  double vsum = 0;
  for (const auto& t : m.tets) {
    const Vec3 &a = m.nodes[t[0]], &b = m.nodes[t[1]], &cc = m.nodes[t[2]], &d = m.nodes[t[3]];
    const double xc = 0.25 * (a[0] + b[0] + cc[0] + d[0]);
    if (!(xc > x_lo && xc < x_hi)) continue;
    const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    const double w[3] = {cc[0] - a[0], cc[1] - a[1], cc[2] - a[2]};
    const double z[3] = {d[0] - a[0], d[1] - a[1], d[2] - a[2]};
    const double v = std::abs((u[1] * w[2] - u[2] * w[1]) * z[0] + (u[2] * w[0] - u[0] * w[2]) * z[1] +
                              (u[0] * w[1] - u[1] * w[0]) * z[2]) /
                     6.0;
    for (int e = 0; e < 3; ++e) {
      double xe = 0.25 * (a[e] + b[e] + cc[e] + d[e]);
      for (int q = 0; q < 4; ++q) xe += -0.05 * r.displacement[t[q]][e];
      for (int q = 4; q < 10; ++q) xe += 0.2 * r.displacement[t[q]][e];
      c[e] += v * xe;
    }
    vsum += v;
  }
  for (int e = 0; e < 3; ++e) c[e] /= vsum;
  return c;
}

}  // namespace calculix_peer
