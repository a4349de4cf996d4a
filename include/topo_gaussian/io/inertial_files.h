// Mass properties for a robot: the identified mass m, centre of mass c and inertia tensor I about c
// (physics/mass_properties.h: I = tr(C) 1 − C, C = Σ m_i (x_i − c)(x_i − c)ᵀ, in the object's frame:
// the frame of the volume the inference ran on) written as the robot's description formats hold them:
//   URDF  <inertial><origin xyz="c" rpy="0 0 0"/><mass value="m"/><inertia ixx=… iyz=…/></inertial>
//         (ixx = I₀₀, ixy = I₀₁, …: the tensor's elements, off-diagonals −Σ m x y, as URDF defines them)
//   SDF   <inertial><pose>c 0 0 0</pose><mass>m</mass><inertia><ixx>…</ixx>…</inertia></inertial>
// each inside a one-link robot / model named after the object, so that a file loads as it is
// (urdfdom, gazebo) and its <inertial> block can be pasted into the lab's own description.
// Where the identifiability analysis (inference/identifiability.h) gave the ten moments' linearised
// standard deviations, both files carry them in a comment beside the numbers.
// A physical inertia (checkInertia): m > 0 and finite; I symmetric and positive definite, with
// principal moments that obey the triangle inequalities I₁ + I₂ ≥ I₃ (every body's do: I₁ + I₂ − I₃ =
// 2 Σ m z'² ≥ 0 along the third principal axis); the files are refused otherwise, naming which.
#pragma once

#include <array>
#include <string>

#include "topo_gaussian/physics/mass_properties.h"

namespace topo_gaussian::io {

/// An identified body's mass properties and what is known of their uncertainty.
struct IdentifiedMass {
  MassProperties mass;
  /// Linearised standard deviations of [m, cx, cy, cz, Ixx, Iyy, Izz, Ixy, Ixz, Iyz] (the ten moments'
  /// order) [kg, m, kg m²]; meaningful only when has_std.
  std::array<double, 10> std{};
  std::array<bool, 10> determined{};  ///< the analysis's verdict per moment (when has_std)
  bool has_std = false;
  std::string summary;  ///< the analysis's sentence (what the experiments determine), "" without one
};

/// The mass properties of a report.json text (topo infer, the inference node): "mass_kg",
/// "center_of_mass", "inertia", and the identifiability analysis's "moments" (std, determined) when it
/// is available. Throws TopoError naming `source` when the text is not JSON or lacks the three entries.
IdentifiedMass identifiedMassFromReport(const std::string& json, const std::string& source);

struct InertiaCheck {
  bool physical = false;
  std::string problem;                                      ///< why not (empty when physical)
  Eigen::Vector3d principal_kg_m2 = Eigen::Vector3d::Zero(); ///< ascending
};

/// The checks of the header comment; relative_tolerance scales the triangle inequality's slack by the
/// largest principal moment (rounding of a thin rod or a flat plate).
InertiaCheck checkInertia(const MassProperties& mass, double relative_tolerance = 1e-9);

/// The one-link URDF (robot `name`, link `name`); throws TopoError (naming `source` and the problem)
/// when checkInertia fails.
std::string urdfInertial(const IdentifiedMass& identified, const std::string& name,
                         const std::string& source = "the identified inertia");
/// The one-link SDF 1.6 model; as urdfInertial.
std::string sdfInertial(const IdentifiedMass& identified, const std::string& name,
                        const std::string& source = "the identified inertia");

}  // namespace topo_gaussian::io
