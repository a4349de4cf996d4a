// Exact integrals of a closed triangle mesh (divergence theorem): the reference that every
// fill result is measured against.
#pragma once

#include <Eigen/Core>

#include "topo_gaussian/geometry/surface_data.h"

namespace topo_gaussian::geometry {

struct MeshIntegrals {
  double volume = 0.0;                                 ///< signed; positive for outward normals
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();  ///< of the enclosed homogeneous solid
  double area = 0.0;
};

MeshIntegrals meshIntegrals(const SurfaceData& mesh);

/// Axis-aligned bounds of the surface's points (finite ones only).
void surfaceBounds(const SurfaceData& surface, Eigen::Vector3d* lo, Eigen::Vector3d* hi);

}  // namespace topo_gaussian::geometry
