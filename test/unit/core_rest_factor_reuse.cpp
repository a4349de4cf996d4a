// The rest stiffness's factor kept from one design to the next (rest_factor_reuse.h): a next design
// solved with the earlier design's factor reaches the equilibrium a fresh factor gives (to Newton's
// tolerance); another clamp or inertia, or a factor a live simulator holds, gets its own; the rule
// that renews a factor weighs the extra applications against a new factor's cost (also through
// find()); a factor whose application failed is dropped, and the host's fallback for a refused
// external factor is not kept.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "test_clouds.h"
#include "test_soft_bodies.h"
#include "topo_gaussian/common/error.h"
#include "topo_gaussian/physics/rest_factor_reuse.h"
#include "topo_gaussian/physics/soft_body.h"

using namespace topo_gaussian;

namespace {

/// The design: a 12-cell cantilever whose pressurised core of E chamber_young reaches chamber_cells cells.
std::unique_ptr<SoftBodySimulator> makeDesign(double chamber_young, int chamber_cells, const SoftBodyOptions& so,
                                              int clamp_cells = 1) {
  return topo_test::pneumaticCantilever(12, chamber_young, chamber_cells, so, clamp_cells);
}

/// An external factor that refuses to factorise (the GPU without memory) or to solve (a device error).
class FailingSolver : public CholeskySolver {
 public:
  explicit FailingSolver(bool at_factorize) : at_factorize_(at_factorize) {}
  bool factorize(const Eigen::SparseMatrix<double>&) override {
    if (at_factorize_) throw TopoError("test solver", "no memory", "none");
    return true;
  }
  void solve(const Eigen::VectorXd&, Eigen::VectorXd*) const override {
    throw TopoError("test solver", "a device error", "none");
  }
  std::string name() const override { return "test solver"; }
  double bytes() const override { return 0.0; }

 private:
  bool at_factorize_;
};

double largestDifference(const SoftBodySimulator& a, const SoftBodySimulator& b) {
  double d = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) d = std::max(d, (a.positions()[i] - b.positions()[i]).norm());
  return d;
}

double largestDisplacement(const SoftBodySimulator& s) {
  double d = 0.0;
  for (std::size_t i = 0; i < s.size(); ++i) d = std::max(d, (s.positions()[i] - s.sph().restPositions()[i]).norm());
  return d;
}

}  // namespace

TEST(RestFactorReuse, RenewsAFactorWhenTheExtraApplicationsCostMoreThanANewOne) {
  // 50 more applications at 10 ms are 0.5 s: below a 0.6 s factor, kept; 70 more are 0.7 s: renewed.
  EXPECT_FALSE(RestFactorReuse::refactorise(100, 150, 0.01, 0.6));
  EXPECT_TRUE(RestFactorReuse::refactorise(100, 170, 0.01, 0.6));
  EXPECT_FALSE(RestFactorReuse::refactorise(100, 80, 0.01, 0.0));  // fewer than the first use: kept
}

TEST(RestFactorReuse, ANextDesignReachesTheEquilibriumOfAFreshFactor) {
  SoftBodyOptions so;
  so.rest_factor_reuse = std::make_shared<RestFactorReuse>(1e9);  // a new factor "costs" 1e9 s: always kept
  NewtonOptions newton;
  newton.tolerance = 1e-10;
  {
    auto first = makeDesign(1e5, 8, so);  // the design the factor is made for
    ASSERT_TRUE(first->solveStatic(newton, 2).newton.converged);
  }
  // The next designs: a longer chamber, then a stiffer one; each against a fresh factor of its own.
  for (const auto& [young, cells] : {std::pair<double, int>{1e5, 10}, {3e5, 10}}) {
    auto reused = makeDesign(young, cells, so);
    const SolveReport r = reused->solveStatic(newton, 2);
    auto fresh = makeDesign(young, cells, SoftBodyOptions());
    const SolveReport f = fresh->solveStatic(newton, 2);
    ASSERT_TRUE(r.newton.converged) << r.newton.message;
    ASSERT_TRUE(f.newton.converged) << f.newton.message;
    EXPECT_GT(largestDisplacement(*fresh), 5e-5) << "the chamber bends the cantilever (~80 µm)";
    EXPECT_LT(largestDifference(*reused, *fresh), 1e-7 * largestDisplacement(*fresh))
        << "E " << young << ", chamber " << cells << " cells: CG " << r.newton.cg_iterations << " reused / "
        << f.newton.cg_iterations << " fresh";
    reused.reset();  // the factor is free for the next design
  }
  const RestFactorReuse::Counts c = so.rest_factor_reuse->counts();
  EXPECT_EQ(c.factors, 1);
  EXPECT_EQ(c.reuses, 2);
}

TEST(RestFactorReuse, AnotherClampOrAFactorStillHeldGetsItsOwn) {
  SoftBodyOptions so;
  so.rest_factor_reuse = std::make_shared<RestFactorReuse>();
  auto held = makeDesign(1e5, 8, so);
  held->systemPreconditioner(0.0);
  auto next = makeDesign(1e5, 9, so);
  next->systemPreconditioner(0.0);  // `held` still holds the factor: not shared
  EXPECT_EQ(so.rest_factor_reuse->lastRefusal(), "held by another simulator");
  EXPECT_EQ(so.rest_factor_reuse->counts().factors, 2);
  next.reset();
  held.reset();
  auto clamped_more = makeDesign(1e5, 8, so, 2);
  clamped_more->systemPreconditioner(0.0);
  EXPECT_EQ(so.rest_factor_reuse->lastRefusal(), "another body, clamp or inertia");
  EXPECT_EQ(so.rest_factor_reuse->counts().factors, 3);
  clamped_more->systemPreconditioner(1e6);  // an implicit step's inertia: its own factor too
  EXPECT_EQ(so.rest_factor_reuse->counts().factors, 4);
  EXPECT_EQ(so.rest_factor_reuse->counts().reuses, 0);
}

TEST(RestFactorReuse, RenewsThroughFindWhenTheLastUseTookMoreApplications) {
  SoftBodyOptions so;
  // a new factor "costs" nothing; the rule between uses only (the one during a use: below)
  so.rest_factor_reuse = std::make_shared<RestFactorReuse>(0.0, false);
  Eigen::VectorXd r, z;
  {
    auto first = makeDesign(1e5, 8, so);  // its first use: one application
    r = Eigen::VectorXd::Ones(3 * static_cast<Eigen::Index>(first->size()));
    first->systemPreconditioner(0.0)(r, &z);
  }
  {
    auto second = makeDesign(1e5, 10, so);  // kept; a static solve: many applications
    ASSERT_TRUE(second->solveStatic(NewtonOptions(), 2).newton.converged);
  }
  EXPECT_EQ(so.rest_factor_reuse->counts().reuses, 1);
  auto third = makeDesign(1e5, 10, so);
  third->systemPreconditioner(0.0);
  const std::string why = so.rest_factor_reuse->lastRefusal();
  EXPECT_NE(why.find("its last use took"), std::string::npos) << why;
  EXPECT_NE(why.find("against 1 in its first"), std::string::npos) << why;
  EXPECT_EQ(so.rest_factor_reuse->counts().factors, 2);
  third->systemPreconditioner(0.0);  // the same simulator again: the same use, nothing counted
  EXPECT_EQ(so.rest_factor_reuse->counts().factors, 2);
  EXPECT_EQ(so.rest_factor_reuse->counts().reuses, 1);
}

// The rule during a use: a design whose solves take more applications each than the factor's own
// design took renews the factor within its own solve when a new factor costs less than the extra
// applications (here nothing), and still reaches a fresh factor's equilibrium; where a new factor
// costs more (1e9 s) it is kept through the solve.
TEST(RestFactorReuse, RenewsDuringAUseWhenItsSolvesTakeMoreApplicationsEach) {
  NewtonOptions newton;
  newton.tolerance = 1e-10;
  for (const double factor_seconds : {0.0, 1e9}) {
    SoftBodyOptions so;
    so.rest_factor_reuse = std::make_shared<RestFactorReuse>(factor_seconds);
    {
      auto first = makeDesign(1e5, 8, so);  // the factor's own design: its applications a solve
      ASSERT_TRUE(first->solveStatic(newton, 2).newton.converged);
    }
    auto far = makeDesign(2e6, 12, so);  // a much stiffer, longer chamber: more applications a solve
    const SolveReport r = far->solveStatic(newton, 2);
    ASSERT_TRUE(r.newton.converged) << r.newton.message;
    auto fresh = makeDesign(2e6, 12, SoftBodyOptions());
    ASSERT_TRUE(fresh->solveStatic(newton, 2).newton.converged);
    EXPECT_LT(largestDifference(*far, *fresh), 1e-7 * largestDisplacement(*fresh));
    const RestFactorReuse::Counts c = so.rest_factor_reuse->counts();
    EXPECT_EQ(c.reuses, 1);
    if (factor_seconds == 0.0) {
      EXPECT_EQ(c.renewed_during_use, 1);
      EXPECT_EQ(c.factors, 2);
      const std::string why = so.rest_factor_reuse->lastRefusal();
      EXPECT_NE(why.find("during a use"), std::string::npos) << why;
    } else {
      EXPECT_EQ(c.renewed_during_use, 0);
      EXPECT_EQ(c.factors, 1);
    }
  }
}

TEST(RestFactorReuse, AFailedFactorIsDroppedAndAHostFallbackIsNotKept) {
  SoftBodyOptions so;
  so.rest_factor_reuse = std::make_shared<RestFactorReuse>(1e9);
  so.cholesky_external = [] { return std::make_unique<FailingSolver>(false); };
  {
    auto a = makeDesign(1e5, 8, so);
    Eigen::VectorXd r = Eigen::VectorXd::Ones(3 * static_cast<Eigen::Index>(a->size())), z;
    EXPECT_THROW(a->systemPreconditioner(0.0)(r, &z), TopoError);
  }
  {
    auto b = makeDesign(1e5, 9, so);
    b->systemPreconditioner(0.0);
    EXPECT_EQ(so.rest_factor_reuse->lastRefusal(), "its application failed");
    EXPECT_EQ(so.rest_factor_reuse->counts().factors, 2);
  }
  // The external factor refused (the GPU's memory): the host's factor, with a note, is not kept.
  SoftBodyOptions fallback = so;
  fallback.rest_factor_reuse = std::make_shared<RestFactorReuse>(1e9);
  fallback.cholesky_external = [] { return std::make_unique<FailingSolver>(true); };
  auto c = makeDesign(1e5, 8, fallback);
  c->systemPreconditioner(0.0);
  EXPECT_NE(c->preconditionerNote().find("on the host, not the GPU"), std::string::npos) << c->preconditionerNote();
  EXPECT_EQ(fallback.rest_factor_reuse->counts().factors, 0);
}
