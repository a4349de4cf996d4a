#include "topo_gaussian/geometry/interior_fill.h"

#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <random>
#include <sstream>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/number_text.h"
#include "topo_gaussian/geometry/mesh_metrics.h"

namespace topo_gaussian::geometry {

namespace {

// Distance to the nearest other point over a subsample, at the given quantile (0.5: the typical
// sampling spacing; 0.9: the spacing in the sparse parts of the surface).
double typicalPointSpacing(const std::vector<Eigen::Vector3d>& pts, double quantile = 0.5) {
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
  cloud->resize(pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) cloud->points[i].getVector3fMap() = pts[i].cast<float>();
  pcl::KdTreeFLANN<pcl::PointXYZ> tree;
  tree.setInputCloud(cloud);
  const std::size_t step = std::max<std::size_t>(1, pts.size() / 2000);
  std::vector<double> d;
  std::vector<int> idx(2);
  std::vector<float> d2(2);
  for (std::size_t i = 0; i < pts.size(); i += step)
    if (tree.nearestKSearch(cloud->points[i], 2, idx, d2) == 2 && d2[1] > 0.f) d.push_back(std::sqrt(double(d2[1])));
  if (d.empty()) return 0.0;
  const std::size_t k = std::min(d.size() - 1, std::size_t(quantile * double(d.size())));
  std::nth_element(d.begin(), d.begin() + k, d.end());
  return d[k];
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

void checkCells(double cells, double max_cells, double h, const std::string& name, const char* what) {
  if (cells > max_cells)
    throw TopoError(name,
                    std::string("spacing ") + numberText(h, 3) + " m would create " + numberText(cells, 3) + " " +
                        what + " (limit " + numberText(max_cells, 3) + ")",
                    "use a larger spacing (--spacing) or a smaller particle count (--count)");
}

class Filler {
 public:
  Filler(const SurfaceData& s, const FillOptions& o, FillReport& r) : s_(s), o_(o), r_(r) {
    surfaceBounds(s, &lo_, &hi_);
  }

  Occupancy fillAt(double h) {
    checkCells(Lattice::cellCount(lo_, hi_, h, 1), o_.max_cells, h, s_.source, "lattice cells");
    const Lattice out = Lattice::covering(lo_, hi_, h, 1);
    if (s_.kind == SurfaceKind::Mesh && r_.topology.closed()) {
      r_.method = "mesh-parity";
      return Occupancy{out, meshInsideParity(s_, out)};
    }
    const double longest = (hi_ - lo_).maxCoeff();
    const double g = o_.grid_resolution > 0 ? longest / o_.grid_resolution : h;
    DensityFillResult res;
    Lattice grid;
    if (s_.kind == SurfaceKind::Gaussians) {
      r_.method = "gaussian-density";
      DensityFillOptions d = o_.density;
      if (sparse_spacing_ < 0.0) sparse_spacing_ = typicalPointSpacing(s_.points, 0.9);
      if (d.min_sigma_m < 0.0) d.min_sigma_m = sparse_spacing_;
      if (d.closing_m < 0.0) d.closing_m = 3.0 * sparse_spacing_;
      grid = densityGrid(g, 3.0 * std::max(robustSigmaMax(), d.min_sigma_m));
      res = densityFill(s_.points, s_.covariances, s_.opacity, grid, d);
      r_.closing_cells = d.closing_cells < 0 ? std::max(1, int(std::ceil(d.closing_m / g))) : d.closing_cells;
    } else {
      const bool mesh = s_.kind == SurfaceKind::Mesh;
      r_.method = mesh ? "mesh-sample-density" : "point-density";
      const double sigma_floor = 0.75 * g;
      DensityFillOptions d = o_.density;
      if (mesh) {
        if (d.closing_m < 0.0) d.closing_m = g;
        grid = densityGrid(g, 3.0 * sigma_floor);
        res = densityFillPoints(sampleTriangles(s_, 0.5 * g), 0.5 * g, sigma_floor, grid, d);
      } else {
        if (point_spacing_ < 0.0) point_spacing_ = typicalPointSpacing(s_.points);
        if (sparse_spacing_ < 0.0) sparse_spacing_ = typicalPointSpacing(s_.points, 0.9);
        if (d.closing_m < 0.0) d.closing_m = 3.0 * sparse_spacing_;
        const double sigma = std::max(sigma_floor, point_spacing_);
        grid = densityGrid(g, 3.0 * sigma);
        res = densityFillPoints(s_.points, std::max(point_spacing_, 1e-12), sigma, grid, d);
      }
      r_.closing_cells = d.closing_cells < 0 ? std::max(1, int(std::ceil(d.closing_m / g))) : d.closing_cells;
    }
    r_.dense_cells = res.dense_cells;
    r_.ray_filled_cells = res.ray_filled_cells;
    r_.leaked_cells = res.leaked_cells;
    r_.open_fraction = res.open_fraction();
    if (r_.open_fraction > o_.max_open_fraction) throwOpen(g);
    return resample(grid, res.solid, out);
  }

 private:
  Lattice densityGrid(double g, double reach) {
    const int pad = 2 + int(std::ceil(reach / g));
    checkCells(Lattice::cellCount(lo_, hi_, g, pad), o_.max_cells, g, s_.source, "density grid cells");
    return Lattice::covering(lo_, hi_, g, pad);
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
    throw TopoError(s_.source, "the surface is open: " + detail,
                    "close the holes (e.g. MeshLab: Close Holes, or scan the missing sides), or seal gaps up to "
                    "2·N grid cells (" +
                        numberText(g, 3) + " m each; N was " + std::to_string(r_.closing_cells) +
                        ") with closing_cells = N (CLI --closing-cells N), "
                        "or accept a partial fill by raising max_open_fraction above " +
                        numberText(r_.open_fraction, 3));
  }

  const SurfaceData& s_;
  const FillOptions& o_;
  FillReport& r_;
  Eigen::Vector3d lo_, hi_;
  double point_spacing_ = -1.0;
  double sparse_spacing_ = -1.0;
};

VolumeCloud toCloud(const Occupancy& occ, const FillOptions& o) {
  const Lattice& L = occ.lattice;
  VolumeCloud cloud;
  cloud.spacing = L.h;
  std::mt19937 rng(o.seed);
  std::uniform_real_distribution<double> u(-o.jitter, o.jitter);
  const double v = L.h * L.h * L.h;
  auto solidAt = [&](int i, int j, int k) {
    return i >= 0 && j >= 0 && k >= 0 && i < L.n[0] && j < L.n[1] && k < L.n[2] && occ.solid[L.index(i, j, k)];
  };
  for (int k = 0; k < L.n[2]; ++k)
    for (int j = 0; j < L.n[1]; ++j)
      for (int i = 0; i < L.n[0]; ++i) {
        if (!occ.solid[L.index(i, j, k)]) continue;
        Eigen::Vector3d x = L.center(i, j, k);
        if (o.jitter > 0.0) x += L.h * Eigen::Vector3d(u(rng), u(rng), u(rng));
        cloud.X.push_back(x);
        cloud.V.push_back(v);
        const bool inner = solidAt(i - 1, j, k) && solidAt(i + 1, j, k) && solidAt(i, j - 1, k) &&
                           solidAt(i, j + 1, k) && solidAt(i, j, k - 1) && solidAt(i, j, k + 1);
        cloud.surface.push_back(inner ? 0 : 1);
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
    bad("max_open_fraction " + numberText(o.max_open_fraction, 3) + " is outside [0, 1]", "use the default 0.02");
}

VolumeCloud fillInterior(const SurfaceData& s, const FillOptions& o, FillReport* report) {
  const auto t0 = std::chrono::steady_clock::now();
  validateFillOptions(o, s.source + " fill options");
  FillReport local;
  FillReport& r = report ? *report : local;
  r = FillReport{};
  r.points_in = s.size();
  r.triangles_in = s.triangles.size();
  if (s.points.empty()) throw TopoError(s.source, "has no points", "check that the file or topic carries a surface");
  for (const auto& p : s.points)
    if (!p.allFinite())
      throw TopoError(s.source, "has NaN or infinite coordinates", "clean the surface first (cleanSurface drops them)");
  surfaceBounds(s, &r.bbox_min, &r.bbox_max);
  const Eigen::Vector3d ext = r.bbox_max - r.bbox_min;
  if (s.kind == SurfaceKind::Mesh && s.triangles.empty())
    throw TopoError(s.source, "is a mesh without faces", "export the faces too, or load it as a point cloud");
  if (s.kind != SurfaceKind::Mesh && s.size() < 4)
    throw TopoError(s.source, "has only " + std::to_string(s.size()) + " point(s): no volume can be enclosed",
                    "give a surface sampled all around the object");
  if (ext.minCoeff() <= 0.0)
    throw TopoError(s.source,
                    "has zero extent along " +
                        std::string(ext.x() <= 0   ? "x"
                                    : ext.y() <= 0 ? "y"
                                                   : "z") +
                        " (bounding box " + numberText(ext.x(), 3) + " × " + numberText(ext.y(), 3) + " × " +
                        numberText(ext.z(), 3) + " m): it encloses no volume",
                    "give a surface that surrounds a solid, not a flat patch");
  if (s.kind == SurfaceKind::Mesh) r.topology = analyseMesh(s);

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
  VolumeCloud cloud = toCloud(occ, o);
  if (cloud.empty())
    throw TopoError(s.source, "encloses no volume at spacing " + numberText(h, 3) + " m (" + r.method + ")",
                    "check that the surface is closed (a partial scan has no inside), or use a finer spacing");
  r.spacing_m = cloud.spacing;
  r.particles_out = cloud.size();
  r.surface_particles = cloud.surfaceCount();
  r.total_volume_m3 = cloud.totalVolume();
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return cloud;
}

}  // namespace topo_gaussian::geometry
