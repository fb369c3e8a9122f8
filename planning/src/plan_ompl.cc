#include "vinci/planning/plan_ompl.h"

#include <ompl/base/ProjectionEvaluator.h>
#include <ompl/base/goals/GoalSampleableRegion.h>
#include <ompl/base/objectives/PathLengthOptimizationObjective.h>
#include <ompl/base/spaces/SE2StateSpace.h>
#include <ompl/control/PathControl.h>
#include <ompl/control/SimpleSetup.h>
#include <ompl/control/planners/kpiece/KPIECE1.h>
#include <ompl/control/planners/rrt/RRT.h>
#include <ompl/control/planners/sst/SST.h>
#include <ompl/control/spaces/DiscreteControlSpace.h>
#include <ompl/util/RandomNumbers.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <limits>
#include <mutex>
#include <thread>
#include <unordered_map>
#include <vector>

#ifndef VINCI_OMPL_VERSION
#error "VINCI_OMPL_VERSION must be defined by the build (planning/CMakeLists.txt)"
#endif

namespace vinci::planning {
namespace {

namespace ob = ompl::base;
namespace oc = ompl::control;

constexpr double kPi = 3.14159265358979323846;

double PlateSize(const PlanSpec& s) { return std::max(s.x_max - s.x_min, s.y_max - s.y_min); }

// The SO2 weight (m/rad) of a part's SE2 distance: the goal's tolerance ratio when it has an
// angle (so that the distance weighs angle and position errors as the goal does), else
// kAngleWeight.
double AngleWeight(const PartGoal& g) {
  return g.has_angle ? g.tolerance / g.angle_tolerance : kAngleWeight;
}

// One workspace per calling thread (the planner's; a benchmark may use others).
class ThreadWorkspaces {
 public:
  sim::Workspace* Get() {
    std::lock_guard<std::mutex> lock(mutex_);
    std::unique_ptr<sim::Workspace>& ws = map_[std::this_thread::get_id()];
    if (!ws) ws = std::make_unique<sim::Workspace>();
    return ws.get();
  }

 private:
  std::mutex mutex_;
  std::unordered_map<std::thread::id, std::unique_ptr<sim::Workspace>> map_;
};

class PlatePropagator : public oc::StatePropagator {
 public:
  PlatePropagator(oc::SpaceInformation* si, const PlanProblem& problem,
                  std::shared_ptr<std::atomic<long long>> count)
      : oc::StatePropagator(si), problem_(problem), count_(std::move(count)) {}

  void propagate(const ob::State* state, const oc::Control* control, double duration,
                 ob::State* result) const override {
    const auto* c = control->as<oc::CompoundControl>();
    const int primitive = c->as<oc::DiscreteControlSpace::ControlType>(0)->value;
    const int cycles = c->as<oc::DiscreteControlSpace::ControlType>(1)->value;
    const long reps = std::max(1L, std::lround(duration / si_->getPropagationStepSize()));
    PartPoses poses = PosesFromState(state, problem_.num_parts());
    sim::Workspace* ws = workspaces_.Get();
    for (long r = 0; r < reps; ++r) {
      const Propagation p = problem_.Propagate(poses, primitive, cycles, ws);
      if (count_) ++*count_;
      if (!p.valid) {  // outside the bounds: the validity checker rejects it
        for (PartPose& q : poses) q.x = problem_.spec().x_max + PlateSize(problem_.spec()) + 1.0;
        break;
      }
      poses = p.poses;
    }
    PosesToState(poses, result);
  }

  bool canPropagateBackward() const override { return false; }

 private:
  const PlanProblem& problem_;
  std::shared_ptr<std::atomic<long long>> count_;
  mutable ThreadWorkspaces workspaces_;
};

class PlateGoal : public ob::GoalSampleableRegion {
 public:
  PlateGoal(const ob::SpaceInformationPtr& si, const PlanProblem& problem)
      : ob::GoalSampleableRegion(si), problem_(problem) {
    setThreshold(1.0);
  }
  double distanceGoal(const ob::State* st) const override {
    return problem_.GoalDistance(PosesFromState(st, problem_.num_parts()));
  }
  void sampleGoal(ob::State* st) const override {
    const PlanSpec& s = problem_.spec();
    PartPoses poses;
    for (const PartGoal& g : s.goals) {
      const double r = g.tolerance * std::sqrt(rng_.uniform01()), a = rng_.uniformReal(-kPi, kPi);
      PartPose p;
      p.x = std::clamp(g.position.x() + r * std::cos(a), s.x_min, s.x_max);
      p.y = std::clamp(g.position.y() + r * std::sin(a), s.y_min, s.y_max);
      p.theta = g.has_angle ? g.angle + rng_.uniformReal(-g.angle_tolerance, g.angle_tolerance)
                            : rng_.uniformReal(-kPi, kPi);
      poses.push_back(p);
    }
    PosesToState(poses, st);
  }
  unsigned int maxSampleCount() const override { return UINT_MAX; }

 private:
  const PlanProblem& problem_;
  mutable ompl::RNG rng_;
};

// KPIECE1's projection: the part positions.
class PartPositionProjection : public ob::ProjectionEvaluator {
 public:
  PartPositionProjection(const ob::StateSpace* space, const PlanSpec& spec)
      : ob::ProjectionEvaluator(space), spec_(spec) {}
  unsigned int getDimension() const override {
    return 2 * static_cast<unsigned int>(spec_.goals.size());
  }
  void defaultCellSizes() override {
    cellSizes_.clear();
    for (std::size_t i = 0; i < spec_.goals.size(); ++i) {
      cellSizes_.push_back((spec_.x_max - spec_.x_min) / kProjectionCells);
      cellSizes_.push_back((spec_.y_max - spec_.y_min) / kProjectionCells);
    }
  }
  void project(const ob::State* state, Eigen::Ref<Eigen::VectorXd> out) const override {
    const auto* c = state->as<ob::CompoundState>();
    for (std::size_t i = 0; i < spec_.goals.size(); ++i) {
      const auto* se2 = c->as<ob::SE2StateSpace::StateType>(static_cast<unsigned int>(i));
      out[static_cast<Eigen::Index>(2 * i)] = se2->getX();
      out[static_cast<Eigen::Index>(2 * i + 1)] = se2->getY();
    }
  }

 private:
  const PlanSpec& spec_;
};

// OMPL 1.5's control::SST deletes its witnesses without freeing the state and control each one
// allocated (findClosestWitness): every planning query leaked them. This SST frees them before
// SST's own clean-up runs (in clear() and in the destructor).
class Sst final : public oc::SST {
 public:
  using oc::SST::SST;
  ~Sst() override { FreeWitnessStates(); }
  void clear() override {
    FreeWitnessStates();
    oc::SST::clear();
  }

 private:
  void FreeWitnessStates() {
    if (!witnesses_) return;
    std::vector<Motion*> witnesses;
    witnesses_->list(witnesses);
    for (Motion* w : witnesses) {
      if (w->state_ != nullptr) si_->freeState(w->state_);
      if (w->control_ != nullptr) siC_->freeControl(w->control_);
      w->state_ = nullptr;
      w->control_ = nullptr;
    }
  }
};

}  // namespace

const char* OmplVersion() { return VINCI_OMPL_VERSION; }

PartPoses PosesFromState(const ob::State* state, int num_parts) {
  const auto* c = state->as<ob::CompoundState>();
  PartPoses poses;
  for (int i = 0; i < num_parts; ++i) {
    const auto* se2 = c->as<ob::SE2StateSpace::StateType>(static_cast<unsigned int>(i));
    poses.push_back({se2->getX(), se2->getY(), se2->getYaw()});
  }
  return poses;
}

void PosesToState(const PartPoses& poses, ob::State* state) {
  auto* c = state->as<ob::CompoundState>();
  for (std::size_t i = 0; i < poses.size(); ++i) {
    auto* se2 = c->as<ob::SE2StateSpace::StateType>(static_cast<unsigned int>(i));
    se2->setXY(poses[i].x, poses[i].y);
    se2->setYaw(std::remainder(poses[i].theta, 2.0 * kPi));
  }
}

ob::PlannerPtr MakePlanner(const oc::SpaceInformationPtr& si, const PlanProblem& problem,
                           PlannerType type) {
  switch (type) {
    case PlannerType::kKpiece1: {
      auto kpiece = std::make_shared<oc::KPIECE1>(si);
      kpiece->setGoalBias(kKpieceGoalBias);
      return kpiece;
    }
    case PlannerType::kSst: {
      auto sst = std::make_shared<Sst>(si);
      const double L = PlateSize(problem.spec());
      sst->setSelectionRadius(kSstSelection * L);
      sst->setPruningRadius(kSstPruning * L);
      return sst;
    }
    case PlannerType::kRrt: {
      auto rrt = std::make_shared<oc::RRT>(si);
      rrt->setGoalBias(kRrtGoalBias);
      return rrt;
    }
  }
  throw std::invalid_argument("MakePlanner: unknown planner");
}

std::shared_ptr<oc::SimpleSetup> MakeSimpleSetup(const PlanProblem& problem, const PartPoses& start,
                                                 PlannerType planner,
                                                 std::shared_ptr<std::atomic<long long>> count) {
  const PlanSpec& spec = problem.spec();
  auto space = std::make_shared<ob::CompoundStateSpace>();
  for (int i = 0; i < problem.num_parts(); ++i) {
    auto se2 = std::make_shared<ob::SE2StateSpace>();
    ob::RealVectorBounds b(2);
    b.setLow(0, spec.x_min);
    b.setHigh(0, spec.x_max);
    b.setLow(1, spec.y_min);
    b.setHigh(1, spec.y_max);
    se2->setBounds(b);
    se2->setSubspaceWeight(1, AngleWeight(spec.goals[static_cast<std::size_t>(i)]));
    se2->setName(spec.goals[static_cast<std::size_t>(i)].part);
    space->addSubspace(se2, 1.0);
  }
  space->lock();
  space->registerDefaultProjection(std::make_shared<PartPositionProjection>(space.get(), spec));

  auto controls = std::make_shared<oc::CompoundControlSpace>(space);
  controls->addSubspace(
      std::make_shared<oc::DiscreteControlSpace>(space, 0, problem.num_primitives() - 1));
  controls->addSubspace(
      std::make_shared<oc::DiscreteControlSpace>(space, spec.min_cycles, spec.max_cycles));
  controls->lock();

  auto ss = std::make_shared<oc::SimpleSetup>(controls);
  const oc::SpaceInformationPtr& si = ss->getSpaceInformation();
  si->setPropagationStepSize(1.0);
  si->setMinMaxControlDuration(1, 1);
  ss->setStatePropagator(std::make_shared<PlatePropagator>(si.get(), problem, std::move(count)));
  oc::SpaceInformation* raw = si.get();
  ss->setStateValidityChecker([raw](const ob::State* s) { return raw->satisfiesBounds(s); });
  ob::ScopedState<> st(space);
  PosesToState(start, st.get());
  ss->setStartState(st);
  ss->setGoal(std::make_shared<PlateGoal>(si, problem));
  // Any solution satisfies the objective: planners that keep improving (SST) stop at the first.
  auto objective = std::make_shared<ob::PathLengthOptimizationObjective>(si);
  objective->setCostThreshold(ob::Cost(std::numeric_limits<double>::infinity()));
  ss->setOptimizationObjective(objective);
  ss->setPlanner(MakePlanner(si, problem, planner));
  return ss;
}

std::vector<PlanStep> StepsFromPath(const oc::PathControl& path) {
  std::vector<PlanStep> steps;
  for (std::size_t i = 0; i < path.getControlCount(); ++i) {
    const auto* c = path.getControl(i)->as<oc::CompoundControl>();
    PlanStep step;
    step.primitive = c->as<oc::DiscreteControlSpace::ControlType>(0)->value;
    step.cycles = c->as<oc::DiscreteControlSpace::ControlType>(1)->value;
    const long reps = std::max(1L, std::lround(path.getControlDuration(i)));
    for (long r = 0; r < reps; ++r) steps.push_back(step);
  }
  return steps;
}

PlanAttempt PlanOnce(const PlanProblem& problem, const PartPoses& start, PlannerType planner,
                     double time_limit, long long max_propagations) {
  if (!(time_limit > 0.0 && time_limit <= PlanLimits::kMaxTimeLimit))
    throw std::invalid_argument("PlanOnce: expected a time limit in (0, 1e6] s, got " +
                                std::to_string(time_limit));
  auto count = std::make_shared<std::atomic<long long>>(0);
  std::shared_ptr<oc::SimpleSetup> ss = MakeSimpleSetup(problem, start, planner, count);
  PlanAttempt a;
  a.start = start;
  ss->setup();
  ob::PlannerTerminationCondition ptc = ob::timedPlannerTerminationCondition(time_limit);
  if (max_propagations > 0)
    ptc = ob::plannerOrTerminationCondition(
        ptc, ob::PlannerTerminationCondition(
                 [count, max_propagations] { return count->load() >= max_propagations; }));
  const ob::PlannerStatus status = ss->solve(ptc);
  a.solve_time_s = ss->getLastPlanComputationTime();
  a.propagations = count->load();
  a.planner_status = status.asString();
  const ob::ProblemDefinitionPtr& pdef = ss->getProblemDefinition();
  a.exact = status == ob::PlannerStatus::EXACT_SOLUTION && pdef->hasExactSolution();
  a.approximate = !a.exact && pdef->hasSolution();
  a.goal_distance = problem.GoalDistance(start);
  if (!pdef->hasSolution()) return a;
  const oc::PathControl& path = ss->getSolutionPath();
  a.steps = StepsFromPath(path);
  a.goal_distance = problem.GoalDistance(
      PosesFromState(path.getState(path.getStateCount() - 1), problem.num_parts()));
  return a;
}

}  // namespace vinci::planning
