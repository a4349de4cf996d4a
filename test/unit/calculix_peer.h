// CalculiX peer for the soft-body tests (DESIGN.md "Physics": soft bodies held to a FEM peer; issue
// 15 §3). Standard library only, so any test (core_*, inference_*) can use it.
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
//    (*NODE PRINT, U);
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

/// A structured grid of cells [lo + (i, j, k) * cell, lo + (i+1, j+1, k+1) * cell]; solid(i, j, k)
/// says which cells are material (the others are void).
struct VoxelGeometry {
  Vec3 lo{0, 0, 0};
  Vec3 cell{1, 1, 1};  ///< cell edge lengths [m]
  int n[3] = {1, 1, 1};
  std::vector<char> solid;  ///< n[0] * n[1] * n[2], x fastest
  bool at(int i, int j, int k) const {
    if (i < 0 || j < 0 || k < 0 || i >= n[0] || j >= n[1] || k >= n[2]) return false;
    return solid[(static_cast<std::size_t>(k) * n[1] + j) * n[0] + i] != 0;
  }
  /// The box [lo, hi] divided into (nx, ny, nz) cells, all solid.
  static VoxelGeometry box(const Vec3& lo, const Vec3& hi, int nx, int ny, int nz) {
    VoxelGeometry g;
    g.lo = lo;
    g.n[0] = nx;
    g.n[1] = ny;
    g.n[2] = nz;
    for (int a = 0; a < 3; ++a) g.cell[a] = (hi[a] - lo[a]) / g.n[a];
    g.solid.assign(static_cast<std::size_t>(nx) * ny * nz, 1);
    return g;
  }
  /// Leaves the cells whose centres lie inside [lo, hi] out (a void).
  void carve(const Vec3& vlo, const Vec3& vhi) {
    for (int k = 0; k < n[2]; ++k)
      for (int j = 0; j < n[1]; ++j)
        for (int i = 0; i < n[0]; ++i) {
          const Vec3 c{lo[0] + (i + 0.5) * cell[0], lo[1] + (j + 0.5) * cell[1], lo[2] + (k + 0.5) * cell[2]};
          bool in = true;
          for (int a = 0; a < 3; ++a) in = in && c[a] > vlo[a] && c[a] < vhi[a];
          if (in) solid[(static_cast<std::size_t>(k) * n[1] + j) * n[0] + i] = 0;
        }
  }
};

struct TetMesh {
  std::vector<Vec3> nodes;                     ///< node id = index + 1
  std::vector<std::array<int, 10>> tets;       ///< 0-based node indices, C3D10 order
  std::vector<std::array<int, 2>> void_faces;  ///< (tet index, face 1..4) facing a void cell
};

/// C3D10 mesh of the solid cells (see the header comment).
inline TetMesh meshVoxels(const VoxelGeometry& g) {
  TetMesh m;
  const int nx = g.n[0] + 1, ny = g.n[1] + 1, nz = g.n[2] + 1;
  std::vector<int> corner(static_cast<std::size_t>(nx) * ny * nz, -1);
  auto cid = [&](int i, int j, int k) {
    int& id = corner[(static_cast<std::size_t>(k) * ny + j) * nx + i];
    if (id < 0) {
      id = static_cast<int>(m.nodes.size());
      m.nodes.push_back({g.lo[0] + i * g.cell[0], g.lo[1] + j * g.cell[1], g.lo[2] + k * g.cell[2]});
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
        }
      }
  // Faces on the boundary of a void cell (inside the grid's bounds, not solid): a face whose three
  // corners lie in one grid plane between a solid and a void cell.
  static const int faces[4][3] = {{0, 1, 2}, {0, 3, 1}, {1, 3, 2}, {2, 3, 0}};
  for (std::size_t t = 0; t < m.tets.size(); ++t) {
    for (int f = 0; f < 4; ++f) {
      Vec3 c{0, 0, 0};
      for (int a = 0; a < 3; ++a)
        for (int d = 0; d < 3; ++d) c[d] += m.nodes[m.tets[t][faces[f][a]]][d] / 3.0;
      // The face's plane: the axis along which all three corners agree.
      for (int d = 0; d < 3; ++d) {
        const double q0 = (m.nodes[m.tets[t][faces[f][0]]][d] - g.lo[d]) / g.cell[d];
        bool plane = true;
        for (int a = 1; a < 3; ++a)
          plane = plane && std::abs((m.nodes[m.tets[t][faces[f][a]]][d] - g.lo[d]) / g.cell[d] - q0) < 1e-9;
        if (!plane) continue;
        const int q = static_cast<int>(std::lround(q0));
        int idx[3];
        for (int e = 0; e < 3; ++e) idx[e] = static_cast<int>(std::floor((c[e] - g.lo[e]) / g.cell[e]));
        int lo_c[3] = {idx[0], idx[1], idx[2]}, hi_c[3] = {idx[0], idx[1], idx[2]};
        lo_c[d] = q - 1;
        hi_c[d] = q;
        const bool in_lo = lo_c[d] >= 0, in_hi = hi_c[d] < g.n[d];
        const bool s_lo = g.at(lo_c[0], lo_c[1], lo_c[2]), s_hi = g.at(hi_c[0], hi_c[1], hi_c[2]);
        if ((s_lo && !s_hi && in_hi) || (s_hi && !s_lo && in_lo)) m.void_faces.push_back({static_cast<int>(t), f + 1});
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
};

/// ccx's output of one run.
struct Result {
  std::vector<Vec3> displacement;  ///< per node (static), [m]
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
      disp = true;
      r.displacement.clear();
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

/// Static solve; displacement per node. clamp_x: nodes with x ≤ clamp_x fixed.
inline Result staticSolve(const TetMesh& m, const Material& mat, double clamp_x, const Load& load) {
  std::ostringstream o;
  o.precision(17);
  detail::writeMesh(o, m);
  detail::writeNset(o, "CLAMP", nodesBelowX(m, clamp_x));
  o << materialDeck(mat);
  o << "*BOUNDARY\nCLAMP, 1, 3\n";
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

}  // namespace calculix_peer
