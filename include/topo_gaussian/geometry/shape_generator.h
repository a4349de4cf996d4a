// Closed, outward-oriented triangle meshes of simple solids with known volume: test objects for
// the demo, the tests and the digital-twin rig.
#pragma once

#include <string>
#include <vector>

#include "topo_gaussian/geometry/surface_data.h"

namespace topo_gaussian::geometry {

/// UV sphere of radius r [m] centred at the origin (segments around, rings from pole to pole).
SurfaceData makeSphere(double radius, int segments = 64, int rings = 32);
/// Torus around z: tube centre radius R, tube radius r [m]; volume 2π²Rr².
SurfaceData makeTorus(double R, double r, int segments = 96, int tube_segments = 48);
/// Axis-aligned box with the given edge lengths [m], centred at the origin (12 triangles).
SurfaceData makeBox(const Eigen::Vector3d& size);

/// Names accepted by makeShape: sphere, torus, box.
const std::vector<std::string>& shapeNames();
/// A shape by name with a single size parameter `size` [m] (sphere radius; torus outer radius,
/// tube = size/3; box edge). Throws TopoError for an unknown name or a non-positive size.
SurfaceData makeShape(const std::string& name, double size);

/// Closed, outward-oriented, watertight mesh of a default soft-body shape (finger, pear, beam,
/// tumbler; the solids of topo_gaussian/physics/default_shapes.h, same dimensions in metres), built
/// from the outline the shape declares there (DefaultShape::outline): a box, a polygon extruded along
/// y (the finger), or a profile revolved about z (pear, tumbler). `resolution` is the number of
/// segments around a full circle (8..4096). Throws TopoError for an unknown name (listing the valid
/// ones) or a bad resolution.
SurfaceData makeDefaultShapeMesh(const std::string& name, int resolution = 64);

/// Writes a mesh as Wavefront OBJ. Throws TopoError when the file cannot be written.
void writeObj(const SurfaceData& mesh, const std::string& path);

}  // namespace topo_gaussian::geometry
