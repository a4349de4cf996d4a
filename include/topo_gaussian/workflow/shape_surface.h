// The surface of a default shape's particle cloud on the shape's true boundary: each surface
// particle (VolumeCloud::surface) is moved along its estimated outward normal (PCA of its neighbours
// within 2.5 spacings, vision/particle_normals.h) onto the boundary, found by bisection on the
// shape's exact inside test between the particle (inside) and 2 spacings out. Particles whose normal
// cannot be estimated, or whose ray does not leave the shape within 2 spacings, stay where they are.
// The rig twins simulate and render this cloud: its ground contact and silhouette are the real
// round bottom and outline, not the lattice's staircase.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "topo_gaussian/physics/default_shapes.h"
#include "topo_gaussian/physics/volume_cloud.h"

namespace topo_gaussian::workflow {

/// Moves the surface particles of `cloud` onto the boundary of `shape` (in place) and returns their
/// positions and outward normals, in the order of the particles.
void projectSurfaceOntoShape(const DefaultShape& shape, VolumeCloud* cloud, std::vector<Eigen::Vector3d>* points,
                             std::vector<Eigen::Vector3d>* normals);

}  // namespace topo_gaussian::workflow
