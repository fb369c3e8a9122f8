// The OMPL side of `vinci plan` (plan.h has the model): state space, control space, state
// propagator, goal region and planners.
//
// State space: a compound of one SE2 space per part (named after the part), position bounds the
// plate extent; the SO2 component weighs tolerance / angle_tolerance m/rad in distances for a
// part whose goal has an angle (angle and position errors then weigh as in the goal distance),
// else kAngleWeight, so that a full turn counts like a few centimetres and positions dominate
// nearest-neighbour queries.
// Control space: a compound of two discrete spaces, the primitive index [0, n − 1] and the cycle
// count [min, max]. Propagation step size 1 and control duration exactly 1 step: one control is
// one primitive application (PlanProblem::Propagate). An invalid propagation (failed step, part
// off the plate) writes a state outside the bounds, which the validity checker (bounds) rejects.
// Goal: a GoalSampleableRegion with distanceGoal = PlanProblem::GoalDistance and threshold 1;
// goal samples are uniform in each part's tolerance disc (and angle interval).
// KPIECE1 projects on the part positions (2 per part), cells of kProjectionCells per plate side;
// its goal bias (extend from the samples closest to the goal) is kKpieceGoalBias.
// SST: selection radius kSstSelection·L and pruning radius kSstPruning·L, L the longer side of the
// plate extent. RRT: goal bias kRrtGoalBias (a share of its extensions head for a goal sample).
#pragma once

#include <ompl/base/Planner.h>
#include <ompl/control/PathControl.h>
#include <ompl/control/SimpleSetup.h>
#include <ompl/control/SpaceInformation.h>

#include <atomic>
#include <memory>
#include <string>
#include <vector>

#include "vinci/planning/plan.h"

namespace vinci::planning {

constexpr double kAngleWeight = 0.005;  ///< m per rad in the SE2 distance
constexpr double kProjectionCells = 30.0;
constexpr double kKpieceGoalBias = 0.3;  ///< KPIECE1: share of extensions from the closest samples
constexpr double kSstSelection = 0.02;
constexpr double kSstPruning = 0.01;
constexpr double kRrtGoalBias = 0.4;  ///< RRT: share of samples drawn from the goal region

/// The OMPL version the build links (CMake's OMPL_VERSION; Debian's headers leave the macro
/// empty).
const char* OmplVersion();

/// Compound-of-SE2 state ↔ poses.
PartPoses PosesFromState(const ompl::base::State* state, int num_parts);
void PosesToState(const PartPoses& poses, ompl::base::State* state);

/// A control::SimpleSetup for `problem` (which must outlive it) starting at `start`: state and
/// control spaces, propagator (counting into *propagations if not null), validity checker, goal
/// and the planner of type `planner`. Not yet set up (SimpleSetup::setup runs on solve).
std::shared_ptr<ompl::control::SimpleSetup> MakeSimpleSetup(
    const PlanProblem& problem, const PartPoses& start, PlannerType planner,
    std::shared_ptr<std::atomic<long long>> propagations = nullptr);

/// A planner of type `type` configured for `problem` (see the file comment).
ompl::base::PlannerPtr MakePlanner(const ompl::control::SpaceInformationPtr& si,
                                   const PlanProblem& problem, PlannerType type);

/// The steps of a control path (one per control; a duration of k steps repeats it k times).
std::vector<PlanStep> StepsFromPath(const ompl::control::PathControl& path);

/// One planner call from `start`, stopped after `time_limit` seconds or (if max_propagations > 0)
/// after that many propagations, whichever comes first (PlanAttempt: steps, exact or
/// approximate, time, propagations). A propagation budget makes a seeded run independent of the
/// machine's speed and load.
PlanAttempt PlanOnce(const PlanProblem& problem, const PartPoses& start, PlannerType planner,
                     double time_limit, long long max_propagations = 0);

}  // namespace vinci::planning
