// The rest stiffness's factor kept from one design to the next (rest_factor_reuse.h): a next design
// solved with the earlier design's factor reaches the equilibrium a fresh factor gives (to Newton's
// tolerance); another clamp or inertia, or a factor a live simulator holds, gets its own; the rule
// that renews a factor weighs the extra applications against a new factor's cost.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "test_clouds.h"
#include "test_soft_bodies.h"
#include "topo_gaussian/physics/rest_factor_reuse.h"
#include "topo_gaussian/physics/soft_body.h"

using namespace topo_gaussian;

namespace {

/// The design: a 12-cell cantilever whose pressurised core of E chamber_young reaches chamber_cells cells.
std::unique_ptr<SoftBodySimulator> makeDesign(double chamber_young, int chamber_cells, const SoftBodyOptions& so,
                                              int clamp_cells = 1) {
  return topo_test::pneumaticCantilever(12, chamber_young, chamber_cells, so, clamp_cells);
}

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
  so.rest_factor_reuse = std::make_shared<RestFactorReuse>();
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
