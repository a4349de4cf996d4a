// workflow/experiment_loop.h: the stopping rule on constructed analyses, the suggestion's overrides
// round trip, and one small loop on a coarse rig twin.
#include <gtest/gtest.h>

#include <chrono>
#include <functional>
#include <cmath>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/workflow/experiment_loop.h"

using namespace topo_gaussian;
using namespace topo_gaussian::inference;
using namespace topo_gaussian::workflow;

namespace {

/// An analysis whose moments have relative stds 1/s_j (J diagonal in natural units 1): s_j = 1000 is
/// determined (0.1 % < 2 %), s_j = 10 is not (10 %).
IdentifiabilityAnalysis analysisWith(int determined) {
  MomentJacobian J = MomentJacobian::Zero(10, 10);
  for (int j = 0; j < 10; ++j) J(j, j) = j < determined ? 1000.0 : 10.0;
  IdentifiabilityAnalysis a = analyseMomentJacobian(J, MomentVector::Ones());
  a.has_suggestion = true;
  a.suggestion.kind = "hang";
  a.suggestion.sentence = "hang it from (0, 0, 0.02) m";
  a.suggestion.score_gain = 1.5;
  return a;
}

}  // namespace

TEST(ExperimentLoop, StopsWhenAllTenAreDeterminedAndLittleIsUncertain) {
  const ExperimentLoopOptions o;  // 5 experiments, 2 % uncertain
  const IdentifiabilityAnalysis all = analysisWith(10);
  ASSERT_EQ(all.moments.size(), 10u);
  EXPECT_EQ(decideNextStep(all, 0.01, 3, o).verdict, LoopVerdict::GoalReached);
  // determined but the region still uncertain: perform the suggestion
  const LoopDecision more = decideNextStep(all, 0.10, 3, o);
  EXPECT_EQ(more.verdict, LoopVerdict::Continue) << more.reason;
  EXPECT_TRUE(more.continues());
  EXPECT_NE(more.reason.find("hang it from"), std::string::npos) << more.reason;
  // an unknown uncertain fraction is not small
  EXPECT_EQ(decideNextStep(all, NAN, 3, o).verdict, LoopVerdict::Continue);
  // the goal is checked before the count: reached with the last allowed experiment
  EXPECT_EQ(decideNextStep(all, 0.01, 5, o).verdict, LoopVerdict::GoalReached);
}

TEST(ExperimentLoop, StopsAtTheMostExperimentsOrWithoutAUsefulSuggestion) {
  ExperimentLoopOptions o;
  o.max_experiments = 4;
  IdentifiabilityAnalysis a = analysisWith(7);  // Ixy, Ixz, Iyz free
  const LoopDecision go = decideNextStep(a, 0.01, 3, o);
  EXPECT_EQ(go.verdict, LoopVerdict::Continue);
  EXPECT_NE(go.reason.find("Ixy Ixz Iyz"), std::string::npos) << "names the free moments: " << go.reason;
  const LoopDecision full = decideNextStep(a, 0.01, 4, o);
  EXPECT_EQ(full.verdict, LoopVerdict::MaxExperiments);
  EXPECT_EQ(verdictName(full.verdict), "max_experiments");

  IdentifiabilityAnalysis none = a;
  none.has_suggestion = false;
  EXPECT_EQ(decideNextStep(none, 0.01, 3, o).verdict, LoopVerdict::NoSuggestion);

  IdentifiabilityAnalysis flat = a;  // gains nothing and fixes nothing new
  flat.suggestion.score_gain = 0.0;
  flat.suggestion.directions_after = flat.determined_directions;
  EXPECT_EQ(decideNextStep(flat, 0.01, 3, o).verdict, LoopVerdict::NoGain);
  flat.suggestion.newly_determined = {"Ixy"};  // ... unless it fixes a moment
  EXPECT_EQ(decideNextStep(flat, 0.01, 3, o).verdict, LoopVerdict::Continue);

  IdentifiabilityAnalysis unavailable;  // no experiment reports moment observations
  EXPECT_EQ(decideNextStep(unavailable, 0.01, 1, o).verdict, LoopVerdict::NotAnalysed);

  ExperimentLoopOptions bad;
  bad.max_experiments = 0;
  EXPECT_THROW(decideNextStep(a, 0.01, 1, bad), TopoError);
  bad = ExperimentLoopOptions();
  bad.max_uncertain_fraction = -0.1;
  EXPECT_THROW(decideNextStep(a, 0.01, 1, bad), TopoError);
}

TEST(ExperimentLoop, TheRuleReadsThePlainEvidenceOfAnActionResultAlike) {
  const IdentifiabilityAnalysis a = analysisWith(7);
  const LoopEvidence e = loopEvidence(a);
  EXPECT_TRUE(e.analysed);
  EXPECT_EQ(e.free, (std::vector<std::string>{"Ixy", "Ixz", "Iyz"}));
  EXPECT_EQ(e.suggestion, a.suggestion.sentence);
  for (double f : {0.01, 0.5})
    for (int n : {3, 5}) EXPECT_EQ(decideNextStep(e, f, n).verdict, decideNextStep(a, f, n).verdict);
  LoopEvidence done;  // what a front end fills from a result: nothing free, a small uncertain volume
  done.analysed = true;
  EXPECT_EQ(decideNextStep(done, 0.015, 4).verdict, LoopVerdict::GoalReached);
  EXPECT_EQ(decideNextStep(done, 0.2, 4).verdict, LoopVerdict::NoSuggestion);
  EXPECT_EQ(decideNextStep(LoopEvidence{}, 0.015, 4).verdict, LoopVerdict::NotAnalysed);
}

TEST(ExperimentLoop, SuggestionOverridesReproduceTheSuggestedConfig) {
  ExperimentSuggestion hang;
  hang.kind = "swing";
  hang.config = TaskConfig::defaults("hanging");
  hang.config.setNumber("density_solid", 5000);
  hang.config.setVector("hanging_point", Eigen::Vector3d(0.0123456789012345, -0.04, 1.0 / 3.0 * 0.06));
  hang.config.setNumber("target_roll_deg", 53.1234567891234);
  hang.config.setNumber("target_pitch_deg", -0.1);
  hang.config.setNumber("axle_swing_period_s", 0.4321);
  ExperimentSuggestion rock;
  rock.kind = "rock";
  rock.config = TaskConfig::defaults("tumbler");
  rock.config.setVector("rocking_axis", Eigen::Vector3d(std::sqrt(0.5), -std::sqrt(0.5), 0));
  rock.config.set("measured_cycles", "1");
  rock.config.set("contact_damping_ratio", "0");
  for (const ExperimentSuggestion& s : {hang, rock}) {
    const SuggestedExperiment out = suggestionOverrides(s);
    EXPECT_EQ(out.task, s.config.task());
    EXPECT_EQ(out.kind, s.kind);
    EXPECT_FALSE(out.overrides.empty());
    const TaskConfig back = configFromOverrides(out);
    for (const auto& spec : s.config.specs()) {
      ASSERT_EQ(back.has(spec.name), s.config.has(spec.name)) << spec.name;
      if (!s.config.has(spec.name)) continue;
      EXPECT_EQ(back.valueText(spec.name), s.config.valueText(spec.name)) << spec.name;
      if (spec.type == ParamType::Vector3)
        EXPECT_EQ(back.vector3(spec.name), s.config.vector3(spec.name)) << spec.name << " exactly";
      if (spec.type == ParamType::Number) EXPECT_EQ(back.number(spec.name), s.config.number(spec.name)) << spec.name;
    }
    // only what differs from the defaults
    for (const auto& a : out.overrides) EXPECT_EQ(a.find("dt_s="), std::string::npos) << a;
  }
  const SuggestedExperiment h = suggestionOverrides(hang);
  bool point = false;
  for (const auto& a : h.overrides) point = point || a.rfind("hanging_point=", 0) == 0;
  EXPECT_TRUE(point);
}

TEST(ExperimentLoop, TwinPerformsTheSuggestionsOfASmallLoop) {
  const auto t0 = std::chrono::steady_clock::now();
  RigTwinOptions to;
  to.spacing_m = 0.006;  // a coarse tumbler: ~1900 particles
  to.loop_cycles = 2;
  to.overrides = {"measured_cycles=1", "density_solid=5000"};
  const RigTwin twin(to);
  TwinPerformer performer(twin);
  TaskConfig rock = TaskConfig::defaults("tumbler");
  for (const char* a : {"contact_damping_ratio=0", "measured_cycles=1", "density_solid=5000", "max_evaluations=8",
                        "restarts=0"})
    rock.setAssignment(a);
  TaskConfig hang = TaskConfig::defaults("hanging");
  for (const char* a : {"density_solid=5000", "max_evaluations=8", "restarts=0", "hanging_point=0,0.04,0.02"})
    hang.setAssignment(a);
  TaskConfig first = TaskConfig::common();
  for (const char* a : {"density_solid=5000", "max_evaluations=8", "restarts=0"}) first.setAssignment(a);
  first.addExperiment("rock10", 1.0, performer.perform(rock));
  first.addExperiment("hang", 1.0, performer.perform(hang, /*weigh=*/true));
  ASSERT_TRUE(first.experiments()[1].config.has("mass_kg")) << "the first hang is weighed";
  ASSERT_TRUE(first.experiments()[0].config.has("period_s"));

  ExperimentLoopOptions o;
  o.max_experiments = 3;
  ExperimentLoopCallbacks cb;
  cb.truth_iou = [&](const InferenceResult& res) {
    std::vector<double> rec(res.r.size()), truth(res.r.size());
    for (std::size_t i = 0; i < res.r.size(); ++i) rec[i] = res.r[i] >= 0.5 ? 0.0 : 1.0;
    for (std::size_t i = 0; i < res.r.size(); ++i) truth[i] = 1.0 - twin.indicator()[i];
    return volumeIou(twin.cloud().V, truth, rec);
  };
  const ExperimentLoopResult loop = runExperimentLoop(twin.cloud(), first, std::ref(performer), o, cb);
  ASSERT_FALSE(loop.steps.empty());
  EXPECT_FALSE(loop.decision.reason.empty());
  for (std::size_t k = 0; k < loop.steps.size(); ++k) {
    const ExperimentLoopStep& s = loop.steps[k];
    EXPECT_EQ(s.experiment_names.size(), 2 + k) << "one experiment more per step";
    EXPECT_EQ(s.determined.size() + s.free.size(), 10u);
    EXPECT_TRUE(std::isfinite(s.truth_iou));
    if (k > 0) {
      EXPECT_FALSE(s.added.empty());
      EXPECT_EQ(s.added_sentence, loop.steps[k - 1].suggestion.sentence);
    }
    if (s.decision.continues()) {
      ASSERT_TRUE(s.has_suggestion);
      EXPECT_FALSE(s.suggested.overrides.empty());
    }
  }
  EXPECT_LE(loop.steps.back().experiment_names.size(), 3u);
  // the performed experiments carry their observations
  for (const auto& e : loop.experiments.experiments()) {
    bool target = false;
    for (const auto& spec : e.config.specs()) target = target || (spec.is_target && e.config.has(spec.name));
    EXPECT_TRUE(target) << e.name;
  }
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("[loop] %zu steps, %s; %.1f s\n", loop.steps.size(), loop.decision.reason.c_str(), s);
}
