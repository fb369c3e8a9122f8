// `vinci plan` at the sample sizes (slow): a single part pose-to-pose on the conveyor
// plate (examples/plan/one_part.yaml) reaches its goal within 5 mm in the re-simulation in ≥ 90%
// of 50 seeded runs; the tripod part of examples/plan/angle.yaml reaches its position and angle
// goal in ≥ 90% of 20. Each run has a budget of propagations (not of time), so the outcome does
// not depend on the machine's load.
#include <gtest/gtest.h>
#include <ompl/util/Console.h>
#include <ompl/util/RandomNumbers.h>

#include <cstdio>
#include <string>

#include "vinci/planning/plan.h"
#include "vinci/planning/plan_spec.h"

namespace vinci::planning {
namespace {

// OMPL's seed can only be set before its first random number: once, for the whole program.
const bool kSeeded = [] {
  ompl::RNG::setSeed(11);
  return true;
}();

// Plans `runs` times with RRT and a budget of `budget` propagations per planner call; returns how
// many were solved, checking that each solved plan's re-simulation ends within every part's
// position (and angle) tolerance.
int SolvedRuns(const std::string& spec, int runs, long long budget) {
  ompl::msg::setLogLevel(ompl::msg::LOG_ERROR);
  const PlanProblem problem(LoadPlanSpec(VINCI_SOURCE_DIR "/examples/plan/" + spec));
  PlanRunOptions o;
  o.planner = PlannerType::kRrt;
  o.time_limit = 600.0;
  o.max_propagations = budget;
  int solved = 0;
  long long propagations = 0;
  for (int run = 0; run < runs; ++run) {
    const PlanResult r = RunPlan(problem, o);
    propagations += r.attempts.front().propagations;
    if (!r.solved) continue;
    ++solved;
    EXPECT_TRUE(r.reached);
    for (std::size_t i = 0; i < problem.spec().goals.size(); ++i) {
      const PartGoal& g = problem.spec().goals[i];
      EXPECT_LE(r.final_position_errors[i], g.tolerance) << spec << " run " << run;
      if (g.has_angle) {
        EXPECT_LE(r.final_angle_errors[i], g.angle_tolerance) << spec << " run " << run;
      }
    }
  }
  std::printf("%s: %d / %d solved, %lld propagations\n", spec.c_str(), solved, runs, propagations);
  return solved;
}

TEST(PlanSlowTest, OnePartExampleReachesGoalInNinetyPercentOfFiftySeededRuns) {
  ASSERT_TRUE(kSeeded);
  EXPECT_GE(SolvedRuns("one_part.yaml", 50, 1500), 45);
}

TEST(PlanSlowTest, AngleExampleReachesPoseInNinetyPercentOfTwentySeededRuns) {
  ASSERT_TRUE(kSeeded);
  EXPECT_GE(SolvedRuns("angle.yaml", 20, 3000), 18);
}

}  // namespace
}  // namespace vinci::planning
