#include "topo_gaussian/physics/volume_cloud.h"

#include <cmath>
#include <limits>

#include "topo_gaussian/common/error.h"

namespace topo_gaussian {

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
}

}  // namespace topo_gaussian
