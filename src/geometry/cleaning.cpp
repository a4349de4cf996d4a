#include "topo_gaussian/geometry/cleaning.h"

#include <pcl/filters/statistical_outlier_removal.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <cmath>

#include "topo_gaussian/common/error.h"

namespace topo_gaussian::geometry {

namespace {

std::size_t keepAndCount(SurfaceData& s, const std::vector<bool>& flags) {
  std::size_t dropped = 0;
  for (bool f : flags) dropped += f ? 0 : 1;
  if (dropped) s.keep(flags);
  return dropped;
}

}  // namespace

CleanReport cleanSurface(SurfaceData& s, const CleanOptions& o) {
  const std::string& name = s.source;
  if (!(o.scale > 0.0) || !std::isfinite(o.scale))
    throw TopoError(name, "scale " + std::to_string(o.scale) + " is not a positive number",
                    "use e.g. 0.001 to convert millimetres to metres");
  if (o.opacity_threshold < 0.0 || o.opacity_threshold >= 1.0)
    throw TopoError(name, "opacity threshold " + std::to_string(o.opacity_threshold) + " is outside [0, 1)",
                    "use the default 0.02");
  if (o.outlier_neighbours < 0 || (o.outlier_neighbours > 0 && !(o.outlier_std_ratio > 0.0)))
    throw TopoError(name, "outlier removal needs k >= 0 and a positive std ratio", "use k=16, ratio=3");
  if ((o.crop_min.array() >= o.crop_max.array()).any())
    throw TopoError(name, "crop box min is not below max on every axis", "give crop_min < crop_max");

  CleanReport r;
  r.points_in = s.size();
  if (s.points.empty()) throw TopoError(name, "has no points", "check that the file or topic carries a surface");

  // 1. non-finite values (positions, and Gaussian parameters)
  std::vector<bool> keep(s.size(), true);
  for (std::size_t i = 0; i < s.size(); ++i) {
    bool ok = s.points[i].allFinite();
    if (s.kind == SurfaceKind::Gaussians) ok = ok && std::isfinite(s.opacity[i]) && s.covariances[i].allFinite();
    keep[i] = ok;
  }
  r.non_finite = keepAndCount(s, keep);
  if (s.points.empty())
    throw TopoError(name, "every one of its " + std::to_string(r.points_in) + " points is NaN or infinite",
                    "re-export the surface; check the exporter's coordinate output");

  // 1b. a point cloud with points written more than once (a scan saved twice, merged exports): the
  // copies would halve the measured sampling spacing and the fill would see a sparse, open surface.
  if (s.kind == SurfaceKind::Points) {
    const std::vector<std::size_t> first = firstAtSamePosition(s.points);
    keep.assign(s.size(), true);
    for (std::size_t i = 0; i < s.size(); ++i) keep[i] = first[i] == i;
    r.duplicates = keepAndCount(s, keep);
  }

  // 2. scale and crop
  if (o.scale != 1.0) {
    for (auto& p : s.points) p *= o.scale;
    for (auto& c : s.scales) c *= o.scale;
    for (auto& C : s.covariances) C *= o.scale * o.scale;
  }
  keep.assign(s.size(), true);
  for (std::size_t i = 0; i < s.size(); ++i)
    keep[i] = (s.points[i].array() >= o.crop_min.array()).all() && (s.points[i].array() <= o.crop_max.array()).all();
  r.cropped = keepAndCount(s, keep);
  // Before anything reaches PCL/FLANN (float k-d trees): coordinates near FLT_MAX abort inside FLANN.
  checkCoordinateRange(s);

  // 3. transparent Gaussians
  if (s.kind == SurfaceKind::Gaussians) {
    keep.assign(s.size(), true);
    for (std::size_t i = 0; i < s.size(); ++i) keep[i] = s.opacity[i] >= o.opacity_threshold;
    r.transparent = keepAndCount(s, keep);
  }

  // 4. statistical outliers (not for meshes: their vertices are the surface)
  if (s.kind != SurfaceKind::Mesh && o.outlier_neighbours > 0 && int(s.size()) > o.outlier_neighbours + 1) {
    pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
    cloud->resize(s.size());
    for (std::size_t i = 0; i < s.size(); ++i) cloud->points[i].getVector3fMap() = s.points[i].cast<float>();
    pcl::StatisticalOutlierRemoval<pcl::PointXYZ> sor(true);
    sor.setInputCloud(cloud);
    sor.setMeanK(o.outlier_neighbours);
    sor.setStddevMulThresh(o.outlier_std_ratio);
    pcl::PointCloud<pcl::PointXYZ> kept;
    sor.filter(kept);
    keep.assign(s.size(), true);
    for (int idx : *sor.getRemovedIndices()) keep[std::size_t(idx)] = false;
    r.outliers = keepAndCount(s, keep);
  }

  if (s.points.empty())
    throw TopoError(name,
                    "no points are left after cleaning (" + std::to_string(r.cropped) + " cropped, " +
                        std::to_string(r.transparent) + " below opacity " + std::to_string(o.opacity_threshold) + ")",
                    "widen the crop box or lower the opacity threshold");

  // 5. recentre on the bounding-box centre
  if (o.recenter) {
    Eigen::Vector3d lo = s.points[0], hi = s.points[0];
    for (const auto& p : s.points) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
    r.shift = -0.5 * (lo + hi);
    for (auto& p : s.points) p += r.shift;
  }
  return r;
}

}  // namespace topo_gaussian::geometry
