// Test helper: lattice VolumeClouds of simple solids (cell-centred, surface = a 6-neighbour cell is
// outside), so physics/inference tests need no files.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <vector>

#include "topo_gaussian/physics/volume_cloud.h"

namespace topo_test {

inline topo_gaussian::VolumeCloud latticeCloud(const std::function<bool(const Eigen::Vector3d&)>& inside,
                                               const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, double h) {
  topo_gaussian::VolumeCloud c;
  c.spacing = h;
  const Eigen::Vector3i n = ((hi - lo) / h).array().ceil().cast<int>();
  auto centre = [&](int i, int j, int k) {
    return Eigen::Vector3d(lo + h * Eigen::Vector3d(i + 0.5, j + 0.5, k + 0.5));
  };
  for (int i = 0; i < n.x(); ++i)
    for (int j = 0; j < n.y(); ++j)
      for (int k = 0; k < n.z(); ++k) {
        const Eigen::Vector3d x = centre(i, j, k);
        if (!inside(x)) continue;
        bool surf = false;
        const int d[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
        for (const auto& o : d) surf = surf || !inside(centre(i + o[0], j + o[1], k + o[2]));
        c.X.push_back(x);
        c.V.push_back(h * h * h);
        c.surface.push_back(surf ? 1 : 0);
      }
  return c;
}

/// A sphere of radius R cut flat at z = cut·R (a round-bottomed tumbler body), centre at the origin.
inline topo_gaussian::VolumeCloud tumblerCloud(double R, double cut, double h) {
  return latticeCloud([&](const Eigen::Vector3d& x) { return x.norm() <= R && x.z() <= cut * R; },
                      Eigen::Vector3d(-R, -R, -R), Eigen::Vector3d(R, R, cut * R), h);
}

/// An axis-aligned box a×b×c centred at the origin.
inline topo_gaussian::VolumeCloud boxCloud(double a, double b, double c, double h) {
  const Eigen::Vector3d half(a / 2, b / 2, c / 2);
  return latticeCloud([&](const Eigen::Vector3d& x) { return (x.cwiseAbs() - half).maxCoeff() <= 0; }, -half, half, h);
}

/// r for the default finger (defaultShapeCloud("finger", h), x in [0, 0.1] m): a chamber (r = 0) below
/// its axis, 0.02 < x < 0.085, −6 < z < −0.5 mm, |y| < 6 mm, inside the skin; solid elsewhere. It
/// bends the finger towards +z under pressure.
inline std::vector<double> fingerChamberBelowAxis(const topo_gaussian::VolumeCloud& c) {
  std::vector<double> r(c.size(), 1.0);
  for (std::size_t i = 0; i < c.size(); ++i) {
    const Eigen::Vector3d& p = c.X[i];
    if (!c.surface[i] && p.x() > 0.02 && p.x() < 0.085 && p.z() > -0.006 && p.z() < -0.0005 && std::abs(p.y()) < 0.006)
      r[i] = 0.0;
  }
  return r;
}

/// What a fill makes of a ball of radius 1.5 h centred on a 3 x 3 x 3 block of cells: the centre cell
/// whole, the 6 face cells 94.3 % inside, the 12 edge cells 50.9 % (the corners, 17 %, hold no particle).
/// Most particles are partial boundary cells: the cube root of the median volume is 0.80 h, not h.
inline topo_gaussian::VolumeCloud smallBallCloud(double h) {
  topo_gaussian::VolumeCloud c;
  c.spacing = h;
  for (int i = -1; i <= 1; ++i)
    for (int j = -1; j <= 1; ++j)
      for (int k = -1; k <= 1; ++k) {
        const int off = std::abs(i) + std::abs(j) + std::abs(k);
        if (off == 3) continue;
        c.X.emplace_back(h * i, h * j, h * k);
        c.V.push_back(h * h * h * (off == 0 ? 1.0 : off == 1 ? 0.9434 : 0.5089));
        c.surface.push_back(off == 0 ? 0 : 1);
      }
  return c;
}

}  // namespace topo_test
