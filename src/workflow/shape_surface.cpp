// The surface particles of a default shape's lattice moved onto its true boundary.
#include "topo_gaussian/workflow/shape_surface.h"

#include "topo_gaussian/vision/particle_normals.h"

namespace topo_gaussian::workflow {

void projectSurfaceOntoShape(const DefaultShape& shape, VolumeCloud* cloud, std::vector<Eigen::Vector3d>* points,
                             std::vector<Eigen::Vector3d>* normals) {
  std::vector<std::size_t> index;
  for (std::size_t i = 0; i < cloud->size(); ++i)
    if (cloud->surface[i]) index.push_back(i);
  const double h = cloud->spacing;
  points->resize(index.size());
  for (std::size_t k = 0; k < index.size(); ++k) (*points)[k] = cloud->X[index[k]];
  *normals = vision::estimateOutwardNormals(cloud->X, *points, 2.5 * h);
  for (std::size_t k = 0; k < index.size(); ++k) {
    const Eigen::Vector3d p = (*points)[k], n = (*normals)[k];
    if (n.squaredNorm() == 0 || !shape.inside(p) || shape.inside(p + 2.0 * h * n)) continue;
    double lo = 0, hi = 2.0 * h;  // inside at lo, outside at hi
    for (int it = 0; it < 30; ++it) {
      const double mid = 0.5 * (lo + hi);
      (shape.inside(p + mid * n) ? lo : hi) = mid;
    }
    (*points)[k] = cloud->X[index[k]] = p + lo * n;
  }
}

}  // namespace topo_gaussian::workflow
