// viewCoverage: how much of an object's outside a set of surface points has seen, and where the
// holes are. Measured over directions from the points' bounding-box centre: the unit sphere is cut
// into equal-area bins (a Fibonacci lattice); a bin is seen when a point lies in it. Unseen bins that
// touch form a hole, named by its direction, a position on the object's bounding sphere, its size and
// a viewpoint to add. Star-shaped objects (a ball, a box, a tumbler) are measured exactly so; a shape
// with a through hole (a torus, a mug's handle) has directions with no surface at all, which read as
// holes (then lower the threshold and rely on the fill's open-surface check).
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

namespace topo_gaussian::geometry {

struct CoverageHole {
  Eigen::Vector3d direction = Eigen::Vector3d::UnitZ();  ///< unit, from the centre towards the hole
  Eigen::Vector3d position = Eigen::Vector3d::Zero();    ///< centre + radius * direction [m]
  double fraction = 0.0;       ///< of all directions (of the object's outside)
  double half_angle_deg = 0.0; ///< of the cone with the same solid angle
  /// A camera position that would see the hole: centre + 3 * radius * direction [m].
  Eigen::Vector3d viewpoint = Eigen::Vector3d::Zero();
  /// e.g. "a hole of 24 % of the surface facing (0, 0, -1) (-z), ~59 deg across, around (0, 0, -0.05) m"
  std::string text(const std::string& frame) const;
};

struct ViewCoverage {
  double fraction = 0.0;  ///< seen directions / all directions, in [0, 1]
  std::size_t bins = 0;   ///< directions the sphere was cut into
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  double radius = 0.0;              ///< largest distance of a point from the centre [m]
  std::vector<CoverageHole> holes;  ///< largest first
  /// "coverage 76.3 % (400 directions); 1 hole: ..." (up to three holes named).
  std::string summary(const std::string& frame) const;
};

/// Coverage of `points` over `bins` directions (at least 20). Fewer than 4 points: coverage 0 with one
/// hole covering everything.
ViewCoverage viewCoverage(const std::vector<Eigen::Vector3d>& points, int bins = 400);

/// Throws TopoError naming `input` when coverage.fraction < min_fraction: the coverage, the largest
/// hole (direction, position, size) and the viewpoint to add, in `frame`.
void requireCoverage(const ViewCoverage& coverage, double min_fraction, const std::string& input,
                     const std::string& frame);

}  // namespace topo_gaussian::geometry
