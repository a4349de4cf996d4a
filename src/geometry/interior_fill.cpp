#include "topo_gaussian/geometry/interior_fill.h"

#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <unistd.h>
#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <random>
#include <sstream>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/number_text.h"
#include "topo_gaussian/geometry/cell_clip.h"
#include "topo_gaussian/geometry/mesh_metrics.h"
#include "topo_gaussian/geometry/surface_field.h"

namespace topo_gaussian::geometry {

namespace {

// Squared distances to the nearest and to the k-th nearest other point, over a subsample of at most
// ~2000 points, from one k-d tree (entries 0 where a point has duplicates that close).
struct NeighbourDistances {
  static constexpr int k = 16;
  std::vector<float> nearest2, kth2;
};
NeighbourDistances neighbourDistances(const std::vector<Eigen::Vector3d>& pts) {
  NeighbourDistances out;
  if (pts.size() < 2) return out;
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
  cloud->resize(pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) cloud->points[i].getVector3fMap() = pts[i].cast<float>();
  pcl::KdTreeFLANN<pcl::PointXYZ> tree;
  tree.setInputCloud(cloud);
  const int want = std::min<int>(NeighbourDistances::k + 1, int(pts.size()));
  const std::size_t step = std::max<std::size_t>(1, pts.size() / 2000);
  std::vector<int> idx(want);
  std::vector<float> d2(want);
  for (std::size_t i = 0; i < pts.size(); i += step) {
    const int found = tree.nearestKSearch(cloud->points[i], want, idx, d2);
    if (found >= 2) out.nearest2.push_back(d2[1]);
    if (found == NeighbourDistances::k + 1) out.kth2.push_back(d2[NeighbourDistances::k]);
  }
  return out;
}

// Distance to the nearest other point at the given quantile (0.5: the typical sampling spacing; 0.9:
// the spacing in the sparse parts of the surface).
double typicalPointSpacing(const NeighbourDistances& n, double quantile) {
  std::vector<double> d;
  for (float d2 : n.nearest2)
    if (d2 > 0.f) d.push_back(std::sqrt(double(d2)));
  if (d.empty()) return 0.0;
  const std::size_t k = std::min(d.size() - 1, std::size_t(quantile * double(d.size())));
  std::nth_element(d.begin(), d.begin() + k, d.end());
  return d[k];
}

// Spacing s of the surface sampling from the area each point covers (areal density 1/s²): the
// median over the subsample of π r_k² / (k − 1/3), r_k the distance to the k-th nearest neighbour
// (unbiased for uniformly random points, whose nearest-neighbour distance is only ~half of s).
double arealPointSpacing(const NeighbourDistances& n) {
  constexpr int k = NeighbourDistances::k;
  std::vector<double> area;
  for (float d2 : n.kth2)
    if (d2 > 0.f) area.push_back(M_PI * double(d2) / (k - 1.0 / 3.0));
  if (area.empty()) return 0.0;
  std::nth_element(area.begin(), area.begin() + area.size() / 2, area.end());
  return std::sqrt(area[area.size() / 2]);
}

// Points on every triangle, no farther apart than `step`.
std::vector<Eigen::Vector3d> sampleTriangles(const SurfaceData& mesh, double step) {
  std::vector<Eigen::Vector3d> out;
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3d &a = mesh.points[t[0]], &b = mesh.points[t[1]], &c = mesh.points[t[2]];
    const double longest = std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()});
    const int n = std::max(1, int(std::ceil(longest / step)));
    for (int i = 0; i <= n; ++i)
      for (int j = 0; i + j <= n; ++j) out.push_back(a + (b - a) * (double(i) / n) + (c - a) * (double(j) / n));
  }
  return out;
}

struct Occupancy {
  Lattice lattice;
  std::vector<std::uint8_t> solid;
  std::vector<float> fraction;  ///< inside fraction per cell (V_i = f_i h³); empty = whole cells
};

// Resamples a solid grid onto the output lattice (nearest grid cell of each lattice centre).
Occupancy resample(const Lattice& grid, const std::vector<std::uint8_t>& solid, const Lattice& out) {
  Occupancy o{out, std::vector<std::uint8_t>(out.cells(), 0)};
  for (int k = 0; k < out.n[2]; ++k)
    for (int j = 0; j < out.n[1]; ++j)
      for (int i = 0; i < out.n[0]; ++i) {
        std::array<int, 3> g;
        if (grid.cellOf(out.center(i, j, k), &g) && solid[grid.index(g[0], g[1], g[2])])
          o.solid[out.index(i, j, k)] = 1;
      }
  return o;
}

// Physical memory [bytes] (0 when unknown).
double physicalMemoryBytes() {
  const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGE_SIZE);
  return pages > 0 && page > 0 ? double(pages) * double(page) : 0.0;
}

// Memory per grid cell while filling [bytes]: density grids hold ~12 per-cell arrays (node and cell
// densities, search bits, parity counts, two distance transforms, masks); the output lattice holds the
// inside flags and, per solid cell, a particle (position, volume, surface flag).
constexpr double kDensityBytesPerCell = 40.0;
constexpr double kLatticeBytesPerCell = 36.0;

// When the bounding box is set by a few far points: a description of it (else ""), for messages.
std::string farPointsNote(const std::vector<Eigen::Vector3d>& pts) {
  if (pts.size() < 20) return "";
  Eigen::Vector3d robust, full;
  std::vector<double> c(pts.size());
  for (int k = 0; k < 3; ++k) {
    for (std::size_t i = 0; i < pts.size(); ++i) c[i] = pts[i][k];
    const auto mm = std::minmax_element(c.begin(), c.end());
    full[k] = *mm.second - *mm.first;
    const std::size_t a = c.size() / 100, b = c.size() - 1 - c.size() / 100;
    std::nth_element(c.begin(), c.begin() + a, c.end());
    const double lo = c[a];
    std::nth_element(c.begin(), c.begin() + b, c.end());
    robust[k] = c[b] - lo;
  }
  if (!(full.maxCoeff() > 10.0 * robust.maxCoeff())) return "";
  return "its bounding box (" + numberText(full.maxCoeff(), 3) +
         " m across) is set by a few far points: 98 % of the "
         "points lie within " +
         numberText(robust.maxCoeff(), 3) + " m";
}

// Refuses a grid that has too many cells or would not fit in memory, naming the real cause.
void checkGrid(double cells, double bytes_per_cell, double h, const FillOptions& o, const SurfaceData& s,
               const char* what) {
  const double memory_limit = o.max_memory_bytes > 0.0 ? o.max_memory_bytes : 0.5 * physicalMemoryBytes();
  const double bytes = cells * bytes_per_cell;
  const bool too_many = cells > o.max_cells, too_big = memory_limit > 0.0 && bytes > memory_limit;
  if (!too_many && !too_big) return;
  const double allowed = std::min(o.max_cells, memory_limit > 0.0 ? memory_limit / bytes_per_cell : o.max_cells);
  const double h_ok = h * std::cbrt(cells / allowed) * 1.05;
  std::string problem = "spacing " + numberText(h, 3) + " m would create " + numberText(cells, 3) + " " + what +
                        " needing about " + numberText(bytes / 1e9, 3) + " GB of memory (limit " +
                        numberText(allowed, 3) + " cells, " +
                        (memory_limit > 0.0 ? numberText(memory_limit / 1e9, 3) + " GB" : std::string("unknown")) +
                        (o.max_memory_bytes > 0.0 ? "" : ": half of this machine's memory") + ")";
  std::string fix;
  const std::string far = farPointsNote(s.points);
  if (!far.empty()) {
    problem += "; " + far;
    fix =
        "crop the far points (--crop-min/--crop-max X,Y,Z around the object) or remove them with outlier removal "
        "(--outlier-neighbours 16 --outlier-std 3); a larger spacing would only blur the object";
  } else if (o.grid_resolution > 0 && std::string(what) == "density grid cells") {
    const int res_ok = std::max(8, int(double(o.grid_resolution) * std::cbrt(allowed / cells) * 0.95));
    fix = "lower the density grid resolution (--grid-resolution " + std::to_string(res_ok) +
          " or less; 0 uses the lattice spacing)";
  } else {
    fix = "use a spacing of at least " + numberText(h_ok, 3) + " m (--spacing " + numberText(h_ok, 3) +
          ") or fewer particles (--count)";
  }
  throw TopoError(s.source, problem, fix);
}

class Filler {
 public:
  Filler(const SurfaceData& s, const FillOptions& o, FillReport& r) : s_(s), o_(o), r_(r) {
    surfaceBounds(s, &lo_, &hi_);
  }

  Occupancy fillAt(double h) {
    checkGrid(Lattice::cellCount(lo_, hi_, h, 1), kLatticeBytesPerCell, h, o_, s_, "lattice cells");
    const Lattice out = Lattice::covering(lo_, hi_, h, 1);
    if (s_.kind == SurfaceKind::Mesh && r_.repair.closed) {
      r_.method = "mesh-parity";
      // Consistently oriented faces: the non-zero winding rule (overlapping shells are their union).
      const InsideRule rule = r_.topology.misoriented_edges ? InsideRule::Parity : InsideRule::NonZeroWinding;
      return Occupancy{out, meshInside(s_, out, rule)};
    }
    const double longest = (hi_ - lo_).maxCoeff();
    const double g = o_.grid_resolution > 0 ? longest / o_.grid_resolution : h;
    DensityFillResult res;
    Lattice grid;
    double shell_sigma_m = 0.0;  // std dev of the splats that made the shell (the floor, in metres)
    if (s_.kind == SurfaceKind::Gaussians) {
      r_.method = "gaussian-density";
      DensityFillOptions d = o_.density;
      measureSpacings();
      if (o_.boundary_fraction) d.split_shell = true;
      if (d.min_sigma_m < 0.0) d.min_sigma_m = sparse_spacing_;
      if (d.closing_m < 0.0) d.closing_m = 3.0 * sparse_spacing_;
      const double sigma_max = robustSigmaMax();
      if (!(sigma_max <= 10.0 * longest))  // the grid's padding is 3σ: it must stay of the object's size
        throw TopoError(s_.source,
                        "99 % of its Gaussians are up to " + numberText(sigma_max, 3) +
                            " m wide (standard deviation), more than ten times the object (" + numberText(longest, 3) +
                            " m): the scale_* values are not log standard deviations in metres, or the file is corrupt",
                        "re-export the 3DGS model (scale_0..2 hold log standard deviations in metres)");
      grid = densityGrid(g, 3.0 * std::max(sigma_max, d.min_sigma_m));
      res = densityFill(s_.points, s_.covariances, s_.opacity, grid, d);
      shell_sigma_m = std::max(d.min_sigma_cells * g, d.min_sigma_m);
      r_.closing_cells = d.closing_cells < 0 ? std::max(1, int(std::ceil(d.closing_m / g))) : d.closing_cells;
    } else {
      const bool mesh = s_.kind == SurfaceKind::Mesh;
      r_.method = mesh ? "mesh-sample-density" : "point-density";
      const double sigma_floor = 0.75 * g;
      DensityFillOptions d = o_.density;
      if (mesh) {
        if (d.closing_m < 0.0) d.closing_m = g;
        grid = densityGrid(g, 3.0 * sigma_floor);
        checkSamples(0.5 * g);
        res = densityFillPoints(sampleTriangles(s_, 0.5 * g), 0.5 * g, sigma_floor, grid, d);
      } else {
        // The nearest-neighbour distance matches the spacing of even samplings only; random ones
        // (and scans) leave gaps twice as wide, so take the spacing from the area per point too.
        measureSpacings();
        if (d.closing_m < 0.0) d.closing_m = 3.0 * sparse_spacing_;
        if (o_.split_point_shell || o_.boundary_fraction) d.split_shell = true;
        const double sigma = std::max(sigma_floor, point_spacing_);
        grid = densityGrid(g, 3.0 * sigma);
        res = densityFillPoints(s_.points, std::max(point_spacing_, 1e-12), sigma, grid, d);
        shell_sigma_m = sigma;
      }
      r_.closing_cells = d.closing_cells < 0 ? std::max(1, int(std::ceil(d.closing_m / g))) : d.closing_cells;
    }
    r_.dense_cells = res.dense_cells;
    r_.ray_filled_cells = res.ray_filled_cells;
    r_.leaked_cells = res.leaked_cells;
    r_.open_fraction = res.open_fraction();
    if (r_.open_fraction > o_.max_open_fraction) throwOpen(g);
    Occupancy occ = resample(grid, res.solid, out);
    if (o_.boundary_fraction && s_.kind != SurfaceKind::Mesh) boundaryFromPoints(grid, res, shell_sigma_m, &occ);
    return occ;
  }

 private:
  // Point spacings of the input (one k-d tree): typical (median nearest neighbour, or the areal
  // spacing when larger, as random samplings leave gaps) and sparse (90th percentile).
  void measureSpacings() {
    if (point_spacing_ >= 0.0 && sparse_spacing_ >= 0.0) return;
    const NeighbourDistances n = neighbourDistances(s_.points);
    point_spacing_ = std::max(typicalPointSpacing(n, 0.5), arealPointSpacing(n));
    sparse_spacing_ = typicalPointSpacing(n, 0.9);
  }

  // Points and Gaussians: the boundary is the zero level of the points' signed distance (IMLS on
  // their normals, given or PCA-estimated, oriented by the density fill `solid` on `grid`), and
  // every cell of occ's lattice gets its inside fraction (surface_field.h). Cells the field does not
  // reach keep the density fill's answer.
  void boundaryFromPoints(const Lattice& grid, const DensityFillResult& res, double shell_sigma_m, Occupancy* occ) {
    OrientedPoints p;
    p.points = s_.points;
    if (s_.hasNormals()) {
      p.normals = s_.normals;
      for (auto& n : p.normals) n = n.allFinite() && n.norm() > 0.0 ? n.normalized() : Eigen::Vector3d::Zero();
    } else {
      if (pca_normals_.empty()) pca_normals_ = pcaNormals(s_.points);
      p.normals = pca_normals_;
    }
    p.weights = s_.kind == SurfaceKind::Gaussians ? s_.opacity : std::vector<double>(s_.size(), 1.0);
    // Depth below the shell's outside: from the empty cells that are not filled (the outside, also
    // under an object left open at the excluded direction, and no floater's shell).
    std::vector<std::uint8_t> empty(grid.cells());
    for (std::size_t c = 0; c < empty.size(); ++c) empty[c] = !res.dense[c] && !res.solid[c];
    // The outermost points lie ≈ σ √(2 ln(D₀/τ)) below the shell's outside (D₀ the splatted density
    // on the surface, τ the threshold: 1.2 σ for a plane of points, D₀ = 2τ; ~1.7 σ for an opaque 3DGS
    // surface, D₀ ≈ 4τ), more where the surface is concave (the shell of both sides adds up): skin
    // 2 σ, plus ¾ of a grid cell for where the shell's outside falls on the grid. In metres, so the
    // points kept do not change with the grid (the 6-neighbour depth in cells did: the donut lost
    // 5.5 % between density grids of 64 and 128 cells). Checked on clean tori (the concave side) and
    // donut_3dgs.ply at 64/128-cell grids and 3/6 mm (geometry_fill, geometry_point_volume).
    const double skin_m = 2.0 * shell_sigma_m + 0.75 * grid.h;
    const double floater_m = 2.0 * shell_sigma_m + 2.0 * grid.h;
    const std::size_t unoriented =
        orientNormals(p, grid, euclideanDistance(grid, empty), euclideanDistance(grid, res.solid), skin_m, floater_m);
    if (unoriented > s_.size() / 4)
      r_.warnings.push_back(numberText(100.0 * double(unoriented) / double(s_.size()), 3) +
                            " % of the surface points lie where the density fill sees no boundary (floaters, or "
                            "a surface thinner than the grid): they are left out of the boundary's position");
    const Lattice& L = occ->lattice;
    // Kernel radius: the sampling spacing (the field is exact for a plane whatever the sampling, so a
    // small radius only costs smoothing of noise; on a curved surface it offsets f by ≈ r²/2R).
    const double radius = std::max(point_spacing_, 0.25 * L.h);
    // A scan much denser than the kernel (on average 3 or more points per cube of radius / 2) is
    // binned first: the field then costs per cube, not per point (a 2M-point sphere R 5 cm at the
    // default 50 000 particles: 3.9 points a cube, the field changes by 7e-6 of the volume).
    {
      OrientedPoints binned = binnedPoints(p, 0.5 * radius);
      std::size_t kept = 0;
      for (double w : p.weights) kept += w > 0.0;
      if (kept >= 3 * binned.points.size()) p = std::move(binned);
    }
    std::size_t inner = 0;
    const auto field = outerSurfaceDistance(p, L, radius, 2.5 * L.h, radius, 4, &inner);
    occ->fraction = cellInsideFractions(L, field, occ->solid);
    for (std::size_t c = 0; c < occ->solid.size(); ++c) occ->solid[c] = occ->fraction[c] > 0.f;
  }

  Lattice densityGrid(double g, double reach) {
    const int pad = 2 + int(std::ceil(reach / g));
    checkGrid(Lattice::cellCount(lo_, hi_, g, pad), kDensityBytesPerCell, g, o_, s_, "density grid cells");
    return Lattice::covering(lo_, hi_, g, pad);
  }

  // Refuses before sampling an open mesh's triangles when the samples would not fit in memory (a
  // few huge triangles at a fine spacing).
  void checkSamples(double step) {
    double n = 0.0;
    for (const auto& t : s_.triangles) {
      const Eigen::Vector3d &a = s_.points[t[0]], &b = s_.points[t[1]], &c = s_.points[t[2]];
      const double k = std::ceil(std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()}) / step);
      n += (k + 1.0) * (k + 2.0) / 2.0;
    }
    const double limit = o_.max_memory_bytes > 0.0 ? o_.max_memory_bytes : 0.5 * physicalMemoryBytes();
    if (limit > 0.0 && n * 24.0 > limit)
      throw TopoError(s_.source,
                      "sampling its triangles every " + numberText(step, 3) +
                          " m (the mesh is open, so it is filled "
                          "by the density method) would take " +
                          numberText(n, 3) + " points, about " + numberText(n * 24.0 / 1e9, 3) +
                          " GB of memory (limit " + numberText(limit / 1e9, 3) + " GB)",
                      "close the mesh (e.g. MeshLab: Close Holes) for the exact inside test, or use a larger spacing "
                      "(--spacing) or fewer particles (--count)");
  }

  // 99th percentile of the Gaussians' largest standard deviation (floaters excluded).
  double robustSigmaMax() {
    std::vector<double> s;
    s.reserve(s_.size());
    for (const auto& sc : s_.scales) s.push_back(sc.maxCoeff());
    if (s.empty()) return 0.0;
    const std::size_t k = std::min(s.size() - 1, std::size_t(0.99 * double(s.size())));
    std::nth_element(s.begin(), s.begin() + k, s.end());
    return s[k];
  }

  [[noreturn]] void throwOpen(double g) {
    std::string detail = numberText(100.0 * r_.open_fraction, 3) + " % of the interior found by ray casting (" +
                         std::to_string(r_.leaked_cells) + " of " + std::to_string(r_.ray_filled_cells) +
                         " grid cells) is connected to the outside through gaps in the surface";
    if (s_.kind == SurfaceKind::Mesh)
      detail += "; the mesh has " + std::to_string(r_.topology.boundary_edges) + " boundary edges (" +
                numberText(100.0 * r_.topology.openFraction(), 3) + " % of its edges, " +
                numberText(r_.topology.boundary_length, 3) + " m of open boundary)";
    std::string fix =
        "close the holes (e.g. MeshLab: Close Holes, or scan the missing sides), or seal gaps up to 2·N grid cells (" +
        numberText(g, 3) + " m each; N was " + std::to_string(r_.closing_cells) +
        ") with closing_cells = N (CLI --closing-cells N)";
    if (r_.open_fraction < 1.0)
      fix += ", or accept a partial fill by raising max_open_fraction (CLI --max-open-fraction, at most 1) to " +
             numberText(std::min(1.0, r_.open_fraction * 1.01 + 1e-3), 3);
    else
      fix += "; all of it leaks, so no max_open_fraction can accept it";
    throw TopoError(s_.source, "the surface is open: " + detail, fix);
  }

  const SurfaceData& s_;
  const FillOptions& o_;
  FillReport& r_;
  Eigen::Vector3d lo_, hi_;
  double point_spacing_ = -1.0;
  double sparse_spacing_ = -1.0;
  std::vector<Eigen::Vector3d> pca_normals_;
};

// Counts of the boundary treatment, for the FillReport.
struct BoundaryCounts {
  std::size_t clipped = 0, merged = 0, own = 0;
};

// One particle per solid cell (at its centre, volume h³). With `parts` (closed meshes, cell_clip.h):
// a solid cell the surface cuts gets the exact inside part of its cell (volume, centroid); a cut cell
// that is not solid (less than half inside) gives its inside part (volume and first moment) to the
// particle of the solid 26-neighbour nearest to that part's centroid, so no volume is lost and no particle gets a
// sliver of a cell (the soft-body SPH sums weigh neighbours by V_j); only a part with no solid
// neighbour (a feature thinner than the spacing) becomes a particle of its own. The surface flag
// keeps its meaning (a solid cell with a 6-neighbour that is not solid). Jitter moves every particle.
VolumeCloud toCloud(const Occupancy& occ, const FillOptions& o, const std::vector<CellPart>* parts = nullptr,
                    BoundaryCounts* counts = nullptr) {
  const Lattice& L = occ.lattice;
  VolumeCloud cloud;
  cloud.spacing = L.h;
  const double v = L.h * L.h * L.h;
  auto solidAt = [&](int i, int j, int k) {
    return i >= 0 && j >= 0 && k >= 0 && i < L.n[0] && j < L.n[1] && k < L.n[2] && occ.solid[L.index(i, j, k)];
  };
  std::vector<std::size_t> cell_of;  // cell index of each particle, ascending
  for (int k = 0; k < L.n[2]; ++k)
    for (int j = 0; j < L.n[1]; ++j)
      for (int i = 0; i < L.n[0]; ++i) {
        if (!occ.solid[L.index(i, j, k)]) continue;
        cloud.X.push_back(L.center(i, j, k));
        cloud.V.push_back(occ.fraction.empty() ? v : v * double(occ.fraction[L.index(i, j, k)]));
        const bool inner = solidAt(i - 1, j, k) && solidAt(i + 1, j, k) && solidAt(i, j - 1, k) &&
                           solidAt(i, j + 1, k) && solidAt(i, j, k - 1) && solidAt(i, j, k + 1);
        cloud.surface.push_back(inner ? 0 : 1);
        if (parts) cell_of.push_back(L.index(i, j, k));
      }
  if (parts && !parts->empty()) {
    auto particleOf = [&](std::size_t cell) -> long {
      const auto it = std::lower_bound(cell_of.begin(), cell_of.end(), cell);
      return it != cell_of.end() && *it == cell ? long(it - cell_of.begin()) : -1;
    };
    // Volume and first moment per particle; a cut solid cell starts from its own inside part.
    std::vector<double> vol = cloud.V;
    std::vector<Eigen::Vector3d> mom(cloud.size());
    for (std::size_t p = 0; p < cloud.size(); ++p) mom[p] = cloud.V[p] * cloud.X[p];
    for (const CellPart& part : *parts)
      if (occ.solid[part.cell]) {
        const long p = particleOf(part.cell);
        vol[p] = part.volume_m3;
        mom[p] = part.volume_m3 * part.centroid;
        if (counts) ++counts->clipped;
      }
    std::vector<CellPart> own;
    const std::size_t plane = std::size_t(L.n[0]) * L.n[1];
    for (const CellPart& part : *parts) {
      if (occ.solid[part.cell]) continue;
      const int k = int(part.cell / plane), j = int((part.cell % plane) / L.n[0]), i = int(part.cell % L.n[0]);
      long best = -1;
      double best_d2 = 0.0;
      for (int dk = -1; dk <= 1; ++dk)
        for (int dj = -1; dj <= 1; ++dj)
          for (int di = -1; di <= 1; ++di) {
            if (!solidAt(i + di, j + dj, k + dk)) continue;
            const double d2 = (L.center(i + di, j + dj, k + dk) - part.centroid).squaredNorm();
            if (best < 0 || d2 < best_d2) {
              best = particleOf(L.index(i + di, j + dj, k + dk));
              best_d2 = d2;
            }
          }
      if (best < 0) {
        own.push_back(part);
        continue;
      }
      vol[best] += part.volume_m3;
      mom[best] += part.volume_m3 * part.centroid;
      if (counts) ++counts->merged;
    }
    for (std::size_t p = 0; p < cloud.size(); ++p)
      if (vol[p] != v) {
        cloud.V[p] = vol[p];
        cloud.X[p] = mom[p] / vol[p];
      }
    for (const CellPart& part : own) {
      cloud.X.push_back(part.centroid);
      cloud.V.push_back(part.volume_m3);
      cloud.surface.push_back(1);
    }
    if (counts) counts->own = own.size();
  }
  if (o.jitter > 0.0) {
    std::mt19937 rng(o.seed);
    std::uniform_real_distribution<double> u(-o.jitter, o.jitter);
    for (auto& x : cloud.X) x += L.h * Eigen::Vector3d(u(rng), u(rng), u(rng));
  }
  return cloud;
}

}  // namespace

void validateFillOptions(const FillOptions& o, const std::string& what) {
  auto bad = [&](const std::string& problem, const std::string& fix) { throw TopoError(what, problem, fix); };
  if (o.spacing_m < 0.0 || !std::isfinite(o.spacing_m))
    bad("spacing " + numberText(o.spacing_m, 3) + " m is negative or not finite",
        "give a positive spacing in metres, or 0 to use the particle count");
  if (o.spacing_m == 0.0 && o.target_count < 8)
    bad("particle count " + std::to_string(o.target_count) + " is too small",
        "ask for at least 8 particles (default 50000)");
  if (o.jitter < 0.0 || o.jitter > 0.5)
    bad("jitter " + numberText(o.jitter, 3) + " is outside [0, 0.5]",
        "use 0 for a regular lattice or up to 0.5 of the spacing");
  if (o.grid_resolution < 0 || o.grid_resolution > 4096)
    bad("grid resolution " + std::to_string(o.grid_resolution) + " is outside [0, 4096]",
        "use 0 (the lattice spacing) or e.g. 100 cells");
  const auto& d = o.density;
  if (!(d.density_threshold > 0.0) || !(d.search_threshold > 0.0))
    bad("density and search thresholds must be positive", "use PhysGaussian's 2.0 and 1.0");
  if (d.search_exclude_direction < -1 || d.search_exclude_direction > 5 || d.ray_cast_direction < 0 ||
      d.ray_cast_direction > 5)
    bad("direction codes must be 0..5 (+x −x +y −y +z −z; exclude may be −1 for none)",
        "use PhysGaussian's exclude 5, ray 4");
  if (d.min_sigma_cells < 0.0 || d.closing_cells < -1 || d.closing_cells > 64 || d.leak_check_closing_cells < 0)
    bad("min_sigma_cells must be >= 0 and closing_cells in -1..64", "use the defaults 0.5 and -1 (automatic)");
  if (o.max_open_fraction < 0.0 || o.max_open_fraction > 1.0)
    bad("max_open_fraction " + numberText(o.max_open_fraction, 3) + " is outside [0, 1]",
        "give a fraction in [0, 1] (default " + numberText(kDefaultMaxOpenFraction, 3) + ")");
}

namespace {

std::string boxText(const Eigen::Vector3d& e) {
  return numberText(e.x(), 3) + " × " + numberText(e.y(), 3) + " × " + numberText(e.z(), 3) + " m";
}

// One warning line per repair of a mesh (see repairMesh), and the fallback when it stays open.
void meshWarnings(FillReport& r, int max_hole_edges) {
  const MeshRepairReport& m = r.repair;
  if (m.welded_vertices)
    r.warnings.push_back("welded " + std::to_string(m.welded_vertices) +
                         " vertex(es) at the exact position of an earlier vertex (a triangle soup, or seams "
                         "written twice), so the faces share their edges");
  if (m.faces_dropped())
    r.warnings.push_back("dropped " + std::to_string(m.faces_dropped()) + " of the " + std::to_string(m.faces_in) +
                         " faces: " + std::to_string(m.degenerate_faces) + " with a repeated vertex, " +
                         std::to_string(m.nonfinite_faces) + " with a NaN/infinite corner, " +
                         std::to_string(m.duplicate_faces) + " duplicated");
  if (m.holes_closed)
    r.warnings.push_back("closed " + std::to_string(m.holes_closed) + " small hole(s) (" +
                         std::to_string(m.hole_edges) + " boundary edges in all; loops of at most " +
                         std::to_string(max_hole_edges) +
                         " edges, e.g. where a vertex with NaN coordinates was removed) with fans");
  if (m.reoriented_faces)
    r.warnings.push_back("re-oriented " + std::to_string(m.reoriented_faces) + " of the " + std::to_string(m.faces_in) +
                         " faces to agree with their neighbours (they ran a shared edge the same way, i.e. their "
                         "normals were flipped; in each connected piece the fewer faces were turned)");
  if (m.ignored_faces)
    r.warnings.push_back("left out " + std::to_string(m.ignored_faces) + " face(s) (" +
                         numberText(m.ignored_area_m2, 3) + " m², " +
                         numberText(100.0 * m.ignored_area_m2 / std::max(m.total_area_m2, 1e-300), 3) +
                         " % of the area) that bound no volume (stray triangles, fins, loose open pieces); the "
                         "closed rest is filled by the exact inside test");
}

// Closed meshes: the exact volume; inverted normals (negative volume) are flipped with a warning,
// a mixed orientation is reported (the fill then keeps whole boundary cells).
void closedMeshOrientation(SurfaceData& mesh, FillReport& r) {
  if (r.topology.misoriented_edges) {
    r.warnings.push_back(
        "the faces are not consistently oriented: " + std::to_string(r.topology.misoriented_edges) +
        " edges are traversed the same way by both of their faces (part of the surface has flipped normals), so "
        "the inside fraction of the boundary cells is undefined: they are whole cells by the ray-parity test (the "
        "staircase: volume, centre of mass and inertia off by about one spacing); re-orient the faces coherently "
        "(e.g. MeshLab: Re-Orient all faces coherently) for an exact boundary");
    return;
  }
  r.mesh_volume_m3 = meshSignedVolume(mesh);
  if (r.mesh_volume_m3 < 0.0) {
    for (auto& t : mesh.triangles) std::swap(t[1], t[2]);
    r.warnings.push_back("the mesh's normals point inwards (signed volume " + numberText(r.mesh_volume_m3, 4) +
                         " m^3): flipped every face; export it with outward normals to silence this");
    r.mesh_volume_m3 = -r.mesh_volume_m3;
  }
}

}  // namespace

VolumeCloud fillInterior(const SurfaceData& input, const FillOptions& o, FillReport* report) {
  const auto t0 = std::chrono::steady_clock::now();
  validateFillOptions(o, input.source + " fill options");
  FillReport local;
  FillReport& r = report ? *report : local;
  r = FillReport{};
  r.points_in = input.size();
  r.triangles_in = input.triangles.size();
  if (input.points.empty())
    throw TopoError(input.source, "has no points", "check that the file or topic carries a surface");
  const bool is_mesh = input.kind == SurfaceKind::Mesh;
  SurfaceData repaired;
  if (is_mesh) {
    if (input.triangles.empty())
      throw TopoError(input.source, "is a mesh without faces", "export the faces too, or load it as a point cloud");
    repaired = repairMesh(input, &r.repair, o.mesh_repair);
    if (repaired.triangles.empty())
      throw TopoError(input.source,
                      "has no usable faces: all " + std::to_string(input.triangles.size()) +
                          " repeat a vertex or have a NaN/infinite corner",
                      "re-export the mesh from a mesh editor; check the exporter's coordinate output");
    meshWarnings(r, o.mesh_repair.max_hole_edges);
  }
  const SurfaceData& s = is_mesh ? repaired : input;
  if (!is_mesh)
    for (const auto& p : s.points)
      if (!p.allFinite())
        throw TopoError(s.source, "has NaN or infinite coordinates",
                        "clean the surface first (cleanSurface drops them)");
  checkCoordinateRange(s);
  surfaceBounds(s, &r.bbox_min, &r.bbox_max);
  const Eigen::Vector3d ext = r.bbox_max - r.bbox_min;
  if (!is_mesh && s.size() < 4)
    throw TopoError(s.source, "has only " + std::to_string(s.size()) + " point(s): no volume can be enclosed",
                    "give a surface sampled all around the object");
  if (ext.minCoeff() <= 0.0)
    throw TopoError(s.source,
                    "has zero extent along " +
                        std::string(ext.x() <= 0   ? "x"
                                    : ext.y() <= 0 ? "y"
                                                   : "z") +
                        " (bounding box " + boxText(ext) + "): it encloses no volume",
                    "give a surface that surrounds a solid, not a flat patch");
  if (ext.maxCoeff() > o.warn_extent_m) {
    const std::string far = farPointsNote(s.points);
    r.warnings.push_back("the surface is " + numberText(ext.maxCoeff(), 3) + " m across (bounding box " + boxText(ext) +
                         ")" + (far.empty() ? "" : "; " + far) +
                         ": if it was modelled in millimetres, give --scale 0.001 (CleanOptions::scale)");
  }
  if (o.spacing_m > 0.0 && o.spacing_m >= ext.minCoeff())
    throw TopoError(s.source,
                    "the object is " + boxText(ext) + ": its thinnest side (" + numberText(ext.minCoeff(), 3) +
                        " m) is not larger than the spacing " + numberText(o.spacing_m, 3) +
                        " m, so the fill would be a slab of whole cells, not its shape",
                    "use a spacing of at most " + numberText(ext.minCoeff() / 10.0, 3) + " m (--spacing " +
                        numberText(ext.minCoeff() / 10.0, 3) + ", ten cells across) or give --count instead");
  if (is_mesh) {
    r.topology = analyseMesh(s);
    if (!r.repair.closed) {
      r.fallback = "the mesh is not closed (" + std::to_string(r.topology.boundary_edges) + " boundary edges, " +
                   numberText(r.topology.boundary_length, 3) + " m of open boundary, after repair)";
      r.warnings.push_back(r.fallback +
                           ": filled by the density method on samples of its triangles instead of the exact inside "
                           "test; close it (e.g. MeshLab: Close Holes) for an exact fill");
    } else {
      closedMeshOrientation(repaired, r);
    }
  }

  Filler filler(s, o, r);
  double h = o.spacing_m;
  Occupancy occ;
  if (h > 0.0) {
    occ = filler.fillAt(h);
  } else {
    // Two passes: the bounding box overestimates the solid, so measure and correct.
    h = std::cbrt(ext.prod() / double(o.target_count));
    occ = filler.fillAt(h);
    std::size_t n = 0;
    for (auto c : occ.solid) n += c;
    if (n > 0 && std::abs(double(n) / double(o.target_count) - 1.0) > 0.15) {
      h *= std::cbrt(double(n) / double(o.target_count));
      occ = filler.fillAt(h);
    }
  }
  VolumeCloud cloud;
  if (r.method == "mesh-parity" && r.topology.misoriented_edges == 0) {
    // Exact boundary: the inside part of every cut cell (cell_clip.h).
    const CellClipResult clip = clipCells(s, occ.lattice);
    if (clip.winding_anomalies) {
      // Shells that overlap (or one turned inside out): the divergence theorem counts the overlap twice.
      r.warnings.push_back(
          "the mesh overlaps itself: in " + std::to_string(clip.winding_anomalies) +
          " cells its winding number leaves 0..1 (closed shells that overlap, a self-intersection, a shell "
          "turned inside out, or an inner shell meant as a void whose faces point out instead of into the void); "
          "filled as the union of its shells (inside where the winding number is not 0), so "
          "the exact mesh volume is not known (the signed volume " +
          numberText(r.mesh_volume_m3, 4) +
          " m^3 counts the overlap twice) and the inside part of the cells where two shells' surfaces cross "
          "is approximate; for an exact boundary make it one closed surface (e.g. MeshLab: a boolean union of its "
          "shells, or Remove Self-Intersecting Faces), and turn a void's faces to point into the void");
      r.mesh_volume_m3 = 0.0;
    }
    // A cell holds a particle when at least half of it is inside (the exact fraction decides, not
    // the parity of its centre, whose ray can graze a vertex): no particle has less than half a
    // cell before the merges add to it.
    Occupancy exact{occ.lattice, clip.inside};
    const double h3 = std::pow(occ.lattice.h, 3);
    for (const CellPart& part : clip.partial)
      if (part.volume_m3 >= 0.5 * h3) exact.solid[part.cell] = 1;
    BoundaryCounts counts;
    cloud = toCloud(exact, o, &clip.partial, &counts);
    r.clipped_cells = counts.clipped;
    r.merged_cells = counts.merged;
    r.own_particle_cells = counts.own;
    r.exact_boundary = clip.winding_anomalies == 0;  // else approximate where two shells' surfaces cross
    if (counts.own)
      r.warnings.push_back(std::to_string(counts.own) +
                           " cell(s) less than half inside have no neighbour holding a particle (parts thinner than "
                           "half the spacing " +
                           numberText(h, 3) + " m): each became a particle of its own, smaller than a cell");
  } else {
    cloud = toCloud(occ, o);
  }
  if (cloud.empty())
    throw TopoError(s.source, "encloses no volume at spacing " + numberText(h, 3) + " m (" + r.method + ")",
                    "check that the surface is closed (a partial scan has no inside), or use a finer spacing");
  cloud.contact = sampleContactSurface(s, cloud, o.contact, &r.warnings);
  r.contact_samples = cloud.contact.size();
  r.contact_spacing_m = cloud.contact.spacing;
  r.contact_area_m2 = cloud.contact.totalArea();
  r.spacing_m = cloud.spacing;
  r.particles_out = cloud.size();
  r.surface_particles = cloud.surfaceCount();
  r.total_volume_m3 = cloud.totalVolume();
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return cloud;
}

}  // namespace topo_gaussian::geometry
