#include "topo_gaussian/physics/default_shapes.h"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <sstream>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/number_text.h"
#include "topo_gaussian/physics/neighbor_list.h"

namespace topo_gaussian {

namespace d = default_shape_dims;

namespace {

constexpr double kMaxLatticeCells = 2e7;

std::string joinedNames() {
  std::string s;
  for (const auto& n : defaultShapeNames()) s += (s.empty() ? "" : ", ") + n;
  return s;
}

std::string metres(double v) { return numberText(v, 4) + " m"; }

double pearVolume() {
  // Composite Simpson on the cross-section area π r(z)²: r² ~ z near the poles, so the integrand
  // is smooth enough; 4000 intervals give ~1e-9 relative (checked against 16000).
  const int n = 4000;
  const double h = d::kPearHeight / n;
  double s = 0.0;
  for (int i = 0; i <= n; ++i) {
    const double r = pearRadius(i * h);
    s += (i == 0 || i == n ? 1.0 : (i % 2 ? 4.0 : 2.0)) * r * r;
  }
  return M_PI * s * h / 3.0;
}

}  // namespace

double pearField(const Eigen::Vector3d& x) {
  const double rho2 = x.x() * x.x() + x.y() * x.y();
  const double a = std::sqrt(rho2 + (x.z() - d::kPearBulbCentreZ) * (x.z() - d::kPearBulbCentreZ)) - d::kPearBulbRadius;
  const double b = std::sqrt(rho2 + (x.z() - d::kPearHeadCentreZ) * (x.z() - d::kPearHeadCentreZ)) - d::kPearHeadRadius;
  const double k = d::kPearBlend;
  const double h = std::max(k - std::abs(a - b), 0.0) / k;
  return std::min(a, b) - h * h * k / 4.0;
}

double pearRadius(double z) {
  if (!(z > 0.0 && z < d::kPearHeight)) return 0.0;  // the poles and beyond
  // The field grows monotonically with the distance from the axis (the smooth minimum is monotone
  // in both arguments), so the surface radius is the single root found by bisection.
  if (pearField(Eigen::Vector3d(0, 0, z)) > 0.0) return 0.0;
  double lo = 0.0, hi = 2.0 * d::kPearBulbRadius;
  for (int it = 0; it < 64; ++it) {
    const double m = 0.5 * (lo + hi);
    (pearField(Eigen::Vector3d(m, 0, z)) <= 0.0 ? lo : hi) = m;
  }
  return lo;
}

namespace {

// One function per shape: its dimensions, exact inside test and outline (the mesh's recipe).

DefaultShape beamShape() {
  DefaultShape s;
  s.description = "cantilever beam, box 0.2 x 0.02 x 0.02 m along +x, clamped at x = 0";
  s.lo = Eigen::Vector3d(0, -d::kBeamHalfWidth, -d::kBeamHalfHeight);
  s.hi = Eigen::Vector3d(d::kBeamLength, d::kBeamHalfWidth, d::kBeamHalfHeight);
  s.thickness_m = 2 * std::min(d::kBeamHalfWidth, d::kBeamHalfHeight);
  s.volume_m3 = d::kBeamLength * 4 * d::kBeamHalfWidth * d::kBeamHalfHeight;
  const Eigen::Vector3d lo = s.lo, hi = s.hi;
  s.inside = [lo, hi](const Eigen::Vector3d& x) {
    return (x.array() >= lo.array()).all() && (x.array() <= hi.array()).all();
  };
  s.outline = [](int) { return ShapeOutline(); };
  return s;
}

DefaultShape fingerShape() {
  DefaultShape s;
  s.description =
      "pneumatic finger along +x, base at x = 0: box 0.1 x 0.02 x 0.015 m with a half-cylinder tip of radius 0.0075 "
      "m";
  s.lo = Eigen::Vector3d(0, -d::kFingerHalfWidth, -d::kFingerHalfHeight);
  s.hi = Eigen::Vector3d(d::kFingerLength, d::kFingerHalfWidth, d::kFingerHalfHeight);
  s.thickness_m = 2 * std::min(d::kFingerHalfWidth, d::kFingerHalfHeight);
  s.volume_m3 = d::kFingerTipCentreX * 4 * d::kFingerHalfWidth * d::kFingerHalfHeight +
                0.5 * M_PI * d::kFingerTipRadius * d::kFingerTipRadius * 2 * d::kFingerHalfWidth;
  const Eigen::Vector3d lo = s.lo, hi = s.hi;
  s.inside = [lo, hi](const Eigen::Vector3d& x) {
    if (!((x.array() >= lo.array()).all() && (x.array() <= hi.array()).all())) return false;
    if (x.x() <= d::kFingerTipCentreX) return true;
    const double dx = x.x() - d::kFingerTipCentreX;
    return dx * dx + x.z() * x.z() <= d::kFingerTipRadius * d::kFingerTipRadius;
  };
  s.outline = [](int resolution) {  // the rectangle with the half-disc tip, extruded along y
    ShapeOutline o;
    o.kind = ShapeOutline::Kind::ExtrudedAlongY;
    o.half_width = d::kFingerHalfWidth;
    const double t = d::kFingerHalfHeight, x0 = d::kFingerTipCentreX;
    const int tip = std::max(2, resolution / 2);
    o.curve.emplace_back(0.0, -t);
    for (int i = 0; i <= tip; ++i) {  // half-disc from (x0, −t) over the tip to (x0, t)
      const double a = -M_PI / 2 + M_PI * i / tip;
      o.curve.emplace_back(i == 0 || i == tip ? x0 : x0 + t * std::cos(a), t * std::sin(a));
    }
    o.curve.emplace_back(0.0, t);
    return o;
  };
  return s;
}

DefaultShape pearShape() {
  DefaultShape s;
  s.description =
      "pear about z, bottom at z = 0, height 0.12 m: bulb radius 0.04 m at z = 0.04, neck ~0.022 m at z = 0.1";
  s.lo = Eigen::Vector3d(-d::kPearBulbRadius, -d::kPearBulbRadius, 0);
  s.hi = Eigen::Vector3d(d::kPearBulbRadius, d::kPearBulbRadius, d::kPearHeight);
  s.thickness_m = 2 * d::kPearHeadRadius;
  static const double volume = pearVolume();
  s.volume_m3 = volume;
  s.inside = [](const Eigen::Vector3d& x) { return pearField(x) <= 0.0; };
  s.outline = [](int resolution) {
    ShapeOutline o;
    o.kind = ShapeOutline::Kind::RevolvedAboutZ;
    // Rings clustered towards the poles (z = H (1 − cos πs)/2): there r ~ √z, so r grows linearly in s.
    const int rings = std::max(4, resolution / 2);
    for (int i = 0; i <= rings; ++i) {
      const double z = i == rings ? d::kPearHeight : 0.5 * d::kPearHeight * (1.0 - std::cos(M_PI * i / rings));
      o.curve.emplace_back(i == 0 || i == rings ? 0.0 : pearRadius(z), z);
    }
    return o;
  };
  return s;
}

DefaultShape tumblerShape() {
  DefaultShape s;
  const double R = d::kTumblerRadius, c = d::kTumblerCutZ;
  s.description = "tumbler body: sphere of radius 0.05 m centred at the origin, cut flat at z = 0.02";
  s.lo = Eigen::Vector3d(-R, -R, -R);
  s.hi = Eigen::Vector3d(R, R, c);
  s.thickness_m = R + c;
  s.volume_m3 = 4.0 / 3.0 * M_PI * R * R * R - M_PI * (R - c) * (R - c) * (2 * R + c) / 3.0;
  s.inside = [R, c](const Eigen::Vector3d& x) { return x.norm() <= R && x.z() <= c; };
  s.outline = [R, c](int resolution) {  // the spherical arc from the bottom pole to the cut, then the flat cap
    ShapeOutline o;
    o.kind = ShapeOutline::Kind::RevolvedAboutZ;
    const double top = std::asin(c / R), rc = std::sqrt(R * R - c * c);
    const int arc = std::max(3, int(std::lround(0.5 * resolution * (top + M_PI / 2) / M_PI)));
    for (int i = 0; i < arc; ++i) {
      const double a = -M_PI / 2 + (top + M_PI / 2) * i / arc;
      o.curve.emplace_back(i == 0 ? 0.0 : R * std::cos(a), R * std::sin(a));
    }
    const int cap = std::max(2, resolution / 8);
    for (int j = 0; j <= cap; ++j) o.curve.emplace_back(rc * (1.0 - double(j) / cap), c);
    return o;
  };
  return s;
}

struct ShapeEntry {
  const char* name;
  DefaultShape (*build)();
};

/// Every default shape, in the order defaultShapeNames() lists them: a new shape is one line here.
const std::vector<ShapeEntry>& shapeRegistry() {
  static const std::vector<ShapeEntry> shapes{
      {"finger", fingerShape}, {"pear", pearShape}, {"beam", beamShape}, {"tumbler", tumblerShape}};
  return shapes;
}

}  // namespace

const std::vector<std::string>& defaultShapeNames() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n;
    for (const auto& e : shapeRegistry()) n.emplace_back(e.name);
    return n;
  }();
  return names;
}

DefaultShape defaultShape(const std::string& name) {
  for (const auto& e : shapeRegistry())
    if (name == e.name) {
      DefaultShape s = e.build();
      s.name = name;
      return s;
    }
  throw TopoError("shape '" + name + "'", "is not a default shape", "use one of: " + joinedNames());
}

VolumeCloud defaultShapeCloud(const std::string& name, double spacing_m) {
  return defaultShapeCloud(defaultShape(name), spacing_m);
}

VolumeCloud defaultShapeCloud(const DefaultShape& shape, double h) {
  const std::string what = "spacing for the " + shape.name + " shape";
  if (!(h > 0.0) || !std::isfinite(h))
    throw TopoError(
        what, metres(h) + " is not a positive number of metres",
        "use a spacing of at most " + metres(shape.thickness_m / 3.0) + ", e.g. " + metres(shape.thickness_m / 10.0));
  if (shape.thickness_m / h < 3.0 - 1e-9)
    throw TopoError(what,
                    metres(h) + " is too coarse: fewer than 3 particles across its thinnest dimension (" +
                        metres(shape.thickness_m) + ")",
                    "use a spacing of at most " + metres(shape.thickness_m / 3.0));
  const Eigen::Vector3d extent = shape.hi - shape.lo;
  // Cells per axis; the small tolerance keeps a spacing that divides the extent from adding a cell.
  Eigen::Vector3i n;
  for (int a = 0; a < 3; ++a) n[a] = std::max(1, int(std::ceil(extent[a] / h - 1e-9)));
  const double cells = double(n.x()) * double(n.y()) * double(n.z());
  if (cells > kMaxLatticeCells)
    throw TopoError(
        what, metres(h) + " is too fine: the lattice would have " + std::to_string(std::llround(cells)) + " cells",
        "use a spacing of at least " + metres(std::cbrt(extent.prod() / kMaxLatticeCells) * 1.01));
  // Centre the lattice on the bounding box: symmetric shapes stay symmetric for any spacing, and a
  // spacing that divides the extent puts the cell faces on the box faces.
  const Eigen::Vector3d origin = 0.5 * (shape.lo + shape.hi) - 0.5 * h * n.cast<double>();
  auto centre = [&](int i, int j, int k) {
    return Eigen::Vector3d(origin + h * Eigen::Vector3d(i + 0.5, j + 0.5, k + 0.5));
  };
  std::vector<std::uint8_t> in(static_cast<std::size_t>(cells), 0);
  auto id = [&](int i, int j, int k) { return (std::size_t(i) * n.y() + j) * n.z() + k; };
  for (int i = 0; i < n.x(); ++i)
    for (int j = 0; j < n.y(); ++j)
      for (int k = 0; k < n.z(); ++k) in[id(i, j, k)] = shape.inside(centre(i, j, k)) ? 1 : 0;
  auto inAt = [&](int i, int j, int k) {
    if (i < 0 || j < 0 || k < 0 || i >= n.x() || j >= n.y() || k >= n.z()) return shape.inside(centre(i, j, k));
    return in[id(i, j, k)] != 0;
  };
  VolumeCloud c;
  c.spacing = h;
  const double v = h * h * h;
  static const int off[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  for (int i = 0; i < n.x(); ++i)
    for (int j = 0; j < n.y(); ++j)
      for (int k = 0; k < n.z(); ++k) {
        if (!in[id(i, j, k)]) continue;
        bool surface = false;
        for (const auto& o : off) surface = surface || !inAt(i + o[0], j + o[1], k + o[2]);
        c.X.push_back(centre(i, j, k));
        c.V.push_back(v);
        c.surface.push_back(surface ? 1 : 0);
      }
  const double fine = cells * 8.0 <= kMaxLatticeCells ? 0.5 * h : h;
  c.contact = shapeContactSamples(shape, fine);
  c.validate("default " + shape.name + " cloud");
  return c;
}

ContactSamples shapeContactSamples(const DefaultShape& shape, double s) {
  if (!(s > 0.0) || !std::isfinite(s))
    throw TopoError("contact spacing for the " + shape.name + " shape", metres(s) + " is not a positive length",
                    "use a positive spacing");
  const Eigen::Vector3d extent = shape.hi - shape.lo;
  Eigen::Vector3i n;
  for (int a = 0; a < 3; ++a) n[a] = std::max(1, int(std::ceil(extent[a] / s - 1e-9))) + 2;
  const double points = double(n.x()) * n.y() * n.z();
  if (points > kMaxLatticeCells)
    throw TopoError("contact spacing for the " + shape.name + " shape",
                    metres(s) + " would need " + std::to_string(std::llround(points)) + " lattice points",
                    "use a spacing of at least " + metres(std::cbrt(extent.prod() / kMaxLatticeCells) * 1.01));
  const Eigen::Vector3d origin = 0.5 * (shape.lo + shape.hi) - 0.5 * s * n.cast<double>();
  auto at = [&](int i, int j, int k) {
    return Eigen::Vector3d(origin + s * Eigen::Vector3d(i + 0.5, j + 0.5, k + 0.5));
  };
  auto id = [&](int i, int j, int k) { return (std::size_t(i) * n.y() + j) * n.z() + k; };
  std::vector<std::uint8_t> in(static_cast<std::size_t>(points), 0);
  for (int i = 0; i < n.x(); ++i)
    for (int j = 0; j < n.y(); ++j)
      for (int k = 0; k < n.z(); ++k) in[id(i, j, k)] = shape.inside(at(i, j, k)) ? 1 : 0;
  ContactSamples out;
  out.origin = "shape surface";
  out.spacing = s;
  std::vector<int> axis;
  std::vector<double> sign;
  for (int i = 0; i < n.x(); ++i)
    for (int j = 0; j < n.y(); ++j)
      for (int k = 0; k < n.z(); ++k)
        for (int a = 0; a < 3; ++a) {
          const int i2 = i + (a == 0), j2 = j + (a == 1), k2 = k + (a == 2);
          if (i2 >= n.x() || j2 >= n.y() || k2 >= n.z() || in[id(i, j, k)] == in[id(i2, j2, k2)]) continue;
          Eigen::Vector3d p_in = at(i, j, k), p_out = at(i2, j2, k2);
          if (!in[id(i, j, k)]) std::swap(p_in, p_out);
          for (int it = 0; it < 60 && (p_out - p_in).norm() > 1e-12; ++it) {
            const Eigen::Vector3d mid = 0.5 * (p_in + p_out);
            (shape.inside(mid) ? p_in : p_out) = mid;
          }
          out.X.push_back(0.5 * (p_in + p_out));
          axis.push_back(a);
          sign.push_back(in[id(i, j, k)] ? 1.0 : -1.0);  // +1: inside → outside along +a
        }
  // Normals from a plane fit of the crossings within 2.5 s. Lines along axis a cross a surface element
  // dA of normal n |n_a| dA / s² times, so weights that add up to the area are s² / Σ_{b∈K} |n_b| for
  // every crossing, K the axes whose lines cross the surface at |n_b| ≥ 0.2 (crossings nearly
  // tangent to the surface are left out: they are few, and each would stand for little area or, with
  // the axis as its normal as once at an ill-fitted point, for a full cell: the tumbler twin then rocked
  // +3.2 % slow at 10°). At an edge or a corner the plane fit is meaningless (the neighbours spread in
  // all three directions): the crossing's axis is the better guess there, standing for s² |n_a|.
  const SpatialGrid grid(out.X, 2.5 * s);
  const double r2 = 2.5 * s * 2.5 * s;
  constexpr double kTangent = 0.2;
  ContactSamples kept;
  kept.origin = out.origin;
  kept.spacing = s;
  for (std::size_t q = 0; q < out.X.size(); ++q) {
    const Eigen::Vector3d& p = out.X[q];
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    Eigen::Matrix3d C = Eigen::Matrix3d::Zero();
    int m = 0;
    grid.query(p, [&](int, const Eigen::Vector3d& x) {
      if ((x - p).squaredNorm() < r2) {
        c += x;
        C += x * x.transpose();
        ++m;
      }
    });
    Eigen::Vector3d nq = Eigen::Vector3d::Unit(axis[q]) * sign[q];
    double area = s * s;
    if (m >= 4) {
      c /= m;
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(C / m - c * c.transpose());
      Eigen::Vector3d e = es.eigenvectors().col(0).normalized();
      if (e[axis[q]] * sign[q] < 0) e = -e;
      if (es.eigenvalues()[0] < 0.05 * es.eigenvalues()[1]) {  // a smooth surface
        if (std::abs(e[axis[q]]) < kTangent) continue;
        double crossing = 0.0;
        for (int b = 0; b < 3; ++b)
          if (std::abs(e[b]) >= kTangent) crossing += std::abs(e[b]);
        nq = e;
        area = s * s / crossing;
      } else if (std::abs(e[axis[q]]) > kTangent) {
        nq = e;
        area = s * s * std::abs(e[axis[q]]);
      }
    }
    kept.X.push_back(p);
    kept.normal.push_back(nq);
    kept.area.push_back(area);
  }
  out = std::move(kept);
  return out;
}

}  // namespace topo_gaussian
