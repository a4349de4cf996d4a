#include "topo_gaussian/geometry/surface_field.h"

#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <unordered_map>

namespace topo_gaussian::geometry {

std::vector<Eigen::Vector3d> pcaNormals(const std::vector<Eigen::Vector3d>& pts, int k) {
  std::vector<Eigen::Vector3d> normals(pts.size(), Eigen::Vector3d::Zero());
  if (pts.size() < 3) return normals;
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
  cloud->resize(pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) cloud->points[i].getVector3fMap() = pts[i].cast<float>();
  pcl::KdTreeFLANN<pcl::PointXYZ> tree;
  tree.setInputCloud(cloud);
  const int want = std::min<int>(k + 1, int(pts.size()));
#pragma omp parallel
  {
    std::vector<int> idx(want);
    std::vector<float> d2(want);
#pragma omp for schedule(dynamic, 256)
    for (long i = 0; i < long(pts.size()); ++i) {
      const int found = tree.nearestKSearch(cloud->points[i], want, idx, d2);
      if (found < 3) continue;
      Eigen::Vector3d mean = Eigen::Vector3d::Zero();
      for (int j = 0; j < found; ++j) mean += pts[idx[j]];
      mean /= double(found);
      Eigen::Matrix3d C = Eigen::Matrix3d::Zero();
      for (int j = 0; j < found; ++j) {
        const Eigen::Vector3d d = pts[idx[j]] - mean;
        C += d * d.transpose();
      }
      if (!(C.trace() > 0.0)) continue;
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(C);
      normals[i] = es.eigenvectors().col(0).normalized();
    }
  }
  return normals;
}

namespace {

// 1D squared distance transform of f (∞ = no seed) on n unit-spaced samples: d[q] = min_p (q − p)² + f[p],
// by the lower envelope of the parabolas rooted at the finite samples (Felzenszwalb & Huttenlocher).
void distanceTransform1d(const double* f, int n, double* d, int* v, double* z) {
  const double inf = std::numeric_limits<double>::infinity();
  int k = -1;
  for (int q = 0; q < n; ++q) {
    if (!std::isfinite(f[q])) continue;
    if (k < 0) {
      k = 0;
      v[0] = q;
      z[0] = -inf;
      z[1] = inf;
      continue;
    }
    double s;
    for (;;) {
      s = ((f[q] + double(q) * q) - (f[v[k]] + double(v[k]) * v[k])) / (2.0 * (q - v[k]));
      if (s > z[k]) break;
      --k;  // z[0] = −∞ stops this at k = 0
    }
    ++k;
    v[k] = q;
    z[k] = s;
    z[k + 1] = inf;
  }
  if (k < 0) {
    std::fill(d, d + n, inf);
    return;
  }
  k = 0;
  for (int q = 0; q < n; ++q) {
    while (z[k + 1] < q) ++k;
    d[q] = (q - v[k]) * double(q - v[k]) + f[v[k]];
  }
}

}  // namespace

std::vector<float> euclideanDistance(const Lattice& L, const std::vector<std::uint8_t>& seeds) {
  const double inf = std::numeric_limits<double>::infinity();
  std::vector<double> d2(L.cells());
  for (std::size_t c = 0; c < d2.size(); ++c) d2[c] = seeds[c] ? 0.0 : inf;
  const std::size_t stride[3] = {1, std::size_t(L.n[0]), std::size_t(L.n[0]) * L.n[1]};
  for (int axis = 0; axis < 3; ++axis) {
    const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3, n = L.n[axis];
#pragma omp parallel
    {
      std::vector<double> f(n), d(n), z(n + 1);
      std::vector<int> v(n);
#pragma omp for collapse(2) schedule(static)
      for (int w = 0; w < L.n[a2]; ++w)
        for (int u = 0; u < L.n[a1]; ++u) {
          const std::size_t base = u * stride[a1] + w * stride[a2];
          for (int m = 0; m < n; ++m) f[m] = d2[base + m * stride[axis]];
          distanceTransform1d(f.data(), n, d.data(), v.data(), z.data());
          for (int m = 0; m < n; ++m) d2[base + m * stride[axis]] = d[m];
        }
    }
  }
  std::vector<float> out(d2.size());
  for (std::size_t c = 0; c < d2.size(); ++c) out[c] = float(L.h * std::sqrt(d2[c]));
  return out;
}

double interpolateCells(const Lattice& L, const std::vector<float>& field, const Eigen::Vector3d& x, double beyond) {
  const Eigen::Vector3d g = (x - L.origin) / L.h;
  if (!(g.minCoeff() >= 0.0 && g.x() <= L.n[0] && g.y() <= L.n[1] && g.z() <= L.n[2])) return beyond;
  int lo[3];
  double t[3];
  for (int a = 0; a < 3; ++a) {
    const double c = std::clamp(g[a] - 0.5, 0.0, double(L.n[a] - 1));
    lo[a] = std::min(int(std::floor(c)), std::max(0, L.n[a] - 2));
    t[a] = L.n[a] > 1 ? c - lo[a] : 0.0;
  }
  double sum = 0.0;
  for (int q = 0; q < 8; ++q) {
    const int i = std::min(lo[0] + (q & 1), L.n[0] - 1), j = std::min(lo[1] + ((q >> 1) & 1), L.n[1] - 1),
              k = std::min(lo[2] + ((q >> 2) & 1), L.n[2] - 1);
    const double w = ((q & 1) ? t[0] : 1 - t[0]) * ((q & 2) ? t[1] : 1 - t[1]) * ((q & 4) ? t[2] : 1 - t[2]);
    if (w > 0.0) sum += w * double(field[L.index(i, j, k)]);
  }
  return sum;
}

std::size_t orientNormals(OrientedPoints& p, const Lattice& grid, const std::vector<float>& outside_m,
                          const std::vector<float>& solid_m, double skin_m, double floater_margin_m) {
  const double inf = std::numeric_limits<double>::infinity();
  // Depth below the shell's outside; beyond the grid: outside.
  auto depth = [&](const Eigen::Vector3d& x) { return interpolateCells(grid, outside_m, x, 0.0) - 0.5 * grid.h; };
  std::size_t unoriented = 0;
  for (std::size_t i = 0; i < p.points.size(); ++i) {
    Eigen::Vector3d& n = p.normals[i];
    int sign = 0;
    const double d = depth(p.points[i]), s = interpolateCells(grid, solid_m, p.points[i], inf);
    if (n.squaredNorm() > 0.0 && d <= skin_m && s <= skin_m + floater_margin_m)
      for (double a : {1.5, 2.5, 4.0}) {
        const double plus = depth(p.points[i] + a * grid.h * n), minus = depth(p.points[i] - a * grid.h * n);
        if (std::abs(plus - minus) > 0.25 * grid.h) {
          sign = minus > plus ? 1 : -1;
          break;
        }
      }
    if (sign == 0) {
      p.weights[i] = 0.0;
      ++unoriented;
    } else {
      n *= double(sign);
    }
  }
  return unoriented;
}

std::vector<double> nodeSignedDistance(const OrientedPoints& p, const Lattice& L, double r, double reach) {
  const int nx = L.n[0] + 1, ny = L.n[1] + 1, nz = L.n[2] + 1;
  std::vector<double> f(std::size_t(nx) * ny * nz, std::numeric_limits<double>::quiet_NaN());
  reach = std::max(reach, 3.0 * r);
  // Buckets of edge `reach` over the lattice (points outside it are never within reach of a node).
  Eigen::Vector3d lo = L.origin - Eigen::Vector3d::Constant(reach);
  std::array<int, 3> nb;
  for (int a = 0; a < 3; ++a) nb[a] = std::max(1, int(std::ceil((L.n[a] * L.h + 2 * reach) / reach)));
  const std::size_t buckets = std::size_t(nb[0]) * nb[1] * nb[2];
  std::vector<std::uint32_t> start(buckets + 1, 0), order;
  std::vector<std::int64_t> bucket_of(p.points.size(), -1);
  auto bucketIndex = [&](const Eigen::Vector3d& x, std::array<int, 3>* b) {
    for (int a = 0; a < 3; ++a) {
      const double t = std::floor((x[a] - lo[a]) / reach);
      if (!(t >= 0.0 && t < nb[a])) return false;
      (*b)[a] = int(t);
    }
    return true;
  };
  for (std::size_t i = 0; i < p.points.size(); ++i) {
    std::array<int, 3> b;
    if (p.weights[i] > 0.0 && bucketIndex(p.points[i], &b)) {
      bucket_of[i] = (std::int64_t(b[2]) * nb[1] + b[1]) * nb[0] + b[0];
      ++start[bucket_of[i] + 1];
    }
  }
  for (std::size_t b = 0; b < buckets; ++b) start[b + 1] += start[b];
  order.resize(start[buckets]);
  {
    std::vector<std::uint32_t> fill(start.begin(), start.end() - 1);
    for (std::size_t i = 0; i < p.points.size(); ++i)
      if (bucket_of[i] >= 0) order[fill[bucket_of[i]]++] = std::uint32_t(i);
  }
  const double inv_r2 = 1.0 / (r * r), reach2 = reach * reach;
#pragma omp parallel
  {
    std::vector<std::pair<double, std::uint32_t>> near;
#pragma omp for collapse(2) schedule(dynamic, 4)
    for (int k = 0; k < nz; ++k)
      for (int j = 0; j < ny; ++j)
        for (int i = 0; i < nx; ++i) {
          const Eigen::Vector3d x = L.origin + L.h * Eigen::Vector3d(i, j, k);
          std::array<int, 3> b;
          if (!bucketIndex(x, &b)) continue;
          near.clear();
          double d2min = std::numeric_limits<double>::infinity();
          for (int bz = std::max(0, b[2] - 1); bz <= std::min(nb[2] - 1, b[2] + 1); ++bz)
            for (int by = std::max(0, b[1] - 1); by <= std::min(nb[1] - 1, b[1] + 1); ++by)
              for (int bx = std::max(0, b[0] - 1); bx <= std::min(nb[0] - 1, b[0] + 1); ++bx) {
                const std::size_t q = (std::size_t(bz) * nb[1] + by) * nb[0] + bx;
                for (std::uint32_t s = start[q]; s < start[q + 1]; ++s) {
                  const double d2 = (x - p.points[order[s]]).squaredNorm();
                  if (d2 > reach2) continue;
                  near.emplace_back(d2, order[s]);
                  d2min = std::min(d2min, d2);
                }
              }
          if (near.empty()) continue;
          double sw = 0.0, sf = 0.0;
          for (const auto& [d2, idx] : near) {  // weights relative to the nearest: no underflow far out
            const double w = p.weights[idx] * std::exp(-(d2 - d2min) * inv_r2);
            sw += w;
            sf += w * p.normals[idx].dot(x - p.points[idx]);
          }
          if (sw > 0.0) f[(std::size_t(k) * ny + j) * nx + i] = sf / sw;
        }
  }
  return f;
}

std::int64_t cubeKey(const Eigen::Vector3d& p, double cell) {
  const Eigen::Array3d q = (p / cell).array().floor();
  return (std::int64_t(q[0]) & 0x1FFFFF) | (std::int64_t(q[1]) & 0x1FFFFF) << 21 |
         (std::int64_t(q[2]) & 0x1FFFFF) << 42;
}

OrientedPoints binnedPoints(const OrientedPoints& p, double cell) {
  struct Bin {
    Eigen::Vector3d x = Eigen::Vector3d::Zero(), n = Eigen::Vector3d::Zero();
    double w = 0.0;
  };
  std::unordered_map<std::int64_t, Bin> bins;
  std::vector<std::int64_t> order;  // first-seen order: the result does not depend on the hash
  for (std::size_t i = 0; i < p.points.size(); ++i) {
    const double a = p.weights[i];
    if (!(a > 0.0)) continue;
    const std::int64_t key = cubeKey(p.points[i], cell);
    auto [it, fresh] = bins.try_emplace(key);
    if (fresh) order.push_back(key);
    it->second.x += a * p.points[i];
    it->second.n += a * p.normals[i];
    it->second.w += a;
  }
  OrientedPoints out;
  out.points.reserve(order.size());
  for (std::int64_t key : order) {
    const Bin& b = bins[key];
    out.points.push_back(b.x / b.w);
    out.normals.push_back(b.n.norm() > 0.0 ? Eigen::Vector3d(b.n.normalized()) : Eigen::Vector3d::Zero());
    out.weights.push_back(b.n.norm() > 0.0 ? b.w : 0.0);
  }
  return out;
}

double interpolateNodes(const Lattice& L, const std::vector<double>& f, const Eigen::Vector3d& x) {
  const int nx = L.n[0] + 1, ny = L.n[1] + 1;
  const Eigen::Vector3d g = (x - L.origin) / L.h;
  const int i = int(std::floor(g.x())), j = int(std::floor(g.y())), k = int(std::floor(g.z()));
  if (i < 0 || j < 0 || k < 0 || i >= L.n[0] || j >= L.n[1] || k >= L.n[2])
    return std::numeric_limits<double>::quiet_NaN();
  const double u = g.x() - i, v = g.y() - j, w = g.z() - k;
  double sum = 0.0;
  for (int q = 0; q < 8; ++q) {
    const double c = f[(std::size_t(k + (q >> 2)) * ny + j + ((q >> 1) & 1)) * nx + i + (q & 1)];
    sum += c * ((q & 1) ? u : 1 - u) * ((q & 2) ? v : 1 - v) * ((q & 4) ? w : 1 - w);
  }
  return sum;  // NaN when a corner is undefined
}

std::vector<double> outerSurfaceDistance(OrientedPoints& p, const Lattice& L, double r, double reach, double depth,
                                         int rounds, std::size_t* dropped) {
  std::size_t total = 0;
  std::vector<double> f = nodeSignedDistance(p, L, r, reach);
  for (int round = 0; round < rounds; ++round) {
    std::size_t n = 0;
    for (std::size_t i = 0; i < p.points.size(); ++i)
      if (p.weights[i] > 0.0 && interpolateNodes(L, f, p.points[i]) < -depth) {
        p.weights[i] = 0.0;
        ++n;
      }
    total += n;
    if (n == 0) break;
    f = nodeSignedDistance(p, L, r, reach);
  }
  if (dropped) *dropped = total;
  return f;
}

double cubeFractionBelowPlane(double fc, const Eigen::Vector3d& g) {
  const Eigen::Vector3d m = g.cwiseAbs();
  const double sum = m.sum();
  if (!(sum > 0.0)) return fc <= 0.0 ? 1.0 : 0.0;
  const double alpha = 0.5 * sum - fc;
  if (alpha <= 0.0) return 0.0;
  if (alpha >= sum) return 1.0;
  // The fraction is P(Σ m_a U_a ≤ α) for independent uniform U_a: over the d components that do not
  // vanish, Σ_{c∈{0,1}^d} (−1)^{|c|} max(0, α − mᵀc)^d / (d! Π m_a). A component below 1e-7 of the
  // sum is dropped (it moves the fraction by < 1e-7; kept, the d = 3 formula would cancel badly).
  double w[3], centre = alpha;  // a dropped component sits at its mean, ½ m_a
  int d = 0;
  for (int a = 0; a < 3; ++a)
    if (m[a] > 1e-7 * sum)
      w[d++] = m[a];
    else
      centre -= 0.5 * m[a];
  double v = 0.0, prod = 1.0, factorial = 1.0;
  for (int a = 0; a < d; ++a) prod *= w[a], factorial *= double(a + 1);
  for (int c = 0; c < (1 << d); ++c) {
    double t = centre;
    for (int a = 0; a < d; ++a)
      if (c & (1 << a)) t -= w[a];
    if (t > 0.0) v += ((__builtin_popcount(c) & 1) ? -1.0 : 1.0) * std::pow(t, d);
  }
  return std::clamp(v / (factorial * prod), 0.0, 1.0);
}

std::vector<float> cellInsideFractions(const Lattice& L, const std::vector<double>& f,
                                       const std::vector<std::uint8_t>& fallback, double min_fraction) {
  const int nx = L.n[0] + 1, ny = L.n[1] + 1;
  std::vector<float> frac(L.cells(), 0.f);
  std::vector<std::uint8_t> undefined(L.cells(), 0);
#pragma omp parallel for schedule(static)
  for (int k = 0; k < L.n[2]; ++k)
    for (int j = 0; j < L.n[1]; ++j)
      for (int i = 0; i < L.n[0]; ++i) {
        double c[8];
        int defined = 0;
        for (int q = 0; q < 8; ++q) {
          c[q] = f[(std::size_t(k + (q >> 2)) * ny + j + ((q >> 1) & 1)) * nx + i + (q & 1)];
          if (std::isfinite(c[q])) ++defined;
        }
        const std::size_t cell = L.index(i, j, k);
        if (defined == 0) {
          undefined[cell] = 1;
          continue;
        }
        // A corner beyond reach is far from every point. Where the density fill says outside, it is
        // (its outside is flooded from the grid's border): +2.5 h, the reach (the mean of the defined
        // corners let one corner, whose nearest point had a tangential normal, fill a whole cell in a
        // donut's hole). Its inside is less sure (PhysGaussian's open −z side fills under overhangs,
        // e.g. below a torus's inner rim): there the defined corners' mean decides.
        double sum = 0.0;
        for (double v : c)
          if (std::isfinite(v)) sum += v;
        for (double& v : c)
          if (!std::isfinite(v)) v = fallback[cell] ? sum / defined : 2.5 * L.h;
        const double fc = (c[0] + c[1] + c[2] + c[3] + c[4] + c[5] + c[6] + c[7]) / 8.0;
        const Eigen::Vector3d g((c[1] - c[0] + c[3] - c[2] + c[5] - c[4] + c[7] - c[6]) / 4.0,
                                (c[2] - c[0] + c[3] - c[1] + c[6] - c[4] + c[7] - c[5]) / 4.0,
                                (c[4] - c[0] + c[5] - c[1] + c[6] - c[2] + c[7] - c[3]) / 4.0);
        frac[cell] = float(cubeFractionBelowPlane(fc, g));
      }
  // Cells beyond the field's reach: solid where the fallback is, and only where that solid is the
  // continuation of the field's inside (connected to a cell at least half inside); a fallback solid
  // cut off from it (the density fill's blob around points the field left out, e.g. floaters in a
  // hole) is not the object.
  {
    std::vector<std::uint8_t> seeds(L.cells()), passable(L.cells());
    for (std::size_t c = 0; c < frac.size(); ++c) {
      seeds[c] = !undefined[c] && frac[c] >= 0.5f;
      passable[c] = undefined[c] && fallback[c];
    }
    const auto reach = distanceTransform6(L, seeds, passable);
    for (std::size_t c = 0; c < frac.size(); ++c)
      if (undefined[c]) frac[c] = fallback[c] && reach[c] != std::numeric_limits<std::int32_t>::max() ? 1.f : 0.f;
  }
  // Small pieces go to the neighbour (of 26) that holds the most of the solid, or when none holds
  // min_fraction, to the cell within two that does (slivers where the zero level grazes a cell).
  std::vector<std::array<int, 3>> d;
  for (int ring = 1; ring <= 2; ++ring)
    for (int a = -ring; a <= ring; ++a)
      for (int b = -ring; b <= ring; ++b)
        for (int e = -ring; e <= ring; ++e)
          if (std::max({std::abs(a), std::abs(b), std::abs(e)}) == ring) d.push_back({a, b, e});
  std::vector<float> out = frac;
  for (int k = 0; k < L.n[2]; ++k)
    for (int j = 0; j < L.n[1]; ++j)
      for (int i = 0; i < L.n[0]; ++i) {
        const std::size_t cell = L.index(i, j, k);
        if (!(frac[cell] > 0.f) || frac[cell] >= min_fraction) continue;
        std::size_t best = cell;
        float best_f = 0.f;
        for (std::size_t m = 0; m < d.size() && !(m == 26 && best != cell); ++m) {
          const auto& o = d[m];
          const int a = i + o[0], b = j + o[1], e = k + o[2];
          if (a < 0 || b < 0 || e < 0 || a >= L.n[0] || b >= L.n[1] || e >= L.n[2]) continue;
          const std::size_t q = L.index(a, b, e);
          if (frac[q] >= min_fraction && frac[q] > best_f) best_f = frac[q], best = q;
        }
        if (best == cell) continue;
        out[best] += frac[cell];
        out[cell] = 0.f;
      }
  return out;
}

}  // namespace topo_gaussian::geometry
