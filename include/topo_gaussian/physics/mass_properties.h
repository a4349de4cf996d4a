// MassProperties: the ten numbers a rigid motion depends on (paper §6.1, DESIGN "Rigid"):
// mass m, centre of mass c and inertia tensor I about c, all in the body (rest) frame.
//
// They come from the particle masses m_i through the raw moments (linear in m_i):
//   M0 = Σ m_i,  M1 = Σ m_i x_i,  M2 = Σ m_i x_i x_iᵀ
// and  c = M1 / M0,  I = tr(C) 1 − C  with  C = M2 − M1 M1ᵀ / M0  (= Σ m_i (x_i−c)(x_i−c)ᵀ).
// A particle stands for a cell of the lattice, not a point: its own second moment about its centre
// is m_i Σ_cell, Σ_cell = (h²/12) 1 for a cube of side h (cubeCellVariance), so
//   M2 = Σ m_i (x_i x_iᵀ + Σ_cell),
// which makes a filled box's inertia exact (the point sum alone is (n²−1)/n² of it). For a cell the
// surface clips the true Σ is smaller; the difference is O(h³) relative and is not modelled.
// Reverse mode: a loss gradient w.r.t. the ten MassProperties parameters is pulled back to the
// raw moments (massPropertiesJacobian) and from there to every m_i (momentsToParticleGradient).
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

namespace topo_gaussian {

/// Raw mass moments: linear in the particle masses.
struct MassMoments {
  double m0 = 0.0;                               ///< Σ m_i [kg]
  Eigen::Vector3d m1 = Eigen::Vector3d::Zero();  ///< Σ m_i x_i [kg m]
  Eigen::Matrix3d m2 = Eigen::Matrix3d::Zero();  ///< Σ m_i x_i x_iᵀ [kg m²]

  /// Packed as [m0, m1x, m1y, m1z, m2xx, m2yy, m2zz, m2xy, m2xz, m2yz].
  Eigen::Matrix<double, 10, 1> toVector() const;
  static MassMoments fromVector(const Eigen::Matrix<double, 10, 1>& v);
};

/// Mass, centre of mass and inertia about the centre of mass, in the body (rest) frame.
struct MassProperties {
  double mass = 0.0;                                  ///< [kg]
  Eigen::Vector3d com = Eigen::Vector3d::Zero();      ///< [m]
  Eigen::Matrix3d inertia = Eigen::Matrix3d::Zero();  ///< about com [kg m²], symmetric

  /// The ten simulation parameters [m, cx, cy, cz, Ixx, Iyy, Izz, Ixy, Ixz, Iyz].
  Eigen::Matrix<double, 10, 1> toVector() const;
  static MassProperties fromVector(const Eigen::Matrix<double, 10, 1>& v);
  /// Principal moments (ascending) and axes (columns) of the inertia tensor.
  void principal(Eigen::Vector3d* moments, Eigen::Matrix3d* axes) const;
};

/// Σ_cell of a cube cell of side spacing_m, per axis: h²/12 [m²] (0 for point masses, spacing 0).
inline double cubeCellVariance(double spacing_m) { return spacing_m * spacing_m / 12.0; }

/// Σ over particles of (m_i, m_i x_i, m_i (x_i x_iᵀ + cell_variance_m2 · 1)). Sizes must agree. OpenMP.
MassMoments computeMassMoments(const std::vector<Eigen::Vector3d>& X, const std::vector<double>& masses,
                               double cell_variance_m2 = 0.0);

/// (m, c, I) from raw moments. Throws TopoError when the mass is not positive and finite.
MassProperties massPropertiesFromMoments(const MassMoments& moments);

/// Convenience: massPropertiesFromMoments(computeMassMoments(X, masses, cell_variance_m2)).
MassProperties computeMassProperties(const std::vector<Eigen::Vector3d>& X, const std::vector<double>& masses,
                                     double cell_variance_m2 = 0.0);

/// J = d MassProperties::toVector() / d MassMoments::toVector() (10×10), at the given moments.
Eigen::Matrix<double, 10, 10> massPropertiesJacobian(const MassMoments& moments);

/// Pull a gradient back from the ten mass-property parameters to the particle masses:
/// dL/dm_i = g_moments · ∂moments/∂m_i, with g_moments = Jᵀ g_props. Overwrites dL_dm (size N).
/// cell_variance_m2 as given to computeMassMoments.
void massPropertiesGradientToParticles(const std::vector<Eigen::Vector3d>& X, const MassMoments& moments,
                                       const Eigen::Matrix<double, 10, 1>& dL_dprops, std::vector<double>* dL_dm,
                                       double cell_variance_m2 = 0.0);

/// dL/dm_i from a gradient w.r.t. the packed raw moments. Overwrites dL_dm (size N). OpenMP.
void momentsGradientToParticles(const std::vector<Eigen::Vector3d>& X, const Eigen::Matrix<double, 10, 1>& dL_dmoments,
                                std::vector<double>* dL_dm, double cell_variance_m2 = 0.0);

}  // namespace topo_gaussian
