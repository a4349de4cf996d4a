// identifiedMassFromReport, checkInertia, urdfInertial, sdfInertial (io/inertial_files.h).
#include "topo_gaussian/io/inertial_files.h"

#include <Eigen/Eigenvalues>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/number_text.h"

namespace topo_gaussian::io {
namespace {

constexpr const char* kMomentNames[10] = {"m", "cx", "cy", "cz", "Ixx", "Iyy", "Izz", "Ixy", "Ixz", "Iyz"};
constexpr const char* kReportFix = "give the report.json that topo infer or the inference node wrote for this run";

/// Exact decimal text (reads back to the same double).
std::string exact(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

/// An XML name: letters, digits, '_', '-', '.'; anything else becomes '_'.
std::string xmlName(const std::string& name) {
  std::string s = name.empty() ? "object" : name;
  for (char& c : s)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.')) c = '_';
  return s;
}

void requirePhysical(const MassProperties& m, const std::string& source) {
  const InertiaCheck c = checkInertia(m);
  if (!c.physical)
    throw TopoError(source, c.problem,
                    "no rigid body has these mass properties; check the run (a negative density or a failed "
                    "inference) before giving them to a robot");
}

/// The comment lines with the standard deviations (empty without them).
std::string stdComment(const IdentifiedMass& id) {
  if (!id.has_std) return "";
  std::string s = "  <!-- standard deviations (linearised, from the experiments' identifiability analysis):";
  for (int k = 0; k < 10; ++k) {
    s += std::string(k % 4 == 0 ? "\n       " : "  ") + kMomentNames[k] + " " + numberText(id.std[k], 3) +
         (id.determined[k] ? "" : " (not determined)");
  }
  return s + " -->\n";
}

}  // namespace

IdentifiedMass identifiedMassFromReport(const std::string& text, const std::string& source) {
  const nlohmann::json j = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded() || !j.is_object()) throw TopoError(source, "is not a JSON object", kReportFix);
  const auto number = [&](const nlohmann::json& v, const std::string& what) {
    if (!v.is_number()) throw TopoError(source, "has no number for " + what, kReportFix);
    return v.get<double>();
  };
  const auto m = j.find("mass_kg"), c = j.find("center_of_mass"), I = j.find("inertia");
  if (m == j.end() || c == j.end() || I == j.end())
    throw TopoError(source, "has no \"mass_kg\", \"center_of_mass\" and \"inertia\"", kReportFix);
  IdentifiedMass out;
  out.mass.mass = number(*m, "mass_kg");
  if (!c->is_array() || c->size() != 3) throw TopoError(source, "has a \"center_of_mass\" that is not 3 numbers", kReportFix);
  for (int a = 0; a < 3; ++a) out.mass.com[a] = number((*c)[a], "center_of_mass[" + std::to_string(a) + "]");
  if (!I->is_array() || I->size() != 3) throw TopoError(source, "has an \"inertia\" that is not a 3 x 3 matrix", kReportFix);
  for (int r = 0; r < 3; ++r) {
    if (!(*I)[r].is_array() || (*I)[r].size() != 3)
      throw TopoError(source, "has an \"inertia\" that is not a 3 x 3 matrix", kReportFix);
    for (int k = 0; k < 3; ++k)
      out.mass.inertia(r, k) = number((*I)[r][k], "inertia[" + std::to_string(r) + "][" + std::to_string(k) + "]");
  }
  const auto ident = j.find("identifiability");
  if (ident != j.end() && ident->is_object()) out.summary = ident->value("summary", std::string());
  if (ident != j.end() && ident->is_object() && ident->value("available", false)) {
    const auto moments = ident->find("moments");
    if (moments != ident->end() && moments->is_object()) {
      out.has_std = true;
      for (int k = 0; k < 10; ++k) {
        const auto e = moments->find(kMomentNames[k]);
        const bool ok = e != moments->end() && e->is_object() && e->contains("std");
        // a free moment's std is +inf, written as null
        out.std[k] = ok && (*e)["std"].is_number() ? (*e)["std"].get<double>() : INFINITY;
        out.determined[k] = ok && e->value("determined", false);
        if (!ok) out.has_std = false;
      }
    }
  }
  return out;
}

InertiaCheck checkInertia(const MassProperties& m, double tol) {
  InertiaCheck c;
  if (!(std::isfinite(m.mass) && m.mass > 0.0)) {
    c.problem = "has a mass of " + numberText(m.mass) + " kg (a body's is positive)";
    return c;
  }
  if (!m.com.allFinite() || !m.inertia.allFinite()) {
    c.problem = "has a centre of mass or inertia that is not finite";
    return c;
  }
  const double scale = m.inertia.cwiseAbs().maxCoeff();
  if (!((m.inertia - m.inertia.transpose()).cwiseAbs().maxCoeff() <= 1e-9 * scale)) {
    c.problem = "has an inertia tensor that is not symmetric";
    return c;
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(m.inertia, Eigen::EigenvaluesOnly);
  c.principal_kg_m2 = es.eigenvalues();
  const Eigen::Vector3d& p = c.principal_kg_m2;
  if (!(p[0] > 0.0)) {
    c.problem = "has an inertia tensor that is not positive definite (principal moments " + numberText(p[0]) + ", " +
                numberText(p[1]) + ", " + numberText(p[2]) + " kg m^2)";
    return c;
  }
  if (p[0] + p[1] < p[2] - tol * p[2]) {
    c.problem = "has principal moments " + numberText(p[0]) + ", " + numberText(p[1]) + ", " + numberText(p[2]) +
                " kg m^2 that break the triangle inequality (the two smaller sum to less than the largest)";
    return c;
  }
  c.physical = true;
  return c;
}

std::string urdfInertial(const IdentifiedMass& id, const std::string& name, const std::string& source) {
  requirePhysical(id.mass, source);
  const MassProperties& m = id.mass;
  const Eigen::Matrix3d& I = m.inertia;
  const std::string n = xmlName(name);
  std::string s;
  s += "<?xml version=\"1.0\"?>\n";
  s += "<!-- Identified by topo_gaussian: mass [kg], centre of mass [m] and inertia about it [kg m^2], in the\n"
       "     object's frame (the volume's coordinates). Paste the <inertial> block into your link. -->\n";
  s += "<robot name=\"" + n + "\">\n";
  s += " <link name=\"" + n + "\">\n";
  s += "  <inertial>\n";
  s += "   <origin xyz=\"" + exact(m.com.x()) + " " + exact(m.com.y()) + " " + exact(m.com.z()) + "\" rpy=\"0 0 0\"/>\n";
  s += "   <mass value=\"" + exact(m.mass) + "\"/>\n";
  s += "   <inertia ixx=\"" + exact(I(0, 0)) + "\" ixy=\"" + exact(I(0, 1)) + "\" ixz=\"" + exact(I(0, 2)) +
       "\" iyy=\"" + exact(I(1, 1)) + "\" iyz=\"" + exact(I(1, 2)) + "\" izz=\"" + exact(I(2, 2)) + "\"/>\n";
  s += "  </inertial>\n";
  s += stdComment(id);
  s += " </link>\n</robot>\n";
  return s;
}

std::string sdfInertial(const IdentifiedMass& id, const std::string& name, const std::string& source) {
  requirePhysical(id.mass, source);
  const MassProperties& m = id.mass;
  const Eigen::Matrix3d& I = m.inertia;
  const std::string n = xmlName(name);
  const auto el = [](const std::string& tag, double v) { return "<" + tag + ">" + exact(v) + "</" + tag + ">"; };
  std::string s;
  s += "<?xml version=\"1.0\"?>\n";
  s += "<!-- Identified by topo_gaussian: mass [kg], centre of mass [m] and inertia about it [kg m^2], in the\n"
       "     object's frame (the volume's coordinates). Paste the <inertial> block into your link. -->\n";
  s += "<sdf version=\"1.6\">\n <model name=\"" + n + "\">\n  <link name=\"" + n + "\">\n";
  s += "   <inertial>\n";
  s += "    <pose>" + exact(m.com.x()) + " " + exact(m.com.y()) + " " + exact(m.com.z()) + " 0 0 0</pose>\n";
  s += "    " + el("mass", m.mass) + "\n";
  s += "    <inertia>" + el("ixx", I(0, 0)) + el("ixy", I(0, 1)) + el("ixz", I(0, 2)) + el("iyy", I(1, 1)) +
       el("iyz", I(1, 2)) + el("izz", I(2, 2)) + "</inertia>\n";
  s += "   </inertial>\n";
  s += stdComment(id);
  s += "  </link>\n </model>\n</sdf>\n";
  return s;
}

}  // namespace topo_gaussian::io
