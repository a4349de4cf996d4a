// VolumeCloud: the particle discretisation of a solid object (paper §4),
// {(X_i, V_i)} plus a surface flag and the lattice spacing it was sampled on, and the contact samples:
// points on the object's true surface {(y_k, n_k, A_k)} (Σ_k A_k ≈ the surface area) that carry the
// ground contact, so the body touches the ground with its real shape rather than with the lattice's
// staircase of surface particles (a staircase rocks up to 7 % slower or faster than the smooth body).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

namespace topo_gaussian {

/// Points on the object's true surface, in the frame of the particles (rigidly attached to the body).
struct ContactSamples {
  std::vector<Eigen::Vector3d> X;       ///< positions on the surface [m]
  std::vector<Eigen::Vector3d> normal;  ///< outward unit normals
  std::vector<double> area;             ///< surface area each sample stands for [m^2]
  double spacing = 0.0;                 ///< typical distance between neighbouring samples [m]
  /// Where they came from, for logs: "mesh triangles", "points", "Gaussian centres", "shape surface".
  std::string origin;

  std::size_t size() const { return X.size(); }
  bool empty() const { return X.empty(); }
  double totalArea() const;
};

struct VolumeCloud {
  std::vector<Eigen::Vector3d> X;     ///< rest positions [m]
  std::vector<double> V;              ///< particle volumes [m^3]; their sum is the enclosed volume
  std::vector<std::uint8_t> surface;  ///< 1 for particles within one spacing of the boundary
  double spacing = 0.0;               ///< lattice spacing h [m]
  ContactSamples contact;             ///< may be empty (then contact falls back to surface particles)

  std::size_t size() const { return X.size(); }
  bool empty() const { return X.empty(); }
  double totalVolume() const;
  /// Volume-weighted centroid Σ V_i X_i / Σ V_i.
  Eigen::Vector3d centroid() const;
  /// Axis-aligned bounds of the particle positions.
  void bounds(Eigen::Vector3d* lo, Eigen::Vector3d* hi) const;
  std::size_t surfaceCount() const;
  /// Throws TopoError (naming `what`) when sizes disagree, a value is not finite,
  /// a volume is not positive or the cloud is empty (and likewise for the contact samples: sizes,
  /// finite positions, unit normals, positive areas and spacing).
  void validate(const std::string& what = "volume cloud") const;
};

/// The spacing of a volume: set once where it is made (the fill, a default shape) and carried by the
/// volume .ply (comment `spacing`) and the `volume` PointCloud2 (field `spacing`). The one fallback for
/// a file or message written before it was carried: the cube root of the median particle volume (a
/// lattice cell holds h^3; the median passes over a fill's partial boundary cells, whose volumes lie
/// between h^3/2 and about 2 h^3). 0 when that median is not a positive finite number (no particles).
double spacingFromVolumes(const std::vector<double>& V);
/// The contact samples' fallback: the square root of the median area (0 likewise).
double spacingFromAreas(const std::vector<double>& area);
/// For the readers of volume files and messages whose input did not carry the spacing: sets
/// `cloud->spacing` with spacingFromVolumes when it is not a positive finite number, and returns a
/// warning for a person that names `source` and says it was derived; "" when the spacing was there
/// or the cloud is empty.
std::string deriveMissingSpacing(VolumeCloud* cloud, const std::string& source);
/// The same for contact samples (spacingFromAreas); "" when they carry a spacing or are empty.
std::string deriveMissingSpacing(ContactSamples* samples, const std::string& source);

/// The body points that touch the ground: the contact samples when the cloud has them, else the
/// surface particles (the lattice staircase). `*note` (optional) is set to a warning for a person
/// when the staircase is used, "" otherwise. `*weights` (optional): each point's area over the mean
/// area (GroundContact::point_weights), empty for the staircase (all 1).
std::vector<Eigen::Vector3d> groundContactPoints(const VolumeCloud& cloud, std::string* note = nullptr,
                                                 std::vector<double>* weights = nullptr);
/// The spacing of groundContactPoints: the contact samples' spacing, else the lattice spacing.
double groundContactSpacing(const VolumeCloud& cloud);

}  // namespace topo_gaussian
