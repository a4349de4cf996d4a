#include "topo_gaussian/physics/volume_cloud.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/number_text.h"

namespace topo_gaussian {

double ContactSamples::totalArea() const {
  double s = 0.0;
  for (double a : area) s += a;
  return s;
}

std::vector<Eigen::Vector3d> groundContactPoints(const VolumeCloud& cloud, std::string* note,
                                                 std::vector<double>* weights) {
  if (note) note->clear();
  if (weights) weights->clear();
  if (!cloud.contact.empty()) {
    if (weights) {
      const double mean = cloud.contact.totalArea() / double(cloud.contact.size());
      for (double a : cloud.contact.area) weights->push_back(a / mean);
    }
    return cloud.contact.X;
  }
  std::vector<Eigen::Vector3d> out;
  for (std::size_t i = 0; i < cloud.size(); ++i)
    if (i < cloud.surface.size() && cloud.surface[i]) out.push_back(cloud.X[i]);
  if (note)
    *note = "the volume has no contact samples on the true surface: ground contact uses its " +
            std::to_string(out.size()) +
            " surface particles (the lattice staircase; rocking periods can be off by several %); fill it again "
            "with `topo fill` to get them";
  return out;
}

double groundContactSpacing(const VolumeCloud& cloud) {
  return cloud.contact.empty() || !(cloud.contact.spacing > 0) ? cloud.spacing : cloud.contact.spacing;
}

namespace {

double positiveMedian(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const auto mid = v.begin() + std::ptrdiff_t(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid > 0.0 && std::isfinite(*mid) ? *mid : 0.0;
}

bool carried(double spacing) { return spacing > 0.0 && std::isfinite(spacing); }

}  // namespace

double spacingFromVolumes(const std::vector<double>& V) { return std::cbrt(positiveMedian(V)); }

double spacingFromAreas(const std::vector<double>& area) { return std::sqrt(positiveMedian(area)); }

std::string deriveMissingSpacing(VolumeCloud* cloud, const std::string& source) {
  if (carried(cloud->spacing) || cloud->empty()) return "";
  cloud->spacing = spacingFromVolumes(cloud->V);
  return source + " does not carry the volume's spacing (written by an older version): derived " +
         numberText(cloud->spacing, 6) +
         " m as the cube root of the median particle volume, which can differ from the spacing it was filled "
         "at; fill it again (topo fill, cloud_ingest) to carry it";
}

std::string deriveMissingSpacing(ContactSamples* samples, const std::string& source) {
  if (carried(samples->spacing) || samples->empty()) return "";
  samples->spacing = spacingFromAreas(samples->area);
  return source + " does not carry the contact samples' spacing (written by an older version): derived " +
         numberText(samples->spacing, 6) + " m as the square root of the median sample area";
}

double VolumeCloud::totalVolume() const {
  double s = 0.0;
  for (double v : V) s += v;
  return s;
}

Eigen::Vector3d VolumeCloud::centroid() const {
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  double w = 0.0;
  for (std::size_t i = 0; i < X.size(); ++i) {
    c += V[i] * X[i];
    w += V[i];
  }
  return w > 0.0 ? Eigen::Vector3d(c / w) : c;
}

void VolumeCloud::bounds(Eigen::Vector3d* lo, Eigen::Vector3d* hi) const {
  Eigen::Vector3d a = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d b = -a;
  for (const auto& x : X) {
    a = a.cwiseMin(x);
    b = b.cwiseMax(x);
  }
  if (lo) *lo = a;
  if (hi) *hi = b;
}

std::size_t VolumeCloud::surfaceCount() const {
  std::size_t n = 0;
  for (auto s : surface) n += s ? 1 : 0;
  return n;
}

void VolumeCloud::validate(const std::string& what) const {
  if (X.empty()) throw TopoError(what, "has no particles", "check the input surface and the fill parameters");
  if (V.size() != X.size() || surface.size() != X.size())
    throw TopoError(what,
                    "has " + std::to_string(X.size()) + " positions but " + std::to_string(V.size()) + " volumes and " +
                        std::to_string(surface.size()) + " surface flags",
                    "build the cloud with one volume and one flag per particle");
  if (!(spacing > 0.0) || !std::isfinite(spacing))
    throw TopoError(what, "has spacing " + std::to_string(spacing), "set a positive lattice spacing");
  for (std::size_t i = 0; i < X.size(); ++i) {
    if (!X[i].allFinite())
      throw TopoError(what, "particle " + std::to_string(i) + " has a non-finite position",
                      "remove NaN/Inf points before filling");
    if (!(V[i] > 0.0) || !std::isfinite(V[i]))
      throw TopoError(what, "particle " + std::to_string(i) + " has volume " + std::to_string(V[i]),
                      "every particle needs a positive finite volume");
  }
  const ContactSamples& c = contact;
  if (c.empty()) return;
  if (c.normal.size() != c.size() || c.area.size() != c.size())
    throw TopoError(what,
                    "has " + std::to_string(c.size()) + " contact samples but " + std::to_string(c.normal.size()) +
                        " normals and " + std::to_string(c.area.size()) + " areas",
                    "give one normal and one area per contact sample");
  if (!(c.spacing > 0.0) || !std::isfinite(c.spacing))
    throw TopoError(what, "has contact sample spacing " + std::to_string(c.spacing),
                    "set the contact samples' spacing (a positive length in m)");
  for (std::size_t k = 0; k < c.size(); ++k) {
    if (!c.X[k].allFinite() || !c.normal[k].allFinite() || std::abs(c.normal[k].norm() - 1.0) > 1e-3 ||
        !(c.area[k] > 0.0) || !std::isfinite(c.area[k]))
      throw TopoError(what,
                      "contact sample " + std::to_string(k) +
                          " has a non-finite position, a normal that is not of unit length, or an area that is not "
                          "positive",
                      "write the volume again with `topo fill`");
  }
}

}  // namespace topo_gaussian
