// Is a triangle mesh a printable solid? Checks that it is a closed, consistently oriented
// 2-manifold: every edge is shared by exactly two triangles that use it in opposite directions, the
// triangles around every vertex form a single fan, and no triangle is degenerate (a repeated vertex
// or zero area). Slicers and CAD tools call such a mesh "watertight".
#pragma once

#include <cstddef>
#include <string>

#include "topo_gaussian/geometry/surface_data.h"

namespace topo_gaussian::geometry {

struct ManifoldCheck {
  std::size_t vertices = 0;  ///< referenced by at least one triangle
  std::size_t triangles = 0;
  std::size_t edges = 0;                 ///< undirected
  std::size_t boundary_edges = 0;        ///< used by one triangle (a hole)
  std::size_t nonmanifold_edges = 0;     ///< used by three or more triangles
  std::size_t misoriented_edges = 0;     ///< two triangles use the edge in the same direction
  std::size_t nonmanifold_vertices = 0;  ///< the triangles around the vertex form more than one fan
  std::size_t degenerate_triangles = 0;  ///< repeated vertex index or zero area
  std::size_t unused_vertices = 0;       ///< points no triangle uses (allowed, reported)
  std::size_t components = 0;            ///< edge-connected pieces (e.g. 2: an outer wall and a cavity)
  std::size_t bodies = 0;                ///< pieces enclosing positive volume: separate solid parts
  std::size_t voids = 0;                 ///< pieces enclosing negative volume: walls of enclosed cavities
  long euler_characteristic = 0;         ///< V − E + F (2 per sphere-like closed piece)
  double min_triangle_area = 0.0;        ///< [m²]
  /// Closed, oriented, manifold and without degenerate triangles.
  bool watertight() const {
    return triangles > 0 && boundary_edges == 0 && nonmanifold_edges == 0 && misoriented_edges == 0 &&
           nonmanifold_vertices == 0 && degenerate_triangles == 0;
  }
  /// One line for a person: "watertight" or what is wrong, with counts.
  std::string summary() const;
};

/// Throws nothing; triangles with an out-of-range index count as degenerate.
ManifoldCheck checkManifold(const SurfaceData& mesh);

}  // namespace topo_gaussian::geometry
