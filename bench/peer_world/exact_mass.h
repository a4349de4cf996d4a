// m = ρ ∫_Ω dV, c = (1/V) ∫_Ω x dV, I_c = ρ (tr(C) 1 − C) with C = ∫_Ω (x − c)(x − c)ᵀ dV:
// exact mass moments of the peer world's objects, made without this package's particles or simulators.
//
// A closed, outward-oriented triangle mesh is a sum of signed tetrahedra (o, a, b, c), one per
// triangle, with o any reference point; each is integrated in closed form:
//   V_t = a'·(b' × c') / 6,  ∫_t x dV = V_t s / 4,  ∫_t x xᵀ dV = V_t (a'a'ᵀ + b'b'ᵀ + c'c'ᵀ + s sᵀ) / 20,
// with a' = a − o, …, s = a' + b' + c' (the canonical tetrahedron formula; exact for the polyhedron).
// Regions of another density add as parts of density (ρ_region − ρ_body) (a cavity: ρ_cavity − ρ_body,
// negative) and are summed by combine() with the parallel-axis theorem.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

namespace topo_gaussian::peer {

/// Mass [kg], centre of mass [m] and the inertia tensor about the centre of mass [kg m²], body frame.
/// A part of negative density (a cavity) has a negative mass and inertia.
struct MassMoments {
  double mass_kg = 0.0;
  Eigen::Vector3d com_m = Eigen::Vector3d::Zero();
  Eigen::Matrix3d inertia_com_kg_m2 = Eigen::Matrix3d::Zero();  ///< about the centre of mass, body frame
};

/// ρ Σ_t over signed tetrahedra (reference point: the vertices' bounding-box centre): volume integrals of a closed,
/// outward-oriented triangle mesh, exact for the polyhedron, times density_kg_m3 (any finite value,
/// negative for a cavity). Throws TopoError naming `mesh_name` when the mesh is not closed (every directed
/// edge (i, j) must be used once and its reverse (j, i) once: no boundary, no edge shared in the same
/// direction), has an index out of range, a triangle with a repeated vertex, a non-finite vertex, or
/// encloses no volume. An inward-oriented mesh (every triangle reversed: negative total volume) is
/// FLIPPED: measured as its outward twin, never thrown.
MassMoments meshMoments(const std::vector<Eigen::Vector3d>& vertices, const std::vector<Eigen::Vector3i>& triangles,
                        double density_kg_m3, const std::string& mesh_name = "triangle mesh");

/// ρ Σ_t over the triangles clipped to n·(x − plane_point) > 0, tetrahedra from a reference point o on the
/// plane (the bounding-box centre of the vertices projected onto it), so the missing cap (in the plane)
/// contributes nothing: the moments of the part of the mesh's solid on the positive side of the plane.
/// plane_normal need not be unit. The same checks as meshMoments (an inward-oriented mesh is flipped);
/// throws also for a zero or non-finite normal and when no volume lies on the positive side.
MassMoments clippedMeshMoments(const std::vector<Eigen::Vector3d>& vertices,
                               const std::vector<Eigen::Vector3i>& triangles, const Eigen::Vector3d& plane_point,
                               const Eigen::Vector3d& plane_normal, double density_kg_m3,
                               const std::string& mesh_name = "triangle mesh");

/// Solid sphere: m = 4/3 π r³ ρ, I = 2/5 m r² 1. Throws for a non-positive radius or non-finite input.
MassMoments sphereMoments(const Eigen::Vector3d& centre_m, double radius_m, double density_kg_m3);

/// Solid ellipsoid with axis-aligned semi-axes (a, b, c): m = 4/3 π a b c ρ, I = m/5 diag(b² + c², a² + c², a² + b²).
MassMoments ellipsoidMoments(const Eigen::Vector3d& centre_m, const Eigen::Vector3d& semi_axes_m, double density_kg_m3);

/// Axis-aligned box with half edges (h_x, h_y, h_z): m = 8 h_x h_y h_z ρ, I = m/3 diag(h_y² + h_z², h_x² + h_z², h_x² +
/// h_y²).
MassMoments boxMoments(const Eigen::Vector3d& centre_m, const Eigen::Vector3d& half_edges_m, double density_kg_m3);

/// M = Σ m_i, c = Σ m_i c_i / M, I = Σ (I_i + m_i (|d_i|² 1 − d_i d_iᵀ)), d_i = c_i − c (parallel-axis theorem).
/// Parts may have negative mass (cavities, regions lighter than the body). Throws TopoError when the total
/// mass is zero or negative (a cavity larger than its body) or a part is not finite.
MassMoments combine(const std::vector<MassMoments>& parts);

/// w(p) = (1/4π) Σ_t Ω_t(p) (the winding number; Ω_t the signed solid angle of triangle t, Van Oosterom–
/// Strackee): true when `point` lies inside the closed mesh (|w| > 1/2, either orientation) or on its surface
/// (on a triangle to rounding). Call it on samples of a region's surface to check that a cavity or insert lies inside
/// the body. Throws TopoError naming `mesh_name` for an index out of range, a non-finite point, or a winding number
/// that is not an integer (|w − round(w)| > 1e-6: the mesh is open or self-overlapping).
bool insideMesh(const std::vector<Eigen::Vector3d>& vertices, const std::vector<Eigen::Vector3i>& triangles,
                const Eigen::Vector3d& point, const std::string& mesh_name = "triangle mesh");

}  // namespace topo_gaussian::peer
