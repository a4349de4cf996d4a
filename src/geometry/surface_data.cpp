// SurfaceData helpers: kind names, filtering by flags, Gaussian covariances.
#include "topo_gaussian/geometry/surface_data.h"

#include <Eigen/Geometry>
#include <cmath>
#include <cstring>
#include <string>
#include <unordered_map>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/number_text.h"

namespace topo_gaussian::geometry {

void checkCoordinateRange(const SurfaceData& s) {
  std::size_t beyond = 0;
  double largest = 0.0;
  for (const auto& p : s.points)
    for (int k = 0; k < 3; ++k)
      if (std::isfinite(p[k]) && std::abs(p[k]) > kMaxCoordinateM) {
        largest = std::max(largest, std::abs(p[k]));
        ++beyond;
      }
  if (!beyond) return;
  throw TopoError(s.source,
                  std::to_string(beyond) + " coordinate(s) of its " + std::to_string(s.points.size()) +
                      " points lie beyond ±" + numberText(kMaxCoordinateM, 3) + " m (largest " +
                      numberText(largest, 3) +
                      " m), where distances overflow; a binary file whose header names the wrong byte order or "
                      "property type reads like this",
                  "check the file's header against its data (re-export it); if the unit is wrong, scale it "
                  "(--scale, e.g. 0.001 for millimetres); if a few points are stray, crop them "
                  "(--crop-min/--crop-max X,Y,Z)");
}

std::vector<std::size_t> firstAtSamePosition(const std::vector<Eigen::Vector3d>& points) {
  struct Key {
    std::uint64_t b[3];
    bool operator==(const Key& o) const { return b[0] == o.b[0] && b[1] == o.b[1] && b[2] == o.b[2]; }
  };
  struct Hash {
    std::size_t operator()(const Key& k) const {
      std::uint64_t h = k.b[0] * 0x9E3779B97F4A7C15ull;
      h = (h ^ (h >> 29) ^ k.b[1]) * 0xBF58476D1CE4E5B9ull;
      h = (h ^ (h >> 31) ^ k.b[2]) * 0x94D049BB133111EBull;
      return std::size_t(h ^ (h >> 32));
    }
  };
  std::unordered_map<Key, std::size_t, Hash> seen;
  seen.reserve(points.size());
  std::vector<std::size_t> first(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    first[i] = i;
    if (!points[i].allFinite()) continue;
    Key k;
    for (int a = 0; a < 3; ++a) {
      const double c = points[i][a] + 0.0;  // -0 → +0
      std::memcpy(&k.b[a], &c, 8);
    }
    first[i] = seen.emplace(k, i).first->second;
  }
  return first;
}

const char* toString(SurfaceKind kind) {
  switch (kind) {
    case SurfaceKind::Gaussians:
      return "gaussians";
    case SurfaceKind::Points:
      return "points";
    case SurfaceKind::Mesh:
      return "mesh";
  }
  return "unknown";
}

namespace {

/// Keeps the entries of a per-point array whose flag is true; arrays of another size
/// (absent optional data) are left alone.
template <typename T, typename Alloc>
void keepEntries(std::vector<T, Alloc>& values, const std::vector<bool>& flags) {
  if (values.size() != flags.size()) return;
  std::size_t out = 0;
  for (std::size_t i = 0; i < values.size(); ++i)
    if (flags[i]) values[out++] = values[i];
  values.resize(out);
}

}  // namespace

void SurfaceData::keep(const std::vector<bool>& flags) {
  const std::size_t n = points.size();
  if (flags.size() != n) {
    throw TopoError(source.empty() ? std::string("surface") : source,
                    "keep() got " + std::to_string(flags.size()) + " flags for " + std::to_string(n) + " points",
                    "pass exactly one flag per point");
  }
  // New index of every kept vertex (-1 for dropped ones), for re-indexing the triangles.
  std::vector<int> remap;
  if (!triangles.empty()) {
    remap.assign(n, -1);
    int next = 0;
    for (std::size_t i = 0; i < n; ++i)
      if (flags[i]) remap[i] = next++;
  }

  keepEntries(normals, flags);
  keepEntries(colors, flags);
  keepEntries(opacity, flags);
  keepEntries(scales, flags);
  keepEntries(rotations, flags);
  keepEntries(covariances, flags);
  keepEntries(points, flags);

  if (!triangles.empty()) {
    std::size_t out = 0;
    for (std::size_t t = 0; t < triangles.size(); ++t) {
      Eigen::Vector3i tri = triangles[t];
      bool ok = true;
      for (int k = 0; k < 3 && ok; ++k) {
        const int v = tri[k];
        if (v < 0 || static_cast<std::size_t>(v) >= n || remap[static_cast<std::size_t>(v)] < 0) {
          ok = false;
        } else {
          tri[k] = remap[static_cast<std::size_t>(v)];
        }
      }
      if (ok) triangles[out++] = tri;
    }
    triangles.resize(out);
  }
}

Eigen::Matrix3d gaussianCovariance(const Eigen::Vector3d& scale, const Eigen::Vector4d& quat_wxyz) {
  const double norm = quat_wxyz.norm();
  // A zero quaternion has no rotation to offer: fall back to the identity so the covariance is the
  // axis-aligned one (readers reject zero quaternions before this point). NaN or infinite entries
  // are not hidden: they propagate into the covariance so that cleaning can find them.
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  if (norm != 0.0) {
    q = Eigen::Quaterniond(quat_wxyz[0] / norm, quat_wxyz[1] / norm, quat_wxyz[2] / norm, quat_wxyz[3] / norm);
  }
  const Eigen::Matrix3d R = q.toRotationMatrix();
  // R S Sᵀ Rᵀ with S = diag(scale): M = R S, Σ = M Mᵀ (symmetric by construction).
  const Eigen::Matrix3d M = R * scale.asDiagonal();
  Eigen::Matrix3d cov = M * M.transpose();
  cov = 0.5 * (cov + cov.transpose()).eval();
  return cov;
}

}  // namespace topo_gaussian::geometry
