// repairMesh: makes a real-world triangle mesh fit for the exact inside test, and says what it changed.
// Welds vertices at exactly the same position (a triangle soup, whatever format it came in), drops
// faces that cannot be part of a surface (a repeated vertex, a NaN/infinite corner, a second copy of a
// face), closes small holes (boundary loops of a few edges, e.g. where a NaN vertex was removed) with
// a fan, peels off open pieces (a stray triangle, an internal fin, a loose sheet) when what is left is
// closed and holds almost all of the area, and turns over the faces whose orientation disagrees with
// their neighbours' (per connected piece the fewer). Every change is counted; fillInterior turns the
// counts into warning lines, and falls back to the density method only with a warning.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "topo_gaussian/geometry/surface_data.h"

namespace topo_gaussian::geometry {

struct MeshRepairOptions {
  int max_hole_edges = 16;                ///< boundary loops of at most this many edges are closed ...
  double max_hole_perimeter_frac = 0.25;  ///< ... when their perimeter is below this × the bbox diagonal
  /// Open pieces are left out when they hold at most this share of the area ...
  double max_ignored_area_frac = 0.05;
  double max_ignored_face_frac = 0.01;  ///< ... or at most this share of the faces (one stray triangle)
};

struct MeshRepairReport {
  std::size_t faces_in = 0;
  /// Vertices at exactly the position of an earlier vertex, merged into it (a triangle soup: every
  /// face with vertices of its own; seams): the faces then share their edges.
  std::size_t welded_vertices = 0;
  std::size_t degenerate_faces = 0;  ///< a vertex index repeated, or out of range: dropped
  std::size_t nonfinite_faces = 0;   ///< a corner with NaN/infinite coordinates: dropped
  std::size_t duplicate_faces = 0;   ///< same three vertices as an earlier face: dropped
  std::size_t holes_closed = 0;      ///< small boundary loops closed by a fan
  std::size_t hole_edges = 0;        ///< edges of those loops
  std::size_t ignored_faces = 0;     ///< faces of open pieces left out of the closed surface
  /// Faces turned over (two vertices swapped) to agree with their edge neighbours, per connected
  /// piece the fewer of the two ways.
  std::size_t reoriented_faces = 0;
  double ignored_area_m2 = 0.0;
  double total_area_m2 = 0.0;  ///< of the valid faces
  bool closed = false;         ///< the returned mesh is closed (every edge used an even number >= 2 of times)
  std::size_t faces_dropped() const { return degenerate_faces + nonfinite_faces + duplicate_faces; }
};

/// The mesh to fill: closed when report->closed (only the closed part, small holes closed), else every
/// valid face (with small holes closed). Unused vertices are removed, so its bounding box is that of
/// the faces kept. Never throws.
SurfaceData repairMesh(const SurfaceData& mesh, MeshRepairReport* report, const MeshRepairOptions& options = {});

}  // namespace topo_gaussian::geometry
