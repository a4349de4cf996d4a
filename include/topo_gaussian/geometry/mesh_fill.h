// Exact inside test of a closed triangle mesh on a lattice (winding number or parity of the crossings
// along z columns, with simulation-of-simplicity tie breaking), and the mesh's topology check (is it closed?).
#pragma once

#include <cstdint>
#include <vector>

#include "topo_gaussian/geometry/lattice.h"
#include "topo_gaussian/geometry/surface_data.h"

namespace topo_gaussian::geometry {

struct MeshTopology {
  std::size_t edges = 0;              ///< distinct undirected edges
  std::size_t boundary_edges = 0;     ///< used by one triangle: the surface is open there
  std::size_t nonmanifold_edges = 0;  ///< used by three or more triangles
  /// Used by two triangles that traverse it in the same direction: the faces on its two sides are
  /// oriented oppositely (part of the surface has flipped normals).
  std::size_t misoriented_edges = 0;
  double boundary_length = 0.0;  ///< summed length of boundary edges [m]
  bool closed() const { return boundary_edges == 0; }
  double openFraction() const { return edges ? double(boundary_edges) / double(edges) : 0.0; }
};

MeshTopology analyseMesh(const SurfaceData& mesh);

/// How a lattice cell's centre is decided inside a closed mesh from its upward ray.
enum class InsideRule {
  /// Non-zero winding: inside where the signed crossings (+1 through a face looking up, −1 down) do
  /// not sum to 0. Overlapping closed shells give their union; an inward shell inside an outward one
  /// a void. Needs consistently oriented faces.
  NonZeroWinding,
  /// Odd number of crossings: indifferent to orientation, but the overlap of two shells is outside.
  Parity,
};

/// 1 for every lattice cell whose centre is inside the mesh by `rule`. Exact for closed meshes: a
/// centre on an edge or vertex in projection is assigned to exactly one triangle. Parallel over columns.
std::vector<std::uint8_t> meshInside(const SurfaceData& mesh, const Lattice& lattice, InsideRule rule);

/// meshInside by ray parity.
std::vector<std::uint8_t> meshInsideParity(const SurfaceData& mesh, const Lattice& lattice);

}  // namespace topo_gaussian::geometry
