// Outward normals of a particle object's surface from the particles alone: the direction from the
// centroid of a particle's neighbours (within a radius) to the particle. On a filled lattice the
// neighbours of a surface particle lie mostly inside the object, so this points outwards; in the
// interior the centroid coincides with the particle and the normal is zero. Eigen only.
#pragma once

#include <Eigen/Core>
#include <vector>

namespace topo_gaussian::vision {

/// Unit outward normals at `query` points, from the neighbours among `particles` within
/// `radius_m` (about 2–3 particle spacings; the query point itself may be one of the particles).
/// A point whose neighbour centroid lies closer than 1e-3·radius gets a zero normal. Grid hashing,
/// O(N + Q). Throws TopoError for a non-positive radius or non-finite positions.
std::vector<Eigen::Vector3d> estimateOutwardNormals(const std::vector<Eigen::Vector3d>& particles,
                                                    const std::vector<Eigen::Vector3d>& query, double radius_m);

}  // namespace topo_gaussian::vision
