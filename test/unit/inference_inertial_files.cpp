// Mass properties for a robot (io/inertial_files.h): a real inference's run folder holds inertial.urdf
// and inertial.sdf; urdfdom (Debian's URDF parser, not ours) loads the URDF and its mass, centre of mass
// and inertia are report.json's to the last bit; the SDF holds the same numbers; the standard
// deviations of the identifiability analysis ride along; an unphysical inertia is refused naming why.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "test_clouds.h"
#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/number_text.h"
#include "topo_gaussian/inference/pipeline.h"
#include "topo_gaussian/inference/report.h"
#include "topo_gaussian/io/inertial_files.h"
#include "topo_gaussian/workflow/interior_export.h"

#ifdef TOPO_HAVE_URDFDOM
#include <urdf_parser/urdf_parser.h>
#endif

using namespace topo_gaussian;
using namespace topo_gaussian::inference;

namespace {

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// A hanging inference on a small box with an off-centre target (so the interior is not symmetric and
/// every inertia element is non-zero), exported as topo infer exports it.
struct ExportedRun {
  std::string dir, report;
  workflow::ExportSummary summary;
};

const ExportedRun& exportedRun() {
  static const ExportedRun r = [] {
    ExportedRun out;
    const VolumeCloud cloud = topo_test::boxCloud(0.06, 0.04, 0.03, 0.005);
    TaskConfig c = TaskConfig::defaults("hanging");
    c.setNumber("target_roll_deg", 8.0);
    c.setNumber("target_pitch_deg", -5.0);
    c.setNumber("mass_kg", 0.06);  // weighed: the mass is determined, the rest of the moments are not
    c.set("max_evaluations", "25");
    const InferenceResult res = runInference(c, cloud);
    out.report = reportJson(res, c);
    out.dir = (std::filesystem::temp_directory_path() / "topo_inertial_files_test").string();
    std::filesystem::remove_all(out.dir);
    workflow::ExportOptions eo;
    eo.output_dir = out.dir;
    eo.report_json = out.report;
    eo.object_name = "test box";
    out.summary = workflow::exportInterior(cloud, res.r, res.density, eo);
    return out;
  }();
  return r;
}

/// The numbers of an attribute / element in XML text.
double xmlNumber(const std::string& text, const std::string& pattern) {
  std::smatch m;
  if (!std::regex_search(text, m, std::regex(pattern))) return NAN;
  return std::stod(m[1].str());
}

}  // namespace

TEST(InertialFiles, TheRunFolderHoldsAUrdfThatUrdfdomLoadsWithTheReportsNumbers) {
  const ExportedRun& r = exportedRun();
  ASSERT_TRUE(std::filesystem::exists(r.dir + "/inertial.urdf")) << r.dir;
  ASSERT_TRUE(std::filesystem::exists(r.dir + "/inertial.sdf")) << r.dir;
  const io::IdentifiedMass id = io::identifiedMassFromReport(slurp(r.dir + "/report.json"), "report.json");
  ASSERT_GT(id.mass.mass, 0.0);
  EXPECT_GT(std::abs(id.mass.inertia(0, 1)) + std::abs(id.mass.inertia(0, 2)) + std::abs(id.mass.inertia(1, 2)),
            1e-6 * id.mass.inertia.trace())
      << "the test needs an interior with products of inertia";
#ifndef TOPO_HAVE_URDFDOM
  GTEST_SKIP() << "urdfdom (liburdfdom-dev) was not found at configure time: scripts/install_deps.sh installs it";
#else
  const urdf::ModelInterfaceSharedPtr model = urdf::parseURDF(slurp(r.dir + "/inertial.urdf"));
  ASSERT_TRUE(model) << "urdfdom could not parse inertial.urdf";
  const urdf::LinkConstSharedPtr link = model->getLink("test_box");
  ASSERT_TRUE(link && link->inertial) << "no link test_box with an <inertial>";
  const urdf::Inertial& in = *link->inertial;
  // Exact: the file holds every double in 17 significant digits.
  EXPECT_EQ(in.mass, id.mass.mass);
  EXPECT_EQ(in.origin.position.x, id.mass.com.x());
  EXPECT_EQ(in.origin.position.y, id.mass.com.y());
  EXPECT_EQ(in.origin.position.z, id.mass.com.z());
  double roll, pitch, yaw;
  in.origin.rotation.getRPY(roll, pitch, yaw);
  EXPECT_EQ(roll, 0.0);
  EXPECT_EQ(pitch, 0.0);
  EXPECT_EQ(yaw, 0.0);
  const Eigen::Matrix3d& I = id.mass.inertia;
  EXPECT_EQ(in.ixx, I(0, 0));
  EXPECT_EQ(in.iyy, I(1, 1));
  EXPECT_EQ(in.izz, I(2, 2));
  EXPECT_EQ(in.ixy, I(0, 1));
  EXPECT_EQ(in.ixz, I(0, 2));
  EXPECT_EQ(in.iyz, I(1, 2));
#endif
}

TEST(InertialFiles, TheSdfHoldsTheSameNumbersAndBothCarryTheStandardDeviations) {
  const ExportedRun& r = exportedRun();
  const std::string sdf = slurp(r.dir + "/inertial.sdf"), urdf = slurp(r.dir + "/inertial.urdf");
  const io::IdentifiedMass id = io::identifiedMassFromReport(r.report, "report");
  const Eigen::Matrix3d& I = id.mass.inertia;
  const std::string num = "([-+0-9.eE]+)";
  EXPECT_EQ(xmlNumber(sdf, "<mass>" + num + "</mass>"), id.mass.mass);
  EXPECT_EQ(xmlNumber(sdf, "<pose>" + num), id.mass.com.x());
  EXPECT_EQ(xmlNumber(sdf, "<ixx>" + num + "</ixx>"), I(0, 0));
  EXPECT_EQ(xmlNumber(sdf, "<ixy>" + num + "</ixy>"), I(0, 1));
  EXPECT_EQ(xmlNumber(sdf, "<ixz>" + num + "</ixz>"), I(0, 2));
  EXPECT_EQ(xmlNumber(sdf, "<iyy>" + num + "</iyy>"), I(1, 1));
  EXPECT_EQ(xmlNumber(sdf, "<iyz>" + num + "</iyz>"), I(1, 2));
  EXPECT_EQ(xmlNumber(sdf, "<izz>" + num + "</izz>"), I(2, 2));
  // the hanging task observes the centre of mass: the analysis gives standard deviations
  ASSERT_TRUE(id.has_std) << "the hanging run's report has no identifiability moments";
  for (const std::string* text : std::vector<const std::string*>{&sdf, &urdf}) {
    EXPECT_NE(text->find("standard deviations"), std::string::npos) << *text;
    EXPECT_NE(text->find("not determined"), std::string::npos)
        << "one hanging pose cannot determine the mass: the file must say so\n" << *text;
  }
  EXPECT_TRUE(id.determined[0] && std::isfinite(id.std[0]) && id.std[0] > 0.0) << id.std[0];
  EXPECT_NE(sdf.find("m " + numberText(id.std[0], 3) + " "), std::string::npos) << sdf;
}

TEST(InertialFiles, AnUnphysicalInertiaIsRefusedNamingWhy) {
  MassProperties m;
  m.mass = 1.0;
  m.inertia = Eigen::Vector3d(1.0, 1.0, 2.5).asDiagonal();  // 1 + 1 < 2.5: no body has these
  io::IdentifiedMass id;
  id.mass = m;
  EXPECT_FALSE(io::checkInertia(m).physical);
  std::string what;
  try {
    io::urdfInertial(id, "bad");
  } catch (const TopoError& e) {
    what = e.what();
  }
  EXPECT_NE(what.find("triangle inequality"), std::string::npos) << what;
  m.inertia = Eigen::Vector3d(1.0, -0.5, 1.0).asDiagonal();
  EXPECT_NE(io::checkInertia(m).problem.find("positive definite"), std::string::npos);
  m.inertia = Eigen::Vector3d(1.0, 1.0, 1.0).asDiagonal();
  m.mass = -2.0;
  EXPECT_NE(io::checkInertia(m).problem.find("mass"), std::string::npos);
  // a thin rod (two equal moments, one ~0) and a flat plate (I3 = I1 + I2) are bodies: accepted
  m.mass = 1.0;
  m.inertia = Eigen::Vector3d(1.0, 1.0, 1e-12).asDiagonal();
  EXPECT_TRUE(io::checkInertia(m).physical) << io::checkInertia(m).problem;
  m.inertia = Eigen::Vector3d(1.0, 2.0, 3.0).asDiagonal();
  EXPECT_TRUE(io::checkInertia(m).physical) << io::checkInertia(m).problem;
  // a rotated body is checked on its principal moments
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  m.inertia = R * Eigen::Vector3d(1.0, 1.2, 2.0).asDiagonal() * R.transpose();
  EXPECT_TRUE(io::checkInertia(m).physical) << io::checkInertia(m).problem;
  m.inertia = R * Eigen::Vector3d(1.0, 1.2, 2.3).asDiagonal() * R.transpose();
  EXPECT_FALSE(io::checkInertia(m).physical);
}

TEST(InertialFiles, AReportWithoutMassPropertiesGetsANoteNotFiles) {
  const VolumeCloud cloud = topo_test::boxCloud(0.03, 0.03, 0.03, 0.01);
  const std::string dir = (std::filesystem::temp_directory_path() / "topo_inertial_files_none").string();
  std::filesystem::remove_all(dir);
  workflow::ExportOptions eo;
  eo.output_dir = dir;
  eo.report_json = "{\"task\": \"hanging\", \"loss_history\": [{\"iteration\": 0, \"loss\": 1.0}]}";
  const std::vector<double> r(cloud.size(), 1.0), density(cloud.size(), 1000.0);
  const workflow::ExportSummary s = workflow::exportInterior(cloud, r, density, eo);
  EXPECT_FALSE(std::filesystem::exists(dir + "/inertial.urdf"));
  bool noted = false;
  for (const auto& n : s.notes) noted |= n.find("inertial.urdf and inertial.sdf not written") != std::string::npos &&
                                         n.find("mass_kg") != std::string::npos;
  EXPECT_TRUE(noted);
}
