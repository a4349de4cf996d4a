// Test helpers shared by the user-path tests: the solid hemisphere mesh they fill, and a task feature
// by name.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "topo_gaussian/geometry/surface_data.h"
#include "topo_gaussian/inference/task.h"

namespace topo_test {

/// Closed, outward-oriented solid hemisphere z ≤ 0 of radius R (flat face up, sphere centre at the
/// origin): a UV cap with `segments` around and `rings` from the bottom pole to the equator, closed by
/// a fan on the flat face. The pole is a cone of one ring's width: keep it small against the contact's
/// travel (R θ) when the mesh stands for a smooth hemisphere.
inline topo_gaussian::geometry::SurfaceData hemisphereMesh(double R, int segments, int rings) {
  const double pi = 3.14159265358979323846;
  topo_gaussian::geometry::SurfaceData s;
  s.kind = topo_gaussian::geometry::SurfaceKind::Mesh;
  s.source = "hemisphere mesh";
  s.points.emplace_back(0, 0, -R);
  for (int i = 1; i <= rings; ++i) {
    const double th = 0.5 * pi * i / rings;  // polar angle from the bottom pole
    for (int j = 0; j < segments; ++j) {
      const double p = 2.0 * pi * j / segments;
      s.points.emplace_back(R * std::sin(th) * std::cos(p), R * std::sin(th) * std::sin(p), -R * std::cos(th));
    }
  }
  s.points.emplace_back(0, 0, 0);
  const int top = int(s.points.size()) - 1;
  auto idx = [&](int i, int j) { return 1 + (i - 1) * segments + (j % segments); };
  for (int j = 0; j < segments; ++j) s.triangles.emplace_back(0, idx(1, j + 1), idx(1, j));
  for (int i = 1; i < rings; ++i)
    for (int j = 0; j < segments; ++j) {
      s.triangles.emplace_back(idx(i, j), idx(i, j + 1), idx(i + 1, j + 1));
      s.triangles.emplace_back(idx(i, j), idx(i + 1, j + 1), idx(i + 1, j));
    }
  for (int j = 0; j < segments; ++j) s.triangles.emplace_back(top, idx(rings, j), idx(rings, j + 1));
  return s;
}

/// The value of the task feature `name` (a test failure, and NaN, when the task has none).
inline double feature(const topo_gaussian::inference::TaskEvaluation& ev, const std::string& name) {
  for (const auto& f : ev.features)
    if (f.name == name) return f.value;
  ADD_FAILURE() << "no feature " << name;
  return NAN;
}

}  // namespace topo_test
