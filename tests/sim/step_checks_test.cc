// The checks the step skeleton (step_skeleton.h) applies after every step of every formulation:
// a non-finite end state and a penetration at the END of the step fail the step with a status.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "test_util.h"
#include "vinci/sim/formulations/capabilities.h"
#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/simulator/simulator.h"

namespace vinci::sim {
namespace {

// Issue 18 item 3: a sphere at x = 1e308 moving at 1e308 m/s reaches x = inf in one step of
// 10 s. The step must fail as non-finite and leave the state unchanged.
TEST(StepChecks, NonFiniteEndStateFailsTheStep) {
  for (const char* formulation : {"stewart-trinkle", "anitescu-potra", "ncp", "gi"}) {
    const Scene scene = ParseScene(std::string(R"(
dimension: 3
stepper: {dt: 10, formulation: )") +
                                   formulation + R"(}
bodies:
  - name: floor
    kind: static
    shapes: [{type: halfspace}]
  - name: ball
    mass: 1.0
    pose: {position: [1.0e308, 0, 1]}
    velocity: {linear: [1.0e308, 0, 0]}
    shapes: [{type: sphere, radius: 0.1}]
)");
    const Simulator sim(scene);
    const State x0 = sim.InitialState();
    Workspace ws;
    State next;
    const StepInfo info = sim.Step(sim.DefaultParams(), x0, StepInput{}, &ws, &next);
    EXPECT_FALSE(info.ok) << formulation;
    EXPECT_EQ(info.status, StepStatus::kNonFinite) << formulation << ": " << info.failure;
    EXPECT_NE(info.failure.find("non-finite"), std::string::npos) << info.failure;
    EXPECT_EQ(next.q, x0.q) << formulation;
    EXPECT_EQ(next.t, x0.t) << formulation;
  }
}

TEST(StepChecks, NonFinitePlanarEndStateFailsTheStep) {
  const Scene scene = ParseScene(R"(
dimension: 2
stepper: {dt: 10}
bodies:
  - name: disc
    mass: 1.0
    pose: {position: [1.0e308, 0]}
    velocity: {linear: [1.0e308, 0]}
    shapes: [{type: disc, radius: 0.1}]
)");
  const Simulator sim(scene);
  Workspace ws;
  State next;
  const StepInfo info = sim.Step(sim.DefaultParams(), sim.InitialState(), StepInput{}, &ws, &next);
  EXPECT_EQ(info.status, StepStatus::kNonFinite) << info.failure;
}

// Issue 18 item 9: a ball dropped from 1 m with dt = 1000 s falls 9.8e6 m through the floor in
// its first step (no contact in the envelope at its start). The END state is checked, so the
// step fails instead of the run ending "solved" deep inside the floor.
TEST(StepChecks, PenetrationAtTheEndOfTheStepFailsTheStep) {
  Scene scene = testing::LoadExample("ball_drop.yaml");
  scene.options.dt = 1000.0;
  const Simulator sim(scene);
  const State x0 = sim.InitialState();
  const Trajectory traj = sim.Rollout(sim.DefaultParams(), x0, 1);
  ASSERT_EQ(traj.steps.size(), 1u);
  EXPECT_FALSE(traj.ok);
  EXPECT_EQ(traj.steps[0].status, StepStatus::kPenetration) << traj.steps[0].failure;
  EXPECT_NE(traj.steps[0].failure.find("end of the step"), std::string::npos)
      << traj.steps[0].failure;
  EXPECT_EQ(traj.states.size(), 1u);  // the penetrating state is not recorded
}

// A step that ends within max_penetration is fine: the ball lands at dt = 1 ms.
TEST(StepChecks, RestingContactPassesTheEndCheck) {
  const Scene scene = testing::LoadExample("ball_drop.yaml");
  const Simulator sim(scene);
  const Trajectory traj = sim.Rollout(sim.DefaultParams(), sim.InitialState(), 600);
  ASSERT_TRUE(traj.ok) << traj.failure;
  for (const StepInfo& s : traj.steps) EXPECT_EQ(s.status, StepStatus::kOk);
  EXPECT_NEAR(traj.states.back().q[2], 0.1, 2e-3);  // resting on the floor (within the envelope)
}

// A start state deeper than max_penetration fails before the solve, with its own status.
TEST(StepChecks, PenetrationAtTheStartHasItsStatus) {
  const Scene scene = ParseScene(R"(
dimension: 3
stepper: {max_penetration: 0.01}
bodies:
  - name: floor
    kind: static
    shapes: [{type: halfspace}]
  - name: ball
    mass: 1.0
    pose: {position: [0, 0, 0.05]}
    shapes: [{type: sphere, radius: 0.1}]
)");
  const Simulator sim(scene);
  Workspace ws;
  State next;
  const StepInfo info = sim.Step(sim.DefaultParams(), sim.InitialState(), StepInput{}, &ws, &next);
  EXPECT_EQ(info.status, StepStatus::kPenetration) << info.failure;
  EXPECT_NE(info.failure.find("start of the step"), std::string::npos) << info.failure;
}

// A non-finite warm start is dropped (cold start), not handed to the solver.
TEST(StepChecks, NonFiniteWarmStartIsIgnored) {
  const Scene scene = testing::LoadExample("ball_drop.yaml");
  const Simulator sim(scene);
  State x = sim.InitialState();
  x.q[2] = 0.1;  // resting
  Workspace ws;
  State a, b;
  const StepInfo ia = sim.Step(sim.DefaultParams(), x, StepInput{}, &ws, &a);
  ASSERT_TRUE(ia.ok) << ia.failure;
  x.warm_start = VectorXd::Constant(a.warm_start.size(), std::nan(""));
  const StepInfo ib = sim.Step(sim.DefaultParams(), x, StepInput{}, &ws, &b);
  ASSERT_TRUE(ib.ok) << ib.failure;
  EXPECT_EQ(a.q, b.q);
}

// A formulation's own Step reports a consistent status too (ok ⇔ kOk), skeleton or not.
TEST(StepChecks, FormulationStepStatusMatchesOk) {
  const Scene scene = testing::LoadExample("ball_drop.yaml");
  const Simulator sim(scene);
  Workspace ws;
  State next;
  StepInfo info;
  sim.formulation().Step(sim.Resolve(sim.DefaultParams(), &ws), sim.InitialState(), StepInput{},
                         &ws, &next, &info);
  EXPECT_TRUE(info.ok);
  EXPECT_EQ(info.status, StepStatus::kOk);
}

TEST(StepChecks, NonFiniteStartStateFailsBeforeTheFormulation) {
  const Simulator sim(testing::LoadExample("ball_drop.yaml"));
  State x = sim.InitialState();
  x.v[0] = std::nan("");
  Workspace ws;
  State next;
  const StepInfo info = sim.Step(sim.DefaultParams(), x, StepInput{}, &ws, &next);
  EXPECT_EQ(info.status, StepStatus::kNonFinite) << info.failure;
  EXPECT_NE(info.failure.find("start of the step"), std::string::npos) << info.failure;
}

TEST(StepChecks, StatusNames) {
  EXPECT_STREQ(ToString(StepStatus::kOk), "ok");
  EXPECT_STREQ(ToString(StepStatus::kNonFinite), "non-finite");
  EXPECT_STREQ(ToString(StepStatus::kPenetration), "penetration");
}

}  // namespace
}  // namespace vinci::sim
