#include "topo_gaussian/geometry/view_fusion.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <unordered_map>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/number_text.h"

namespace topo_gaussian::geometry {

namespace {

constexpr std::int64_t kAxisCells = std::int64_t(1) << 21;  // a voxel key packs 3 x 21 bits

struct Voxel {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  Eigen::Matrix3d second = Eigen::Matrix3d::Zero();  ///< sum of (p - lo)(p - lo)^T
  Eigen::Vector3d to_sensors = Eigen::Vector3d::Zero();  ///< sum of unit directions point -> sensor
  std::size_t count = 0;
};

std::uint64_t key(const Eigen::Vector3i& c) {
  return (std::uint64_t(c.x()) << 42) | (std::uint64_t(c.y()) << 21) | std::uint64_t(c.z());
}

/// The `q` quantile of one coordinate of `pts` (nth_element on a copy).
double quantile(std::vector<double> v, double q) {
  const std::size_t k = std::min(v.size() - 1, std::size_t(q * double(v.size() - 1) + 0.5));
  std::nth_element(v.begin(), v.begin() + std::ptrdiff_t(k), v.end());
  return v[k];
}

void checkPose(const DepthView& v, const std::string& source) {
  const Eigen::Matrix3d R = v.world_from_sensor.linear();
  const double orth = (R.transpose() * R - Eigen::Matrix3d::Identity()).norm();
  if (!v.world_from_sensor.matrix().allFinite() || orth > 1e-6 || R.determinant() < 0.0)
    throw TopoError(source + " " + v.name,
                    "the sensor pose is not a rigid transform (|R^T R - I| = " + numberText(orth, 3) +
                        ", det R = " + numberText(R.determinant(), 3) + ")",
                    "give world <- sensor as a rotation and a translation (a tf transform)");
}

}  // namespace

FusedViews fuseViews(const std::vector<DepthView>& views, const ViewFusionOptions& options, const std::string& source) {
  std::vector<const DepthView*> pointers;
  pointers.reserve(views.size());
  for (const DepthView& v : views) pointers.push_back(&v);
  return fuseViews(pointers, options, source);
}

FusedViews fuseViews(const std::vector<const DepthView*>& views, const ViewFusionOptions& options,
                     const std::string& source) {
  FusedViews f;
  f.views = views.size();
  if (views.empty()) throw TopoError(source, "there are no views", "add depth clouds of the object first");
  if (options.voxel_m < 0.0 || !std::isfinite(options.voxel_m))
    throw TopoError(source, "voxel size " + numberText(options.voxel_m, 6) + " m is negative or not finite",
                    "give a positive voxel edge in metres, or 0 for 1 % of the object's size");
  // Every finite point in the world frame, with the direction back to its sensor.
  std::vector<Eigen::Vector3d> world, to_sensor;
  for (const DepthView* view : views) {
    const DepthView& v = *view;
    checkPose(v, source);
    const Eigen::Vector3d origin = v.world_from_sensor.translation();
    for (const auto& p : v.points) {
      if (!p.allFinite()) continue;
      const Eigen::Vector3d w = v.world_from_sensor * p;
      world.push_back(w);
      const Eigen::Vector3d d = origin - w;
      to_sensor.push_back(d.norm() > 0.0 ? Eigen::Vector3d(d.normalized()) : Eigen::Vector3d::Zero());
    }
  }
  f.points_in = world.size();
  if (world.size() < 4)
    throw TopoError(source, std::to_string(world.size()) + " finite point(s) in " + std::to_string(views.size()) +
                                " view(s)",
                    "publish depth clouds that see the object (x y z in metres, NaN for no return)");
  // The voxel edge: given, or 1 % of the robust bounding box's diagonal.
  double voxel = options.voxel_m;
  if (voxel == 0.0) {
    Eigen::Vector3d lo, hi;
    std::vector<double> axis(world.size());
    for (int k = 0; k < 3; ++k) {
      for (std::size_t i = 0; i < world.size(); ++i) axis[i] = world[i][k];
      lo[k] = quantile(axis, 0.005);
      hi[k] = quantile(axis, 0.995);
    }
    voxel = 0.01 * (hi - lo).norm();
    if (!(voxel > 0.0))
      throw TopoError(source, "all points lie at one position", "point the depth camera at the object");
  }
  f.voxel_m = voxel;
  Eigen::Vector3d lo = world.front(), hi = world.front();
  for (const auto& p : world) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  const Eigen::Vector3d cells = (hi - lo) / voxel;
  if (cells.maxCoeff() >= double(kAxisCells - 2))
    throw TopoError(source,
                    "the points span " + numberText((hi - lo).maxCoeff(), 4) + " m, " +
                        numberText(cells.maxCoeff(), 4) + " voxels of " + numberText(voxel, 4) +
                        " m along one axis (at most 2^21)",
                    "crop the clouds to the object (a box filter before cloud_ingest) or give a larger voxel");
  auto cellOf = [&](const Eigen::Vector3d& p) {
    return Eigen::Vector3i(((p - lo) / voxel).array().floor().cast<int>());
  };
  std::unordered_map<std::uint64_t, Voxel> grid;
  grid.reserve(world.size() / 2);
  for (std::size_t i = 0; i < world.size(); ++i) {
    Voxel& v = grid[key(cellOf(world[i]))];
    v.sum += world[i];
    const Eigen::Vector3d q = world[i] - lo;
    v.second += q * q.transpose();
    v.to_sensors += to_sensor[i];
    ++v.count;
  }
  // Which voxels hold enough points to count.
  std::size_t used = 0;
  for (auto it = grid.begin(); it != grid.end();) {
    if (int(it->second.count) < std::max(1, options.min_points_per_voxel)) {
      ++f.stray_voxels;
      it = grid.erase(it);
    } else {
      used += it->second.count;
      ++it;
    }
  }
  f.voxels = grid.size();
  if (f.voxels < 4)
    throw TopoError(source, "only " + std::to_string(f.voxels) + " voxel(s) of " + numberText(voxel, 4) + " m hold " +
                                std::to_string(std::max(1, options.min_points_per_voxel)) + " or more points",
                    "use a smaller voxel or fewer required points per voxel, or add views");
  f.mean_points_per_voxel = double(used) / double(f.voxels);
  // One point per voxel: its mean, moved onto the plane fitted to the raw points of the voxel and
  // its 26 neighbours. The voxel mean alone keeps the noise across the surface (a voxel cut by the
  // noisy shell holds one tail of it); the plane averages every point within ~1.5 voxels.
  f.surface.points.reserve(f.voxels);
  f.surface.normals.reserve(f.voxels);
  for (const auto& [k, v] : grid) {
    const Eigen::Vector3i c(int((k >> 42) & (kAxisCells - 1)), int((k >> 21) & (kAxisCells - 1)),
                            int(k & (kAxisCells - 1)));
    Eigen::Vector3d sum = Eigen::Vector3d::Zero(), out = Eigen::Vector3d::Zero();
    Eigen::Matrix3d second = Eigen::Matrix3d::Zero();
    double n = 0.0;
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = -1; dz <= 1; ++dz) {
          const Eigen::Vector3i o = c + Eigen::Vector3i(dx, dy, dz);
          if ((o.array() < 0).any() || (o.array() >= int(kAxisCells)).any()) continue;
          const auto it = grid.find(key(o));
          if (it == grid.end()) continue;
          sum += it->second.sum - double(it->second.count) * lo;
          second += it->second.second;
          out += it->second.to_sensors;
          n += double(it->second.count);
        }
    const Eigen::Vector3d mean_local = sum / n;
    const Eigen::Matrix3d cov = second / n - mean_local * mean_local.transpose();
    const Eigen::Vector3d p = v.sum / double(v.count);
    Eigen::Vector3d normal = out;
    Eigen::Vector3d fused = p;
    if (n >= 3.0) {
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
      normal = es.eigenvectors().col(0);
      if (normal.dot(out) < 0.0) normal = -normal;
      fused = p - normal * normal.dot(p - (mean_local + lo));
    }
    f.surface.points.push_back(fused);
    f.surface.normals.push_back(normal.norm() > 0.0 ? Eigen::Vector3d(normal.normalized())
                                                    : Eigen::Vector3d::UnitZ());
  }
  f.surface.kind = SurfaceKind::Points;
  f.surface.source = source + " (" + std::to_string(views.size()) + " views fused)";
  f.coverage = viewCoverage(f.surface.points, options.coverage_bins);
  return f;
}

}  // namespace topo_gaussian::geometry
