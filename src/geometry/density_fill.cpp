#include "topo_gaussian/geometry/density_fill.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>

namespace topo_gaussian::geometry {

namespace {

constexpr float kCutoffExponent = 4.5f;  // splats are truncated at 3 standard deviations

// Adds opacity · exp(−½ dᵀ Q d) of one Gaussian to the grid nodes (cell corners) within its
// 3σ reach. Nodes are ((n0+1) × (n1+1) × (n2+1)), node (i,j,k) at origin + h (i,j,k).
void splatOne(const Eigen::Vector3d& p, const Eigen::Matrix3d& Q, double sigma_max, double opacity, const Lattice& L,
              std::vector<float>& nodes) {
  const int nx = L.n[0] + 1, ny = L.n[1] + 1, nz = L.n[2] + 1;
  const int r = std::max(1, int(std::ceil(3.0 * sigma_max / L.h)));
  const Eigen::Vector3d g = (p - L.origin) / L.h;
  const int ci = int(std::lround(g.x())), cj = int(std::lround(g.y())), ck = int(std::lround(g.z()));
  for (int k = std::max(0, ck - r); k <= std::min(nz - 1, ck + r); ++k)
    for (int j = std::max(0, cj - r); j <= std::min(ny - 1, cj + r); ++j)
      for (int i = std::max(0, ci - r); i <= std::min(nx - 1, ci + r); ++i) {
        const Eigen::Vector3d d = L.origin + L.h * Eigen::Vector3d(i, j, k) - p;
        const double e = 0.5 * d.dot(Q * d);
        if (e > kCutoffExponent) continue;
        const float w = float(opacity * std::exp(-e));
        float& slot = nodes[(std::size_t(k) * ny + j) * nx + i];
#pragma omp atomic
        slot += w;
      }
}

// Cell density = mean of its 8 corner nodes (as PhysGaussian's compute_density).
std::vector<float> cellDensity(const Lattice& L, const std::vector<float>& nodes) {
  const int nx = L.n[0] + 1, ny = L.n[1] + 1;
  std::vector<float> D(L.cells());
#pragma omp parallel for schedule(static)
  for (int k = 0; k < L.n[2]; ++k)
    for (int j = 0; j < L.n[1]; ++j)
      for (int i = 0; i < L.n[0]; ++i) {
        float s = 0.f;
        for (int c = 0; c < 8; ++c)
          s += nodes[(std::size_t(k + (c >> 2)) * ny + j + ((c >> 1) & 1)) * nx + i + (c & 1)];
        D[L.index(i, j, k)] = s / 8.f;
      }
  return D;
}

// Walks every grid line along `axis` and calls f(cells of the line, length).
template <class F>
void forEachLine(const Lattice& L, int axis, F f) {
  const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
  const std::size_t stride[3] = {1, std::size_t(L.n[0]), std::size_t(L.n[0]) * L.n[1]};
#pragma omp parallel
  {
    std::vector<std::size_t> line(L.n[axis]);
#pragma omp for collapse(2) schedule(static)
    for (int v = 0; v < L.n[a2]; ++v)
      for (int u = 0; u < L.n[a1]; ++u) {
        const std::size_t base = u * stride[a1] + v * stride[a2];
        for (int m = 0; m < L.n[axis]; ++m) line[m] = base + m * stride[axis];
        f(line);
      }
  }
}

DensityFillResult fillFromDensity(const Lattice& L, const std::vector<float>& D, DensityFillOptions o) {
  if (o.closing_cells < 0) o.closing_cells = o.closing_m > 0.0 ? std::max(1, int(std::ceil(o.closing_m / L.h))) : 1;
  const std::size_t N = L.cells();
  DensityFillResult res;
  std::vector<std::uint8_t> dense(N), search(N);
  for (std::size_t c = 0; c < N; ++c) {
    dense[c] = D[c] > o.density_threshold;
    search[c] = D[c] > o.search_threshold;
    res.dense_cells += dense[c];
  }

  // PhysGaussian: direction search (bit d set when a search-dense cell lies ahead in direction d)
  // and the number of entries into the shell along the parity ray.
  std::vector<std::uint8_t> hits(N, 0);
  std::vector<std::int32_t> rises(N, 0);
  const int ray_axis = o.ray_cast_direction / 2;
  const bool ray_neg = o.ray_cast_direction % 2;
  for (int axis = 0; axis < 3; ++axis) {
    forEachLine(L, axis, [&](const std::vector<std::size_t>& line) {
      const int n = int(line.size());
      bool seen = false;
      for (int m = n - 1; m >= 0; --m) {  // positive direction: look at cells after m
        if (seen) hits[line[m]] |= std::uint8_t(1u << (2 * axis));
        seen = seen || search[line[m]];
      }
      seen = false;
      for (int m = 0; m < n; ++m) {  // negative direction
        if (seen) hits[line[m]] |= std::uint8_t(1u << (2 * axis + 1));
        seen = seen || search[line[m]];
      }
      if (axis != ray_axis) return;
      auto at = [&](int m) { return ray_neg ? line[n - 1 - m] : line[m]; };
      std::int32_t after = 0;  // rising edges at positions > m+1
      for (int m = n - 1; m >= 0; --m) {
        const bool next = m + 1 < n && search[at(m + 1)];
        rises[at(m)] = after + (next ? 1 : 0);
        if (next && !search[at(m)]) ++after;
      }
    });
  }
  const bool excluding = o.search_exclude_direction >= 0 && o.search_exclude_direction <= 5;
  const std::uint8_t need = 0x3f & ~std::uint8_t(excluding ? 1u << o.search_exclude_direction : 0u);
  std::vector<std::uint8_t> interior(N, 0);
  if (o.closing_cells <= 0) {
    for (std::size_t c = 0; c < N; ++c)
      if (!dense[c] && (hits[c] & need) == need && (rises[c] & 1)) {
        interior[c] = 1;
        ++res.ray_filled_cells;
      }
  }

  // Outside: flood from the grid border through cells away from the (dilated) shell, then grow
  // back by the same radius through non-shell cells (a morphological closing of the shell).
  const int K = o.closing_cells > 0 ? o.closing_cells : std::max(0, o.leak_check_closing_cells);
  auto blocked = dilate6(L, dense, K);
  // The excluded direction is where PhysGaussian lets a surface stay open (−z: the side an object
  // stood on while it was captured). Seal it the same way here: a cell with shell ahead in the
  // opposite direction (above it, for −z) and none behind (below) is not a way in for the outside.
  if (excluding) {
    const std::uint8_t ahead = std::uint8_t(1u << (o.search_exclude_direction ^ 1));
    const std::uint8_t behind = std::uint8_t(1u << o.search_exclude_direction);
    for (std::size_t c = 0; c < N; ++c) blocked[c] |= ((hits[c] & ahead) && !(hits[c] & behind)) ? 1 : 0;
  }
  std::vector<std::uint8_t> border(N, 0), open(N);
  for (std::size_t c = 0; c < N; ++c) open[c] = !blocked[c];
  for (int k = 0; k < L.n[2]; ++k)
    for (int j = 0; j < L.n[1]; ++j)
      for (int i = 0; i < L.n[0]; ++i)
        if (i == 0 || j == 0 || k == 0 || i == L.n[0] - 1 || j == L.n[1] - 1 || k == L.n[2] - 1) {
          const std::size_t c = L.index(i, j, k);
          border[c] = open[c];
        }
  const auto dflood = distanceTransform6(L, border, open);
  std::vector<std::uint8_t> flood(N), notDense(N);
  for (std::size_t c = 0; c < N; ++c) {
    flood[c] = dflood[c] != std::numeric_limits<std::int32_t>::max();
    notDense[c] = !dense[c];
  }
  const auto dout = distanceTransform6(L, flood, notDense, K);
  std::vector<std::uint8_t> outside(N);
  for (std::size_t c = 0; c < N; ++c) outside[c] = dout[c] <= K;

  if (o.closing_cells > 0) {
    // Openness: of the cells walled in by shell in all six directions, how many did the flood reach?
    for (std::size_t c = 0; c < N; ++c) {
      interior[c] = !outside[c] && !dense[c] && (hits[c] & need) == need;
      if (!dense[c] && hits[c] == 0x3f) {
        ++res.ray_filled_cells;
        res.leaked_cells += outside[c];
      }
    }
  } else {
    for (std::size_t c = 0; c < N; ++c)
      if (interior[c] && outside[c]) {
        interior[c] = 0;
        ++res.leaked_cells;
      }
  }

  res.solid.assign(N, 0);
  std::size_t interior_count = 0;
  for (std::size_t c = 0; c < N; ++c) {
    res.solid[c] = interior[c];
    interior_count += interior[c];
  }
  res.dense = dense;
  if (!o.split_shell || interior_count == 0) {
    for (std::size_t c = 0; c < N; ++c) res.solid[c] |= dense[c] && (!outside[c] || interior_count == 0);
    return res;
  }
  // Shell splitting: distance through shell cells from the interior and from everything else.
  std::vector<std::uint8_t> exterior(N);
  for (std::size_t c = 0; c < N; ++c) exterior[c] = !interior[c] && !dense[c];
  const auto din = distanceTransform6(L, interior, dense);
  const auto dex = distanceTransform6(L, exterior, dense);
  for (std::size_t c = 0; c < N; ++c)
    if (dense[c] && din[c] != std::numeric_limits<std::int32_t>::max() && din[c] <= dex[c]) res.solid[c] = 1;
  return res;
}

}  // namespace

DensityFillResult densityFill(const std::vector<Eigen::Vector3d>& centres,
                              const std::vector<Eigen::Matrix3d>& covariances, const std::vector<double>& opacity,
                              const Lattice& L, const DensityFillOptions& o) {
  std::vector<float> nodes(std::size_t(L.n[0] + 1) * (L.n[1] + 1) * (L.n[2] + 1), 0.f);
  const double floor_sigma = std::max(o.min_sigma_cells * L.h, o.min_sigma_m);
#pragma omp parallel for schedule(dynamic, 256)
  for (long i = 0; i < long(centres.size()); ++i) {
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(covariances[i]);
    Eigen::Vector3d var = es.eigenvalues().cwiseMax(std::max(floor_sigma * floor_sigma, 1e-16));
    const Eigen::Matrix3d Q = es.eigenvectors() * var.cwiseInverse().asDiagonal() * es.eigenvectors().transpose();
    splatOne(centres[i], Q, std::sqrt(var.maxCoeff()), opacity[i], L, nodes);
  }
  return fillFromDensity(L, cellDensity(L, nodes), o);
}

DensityFillResult densityFillPoints(const std::vector<Eigen::Vector3d>& points, double s, double sigma,
                                    const Lattice& L, const DensityFillOptions& o) {
  // A plane sampled at areal density 1/s² with Gaussians of opacity w and std dev σ sums to
  // w (2πσ²/s²) exp(−d²/2σ²) at distance d. Choosing w = 2 τ s² / (2πσ²) puts twice the density
  // threshold τ on the surface, so the shell is ~2.4σ thick whatever the sampling density.
  const double w = 2.0 * o.density_threshold * s * s / (2.0 * M_PI * sigma * sigma);
  const Eigen::Matrix3d Q = Eigen::Matrix3d::Identity() / (sigma * sigma);
  std::vector<float> nodes(std::size_t(L.n[0] + 1) * (L.n[1] + 1) * (L.n[2] + 1), 0.f);
#pragma omp parallel for schedule(dynamic, 256)
  for (long i = 0; i < long(points.size()); ++i) splatOne(points[i], Q, sigma, w, L, nodes);
  return fillFromDensity(L, cellDensity(L, nodes), o);
}

}  // namespace topo_gaussian::geometry
