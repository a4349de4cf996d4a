// Topology: representations (point, quadric, neural), indicator, materials, neighbour lists and
// boundary shells. Gradients are checked against central differences.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/physics/neighbor_list.h"
#include "topo_gaussian/topology/indicator.h"
#include "topo_gaussian/topology/materials.h"
#include "topo_gaussian/topology/neural_representation.h"
#include "topo_gaussian/topology/point_representation.h"
#include "topo_gaussian/topology/quadric_representation.h"
#include "topo_gaussian/topology/representation.h"

using namespace topo_gaussian;

namespace {

std::vector<Eigen::Vector3d> randomPoints(std::size_t n, unsigned seed, const Eigen::Vector3d& lo,
                                          const Eigen::Vector3d& hi) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  std::vector<Eigen::Vector3d> X(n);
  for (auto& x : X)
    for (int a = 0; a < 3; ++a) x[a] = lo[a] + (hi[a] - lo[a]) * U(rng);
  return X;
}

std::vector<double> randomWeights(std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> N(0.0, 1.0);
  std::vector<double> w(n);
  for (auto& v : w) v = N(rng) / static_cast<double>(n);  // keeps L = Σ w r of order one
  return w;
}

double projected(const Representation& rep, const Eigen::VectorXd& theta, const IndicatorOptions& opt,
                 const std::vector<double>& w) {
  std::vector<double> r;
  evaluateIndicator(rep, theta, opt, &r);
  double L = 0.0;
  for (std::size_t i = 0; i < r.size(); ++i) L += w[i] * r[i];
  return L;
}

// Relative error of one component, with a floor relative to the whole gradient so that components
// that are (almost) zero are compared in absolute terms.
double relError(double analytic, double numeric, double scale) {
  return std::abs(analytic - numeric) / std::max({std::abs(analytic), std::abs(numeric), 1e-3 * scale});
}

// Checks dL/dθ from indicatorBackward against central differences on `indices` and along a random
// direction. Returns the worst relative error.
double checkGradient(const Representation& rep, const Eigen::VectorXd& theta, const IndicatorOptions& opt,
                     const std::vector<double>& w, const std::vector<int>& indices, double h) {
  Eigen::VectorXd g;
  indicatorBackward(rep, theta, opt, w, &g);
  EXPECT_EQ(g.size(), rep.numParameters());
  const double scale = g.cwiseAbs().maxCoeff();
  EXPECT_GT(scale, 0.0);
  double worst = 0.0;
  for (int k : indices) {
    Eigen::VectorXd tp = theta, tm = theta;
    tp[k] += h;
    tm[k] -= h;
    const double fd = (projected(rep, tp, opt, w) - projected(rep, tm, opt, w)) / (2.0 * h);
    const double e = relError(g[k], fd, scale);
    EXPECT_LT(e, 1e-5) << rep.name() << " parameter " << k << ": analytic " << g[k] << " numeric " << fd;
    worst = std::max(worst, e);
  }
  // Full directional derivative along a random unit direction.
  std::mt19937 rng(99);
  std::normal_distribution<double> N(0.0, 1.0);
  Eigen::VectorXd d(theta.size());
  for (Eigen::Index k = 0; k < d.size(); ++k) d[k] = N(rng);
  d.normalize();
  const double fd = (projected(rep, theta + h * d, opt, w) - projected(rep, theta - h * d, opt, w)) / (2.0 * h);
  const double an = g.dot(d);
  const double e = std::abs(an - fd) / std::max(std::abs(an), 1e-12);
  EXPECT_LT(e, 1e-5) << rep.name() << " directional derivative: analytic " << an << " numeric " << fd;
  return std::max(worst, e);
}

std::vector<int> allIndices(int n) {
  std::vector<int> v(n);
  for (int k = 0; k < n; ++k) v[k] = k;
  return v;
}

template <class F>
std::string errorOf(F&& f) {
  try {
    f();
  } catch (const TopoError& e) {
    return e.what();
  }
  return "<no TopoError>";
}

// n³ lattice of spacing h with the outermost layer flagged as surface.
void latticeCube(int n, double h, std::vector<Eigen::Vector3d>* X, std::vector<std::uint8_t>* surface) {
  X->clear();
  surface->clear();
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        X->emplace_back(i * h, j * h, k * h);
        const bool s = i == 0 || j == 0 || k == 0 || i == n - 1 || j == n - 1 || k == n - 1;
        surface->push_back(s ? 1 : 0);
      }
}

int cube(int n) { return n <= 0 ? 0 : n * n * n; }

}  // namespace

// ---------------------------------------------------------------- quadric

TEST(Quadric, UnitSphereClosedForm) {
  // Bounds [0, 2]³: centre (1, 1, 1), scale 1, so u = x − (1, 1, 1).
  std::vector<Eigen::Vector3d> X = {{0, 0, 0},   {2, 2, 2},       {1, 1, 1}, {2, 1, 1},
                                    {1.5, 1, 1}, {1.5, 1.5, 1.5}, {0, 2, 1}};
  RepresentationOptions opt;
  opt.kind = "quadric";
  const auto rep = makeRepresentation(opt, X);
  EXPECT_EQ(rep->name(), "quadric");
  ASSERT_EQ(rep->numParameters(), 10);
  Eigen::VectorXd t = Eigen::VectorXd::Zero(10);
  t << 1, 1, 1, 0, 0, 0, 0, 0, 0, -0.25;
  std::vector<double> s;
  rep->field(t, &s);
  ASSERT_EQ(s.size(), X.size());
  const std::vector<double> expected = {3 - 0.25, 3 - 0.25, -0.25, 0.75, 0.0, 0.75 - 0.25, 2 - 0.25};
  for (std::size_t i = 0; i < X.size(); ++i) EXPECT_NEAR(s[i], expected[i], 1e-14) << "point " << i;

  // Off-diagonal entries count twice, linear and constant terms as written.
  t.setZero();
  t[3] = 1.0;  // a_xy
  t[8] = 0.5;  // b_z
  t[9] = 0.1;  // c
  rep->field(t, &s);
  for (std::size_t i = 0; i < X.size(); ++i) {
    const Eigen::Vector3d u = X[i] - Eigen::Vector3d(1, 1, 1);
    EXPECT_NEAR(s[i], 2 * u.x() * u.y() + 0.5 * u.z() + 0.1, 1e-14);
  }
  const NormalisedFrame f = NormalisedFrame::fromPoints(X);
  EXPECT_EQ(f.centre, Eigen::Vector3d(1, 1, 1));
  EXPECT_DOUBLE_EQ(f.scale, 1.0);

  // Initial design: s = initial_field everywhere; unbounded.
  rep->field(rep->initialParameters(), &s);
  for (double v : s) EXPECT_DOUBLE_EQ(v, 0.3);
  Eigen::VectorXd lo, hi;
  rep->bounds(&lo, &hi);
  ASSERT_EQ(lo.size(), 10);
  ASSERT_EQ(hi.size(), 10);
  EXPECT_TRUE(std::isinf(lo[0]) && lo[0] < 0);
  EXPECT_TRUE(std::isinf(hi[9]) && hi[9] > 0);
}

TEST(Quadric, FrameIsUnitIndependent) {
  // The same shape in millimetres and metres gives the same field for the same θ.
  auto Xm = randomPoints(200, 3, Eigen::Vector3d(-0.05, 0, 0.1), Eigen::Vector3d(0.03, 0.02, 0.2));
  std::vector<Eigen::Vector3d> Xmm(Xm.size());
  for (std::size_t i = 0; i < Xm.size(); ++i) Xmm[i] = 1000.0 * Xm[i];
  QuadricRepresentation a(Xm, 0.3), b(Xmm, 0.3);
  Eigen::VectorXd t(10);
  t << 1.0, 0.5, -0.3, 0.2, -0.1, 0.4, 0.3, -0.2, 0.1, -0.05;
  std::vector<double> sa, sb;
  a.field(t, &sa);
  b.field(t, &sb);
  for (std::size_t i = 0; i < sa.size(); ++i) EXPECT_NEAR(sa[i], sb[i], 1e-12);
  EXPECT_NEAR(b.frame().scale, 1000.0 * a.frame().scale, 1e-9);
  // fieldAt at the particles equals field.
  std::vector<double> sc;
  a.fieldAt(t, Xm, &sc);
  for (std::size_t i = 0; i < sa.size(); ++i) EXPECT_NEAR(sa[i], sc[i], 1e-14);
}

TEST(Quadric, GradientMatchesFiniteDifferences) {
  const auto X = randomPoints(500, 11, Eigen::Vector3d(-0.1, -0.05, 0), Eigen::Vector3d(0.1, 0.05, 0.08));
  RepresentationOptions opt;
  opt.kind = "quadric";
  const auto rep = makeRepresentation(opt, X);
  Eigen::VectorXd t(10);
  t << 1.2, 0.8, 1.5, 0.1, -0.2, 0.15, 0.05, -0.1, 0.2, -0.4;  // an ellipsoid-like interface inside
  IndicatorOptions io;
  io.epsilon = 0.1;
  const double worst = checkGradient(*rep, t, io, randomWeights(X.size(), 5), allIndices(10), 1e-6);
  RecordProperty("quadric_fd_rel_error", std::to_string(worst));
}

TEST(Quadric, DistanceFieldIsTheDistanceToTheSurfaceAtAnyScaleOfTheta) {
  // Bounds [0, 2]³: u = x − (1, 1, 1). The sphere |u| = 0.5 written k (|u|² − 0.25) for any k > 0.
  std::vector<Eigen::Vector3d> X = {{0, 0, 0},   {2, 2, 2},    {1.5, 1, 1}, {1.6, 1, 1},
                                    {1.4, 1, 1}, {1, 1.52, 1}, {1, 1, 1.9}};
  QuadricRepresentation q(X, 0.3);
  const double unit = 0.01;
  q.setDistanceUnit(unit);
  EXPECT_DOUBLE_EQ(q.distanceUnit(), unit);
  for (double k : {1e-3, 1.0, 250.0}) {
    Eigen::VectorXd t(10);
    t << k, k, k, 0, 0, 0, 0, 0, 0, -0.25 * k;
    std::vector<double> s;
    q.field(t, &s);
    // (|u|² − R²) / (2|u|) = (|u| − R)(|u| + R) / (2|u|): the distance |u| − R to first order.
    for (std::size_t i = 0; i < X.size(); ++i) {
      const double d = (X[i] - Eigen::Vector3d(1, 1, 1)).norm();
      const double expected = (d * d - 0.25) / std::sqrt(4 * d * d + 3e-6) / unit;  // κ²|θ_{A,b}|² = 3e-6 k²
      EXPECT_NEAR(s[i], expected, 1e-9 * std::max(1.0, std::abs(expected))) << "k " << k << " point " << i;
    }
    EXPECT_NEAR(s[2], 0.0, 1e-12);                      // on the surface
    EXPECT_NEAR(s[3], 0.11 / 1.2 / unit, 1e-3 / unit);  // 0.1 outside: 0.092 (the first-order distance)
    EXPECT_LT(s[4], -8.0);                              // 0.1 inside
  }
  // The algebraic field again with unit 0; a negative unit is refused.
  q.setDistanceUnit(0.0);
  Eigen::VectorXd t(10);
  t << 1, 1, 1, 0, 0, 0, 0, 0, 0, -0.25;
  std::vector<double> s;
  q.field(t, &s);
  EXPECT_NEAR(s[3], 0.36 - 0.25, 1e-14);
  EXPECT_NE(errorOf([&] { q.setDistanceUnit(-1.0); }).find("quadric distance unit"), std::string::npos);
}

TEST(Quadric, DistanceFieldCannotSpreadGrey) {
  // A lattice; the algebraic field of a small sphere with θ shrunk 100× is grey over most of the body, the
  // distance field of the same θ is binary (r ∉ (0.05, 0.95): |d| > 2.94 w) beyond four boundary widths w of
  // the sphere (outside, the first-order distance is (d² − R²)/(2d) < d − R).
  std::vector<Eigen::Vector3d> X;
  for (int i = 0; i < 21; ++i)
    for (int j = 0; j < 21; ++j)
      for (int k = 0; k < 21; ++k) X.emplace_back(0.005 * i, 0.005 * j, 0.005 * k);  // 0.1 m cube, h 5 mm
  QuadricRepresentation algebraic(X, 0.3), distance(X, 0.3);
  IndicatorOptions io;                      // ε 0.05
  const double w_m = 0.0025, scale = 0.05;  // boundary width half the spacing; scale = half the extent
  distance.setDistanceUnit(w_m / (io.epsilon * scale));
  Eigen::VectorXd t(10);
  t << 1, 1, 1, 0, 0, 0, 0, 0, 0, -0.16;  // |u| < 0.4: a 20 mm sphere in the middle
  t *= 0.01;
  auto greyAndFar = [&](const Representation& rep, int* grey, int* grey_far) {
    std::vector<double> r;
    evaluateIndicator(rep, t, io, &r);
    *grey = *grey_far = 0;
    for (std::size_t i = 0; i < X.size(); ++i) {
      const bool g = r[i] > 0.05 && r[i] < 0.95;
      const double d = std::abs((X[i] - Eigen::Vector3d(0.05, 0.05, 0.05)).norm() - 0.02);
      *grey += g;
      *grey_far += g && d > 4 * w_m;
    }
  };
  int grey_a, far_a, grey_d, far_d;
  greyAndFar(algebraic, &grey_a, &far_a);
  greyAndFar(distance, &grey_d, &far_d);
  EXPECT_GT(grey_a, static_cast<int>(X.size()) / 2);  // the algebraic field: grey almost everywhere
  EXPECT_EQ(far_d, 0);                                // the distance field: grey only at the surface
  EXPECT_GT(grey_d, 0);
  EXPECT_LT(grey_d, static_cast<int>(X.size()) / 10);
}

TEST(Quadric, DistanceFieldGradientMatchesFiniteDifferences) {
  const auto X = randomPoints(500, 11, Eigen::Vector3d(-0.1, -0.05, 0), Eigen::Vector3d(0.1, 0.05, 0.08));
  QuadricRepresentation rep(X, 0.3);
  rep.setDistanceUnit(0.5);
  Eigen::VectorXd t(10);
  t << 1.2, 0.8, 1.5, 0.1, -0.2, 0.15, 0.05, -0.1, 0.2, -0.4;
  IndicatorOptions io;
  io.epsilon = 0.1;
  const double worst = checkGradient(rep, t, io, randomWeights(X.size(), 5), allIndices(10), 1e-6);
  // A hyperboloid (A indefinite) through the middle, where |∇s| is small near its saddle.
  t << 1.0, -0.7, 0.4, 0.3, 0.0, -0.2, 0.1, 0.0, -0.05, 0.02;
  const double worst_saddle = checkGradient(rep, t, io, randomWeights(X.size(), 6), allIndices(10), 1e-7);
  RecordProperty("quadric_distance_fd_rel_error", std::to_string(std::max(worst, worst_saddle)));
}

// Several gradients in one pass (the ten mass moments' dp/dθ): each column as fieldBackward gives it, for the
// algebraic and the distance field, and through the indicator (the default implementation on a point rep).
TEST(Quadric, GradientColumnsMatchOneAtATime) {
  const auto X = randomPoints(3000, 12, Eigen::Vector3d(-0.1, -0.05, 0), Eigen::Vector3d(0.1, 0.05, 0.08));
  Eigen::VectorXd t(10);
  t << 1.2, 0.8, 1.5, 0.1, -0.2, 0.15, 0.05, -0.1, 0.2, -0.4;
  Eigen::MatrixXd W(X.size(), 4);
  for (int k = 0; k < 4; ++k)
    W.col(k) = Eigen::Map<const Eigen::VectorXd>(randomWeights(X.size(), 20 + k).data(), X.size());
  W.row(7).setZero();  // a particle that no gradient reaches
  IndicatorOptions io;
  io.epsilon = 0.1;
  io.pinned.assign(X.size(), 0);
  for (std::size_t i = 0; i < X.size(); i += 5) io.pinned[i] = 1;  // no gradient through a pinned particle
  for (double unit : {0.0, 0.5}) {
    QuadricRepresentation rep(X, 0.3);
    rep.setDistanceUnit(unit);
    Eigen::MatrixXd G, Gi;
    rep.fieldBackwardColumns(t, W, &G);
    indicatorBackwardColumns(rep, t, io, W, &Gi);
    ASSERT_EQ(G.rows(), 10);
    ASSERT_EQ(G.cols(), 4);
    for (int k = 0; k < 4; ++k) {
      std::vector<double> w(W.col(k).data(), W.col(k).data() + W.rows());
      Eigen::VectorXd g, gi;
      rep.fieldBackward(t, w, &g);
      indicatorBackward(rep, t, io, w, &gi);
      EXPECT_LE((G.col(k) - g).norm(), 1e-12 * g.norm()) << "unit " << unit << " column " << k;
      EXPECT_LE((Gi.col(k) - gi).norm(), 1e-12 * gi.norm()) << "unit " << unit << " column " << k;
    }
  }
  RepresentationOptions opt;
  opt.kind = "point";
  const auto point = makeRepresentation(opt, X);
  const Eigen::VectorXd tp = Eigen::VectorXd::Constant(static_cast<Eigen::Index>(X.size()), 0.2);
  Eigen::MatrixXd Gp;
  point->fieldBackwardColumns(tp, W, &Gp);
  std::vector<double> w1(W.col(1).data(), W.col(1).data() + W.rows());
  Eigen::VectorXd g1;
  point->fieldBackward(tp, w1, &g1);
  EXPECT_EQ(Gp.col(1), g1);
  QuadricRepresentation rep(X, 0.3);
  Eigen::MatrixXd G;
  EXPECT_NE(errorOf([&] { rep.fieldBackwardColumns(t, W.topRows(10), &G); }).find("quadric field gradients"),
            std::string::npos);
}

// ---------------------------------------------------------------- point

TEST(Point, BoundsInitialAndGradient) {
  const auto X = randomPoints(300, 2, Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones());
  RepresentationOptions opt;
  opt.kind = "point";
  opt.point_bound = 2.0;
  opt.initial_field = 0.5;
  const auto rep = makeRepresentation(opt, X);
  EXPECT_EQ(rep->name(), "point");
  ASSERT_EQ(rep->numParameters(), 300);
  EXPECT_EQ(rep->numParticles(), 300u);
  const Eigen::VectorXd t0 = rep->initialParameters();
  ASSERT_EQ(t0.size(), 300);
  EXPECT_TRUE((t0.array() == 0.5).all());
  Eigen::VectorXd lo, hi;
  rep->bounds(&lo, &hi);
  ASSERT_EQ(lo.size(), 300);
  ASSERT_EQ(hi.size(), 300);
  EXPECT_TRUE((lo.array() == -2.0).all());
  EXPECT_TRUE((hi.array() == 2.0).all());

  std::mt19937 rng(8);
  std::uniform_real_distribution<double> U(-0.3, 0.3);
  Eigen::VectorXd t(300);
  for (int k = 0; k < 300; ++k) t[k] = U(rng);
  IndicatorOptions io;
  io.epsilon = 0.1;
  checkGradient(*rep, t, io, randomWeights(X.size(), 6), allIndices(300), 1e-6);
}

TEST(Point, PinnedParticlesStayPinnedWithZeroGradient) {
  const auto X = randomPoints(100, 4, Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones());
  PointRepresentation rep(X.size(), 0.3, 1.0);
  IndicatorOptions io;
  io.epsilon = 0.05;
  io.pinned.assign(X.size(), 0);
  for (std::size_t i = 0; i < X.size(); i += 3) io.pinned[i] = 1;
  io.pinned_value = 0.8;
  Eigen::VectorXd t = Eigen::VectorXd::LinSpaced(100, -0.5, 0.5);
  std::vector<double> r;
  evaluateIndicator(rep, t, io, &r);
  std::vector<double> w(X.size(), 1.0);
  Eigen::VectorXd g;
  indicatorBackward(rep, t, io, w, &g);
  for (std::size_t i = 0; i < X.size(); ++i) {
    if (io.pinned[i]) {
      EXPECT_EQ(r[i], 0.8);
      EXPECT_EQ(g[i], 0.0);
    } else {
      const double expected = 1.0 / (1.0 + std::exp(-t[i] / 0.05));
      EXPECT_NEAR(r[i], expected, 1e-15);
      EXPECT_NEAR(g[i], expected * (1 - expected) / 0.05, 1e-12);
      EXPECT_GT(g[i], 0.0);
    }
  }
}

// ---------------------------------------------------------------- neural

TEST(Neural, ParameterCountOfThePaperNetwork) {
  // 3→512 (3·512 + 2·512) + 6 × 512→512 (512² + 2·512) + 512→1 (512 + 2).
  const int expected = (3 * 512 + 1024) + 6 * (512 * 512 + 1024) + (512 + 2);
  EXPECT_EQ(expected, 1582082);
  EXPECT_EQ(NeuralRepresentation::parameterCount(8, 512), expected);
  EXPECT_EQ(NeuralRepresentation::parameterCount(4, 32), (3 * 32 + 64) + 2 * (32 * 32 + 64) + (32 + 2));

  const auto X = randomPoints(2000, 21, Eigen::Vector3d(-0.2, -0.1, 0), Eigen::Vector3d(0.2, 0.1, 0.3));
  RepresentationOptions opt;
  opt.kind = "neural";  // default 8 × 512
  const auto rep = makeRepresentation(opt, X);
  EXPECT_EQ(rep->name(), "neural");
  ASSERT_EQ(rep->numParameters(), expected);
  const Eigen::VectorXd t = rep->initialParameters();
  ASSERT_EQ(t.size(), expected);
  EXPECT_TRUE(t.allFinite());

  const auto t0 = std::chrono::steady_clock::now();
  std::vector<double> s;
  rep->field(t, &s);
  const auto t1 = std::chrono::steady_clock::now();
  Eigen::VectorXd g;
  rep->fieldBackward(t, randomWeights(X.size(), 3), &g);
  const auto t2 = std::chrono::steady_clock::now();
  const double fwd = std::chrono::duration<double>(t1 - t0).count();
  const double bwd = std::chrono::duration<double>(t2 - t1).count();
  RecordProperty("neural_8x512_2000pts_forward_s", std::to_string(fwd));
  RecordProperty("neural_8x512_2000pts_field_backward_s", std::to_string(bwd));
  std::printf("neural 8x512, 2000 particles: forward %.3f s, forward+backward %.3f s\n", fwd, bwd);

  double worst = 0.0;
  for (double v : s) worst = std::max(worst, std::abs(v - 0.3));
  EXPECT_LT(worst, 0.05);
  ASSERT_EQ(g.size(), expected);
  EXPECT_TRUE(g.allFinite());
  EXPECT_GT(g.head(3 * 512).norm(), 0.0);  // first-layer v receives gradient
}

TEST(Neural, InitialFieldIsSolidAndDeterministic) {
  const auto X = randomPoints(3000, 12, Eigen::Vector3d(-1, -2, -0.5), Eigen::Vector3d(1, 2, 0.5));
  for (unsigned seed : {1u, 2u, 3u, 4u, 5u}) {
    NeuralOptions o;
    o.depth = 4;
    o.width = 32;
    o.seed = seed;
    o.initial_field = 0.4;
    NeuralRepresentation a(o, X), b(o, X);
    const Eigen::VectorXd ta = a.initialParameters(), tb = b.initialParameters();
    EXPECT_EQ(ta, tb) << "same seed must give the same parameters";
    EXPECT_EQ(ta[ta.size() - 1], 0.4);  // output bias is the last parameter
    std::vector<double> s;
    a.field(ta, &s);
    for (double v : s) ASSERT_NEAR(v, 0.4, 0.05) << "seed " << seed;
    std::vector<double> s2;
    b.field(tb, &s2);
    EXPECT_EQ(s, s2);
    // Evaluating elsewhere in the frame works too (corners of the box, the centre).
    std::vector<double> sa;
    a.fieldAt(ta, {Eigen::Vector3d(-1, -2, -0.5), Eigen::Vector3d(1, 2, 0.5), Eigen::Vector3d::Zero()}, &sa);
    for (double v : sa) EXPECT_NEAR(v, 0.4, 0.05);
  }
  NeuralOptions o1, o2;
  o1.depth = o2.depth = 3;
  o1.width = o2.width = 16;
  o2.seed = o1.seed + 1;
  NeuralRepresentation a(o1, X), b(o2, X);
  EXPECT_NE(a.initialParameters(), b.initialParameters());
}

TEST(Neural, GradientReachesEveryLayer) {
  const auto X = randomPoints(1500, 13, Eigen::Vector3d::Zero(), Eigen::Vector3d(1, 1, 2));
  NeuralOptions o;
  o.depth = 4;
  o.width = 32;
  NeuralRepresentation rep(o, X);
  const Eigen::VectorXd t = rep.initialParameters();
  Eigen::VectorXd g;
  rep.fieldBackward(t, randomWeights(X.size(), 14), &g);
  // Per layer: v block, g block, b block all receive gradient at the initial design.
  int offset = 0;
  for (int l = 0; l < o.depth; ++l) {
    const int in = l == 0 ? 3 : o.width, out = l == o.depth - 1 ? 1 : o.width;
    EXPECT_GT(g.segment(offset, in * out).norm(), 0.0) << "v of layer " << l;
    offset += in * out;
    EXPECT_GT(g.segment(offset, out).norm(), 0.0) << "g of layer " << l;
    offset += out;
    EXPECT_GT(g.segment(offset, out).norm(), 0.0) << "b of layer " << l;
    offset += out;
  }
  EXPECT_EQ(offset, rep.numParameters());
  // The output bias derivative is Σ dL/ds exactly.
  const auto w = randomWeights(X.size(), 14);
  double sum = 0.0;
  for (double v : w) sum += v;
  EXPECT_NEAR(g[g.size() - 1], sum, 1e-14);
}

TEST(Neural, GradientMatchesFiniteDifferences) {
  const auto X = randomPoints(400, 31, Eigen::Vector3d(-0.1, -0.1, 0), Eigen::Vector3d(0.1, 0.2, 0.15));
  RepresentationOptions ro;
  ro.kind = "neural";
  ro.neural.depth = 4;
  ro.neural.width = 32;
  ro.neural.seed = 3;
  const auto base = makeRepresentation(ro, X);
  const auto& rep = dynamic_cast<const NeuralRepresentation&>(*base);
  // Move the interface into the object: output gain 1 and bias 0, so r varies over the particles.
  Eigen::VectorXd t = rep.initialParameters();
  const int P = rep.numParameters();
  t[P - 2] = 1.0;  // output g (last layer: v (width), g (1), b (1))
  t[P - 1] = 0.0;  // output b
  std::vector<double> s;
  rep.field(t, &s);
  double smin = 1e9, smax = -1e9;
  for (double v : s) smin = std::min(smin, v), smax = std::max(smax, v);
  EXPECT_LT(smax - smin, 10.0);
  EXPECT_GT(smax - smin, 0.05);  // a non-trivial field

  // Only particles well away from ReLU kinks enter the loss.
  std::vector<double> margin;
  rep.kinkMargin(t, &margin);
  auto w = randomWeights(X.size(), 32);
  int used = 0;
  for (std::size_t i = 0; i < X.size(); ++i) {
    if (margin[i] < 1e-3)
      w[i] = 0.0;
    else
      ++used;
  }
  EXPECT_GT(used, 300);

  // 30 random parameters plus the ends of every block of the first and last layers.
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> pick(0, P - 1);
  std::set<int> idx = {0, 95, 96, 127, 128, 159, P - 34, P - 3, P - 2, P - 1};
  while (idx.size() < 40) idx.insert(pick(rng));
  IndicatorOptions io;
  io.epsilon = 0.2;
  const double worst = checkGradient(rep, t, io, w, std::vector<int>(idx.begin(), idx.end()), 1e-6);
  RecordProperty("neural_fd_rel_error", std::to_string(worst));
}

// ---------------------------------------------------------------- indicator

TEST(Indicator, SigmoidValuesAndSaturation) {
  const std::vector<Eigen::Vector3d> X(5, Eigen::Vector3d::Zero());
  PointRepresentation rep(5, 0.0, 2000.0);
  Eigen::VectorXd t(5);
  t << -1000.0, -0.05, 0.0, 0.05, 1000.0;
  IndicatorOptions io;
  io.epsilon = 0.05;
  std::vector<double> r;
  evaluateIndicator(rep, t, io, &r);
  EXPECT_EQ(r[0], 0.0);
  EXPECT_NEAR(r[1], 1.0 / (1.0 + std::exp(1.0)), 1e-15);
  EXPECT_EQ(r[2], 0.5);
  EXPECT_NEAR(r[3], 1.0 / (1.0 + std::exp(-1.0)), 1e-15);
  EXPECT_EQ(r[4], 1.0);
  Eigen::VectorXd g;
  indicatorBackward(rep, t, io, std::vector<double>(5, 1.0), &g);
  EXPECT_TRUE(g.allFinite());
  EXPECT_EQ(g[0], 0.0);
  EXPECT_NEAR(g[2], 0.25 / 0.05, 1e-12);
}

TEST(Indicator, BoundaryShellCountsLatticeLayers) {
  const int n = 12;
  const double h = 0.01;
  std::vector<Eigen::Vector3d> X;
  std::vector<std::uint8_t> surface;
  latticeCube(n, h, &X, &surface);
  auto count = [](const std::vector<std::uint8_t>& f) {
    int c = 0;
    for (auto v : f) c += v ? 1 : 0;
    return c;
  };
  EXPECT_EQ(count(boundaryShell(X, surface, 0.0)), cube(n) - cube(n - 2));
  EXPECT_EQ(count(boundaryShell(X, surface, -1.0)), cube(n) - cube(n - 2));
  // Distance from layer k to the surface is k·h (strictly less than the thickness to count).
  EXPECT_EQ(count(boundaryShell(X, surface, 0.5 * h)), cube(n) - cube(n - 2));
  EXPECT_EQ(count(boundaryShell(X, surface, 1.5 * h)), cube(n) - cube(n - 4));
  EXPECT_EQ(count(boundaryShell(X, surface, 2.5 * h)), cube(n) - cube(n - 6));
  EXPECT_EQ(count(boundaryShell(X, surface, 3.5 * h)), cube(n) - cube(n - 8));
  EXPECT_EQ(count(boundaryShell(X, surface, 10.0 * h)), cube(n));
  // Exactly which particles: layer index min(i, n−1−i, …) < 3 for thickness 2.5 h.
  const auto shell = boundaryShell(X, surface, 2.5 * h);
  for (int k = 0, p = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i, ++p) {
        const int layer = std::min({i, j, k, n - 1 - i, n - 1 - j, n - 1 - k});
        ASSERT_EQ(shell[p] != 0, layer < 3) << i << " " << j << " " << k;
      }
  // No surface particles: nothing is in the shell.
  EXPECT_EQ(count(boundaryShell(X, std::vector<std::uint8_t>(X.size(), 0), 2.5 * h)), 0);
  EXPECT_NE(errorOf([&] { boundaryShell(X, std::vector<std::uint8_t>(3, 1), h); }).find("surface flags"),
            std::string::npos);
}

// ---------------------------------------------------------------- materials

TEST(Materials, ValueDerivativeFloorAndContinuous) {
  MaterialInterpolation m;
  m.value_r0 = 10.0;
  m.value_r1 = 1000.0;
  m.power = 3.0;
  m.floor = 1e-3;
  EXPECT_NO_THROW(m.validate("density"));
  EXPECT_DOUBLE_EQ(m.value(0.0), 10.0);
  EXPECT_DOUBLE_EQ(m.value(1.0), 1000.0);
  EXPECT_DOUBLE_EQ(m.value(0.5), 10.0 + 0.125 * 990.0);
  const double h = 1e-6;
  for (double r : {0.05, 0.2, 0.5, 0.77, 0.95}) {
    const double fd = (m.value(r + h) - m.value(r - h)) / (2 * h);
    EXPECT_NEAR(m.derivative(r), fd, 1e-6 * std::abs(fd)) << "r = " << r;
    EXPECT_NEAR(m.derivative(r), 3 * r * r * 990.0, 1e-9);
  }
  // Floor active: q = 1000 r³ < 1 for r < 0.1.
  MaterialInterpolation f;
  f.value_r0 = 0.0;
  f.value_r1 = 1000.0;
  f.power = 3.0;
  f.floor = 1.0;
  EXPECT_DOUBLE_EQ(f.value(0.05), 1.0);
  EXPECT_EQ(f.derivative(0.05), 0.0);
  EXPECT_DOUBLE_EQ(f.value(0.0), 1.0);
  EXPECT_EQ(f.derivative(0.0), 0.0);
  EXPECT_NEAR(f.derivative(0.5), 750.0, 1e-9);
  // Continuous mode forces p = 1.
  MaterialInterpolation c = m;
  c.continuous = true;
  EXPECT_DOUBLE_EQ(c.value(0.25), 10.0 + 0.25 * 990.0);
  EXPECT_DOUBLE_EQ(c.derivative(0.25), 990.0);
  EXPECT_DOUBLE_EQ(c.derivative(0.0), 990.0);
  // apply() matches value()/derivative() and works without dq.
  const std::vector<double> r = {0.0, 0.1, 0.5, 1.0};
  std::vector<double> q, dq;
  m.apply(r, &q, &dq);
  ASSERT_EQ(q.size(), 4u);
  ASSERT_EQ(dq.size(), 4u);
  for (std::size_t i = 0; i < r.size(); ++i) {
    EXPECT_EQ(q[i], m.value(r[i]));
    EXPECT_EQ(dq[i], m.derivative(r[i]));
  }
  m.apply(r, &q, nullptr);
  EXPECT_EQ(q.size(), 4u);
}

TEST(Materials, ValidateNamesTheField) {
  MaterialInterpolation m;
  m.value_r0 = -1.0;
  std::string e = errorOf([&] { m.validate("density"); });
  EXPECT_NE(e.find("density"), std::string::npos) << e;
  EXPECT_NE(e.find("value_r0"), std::string::npos) << e;
  EXPECT_NE(e.find("negative"), std::string::npos) << e;
  m = MaterialInterpolation();
  m.value_r1 = -5.0;
  EXPECT_NE(errorOf([&] { m.validate("density"); }).find("value_r1"), std::string::npos);
  m = MaterialInterpolation();
  m.power = 0.5;
  e = errorOf([&] { m.validate("stiffness"); });
  EXPECT_NE(e.find("power"), std::string::npos) << e;
  EXPECT_NE(e.find("stiffness"), std::string::npos) << e;
  m = MaterialInterpolation();
  m.floor = 0.0;
  EXPECT_NE(errorOf([&] { m.validate("density"); }).find("floor"), std::string::npos);
  m.floor = -1.0;
  EXPECT_NE(errorOf([&] { m.validate("density"); }).find("floor"), std::string::npos);
  m = MaterialInterpolation();
  m.value_r1 = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(errorOf([&] { m.validate("density"); }).find("value_r1"), std::string::npos);
}

// ---------------------------------------------------------------- neighbour list

TEST(NeighborList, MatchesBruteForce) {
  const auto X = randomPoints(2000, 41, Eigen::Vector3d::Zero(), Eigen::Vector3d(1.0, 0.5, 0.8));
  const double radius = 0.1;
  const NeighborList nl = buildNeighborList(X, radius);
  const NeighborList nls = buildNeighborList(X, radius, true);
  ASSERT_EQ(nl.size(), X.size());
  ASSERT_EQ(nl.offsets.size(), X.size() + 1);
  ASSERT_EQ(nls.size(), X.size());
  EXPECT_EQ(nls.indices.size(), nl.indices.size() + X.size());
  std::size_t total = 0;
  for (std::size_t i = 0; i < X.size(); ++i) {
    std::vector<int> brute;
    for (std::size_t j = 0; j < X.size(); ++j)
      if (j != i && (X[j] - X[i]).squaredNorm() < radius * radius) brute.push_back(static_cast<int>(j));
    const std::vector<int> got(nl.begin(i), nl.end(i));
    ASSERT_EQ(got, brute) << "point " << i;
    std::vector<int> with_self = brute;
    with_self.insert(std::lower_bound(with_self.begin(), with_self.end(), static_cast<int>(i)), static_cast<int>(i));
    ASSERT_EQ(std::vector<int>(nls.begin(i), nls.end(i)), with_self) << "point " << i;
    total += brute.size();
  }
  EXPECT_EQ(nl.indices.size(), total);
  EXPECT_GT(total, 10 * X.size());  // a meaningful density
}

TEST(NeighborList, SparseCloudsAndEdgeCases) {
  // Two clusters far apart: the grid switches to sorted cell keys; results still exact.
  auto X = randomPoints(300, 42, Eigen::Vector3d::Zero(), Eigen::Vector3d(0.2, 0.2, 0.2));
  const auto far = randomPoints(300, 43, Eigen::Vector3d(500, -300, 800), Eigen::Vector3d(500.2, -299.8, 800.2));
  X.insert(X.end(), far.begin(), far.end());
  const double radius = 0.05;
  const NeighborList nl = buildNeighborList(X, radius);
  for (std::size_t i = 0; i < X.size(); ++i) {
    std::vector<int> brute;
    for (std::size_t j = 0; j < X.size(); ++j)
      if (j != i && (X[j] - X[i]).squaredNorm() < radius * radius) brute.push_back(static_cast<int>(j));
    ASSERT_EQ(std::vector<int>(nl.begin(i), nl.end(i)), brute) << "point " << i;
  }
  // Empty cloud; single point; duplicates.
  EXPECT_EQ(buildNeighborList({}, 0.1).size(), 0u);
  EXPECT_EQ(buildNeighborList({}, 0.1).offsets.size(), 1u);
  const NeighborList one = buildNeighborList({Eigen::Vector3d(1, 2, 3)}, 0.1, true);
  ASSERT_EQ(one.size(), 1u);
  EXPECT_EQ(one.count(0), 1);
  const NeighborList dup = buildNeighborList({Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()}, 0.1);
  EXPECT_EQ(dup.count(0), 1);
  EXPECT_EQ(dup.count(1), 1);
  // Bad radius / points.
  for (double bad : {0.0, -0.1, std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()})
    EXPECT_NE(errorOf([&] { buildNeighborList(X, bad); }).find("radius"), std::string::npos) << bad;
  std::vector<Eigen::Vector3d> nan_pts = {Eigen::Vector3d::Zero(),
                                          Eigen::Vector3d(std::numeric_limits<double>::quiet_NaN(), 0, 0)};
  EXPECT_NE(errorOf([&] { buildNeighborList(nan_pts, 0.1); }).find("point 1"), std::string::npos);
}

// ---------------------------------------------------------------- bad input

TEST(TopologyErrors, BadParametersKindsAndOptions) {
  const auto X = randomPoints(50, 51, Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones());
  RepresentationOptions opt;
  opt.kind = "quadric";
  const auto q = makeRepresentation(opt, X);
  std::vector<double> s;
  std::string e = errorOf([&] { q->field(Eigen::VectorXd::Zero(9), &s); });
  EXPECT_NE(e.find("quadric"), std::string::npos) << e;
  EXPECT_NE(e.find("has 9 values, expected 10"), std::string::npos) << e;
  Eigen::VectorXd t = q->initialParameters();
  t[4] = std::numeric_limits<double>::quiet_NaN();
  e = errorOf([&] { q->field(t, &s); });
  EXPECT_NE(e.find("entry 4 is not finite"), std::string::npos) << e;
  Eigen::VectorXd g;
  e = errorOf([&] { q->fieldBackward(t, std::vector<double>(50, 1.0), &g); });
  EXPECT_NE(e.find("not finite"), std::string::npos) << e;
  e = errorOf([&] { q->fieldBackward(q->initialParameters(), std::vector<double>(49, 1.0), &g); });
  EXPECT_NE(e.find("49 values for 50 particles"), std::string::npos) << e;

  opt.kind = "neural";
  opt.neural.depth = 3;
  opt.neural.width = 8;
  const auto nn = makeRepresentation(opt, X);
  e = errorOf([&] { nn->field(Eigen::VectorXd::Zero(3), &s); });
  EXPECT_NE(e.find("neural"), std::string::npos) << e;
  EXPECT_NE(e.find("expected " + std::to_string(nn->numParameters())), std::string::npos) << e;
  t = nn->initialParameters();
  t[t.size() - 1] = std::numeric_limits<double>::infinity();
  EXPECT_NE(errorOf([&] { nn->fieldBackward(t, std::vector<double>(50, 1.0), &g); }).find("not finite"),
            std::string::npos);

  opt.kind = "point";
  const auto p = makeRepresentation(opt, X);
  EXPECT_NE(errorOf([&] { p->field(Eigen::VectorXd::Zero(51), &s); }).find("expected 50"), std::string::npos);

  opt.kind = "voxel";
  e = errorOf([&] { makeRepresentation(opt, X); });
  EXPECT_NE(e.find("voxel"), std::string::npos) << e;
  EXPECT_NE(e.find("point, quadric, neural"), std::string::npos) << e;

  opt.kind = "neural";
  opt.neural.depth = 1;
  EXPECT_NE(errorOf([&] { makeRepresentation(opt, X); }).find("depth"), std::string::npos);
  opt.neural.depth = 3;
  opt.neural.width = 0;
  EXPECT_NE(errorOf([&] { makeRepresentation(opt, X); }).find("width"), std::string::npos);
  opt.kind = "point";
  opt.point_bound = 0.0;
  EXPECT_NE(errorOf([&] { makeRepresentation(opt, X); }).find("point_bound"), std::string::npos);
  opt.point_bound = 1.0;
  opt.initial_field = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(errorOf([&] { makeRepresentation(opt, X); }).find("initial_field"), std::string::npos);
  opt = RepresentationOptions();
  EXPECT_NE(errorOf([&] { makeRepresentation(opt, {}); }).find("empty"), std::string::npos);
  std::vector<Eigen::Vector3d> bad = X;
  bad[7].y() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(errorOf([&] { makeRepresentation(opt, bad); }).find("particle 7"), std::string::npos);

  // Indicator options.
  IndicatorOptions io;
  std::vector<double> r;
  for (double eps : {0.0, -0.1, std::numeric_limits<double>::quiet_NaN()}) {
    io.epsilon = eps;
    e = errorOf([&] { evaluateIndicator(*q, q->initialParameters(), io, &r); });
    EXPECT_NE(e.find("epsilon"), std::string::npos) << e;
    EXPECT_NE(errorOf([&] {
                indicatorBackward(*q, q->initialParameters(), io, std::vector<double>(50, 1.0), &g);
              }).find("epsilon"),
              std::string::npos);
  }
  io.epsilon = 0.05;
  io.pinned.assign(10, 1);
  e = errorOf([&] { evaluateIndicator(*q, q->initialParameters(), io, &r); });
  EXPECT_NE(e.find("pinned mask"), std::string::npos) << e;
  io.pinned.clear();
  e = errorOf([&] { indicatorBackward(*q, q->initialParameters(), io, std::vector<double>(3, 1.0), &g); });
  EXPECT_NE(e.find("dL/dr"), std::string::npos) << e;
}
