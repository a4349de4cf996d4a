#include "topo_gaussian/geometry/contact_samples.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <unordered_map>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/number_text.h"
#include "topo_gaussian/geometry/surface_field.h"
#include "topo_gaussian/physics/neighbor_list.h"

namespace topo_gaussian::geometry {
namespace {

std::vector<Eigen::Vector3d> boundaryParticles(const VolumeCloud& c) {
  std::vector<Eigen::Vector3d> out;
  for (std::size_t i = 0; i < c.size(); ++i)
    if (c.surface[i]) out.push_back(c.X[i]);
  if (out.empty()) out = c.X;
  return out;
}

/// Mean of the filled particles within `radius` of p (p itself when none is that close).
Eigen::Vector3d localInside(const SpatialGrid& grid, const Eigen::Vector3d& p, double radius) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  int n = 0;
  grid.query(p, [&](int, const Eigen::Vector3d& x) {
    if ((x - p).squaredNorm() < radius * radius) {
      sum += x;
      ++n;
    }
  });
  return n ? Eigen::Vector3d(sum / n) : p;
}

double signedVolume(const SurfaceData& m) {
  double v = 0.0;
  for (const auto& t : m.triangles) v += m.points[t[0]].dot(m.points[t[1]].cross(m.points[t[2]]));
  return v / 6.0;
}

void checkCount(double count, double s, const ContactSampleOptions& o, const SurfaceData& surface) {
  if (count <= o.max_samples) return;
  throw TopoError(surface.source,
                  "would need " + numberText(count, 3) + " contact samples at spacing " + numberText(s, 3) +
                      " m (limit " + numberText(o.max_samples, 3) + ")",
                  "give a coarser contact spacing, at least " + numberText(s * std::sqrt(count / o.max_samples), 3) +
                      " m (FillOptions::contact.spacing_m, `topo fill --contact-spacing`)");
}

std::uint64_t mix(std::uint64_t x) {  // splitmix64: a fixed pseudo-random visiting order
  x += 0x9E3779B97F4A7C15ULL;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ULL;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBULL;
  return x ^ (x >> 31);
}

/// Poisson-disk thinning of dense candidates (≈ 9 per s²): visiting them in a fixed pseudo-random order,
/// keep one when no kept sample is within r = 0.85 s (a maximal set: ≈ 1 / s² samples per area, evenly
/// spread — an irregular sampling makes the ground contact bumpy, and at 3° a hemisphere then rocks
/// 10 % slow). Every candidate's area (and normal, area-weighted) goes to the nearest kept sample,
/// which is within r, so Σ A_k is kept.
ContactSamples thinToSpacing(const ContactSamples& c, double s) {
  const double r = 0.85 * s;
  std::vector<std::pair<std::uint64_t, int>> order(c.size());
  for (std::size_t i = 0; i < c.size(); ++i) order[i] = {mix(i), int(i)};
  std::sort(order.begin(), order.end());
  // Kept samples by cube of edge r: an open-addressing table from the cube's key to its first sample,
  // the others chained through next (the cubes of a surface are few and scattered in its box).
  std::vector<std::int64_t> keys(1024, -1);
  std::vector<int> head(1024, -1), next(c.size(), -1);
  std::size_t used = 0;
  auto slot = [&](std::int64_t key) {
    std::size_t k = mix(std::uint64_t(key)) & (keys.size() - 1);
    while (keys[k] != -1 && keys[k] != key) k = (k + 1) & (keys.size() - 1);
    return k;
  };
  auto pack = [](const Eigen::Array3i& q) {
    return (std::int64_t(q[0]) & 0x1FFFFF) | (std::int64_t(q[1]) & 0x1FFFFF) << 21 |
           (std::int64_t(q[2]) & 0x1FFFFF) << 42;
  };
  std::vector<int> kept;
  for (const auto& oi : order) {
    const int i = oi.second;
    const Eigen::Array3i q = (c.X[i] / r).array().floor().cast<int>();
    bool near = false;
    for (int dx = -1; dx <= 1 && !near; ++dx)
      for (int dy = -1; dy <= 1 && !near; ++dy)
        for (int dz = -1; dz <= 1 && !near; ++dz)
          for (int j = head[slot(pack(q + Eigen::Array3i(dx, dy, dz)))]; j >= 0 && !near; j = next[j])
            near = (c.X[j] - c.X[i]).squaredNorm() < r * r;
    if (near) continue;
    if (2 * (used + 1) > keys.size()) {  // grow: keep the table at most half full
      std::vector<std::int64_t> old_keys(2 * keys.size(), -1);
      std::vector<int> old_head(2 * keys.size(), -1);
      old_keys.swap(keys), old_head.swap(head);
      for (std::size_t k = 0; k < old_keys.size(); ++k)
        if (old_keys[k] != -1) {
          const std::size_t t = slot(old_keys[k]);
          keys[t] = old_keys[k], head[t] = old_head[k];
        }
    }
    const std::int64_t key = pack(q);
    const std::size_t t = slot(key);
    if (keys[t] == -1) keys[t] = key, ++used;
    next[i] = head[t], head[t] = i;
    kept.push_back(i);
  }
  // Lloyd relaxation (4 rounds): every candidate goes to its nearest sample, and each sample moves to
  // the area-weighted centroid of its candidates, taking their summed area and mean normal. The samples
  // become nearly centroidal Voronoi sites: evenly spread with areas that tile the surface, so the
  // ground's pressure centre follows the smooth surface (an irregular set moves it by ~ s / √N).
  ContactSamples out;
  out.origin = c.origin;
  out.spacing = s;
  for (int i : kept) out.X.push_back(c.X[i]);
  std::vector<int> owner(c.size(), -1);
  for (int round = 0; round < 5; ++round) {
    const SpatialGrid grid(out.X, 2.0 * r);
    const std::ptrdiff_t nc = static_cast<std::ptrdiff_t>(c.size());
#pragma omp parallel for schedule(static)
    for (std::ptrdiff_t i = 0; i < nc; ++i) {
      double best = 4.0 * r * r;
      grid.query(c.X[i], [&](int j, const Eigen::Vector3d& x) {
        const double d2 = (x - c.X[i]).squaredNorm();
        if (d2 < best) best = d2, owner[i] = j;
      });
    }
    std::vector<Eigen::Vector3d> sum(out.size(), Eigen::Vector3d::Zero()), nsum(out.size(), Eigen::Vector3d::Zero());
    std::vector<double> area(out.size(), 0.0);
    for (std::size_t i = 0; i < c.size(); ++i) {
      if (owner[i] < 0) continue;
      sum[owner[i]] += c.area[i] * c.X[i];
      nsum[owner[i]] += c.area[i] * c.normal[i];
      area[owner[i]] += c.area[i];
    }
    // Samples that lost every candidate are dropped (their area is with their neighbours).
    ContactSamples next;
    next.origin = c.origin;
    next.spacing = s;
    for (std::size_t k = 0; k < out.size(); ++k) {
      if (!(area[k] > 0.0)) continue;
      next.X.push_back(sum[k] / area[k]);
      next.normal.push_back(nsum[k].norm() > 0 ? Eigen::Vector3d(nsum[k].normalized()) : Eigen::Vector3d::UnitZ());
      next.area.push_back(area[k]);
    }
    out = std::move(next);
  }
  return out;
}

ContactSamples meshSamples(const SurfaceData& m, const VolumeCloud& filled, double s, const ContactSampleOptions& o,
                           std::vector<std::string>* warnings) {
  ContactSamples out;
  out.origin = "mesh triangles";
  out.spacing = s;
  // A closed mesh is oriented by the sign of its signed volume; an open one face by face, away from the
  // filled particles (its signed volume means nothing).
  bool closed_orientation = true;
  {
    std::unordered_map<std::uint64_t, int> edge_use;
    for (const auto& t : m.triangles)
      for (int e = 0; e < 3; ++e) {
        const std::uint64_t a = std::uint32_t(t[e]), b = std::uint32_t(t[(e + 1) % 3]);
        ++edge_use[std::min(a, b) << 32 | std::max(a, b)];
      }
    for (const auto& kv : edge_use) closed_orientation = closed_orientation && kv.second == 2;
  }
  double sigma = 1.0;
  if (closed_orientation) {
    const double v = signedVolume(m);
    if (v < 0.0) {
      sigma = -1.0;
      warnings->push_back(m.source + ": its faces are oriented inwards (signed volume " + numberText(v, 4) +
                          " m^3 < 0): the contact normals were flipped outward; re-export it with outward normals");
    }
  }
  // n_t = max(1, round(A_t / s²)) samples per face at the points of the R2 low-discrepancy sequence
  // folded into the triangle (uniform on it whatever its shape: a k × k subdivision oversamples slivers),
  // each standing for A_t / n_t.
  double count = 0.0;
  std::size_t degenerate = 0;
  std::vector<long> k(m.triangles.size(), 0);
  for (std::size_t t = 0; t < m.triangles.size(); ++t) {
    const Eigen::Vector3d &a = m.points[m.triangles[t][0]], &b = m.points[m.triangles[t][1]],
                          &c = m.points[m.triangles[t][2]];
    const double area = 0.5 * (b - a).cross(c - a).norm();
    if (!(area > 0.0)) {
      ++degenerate;
      continue;
    }
    k[t] = std::max(1L, std::lround(9.0 * area / (s * s)));
    count += double(k[t]);
  }
  checkCount(count / 9.0, s, o, m);
  if (degenerate)
    warnings->push_back(m.source + ": " + std::to_string(degenerate) + " faces of zero area carry no contact samples");
  out.X.reserve(std::size_t(count));
  out.normal.reserve(std::size_t(count));
  out.area.reserve(std::size_t(count));
  std::unique_ptr<SpatialGrid> inside;
  if (!closed_orientation) inside = std::make_unique<SpatialGrid>(filled.X, 2.0 * filled.spacing);
  constexpr double kR2a = 0.7548776662466927, kR2b = 0.5698402909980532;  // 1/g, 1/g² (g³ = g + 1)
  long sequence = 0;
  for (std::size_t t = 0; t < m.triangles.size(); ++t) {
    if (!k[t]) continue;
    const Eigen::Vector3d& a = m.points[m.triangles[t][0]];
    const Eigen::Vector3d u = m.points[m.triangles[t][1]] - a, v = m.points[m.triangles[t][2]] - a;
    Eigen::Vector3d n = sigma * u.cross(v).normalized();
    if (inside) {
      const Eigen::Vector3d centre = a + (u + v) / 3.0;
      if ((centre - localInside(*inside, centre, 2.0 * filled.spacing)).dot(n) < 0.0) n = -n;
    }
    const double area = 0.5 * u.cross(v).norm() / double(k[t]);
    if (k[t] == 1) {
      out.X.push_back(a + (u + v) / 3.0);
    } else {
      // The sequence runs on from face to face, so the faces of a fan do not all leave their apex empty.
      for (long i = 0; i < k[t]; ++i, ++sequence) {
        double x = std::fmod(0.5 + kR2a * double(sequence), 1.0), y = std::fmod(0.5 + kR2b * double(sequence), 1.0);
        if (x + y > 1.0) x = 1.0 - x, y = 1.0 - y;
        out.X.push_back(a + x * u + y * v);
        if (i + 1 < k[t]) out.normal.push_back(n), out.area.push_back(area);
      }
    }
    out.normal.push_back(n);
    out.area.push_back(area);
  }
  return thinToSpacing(out, s);
}

/// A fitted height field h(u, v) = c0 + c1 u + c2 v + c3 u² + c4 uv + c5 v² over the plane (c; t1, t2)
/// with normal n.
struct QuadricPatch {
  bool valid = false;
  Eigen::Vector3d c, t1, t2, n;
  Eigen::Matrix<double, 6, 1> co;
  double u = 0.0, v = 0.0;  ///< the fitted point's own plane coordinates
  Eigen::Vector3d point(double a, double b) const {
    return c + a * t1 + b * t2 + (co[0] + co[1] * a + co[2] * b + co[3] * a * a + co[4] * a * b + co[5] * b * b) * n;
  }
  Eigen::Vector3d normal(double a, double b) const {
    return (n - (co[1] + 2 * co[3] * a + co[4] * b) * t1 - (co[2] + co[4] * a + 2 * co[5] * b) * t2).normalized();
  }
};

/// The means a scan's contact patches are fitted to, with a grid whose cells hold radius_m.
struct PatchNeighbours {
  PatchNeighbours(const std::vector<Eigen::Vector3d>& x, const std::vector<double>& w, const std::vector<double>& c,
                  double radius)
      : mean(x), weight(w), count(c), radius_m(radius), grid(x, radius) {}
  const std::vector<Eigen::Vector3d>& mean;
  const std::vector<double>& weight;  ///< a mean's share of the area
  const std::vector<double>& count;   ///< the points it averages
  double radius_m;
  SpatialGrid grid;
};

struct PatchFit {
  QuadricPatch patch;  ///< valid from 12 neighbours on
  Eigen::Vector3d plane_normal = Eigen::Vector3d::Zero(), plane_point = Eigen::Vector3d::Zero();
  int m = 0;                  ///< neighbours within the radius
  double radius_m = 0.0;      ///< R_f
  double noise_m = 0.0;       ///< the points' scatter about the fit: σ² = Σ w r² / Σ (w / count)
  double height_sd_unit = 0;  ///< std of the fitted height at the point for unit point noise
};

// Quadric moving-least-squares patch of the means within R_f of p (Gaussian weights of width R_f / 2,
// times each mean's area share): the weighted plane, then h(u, v) = c0 + c1 u + c2 v + c3 u² + c4 uv +
// c5 v² over it by weighted least squares. The quadratic term follows the surface's curvature, so a
// wide fit smooths noise without pulling samples inside (a plane fit of radius R_f on a sphere of
// radius R would, by ~R_f²/(4R)). The height's standard deviation for unit point noise is the
// sandwich [A⁻¹ B A⁻¹]₀₀, A = Σ w φφᵀ, B = Σ w² φφᵀ / count (a mean of n points has variance σ²/n).
PatchFit quadricFit(const PatchNeighbours& nb, const Eigen::Vector3d& p, double rf) {
  PatchFit f;
  f.radius_m = rf;
  const double w2 = 0.25 * rf * rf;
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  Eigen::Matrix3d C = Eigen::Matrix3d::Zero();
  double wsum = 0.0;
  thread_local std::vector<std::pair<int, double>> near;
  near.clear();
  nb.grid.query(p, [&](int j, const Eigen::Vector3d& x) {
    const double d2 = (x - p).squaredNorm();
    if (d2 >= rf * rf) return;
    const double w = std::exp(-d2 / w2) * nb.weight[j];
    near.emplace_back(j, w);
    c += w * x;
    C += w * x * x.transpose();
    wsum += w;
  });
  f.m = int(near.size());
  if (f.m < 4) return f;
  c /= wsum;
  C = C / wsum - c * c.transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(C);
  const Eigen::Vector3d nrm = es.eigenvectors().col(0);
  const Eigen::Vector3d t1 = es.eigenvectors().col(2), t2 = nrm.cross(t1);
  f.plane_normal = nrm;
  f.plane_point = p - (p - c).dot(nrm) * nrm;
  if (f.m < 12) return f;
  using Vec6 = Eigen::Matrix<double, 6, 1>;
  auto basis = [&](const Eigen::Vector3d& x) {
    const Eigen::Vector3d d = x - c;
    const double u = d.dot(t1), v = d.dot(t2);
    Vec6 phi;
    phi << 1, u, v, u * u, u * v, v * v;
    return phi;
  };
  Eigen::Matrix<double, 6, 6> A = Eigen::Matrix<double, 6, 6>::Zero(), B = A;
  Vec6 bvec = Vec6::Zero();
  for (const auto& [j, w] : near) {
    const Vec6 phi = basis(nb.mean[j]);
    A += w * phi * phi.transpose();
    B += (w * w / nb.count[j]) * phi * phi.transpose();
    bvec += w * (nb.mean[j] - c).dot(nrm) * phi;
  }
  const Eigen::LDLT<Eigen::Matrix<double, 6, 6>> ldlt(A);
  f.patch.co = ldlt.solve(bvec);
  if (!f.patch.co.allFinite()) return f;
  double res2 = 0.0, wn = 0.0;
  for (const auto& [j, w] : near) {
    const double r = (nb.mean[j] - c).dot(nrm) - basis(nb.mean[j]).dot(f.patch.co);
    res2 += w * r * r;
    wn += w / nb.count[j];
  }
  f.noise_m = std::sqrt(res2 / wn);
  const Eigen::Vector3d d = p - c;
  f.patch.u = d.dot(t1);
  f.patch.v = d.dot(t2);
  const Vec6 g = ldlt.solve(basis(p));  // A⁻¹ φ(p): the fitted height is gᵀ b
  f.height_sd_unit = std::sqrt(std::max(0.0, g.dot(B * g)));
  f.patch.valid = true;
  f.patch.c = c, f.patch.t1 = t1, f.patch.t2 = t2, f.patch.n = nrm;
  return f;
}

struct FitWidening {
  double noise_m = 0.0;          ///< the points' scatter about their fits at R_f = 8 s (median)
  double median_radius_m = 0.0;  ///< R_f the fits ended at (median)
  double short_fraction = 0.0;   ///< fits that stopped before their noise target (feature or R_f max)
};

// A noisy scan's fits widen until the noise no longer bends the contact surface. The fitted heights
// e(x) carry noise of std σ_h = σ · height_sd_unit, correlated over the Gaussian's width w = R_f / 2,
// so the surface's curvature is off by ~√3 σ_h / w² (a Gaussian-correlated field's second
// derivative). That must stay within 0.5 % of κ_ref = 2 / the body's diagonal: a rocking period
// follows the curvature under the contact. A hemisphere scanned with 0.3 mm noise (2 mm apart) rocked
// −5.1…−0.4 % off at R_f = 8 s (four samplings of the noise), −2.7…+1.2 % with a 1 % bound, and
// −1.5…+1.0 % (twelve samplings, mean −0.2 %) with 0.5 %. σ_h falls as 1 / w (the points in the fit grow as w²), so the
// radius that meets the target is predicted from the first fit, R_f ∝ ratio^(1/3), and tried; a wider
// fit is kept only while it still fits about as well as the first (scatter ≤ 1.5 × the first's or the
// scan's median): an edge or a small feature inside it would raise the scatter, and the fit goes back
// towards R_f = 8 s (geometric halving, twice).
FitWidening widenNoisyFits(const PatchNeighbours& base, const std::vector<Eigen::Vector3d>& mean, double rf0,
                           double rf_max, double kappa_ref, std::vector<PatchFit>* fit) {
  FitWidening out;
  std::vector<double> noise;
  for (const PatchFit& f : *fit)
    if (f.patch.valid) noise.push_back(f.noise_m);
  if (noise.empty()) return out;
  std::nth_element(noise.begin(), noise.begin() + noise.size() / 2, noise.end());
  out.noise_m = noise[noise.size() / 2];
  constexpr double kCurvatureShare = 0.005;  // 1 % left the hemisphere's period −2.7 % for one sampling
  auto bend = [&](const PatchFit& f) {       // curvature the noise puts into the fitted surface [1/m]
    const double w = 0.5 * f.radius_m;
    return std::sqrt(3.0) * out.noise_m * f.height_sd_unit / (w * w);
  };
  const double target = kCurvatureShare * kappa_ref;
  // grids at R_f = rf0 · 2^k, each queried for the radii up to its cell
  std::vector<std::unique_ptr<PatchNeighbours>> grids;
  for (double cell = 2.0 * rf0; cell < 2.0 * rf_max; cell *= 2.0)
    grids.push_back(std::make_unique<PatchNeighbours>(base.mean, base.weight, base.count, cell));
  auto fitAt = [&](const Eigen::Vector3d& p, double rf) {
    for (const auto& g : grids)
      if (rf <= g->radius_m) return quadricFit(*g, p, rf);
    return quadricFit(*grids.back(), p, std::min(rf, grids.back()->radius_m));
  };
  const long n = long(mean.size());
  std::vector<double> radius(mean.size(), rf0);
  std::vector<std::uint8_t> short_of(mean.size(), 0);
#pragma omp parallel for schedule(dynamic, 64)
  for (long k = 0; k < n; ++k) {
    PatchFit& f = (*fit)[k];
    if (!f.patch.valid || out.noise_m <= 0.0 || bend(f) <= target) continue;
    const double wanted = std::min(rf_max, rf0 * std::cbrt(bend(f) / target));
    if (grids.empty() || wanted <= rf0 * 1.05) {
      short_of[k] = 1;
      continue;
    }
    const double allowed = 1.5 * std::max(f.noise_m, out.noise_m);
    bool kept = false;
    for (int step = 0; step < 3 && !kept; ++step) {
      const double rf = rf0 * std::pow(wanted / rf0, std::pow(0.5, step));
      PatchFit wide = fitAt(mean[k], rf);
      if (wide.patch.valid && wide.noise_m <= allowed) {
        short_of[k] = step > 0 || bend(wide) > 1.05 * target;
        f = wide;
        kept = true;
      }
    }
    if (!kept) short_of[k] = 1;
    radius[k] = f.radius_m;
  }
  std::nth_element(radius.begin(), radius.begin() + radius.size() / 2, radius.end());
  out.median_radius_m = radius[radius.size() / 2];
  out.short_fraction = double(std::count(short_of.begin(), short_of.end(), 1)) / double(mean.size());
  return out;
}

ContactSamples pointSamples(const SurfaceData& surface, const VolumeCloud& filled, double s,
                            const ContactSampleOptions& o, std::vector<std::string>* warnings) {
  const bool gaussians = surface.kind == SurfaceKind::Gaussians;
  ContactSamples out;
  out.origin = gaussians ? "Gaussian centres" : "points";
  out.spacing = s;
  const double h = filled.spacing;
  // Floaters: points farther than 2 h from every boundary particle. Decided per cube of side s (the
  // same answer for every point of a cube whose centre lies nearer than 2h − δ or farther than
  // 2h + δ, δ = √3 s / 2 its half-diagonal; each point of the cubes in between on its own): a dense
  // scan (millions of points) costs one query per cube instead of one per point.
  const std::vector<Eigen::Vector3d> boundary = boundaryParticles(filled);
  const double reach = 2.0 * h, half_diagonal = 0.5 * std::sqrt(3.0) * s;
  const SpatialGrid near_boundary(boundary, reach + half_diagonal);
  std::unordered_map<std::int64_t, char> verdict;  // 'c' all close, 'f' all floaters, 'm' mixed
  auto closeToBody = [&](const Eigen::Vector3d& p) {
    const std::int64_t key = cubeKey(p, s);
    auto it = verdict.find(key);
    if (it == verdict.end()) {
      const Eigen::Vector3d centre = (((p / s).array().floor() + 0.5) * s).matrix();
      double d2 = std::numeric_limits<double>::infinity();
      near_boundary.query(centre,
                          [&](int, const Eigen::Vector3d& x) { d2 = std::min(d2, (x - centre).squaredNorm()); });
      const double d = std::sqrt(d2);
      it = verdict.emplace(key, d < reach - half_diagonal ? 'c' : (d >= reach + half_diagonal ? 'f' : 'm')).first;
    }
    if (it->second != 'm') return it->second == 'c';
    bool close = false;
    near_boundary.query(p,
                        [&](int, const Eigen::Vector3d& x) { close = close || (x - p).squaredNorm() < reach * reach; });
    return close;
  };
  struct Cell {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero(), normal = Eigen::Vector3d::Zero();
    int n = 0;
  };
  std::unordered_map<std::int64_t, Cell> cells;
  std::size_t floaters = 0, faint = 0;
  const bool with_normals = surface.hasNormals();
  for (std::size_t i = 0; i < surface.size(); ++i) {
    if (gaussians && i < surface.opacity.size() && surface.opacity[i] < o.min_opacity) {
      ++faint;
      continue;
    }
    const Eigen::Vector3d& p = surface.points[i];
    if (!p.allFinite()) continue;
    if (!closeToBody(p)) {
      ++floaters;
      continue;
    }
    Cell& c = cells[cubeKey(p, s / 3.0)];
    c.sum += p;
    ++c.n;
    if (with_normals && surface.normals[i].allFinite()) c.normal += surface.normals[i];
  }
  if (floaters)
    warnings->push_back(surface.source + ": " + std::to_string(floaters) +
                        " points lie farther than 2 spacings from the filled body (floaters): not contact samples");
  checkCount(double(cells.size()) / 9.0, s, o, surface);
  // A scan denser than ~s/2 (at least 4 occupied cells of s/3 per cube of s on average) is binned
  // again by cubes of s: each mean then averages the points of a cube (the same points, so the fits
  // below see the same noise averaging) and the fits need ~9× fewer neighbours each (a 2M-point scan
  // went from ~1 700 to ~200). Sparser scans keep one mean per s/3 cell, as before.
  bool dense = false;
  {
    std::unordered_map<std::int64_t, Cell> coarse;
    for (const auto& kv : cells) {
      Cell& c = coarse[cubeKey(kv.second.sum / kv.second.n, s)];
      c.sum += kv.second.sum;
      c.normal += kv.second.normal;
      c.n += kv.second.n;
    }
    dense = cells.size() >= 4 * coarse.size();
    if (dense) cells.swap(coarse);
  }
  std::vector<Eigen::Vector3d> mean, given;
  std::vector<double> weight;  // a mean's share of the area: its points (dense), else 1
  std::vector<double> count;   // the points a mean averages (its noise variance is σ² / count)
  mean.reserve(cells.size());
  for (const auto& kv : cells) {
    mean.push_back(kv.second.sum / kv.second.n);
    given.push_back(kv.second.normal);
    weight.push_back(dense ? double(kv.second.n) : 1.0);
    count.push_back(double(kv.second.n));
  }
  if (mean.empty()) return out;
  // One moving-least-squares step of second order (quadricFit): the height over the weighted plane of
  // the neighbours within R_f, fitted as a quadric, and the point moved onto it. R_f = 8 s unless the
  // scan is noisy; then each fit widens until its noise no longer bends the surface (widenNoisyFits).
  const double r = 2.5 * s, rf0 = 8.0 * s;
  Eigen::Vector3d lo, hi;
  filled.bounds(&lo, &hi);
  const double diagonal = (hi - lo).norm() + h;
  const double rf_max = std::max(rf0, 0.25 * diagonal);
  const PatchNeighbours base{mean, weight, count, rf0};
  const SpatialGrid particles(filled.X, 2.0 * h);
  // A scan is often sparser than s and unevenly spaced, and the thinning and Lloyd's relaxation can
  // only even out a sampling denser than s (uneven samples move the ground's pressure centre): each
  // point spreads candidates over its patch (below).
  const long n = long(mean.size());
  std::vector<PatchFit> fit(mean.size());
  std::vector<double> near(mean.size(), 0.0), kde(mean.size(), 0.0);
#pragma omp parallel for schedule(dynamic, 256)
  for (long k = 0; k < n; ++k) {
    fit[k] = quadricFit(base, mean[k], rf0);
    base.grid.query(mean[k], [&](int j, const Eigen::Vector3d& x) {
      const double d2 = (x - mean[k]).squaredNorm();
      if (d2 < r * r) near[k] += weight[j];
      if (dense) kde[k] += weight[j] * std::exp(-d2 / (2.0 * s * s));
    });
  }
  const FitWidening widening = widenNoisyFits(base, mean, rf0, rf_max, 2.0 / diagonal, &fit);
  // Each point spreads candidates evenly over its fitted patch (the R2 sequence, ≈ 36 per s²), each
  // standing for its share of the patch's area: they are then denser than a mesh's whatever the scan's
  // own spacing, and the thinning and Lloyd's relaxation spread the samples evenly over the fitted
  // surface and give each the area of its cell. A sparse scan's point keeps only the candidates of a
  // disk of radius min(1.5 √A, r) (A ≈ π r² / its neighbours within r) whose nearest point it is along
  // the patch's plane: the points' Voronoi cells on the surface, which tile it, so the areas follow the
  // surface and not the count of neighbours (a 1 mm scan's points lie where the lattice's layers meet
  // the round bottom, in rings; with areas from the count a doll rocked −0.93 … +3.11 % off its exact
  // period over 5…25°, with those of the cells −0.44 … +0.94 %). A dense scan's means keep their
  // kernel-density share over a disk of that area.
  const SpatialGrid nearest_mean(mean, r);
  std::vector<std::vector<Eigen::Vector3d>> cx(mean.size()), cn(mean.size());
  std::vector<std::vector<double>> ca(mean.size());
#pragma omp parallel for schedule(dynamic, 256)
  for (long k = 0; k < n; ++k) {
    const Eigen::Vector3d& p = mean[k];
    const Eigen::Vector3d pin = localInside(particles, p, 2.0 * h);
    const PatchFit& f = fit[k];
    Eigen::Vector3d nrm = f.m >= 4 ? f.plane_normal : Eigen::Vector3d(p - pin);
    Eigen::Vector3d y = f.m >= 4 ? f.plane_point : p;
    if (f.patch.valid) {
      y = f.patch.point(f.patch.u, f.patch.v);
      nrm = f.patch.normal(f.patch.u, f.patch.v);
    }
    const Eigen::Vector3d reference = given[k].squaredNorm() > 0 ? given[k] : Eigen::Vector3d(p - pin);
    const double sign = nrm.dot(reference) < 0.0 ? -1.0 : 1.0;
    // The share of the area: 1 / (the means within r) for a sparse scan; for a dense one its points over
    // the Gaussian kernel density of points (width s), which a count within a sharp radius would
    // overestimate by the lattice-like means at ~s spacing (21 cells of s within 2.5 s, not 19.6: −6 %).
    const double area =
        dense ? 2.0 * M_PI * s * s * weight[k] / std::max(weight[k], kde[k]) : M_PI * r * r / std::max(1.0, near[k]);
    auto put = [&](const Eigen::Vector3d& x, const Eigen::Vector3d& nv, double a) {
      cx[k].push_back(x);
      cn[k].push_back(nv.norm() > 0 ? Eigen::Vector3d(sign * nv.normalized()) : Eigen::Vector3d::UnitZ());
      ca[k].push_back(a);
    };
    if (f.patch.valid) {
      const double rho = dense ? std::sqrt(area / M_PI) : std::min(1.5 * std::sqrt(area), r);
      const int kc = int(std::clamp(std::lround(36.0 * M_PI * rho * rho / (s * s)), 1L, 1600L));
      constexpr double kR2a = 0.7548776662466927, kR2b = 0.5698402909980532;
      std::vector<Eigen::Vector3d> px, pn;
      std::vector<double> pa;
      double cell = 0.0;  // the patch area of the kept candidates (sparse: the point's Voronoi cell)
      for (int q = 0; q < kc; ++q) {
        // equal-area disk points: radius √t ρ, angle 2π w (t, w the R2 sequence; the first at the centre)
        const double t = q == 0 ? 0.0 : std::fmod(0.5 + kR2a * q, 1.0), w = std::fmod(0.5 + kR2b * q, 1.0);
        const double du = rho * std::sqrt(t) * std::cos(2.0 * M_PI * w),
                     dv = rho * std::sqrt(t) * std::sin(2.0 * M_PI * w);
        const Eigen::Vector3d x = f.patch.point(f.patch.u + du, f.patch.v + dv);
        if (!dense) {
          // distances along the patch's plane: a noisy scan's means scatter across the surface, and the
          // point's own patch passes nearer its own mean (the cells would overlap: +10 % area at 0.3 mm
          // noise)
          const Eigen::Vector3d& pn0 = f.patch.n;
          auto tangential2 = [&](const Eigen::Vector3d& d) { return d.squaredNorm() - std::pow(d.dot(pn0), 2); };
          const double best = tangential2(x - p);
          bool mine = true;
          nearest_mean.query(x, [&](int j, const Eigen::Vector3d& m) {
            if (j != int(k) && tangential2(m - x) < best) mine = false;
          });
          if (!mine) continue;
        }
        // the patch's area element over its plane: |∂x/∂u × ∂x/∂v| = 1 / (n · plane normal)
        const Eigen::Vector3d nv = f.patch.normal(f.patch.u + du, f.patch.v + dv);
        const double da = M_PI * rho * rho / kc / std::max(0.2, std::abs(nv.dot(f.patch.n)));
        px.push_back(x), pn.push_back(nv), pa.push_back(da);
        cell += da;
      }
      const double scale = dense ? area / std::max(cell, 1e-300) : 1.0;
      for (std::size_t q = 0; q < px.size(); ++q) put(px[q], pn[q], pa[q] * scale);
      if (px.empty()) put(y, nrm, area);
    } else {
      put(y, nrm, area);
    }
  }
  if (widening.noise_m > 0.05 * s) {
    std::string text = surface.source + ": the points scatter " + numberText(widening.noise_m * 1e3, 3) +
                       " mm about their local fits (median) against a contact spacing of " + numberText(s * 1e3, 3) +
                       " mm: the contact fits widened to " + numberText(widening.median_radius_m * 1e3, 3) +
                       " mm (median; " + numberText(rf0 * 1e3, 3) +
                       " mm for a clean scan) so that the noise bends the contact surface by at most 0.5 % of the "
                       "body's curvature scale (2 / its diagonal), which smooths away details smaller than that";
    if (widening.short_fraction > 0.1)
      text += "; " + numberText(100.0 * widening.short_fraction, 2) +
              " % of the points could not widen that far (edges and small features stop the fit, or " +
              numberText(rf_max * 1e3, 3) +
              " mm is reached): rolling and rocking on those parts keeps part of the roughness; give a smoother "
              "or denser scan, or a mesh";
    warnings->push_back(text);
  }
  for (std::size_t k = 0; k < cx.size(); ++k)
    for (std::size_t q = 0; q < cx[k].size(); ++q) {
      out.X.push_back(cx[k][q]);
      out.normal.push_back(cn[k][q]);
      out.area.push_back(ca[k][q]);
    }
  (void)faint;
  return thinToSpacing(out, s);
}

/// Boundary particles with no sample within max(2 h, 3 s): the surface has a hole there.
void patchHoles(const VolumeCloud& filled, const std::string& source, ContactSamples* out,
                std::vector<std::string>* warnings) {
  const double h = filled.spacing, reach = std::max(2.0 * h, 3.0 * out->spacing);
  const SpatialGrid grid(out->X, reach);
  const SpatialGrid inside(filled.X, 2.0 * h);
  std::size_t boundary = 0;
  std::vector<Eigen::Vector3d> uncovered;
  for (std::size_t i = 0; i < filled.size(); ++i) {
    if (!filled.surface[i]) continue;
    ++boundary;
    bool covered = false;
    grid.query(filled.X[i],
               [&](int, const Eigen::Vector3d& x) { covered = covered || (x - filled.X[i]).norm() < reach; });
    if (!covered) uncovered.push_back(filled.X[i]);
  }
  if (uncovered.empty()) return;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (const auto& p : uncovered) centre += p;
  centre /= double(uncovered.size());
  const double fraction = double(uncovered.size()) / double(std::max<std::size_t>(1, boundary));
  // Small holes are sampling gaps (a sparse scan); a large one is a missing piece of the surface.
  if (fraction < 0.002) return;
  for (const auto& p : uncovered) {
    out->X.push_back(p);
    Eigen::Vector3d n = p - localInside(inside, p, 2.0 * h);
    out->normal.push_back(n.norm() > 0 ? Eigen::Vector3d(n.normalized()) : Eigen::Vector3d::UnitZ());
    out->area.push_back(h * h);
  }
  warnings->push_back(source + ": the surface has a hole: " + numberText(100.0 * fraction, 2) + " % of the boundary (" +
                      std::to_string(uncovered.size()) + " particles, centred at (" + numberText(centre.x(), 3) + ", " +
                      numberText(centre.y(), 3) + ", " + numberText(centre.z(), 3) +
                      ") m) has no surface sample within " + numberText(reach, 3) +
                      " m; there the body touches the ground with its lattice particles (a staircase). Scan that "
                      "region again if the object rests or rolls on it");
}

}  // namespace

double defaultContactSpacing(const VolumeCloud& filled, SurfaceKind kind) {
  Eigen::Vector3d lo, hi;
  filled.bounds(&lo, &hi);
  const double d = (hi - lo).norm() + filled.spacing;
  return std::min(0.5 * filled.spacing, d / (kind == SurfaceKind::Mesh ? 400.0 : 200.0));
}

ContactSamples sampleContactSurface(const SurfaceData& surface, const VolumeCloud& filled,
                                    const ContactSampleOptions& o, std::vector<std::string>* warnings) {
  std::vector<std::string> local;
  if (!warnings) warnings = &local;
  if (!o.enabled) return ContactSamples{};
  if (!(o.spacing_m >= 0.0) || !std::isfinite(o.spacing_m))
    throw TopoError("contact spacing", "is " + numberText(o.spacing_m, 4) + " m",
                    "give a positive spacing in m, or 0 for the automatic one");
  const bool mesh = surface.kind == SurfaceKind::Mesh && !surface.triangles.empty();
  const double s =
      o.spacing_m > 0.0 ? o.spacing_m : defaultContactSpacing(filled, mesh ? SurfaceKind::Mesh : SurfaceKind::Points);
  ContactSamples out =
      mesh ? meshSamples(surface, filled, s, o, warnings) : pointSamples(surface, filled, s, o, warnings);
  if (out.empty())
    throw TopoError(surface.source,
                    "gives no contact samples: none of its " + std::to_string(surface.size()) +
                        " points lies on the filled body's boundary",
                    "check that the surface and the volume are the same object in the same frame");
  patchHoles(filled, surface.source, &out, warnings);
  return out;
}

}  // namespace topo_gaussian::geometry
