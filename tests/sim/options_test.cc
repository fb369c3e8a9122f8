// SimulatorOptions (one scene at two fidelities, validation, typed solver options, the name
// lists) and RolloutOptions (observer, stop condition, sparse recording, failed steps).
#include "vinci/sim/simulator/options.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <string>

#include "test_util.h"
#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/model/state_util.h"
#include "vinci/sim/simulator/simulator.h"

namespace vinci::sim {
namespace {

using testing::LoadExample;

// The block carries a damping matrix only for the first-order model, the one formulation that
// reads it (the others reject a scene with one: capabilities.h).
std::string BlockScene(const std::string& stepper) {
  const std::string damping =
      stepper.find("first-order") != std::string::npos ? "    damping: [2.0, 2.0, 0.5]\n" : "";
  return R"(
name: block
dimension: 2
gravity: [0, -9.81]
stepper: )" +
         stepper +
         R"(
friction: {default: 0.3}
bodies:
  - name: floor
    kind: static
    shapes: [{type: halfplane}]
  - name: block
    mass: 1.0
    pose: {position: [0, 0.1], angle: 0.2}
    velocity: {linear: [1.0, 0], angular: 3.0}
)" + damping +
         R"(    shapes: [{type: polygon, vertices: [[-0.1, -0.05], [0.1, -0.05], [0.1, 0.05], [-0.1, 0.05]]}]
)";
}

std::vector<std::uint64_t> Hashes(const Trajectory& t) {
  std::vector<std::uint64_t> h;
  for (const State& x : t.states) h.push_back(StateHash(x));
  return h;
}

void ExpectMessage(const std::function<void()>& f, const std::string& needle) {
  try {
    f();
    ADD_FAILURE() << "expected std::invalid_argument mentioning '" << needle << "'";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
  }
}

TEST(OptionsTest, DefaultsAreTheScenesStepperSection) {
  const Scene scene = ParseScene(BlockScene("{dt: 0.002, envelope: 0.003, solver: pgs}"));
  const SimulatorOptions o = SimulatorOptions::FromScene(scene);
  EXPECT_EQ(o.dt, 0.002);
  EXPECT_EQ(o.envelope, 0.003);
  EXPECT_EQ(o.solver, "pgs");
  const Simulator sim(scene);
  EXPECT_EQ(sim.options().dt, 0.002);
  EXPECT_EQ(sim.options().solver, "pgs");
}

// One scene, two fidelities: the options given to the Simulator replace the scene's, with the
// same result as a scene file that says so.
TEST(OptionsTest, OneSceneRunsWithOtherOptions) {
  const Scene scene = ParseScene(BlockScene("{dt: 0.001}"));
  SimulatorOptions o = SimulatorOptions::FromScene(scene);
  o.dt = 0.004;
  o.formulation = FormulationType::kAnitescuPotra;
  const Simulator coarse(scene, o);
  const Simulator fine(scene);
  const Simulator file(ParseScene(BlockScene("{dt: 0.004, formulation: anitescu-potra}")));
  EXPECT_EQ(coarse.formulation().name(), file.formulation().name());
  EXPECT_EQ(fine.options().dt, 0.001);  // the scene itself is unchanged
  const Trajectory a = coarse.Rollout(coarse.DefaultParams(), coarse.InitialState(), 100);
  const Trajectory b = file.Rollout(file.DefaultParams(), file.InitialState(), 100);
  ASSERT_TRUE(a.ok && b.ok);
  EXPECT_EQ(Hashes(a), Hashes(b));
  EXPECT_NEAR(a.states.back().t, 0.4, 1e-12);
}

TEST(OptionsTest, InvalidOptionsNameTheField) {
  const Scene scene = ParseScene(BlockScene("{dt: 0.001}"));
  const auto with = [&](const std::function<void(SimulatorOptions*)>& edit) {
    return [&scene, edit] {
      SimulatorOptions o = SimulatorOptions::FromScene(scene);
      edit(&o);
      Simulator sim(scene, o);
    };
  };
  ExpectMessage(with([](SimulatorOptions* o) { o->dt = 0.0; }), "dt = 0");
  ExpectMessage(with([](SimulatorOptions* o) { o->friction_directions = 3; }),
                "friction_directions = 3");
  ExpectMessage(with([](SimulatorOptions* o) { o->envelope = -1.0; }), "envelope = -1");
  ExpectMessage(with([](SimulatorOptions* o) { o->max_penetration = 0.0; }), "max_penetration");
  ExpectMessage(with([](SimulatorOptions* o) { o->solver = "simplex"; }), "fb-newton");
  ExpectMessage(with([](SimulatorOptions* o) {
                  o->formulation = FormulationType::kGeometricallyImplicit;
                  o->solver = "pgs";
                }),
                "semismooth-newton");
  ExpectMessage(with([](SimulatorOptions* o) { o->solver_options.pgs.relaxation = 2.5; }),
                "pgs.relaxation = 2.5");
  ExpectMessage(with([](SimulatorOptions* o) { o->solver_options.mcp.tolerance = -1.0; }),
                "mcp.tolerance");
  RolloutOptions r;
  r.record_every = 0;
  const Simulator sim(scene);
  ExpectMessage([&] { sim.Rollout(sim.DefaultParams(), sim.InitialState(), {StepInput{}}, r); },
                "record_every = 0");
}

// The typed options reach the solver the simulator builds.
TEST(OptionsTest, TypedSolverOptionsReachTheSolver) {
  const Scene scene = LoadExample("box_stack.yaml");
  SimulatorOptions o = SimulatorOptions::FromScene(scene);
  o.solver = "pgs";
  const Simulator pgs(scene, o);
  o.solver_options.pgs.max_sweeps = 1;
  const Simulator one_sweep(scene, o);
  const Trajectory ok = pgs.Rollout(pgs.DefaultParams(), pgs.InitialState(), 2);
  ASSERT_TRUE(ok.ok) << ok.failure;
  EXPECT_GT(ok.steps[0].solver.iterations, 1);  // the cold first step needs several sweeps
  const Trajectory bad = one_sweep.Rollout(one_sweep.DefaultParams(), one_sweep.InitialState(), 2);
  EXPECT_FALSE(bad.ok);
  EXPECT_EQ(bad.steps[0].solver.iterations, 1);
  EXPECT_NE(bad.failure.find("pgs"), std::string::npos) << bad.failure;
}

TEST(OptionsTest, NameListsMatchTheSceneFile) {
  for (const std::string& name : FormulationNames()) {
    const FormulationType type = ParseFormulation(name);
    EXPECT_EQ(std::string(ToString(type)), name);
    const Scene s = ParseScene(BlockScene("{formulation: " + name + "}"));
    EXPECT_EQ(s.options.formulation, type) << name;
  }
  EXPECT_EQ(FormulationNames().size(), 8u);
  ExpectMessage([] { ParseFormulation("verlet"); }, "stewart-trinkle");
  const std::vector<std::string> solvers = AllSolverNames();
  for (const char* s : {"lemke", "pgs", "fb-newton", "semismooth-newton"})
    EXPECT_NE(std::find(solvers.begin(), solvers.end(), s), solvers.end()) << s;
}

TEST(RolloutOptionsTest, ObserverStopAndRecording) {
  const Simulator sim(ParseScene(BlockScene("{dt: 0.001}")));
  const Params p = sim.DefaultParams();
  constexpr int kSteps = 50;
  const std::vector<StepInput> inputs(kSteps);
  const Trajectory full = sim.Rollout(p, sim.InitialState(), inputs);
  ASSERT_TRUE(full.ok) << full.failure;

  // The observer sees every step's state, recorded or not.
  RolloutOptions o;
  o.record_every = 7;
  std::vector<int> seen;
  o.observer = [&](int k, const State& x, const StepInfo& info) {
    EXPECT_TRUE(info.ok);
    EXPECT_EQ(StateHash(x), StateHash(full.states[k + 1])) << k;
    seen.push_back(k);
  };
  const Trajectory sparse = sim.Rollout(p, sim.InitialState(), inputs, o);
  ASSERT_TRUE(sparse.ok);
  EXPECT_EQ(static_cast<int>(seen.size()), kSteps);
  EXPECT_EQ(sparse.steps.size(), full.steps.size());
  EXPECT_EQ(sparse.record_every, 7);
  ASSERT_EQ(sparse.states.size(), 1u + kSteps / 7 + 1);  // x0, x7 … x49, and the final x50
  for (std::size_t i = 0; i + 1 < sparse.states.size(); ++i)
    EXPECT_EQ(StateHash(sparse.states[i]), StateHash(full.states[7 * i])) << i;
  EXPECT_EQ(StateHash(sparse.states.back()), StateHash(full.states.back()));

  // Stop once the block has slid 2 cm.
  RolloutOptions s;
  s.stop = [](int, const State& x) { return x.q[0] > 0.02; };
  const Trajectory stopped = sim.Rollout(p, sim.InitialState(), inputs, s);
  ASSERT_TRUE(stopped.ok);
  EXPECT_TRUE(stopped.stopped);
  int first = 0;
  while (!(full.states[first].q[0] > 0.02)) ++first;
  ASSERT_LT(first, kSteps);
  EXPECT_EQ(stopped.states.size(), static_cast<std::size_t>(first + 1));
  EXPECT_EQ(stopped.steps.size(), static_cast<std::size_t>(first));
  EXPECT_FALSE(full.stopped);
}

// A failed step after unrecorded ones still leaves the final state last.
TEST(RolloutOptionsTest, FailedStepKeepsTheFinalState) {
  const Scene scene = LoadExample("ball_drop.yaml");
  SimulatorOptions o = SimulatorOptions::FromScene(scene);
  o.solver_options.lemke.max_pivots = 1;  // fails at the first step with contacts
  const Simulator limited(scene, o);
  const Simulator normal(scene);
  const int steps = 600;  // the ball reaches the floor after ~430 steps
  const Trajectory full = normal.Rollout(normal.DefaultParams(), normal.InitialState(), steps);
  ASSERT_TRUE(full.ok);
  for (WarmStartPolicy policy : {WarmStartPolicy::kKeep, WarmStartPolicy::kCold}) {
    RolloutOptions r;
    r.record_every = 7;
    r.warm_start = policy;
    const Trajectory t = limited.Rollout(limited.DefaultParams(), limited.InitialState(),
                                         std::vector<StepInput>(steps), r);
    ASSERT_FALSE(t.ok);
    const int failed = static_cast<int>(t.steps.size()) - 1;
    EXPECT_GT(failed, 300);
    EXPECT_NE(failed % 7, 0) << "pick another record_every: the failure falls on a record";
    EXPECT_EQ(t.states.size(), static_cast<std::size_t>(1 + failed / 7 + 1));
    EXPECT_EQ(StateHash(t.states.back()), StateHash(full.states[failed]));
  }
}

}  // namespace
}  // namespace vinci::sim
