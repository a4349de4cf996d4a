// SurfaceData: what an input file or topic tells about an object's outside.
// One struct for the three kinds of input: 3D Gaussians, plain points, triangle meshes.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

namespace topo_gaussian::geometry {

enum class SurfaceKind { Gaussians, Points, Mesh };

const char* toString(SurfaceKind kind);

struct SurfaceData {
  SurfaceKind kind = SurfaceKind::Points;
  std::string source;  ///< file name or topic, used in messages

  std::vector<Eigen::Vector3d> points;   ///< positions (mesh: vertices)
  std::vector<Eigen::Vector3d> normals;  ///< optional, same size as points when present
  std::vector<Eigen::Vector3d> colors;   ///< optional RGB in [0,1] (Gaussians: SH DC term → colour)

  // Gaussians only (same size as points):
  std::vector<double> opacity;               ///< after sigmoid, in [0,1]
  std::vector<Eigen::Vector3d> scales;       ///< after exp, standard deviations [m]
  std::vector<Eigen::Vector4d> rotations;    ///< normalised quaternion (w, x, y, z)
  std::vector<Eigen::Matrix3d> covariances;  ///< R S Sᵀ Rᵀ
  int sh_degree = -1;                        ///< 0..3 for Gaussians, -1 otherwise

  std::vector<Eigen::Vector3i> triangles;  ///< mesh faces (polygons fan-triangulated)

  std::size_t size() const { return points.size(); }
  bool hasNormals() const { return !normals.empty() && normals.size() == points.size(); }
  bool hasColors() const { return !colors.empty() && colors.size() == points.size(); }

  /// Keeps only the points whose flag is true (all per-point arrays; meshes are re-indexed
  /// and triangles that lose a vertex are dropped).
  void keep(const std::vector<bool>& flags);
};

/// Largest coordinate magnitude a surface may have [m]. Beyond it squared distances in float (PCL's
/// k-d trees) overflow and FLANN aborts; no object a lab fills is 1000 km from its origin, so such
/// values are a unit error or a corrupt file (wrong byte order or property type in a binary header).
constexpr double kMaxCoordinateM = 1e6;

/// Throws TopoError naming `surface.source` when a finite coordinate exceeds kMaxCoordinateM (with
/// how many points do, the largest value, and the fix). NaN/infinite values are left to cleaning.
void checkCoordinateRange(const SurfaceData& surface);

/// Per point, the index of the first point with exactly the same coordinates (itself when it is the
/// first; −0 equals +0; a point with a NaN/infinite coordinate is always its own). Hash-based, O(n):
/// the one weld of the fill (mesh vertices, repeated cloud points).
std::vector<std::size_t> firstAtSamePosition(const std::vector<Eigen::Vector3d>& points);

/// Covariance R S Sᵀ Rᵀ of a Gaussian from its scale (std devs) and quaternion (w,x,y,z).
Eigen::Matrix3d gaussianCovariance(const Eigen::Vector3d& scale, const Eigen::Vector4d& quat_wxyz);

}  // namespace topo_gaussian::geometry
