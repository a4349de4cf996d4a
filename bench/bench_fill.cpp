// Fill benchmark: our clean+fill against a mesh-based baseline in the same process — PCL normal
// estimation + Poisson reconstruction of the same points, then the exact inside test on that mesh
// at the same lattice spacing (the kind of pipeline the paper beat by 5.26×).
// One JSON line per case on stdout. Usage:
//   bench_fill FILE [--count N]          a file from ../shared/data (or any surface)
//   bench_fill --synthetic-gaussians N    N random Gaussians on a sphere: ours only, peak RSS
#include <pcl/features/normal_3d_omp.h>
#include <pcl/point_types.h>
#include <pcl/surface/poisson.h>
#include <sys/resource.h>

#include <chrono>
#include <iostream>
#include <random>
#include <string>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/geometry/ingest.h"
#include "topo_gaussian/geometry/lattice.h"
#include "topo_gaussian/geometry/mesh_fill.h"
#include "topo_gaussian/geometry/mesh_metrics.h"
#include "topo_gaussian/geometry/surface_reader.h"

using namespace topo_gaussian;
using namespace topo_gaussian::geometry;
using Clock = std::chrono::steady_clock;

namespace {

double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

double peakRssMb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_maxrss / 1024.0;
}

struct Baseline {
  double normals_s = 0, poisson_s = 0, inside_s = 0;
  std::size_t particles = 0, mesh_triangles = 0;
};

// Mesh-based baseline on the surface's points.
Baseline runBaseline(const SurfaceData& s, double spacing) {
  Baseline b;
  auto t = Clock::now();
  pcl::PointCloud<pcl::PointXYZ>::Ptr xyz(new pcl::PointCloud<pcl::PointXYZ>);
  for (const auto& p : s.points) xyz->push_back(pcl::PointXYZ(float(p.x()), float(p.y()), float(p.z())));
  pcl::PointCloud<pcl::Normal> normals;
  pcl::NormalEstimationOMP<pcl::PointXYZ, pcl::Normal> ne;
  ne.setInputCloud(xyz);
  ne.setKSearch(16);
  ne.compute(normals);
  Eigen::Vector3f c = Eigen::Vector3f::Zero();
  for (const auto& p : *xyz) c += p.getVector3fMap();
  c /= float(xyz->size());
  pcl::PointCloud<pcl::PointNormal>::Ptr pn(new pcl::PointCloud<pcl::PointNormal>);
  for (std::size_t i = 0; i < xyz->size(); ++i) {
    pcl::PointNormal q;
    q.getVector3fMap() = xyz->points[i].getVector3fMap();
    Eigen::Vector3f n = normals[i].getNormalVector3fMap();
    if (!n.allFinite()) continue;
    if (n.dot(q.getVector3fMap() - c) < 0) n = -n;  // orient away from the centroid
    q.getNormalVector3fMap() = n;
    pn->push_back(q);
  }
  b.normals_s = since(t);
  t = Clock::now();
  pcl::Poisson<pcl::PointNormal> poisson;
  poisson.setDepth(8);
  poisson.setInputCloud(pn);
  pcl::PointCloud<pcl::PointNormal> verts;
  std::vector<pcl::Vertices> polys;
  poisson.reconstruct(verts, polys);
  b.poisson_s = since(t);
  t = Clock::now();
  SurfaceData mesh;
  mesh.kind = SurfaceKind::Mesh;
  for (const auto& v : verts) mesh.points.emplace_back(v.x, v.y, v.z);
  for (const auto& p : polys)
    for (std::size_t k = 1; k + 1 < p.vertices.size(); ++k)
      mesh.triangles.emplace_back(int(p.vertices[0]), int(p.vertices[k]), int(p.vertices[k + 1]));
  b.mesh_triangles = mesh.triangles.size();
  Eigen::Vector3d lo, hi;
  surfaceBounds(mesh, &lo, &hi);
  const Lattice L = Lattice::covering(lo, hi, spacing, 1);
  for (auto v : meshInsideParity(mesh, L)) b.particles += v;
  b.inside_s = since(t);
  return b;
}

SurfaceData syntheticGaussians(std::size_t n) {
  SurfaceData s;
  s.kind = SurfaceKind::Gaussians;
  s.source = "synthetic sphere of " + std::to_string(n) + " Gaussians";
  std::mt19937 rng(7);
  std::normal_distribution<double> g;
  const double r = 0.1, sigma = 0.1 * std::sqrt(4 * M_PI / double(n));  // ~ spacing of the points
  s.points.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    Eigen::Vector3d p(g(rng), g(rng), g(rng));
    p = r * p.normalized();
    s.points.push_back(p);
    s.opacity.push_back(0.8);
    s.scales.emplace_back(sigma, sigma, 0.1 * sigma);
    Eigen::Vector4d q(g(rng), g(rng), g(rng), g(rng));
    s.rotations.push_back(q.normalized());
    s.covariances.push_back(gaussianCovariance(s.scales.back(), s.rotations.back()));
  }
  s.sh_degree = 0;
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::cerr << "usage: bench_fill FILE [--count N] | --synthetic-gaussians N\n";
    return 2;
  }
  try {
    IngestOptions o;
    const std::string first = argv[1];
    if (first == "--synthetic-gaussians") {
      const std::size_t n = argc > 2 ? std::stoul(argv[2]) : 1000000;
      SurfaceData s = syntheticGaussians(n);
      const double rss_before = peakRssMb();
      const auto t = Clock::now();
      const IngestResult r = ingestSurface(std::move(s), o);
      std::cout << "{\"case\":\"synthetic_gaussians\",\"points\":" << n << ",\"particles\":" << r.cloud.size()
                << ",\"ours_s\":" << since(t) << ",\"baseline_s\":null,\"peak_rss_mb\":" << peakRssMb()
                << ",\"rss_before_fill_mb\":" << rss_before << "}" << std::endl;
      return 0;
    }
    if (argc > 3 && std::string(argv[2]) == "--count") o.fill.target_count = std::stoul(argv[3]);
    const SurfaceData s = readSurface(first);
    // ours: clean + fill from the surface in memory (reading the file is common to both)
    auto t = Clock::now();
    const IngestResult r = ingestSurface(s, o);
    const double ours = since(t);
    const Baseline b = runBaseline(s, r.cloud.spacing);
    const double base = b.normals_s + b.poisson_s + b.inside_s;
    const std::string name = first.substr(first.find_last_of('/') + 1);
    std::cout << "{\"case\":\"" << name << "\",\"kind\":\"" << toString(s.kind) << "\",\"points\":" << s.size()
              << ",\"particles\":" << r.cloud.size() << ",\"spacing_m\":" << r.cloud.spacing << ",\"ours_s\":" << ours
              << ",\"baseline_s\":" << base << ",\"speedup\":" << base / ours
              << ",\"baseline_normals_s\":" << b.normals_s << ",\"baseline_poisson_s\":" << b.poisson_s
              << ",\"baseline_inside_s\":" << b.inside_s << ",\"baseline_particles\":" << b.particles
              << ",\"peak_rss_mb\":" << peakRssMb() << "}" << std::endl;
  } catch (const TopoError& e) {
    std::cerr << "bench_fill: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
