// Steps per second of Simulator::Step on the shared example scenes (bench/README.md).
//
// One benchmark iteration = one Simulator::Step, from a state in the scene's interesting
// regime. Counters: steps/s (rate), contacts and Lemke pivots per step (averages over the
// timed steps), and, for jointed scenes, bilateral rows per step.
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/simulator/simulator.h"

namespace vinci::sim {
namespace {

std::string ScenePath(const std::string& file) {
  return std::string(VINCI_SOURCE_DIR "/examples/scenes/") + file;
}

// What to do before and during the timed steps.
struct Regime {
  /// Steps run (untimed) before the first timed step, e.g. to let a stack settle.
  int settle_steps = 0;
  /// Restart from the initial state once t exceeds this (s); ≤ 0: never restart.
  double restart_after = 0.0;
  /// Overrides of named parameters (e.g. "mu.default").
  std::vector<std::pair<std::string, double>> params;
  /// Drop the LCP warm start before every timed step (cost of a cold Lemke solve).
  bool cold_start = false;
};

void RunScene(benchmark::State& state, const std::string& file, const Regime& regime) {
  Simulator sim(LoadSceneFile(ScenePath(file)));
  Params p = sim.DefaultParams();
  for (const auto& [name, value] : regime.params)
    p.values[sim.scene().param_table().Index(name)] = value;

  const State x0 = sim.InitialState();
  State x = x0, next;
  Workspace ws;
  for (int k = 0; k < regime.settle_steps; ++k) {
    const StepInfo info = sim.Step(p, x, StepInput{}, &ws, &next);
    if (!info.ok) {
      state.SkipWithError(
          ("settling failed at t = " + std::to_string(x.t) + ": " + info.failure).c_str());
      return;
    }
    std::swap(x, next);
  }

  const StepInput u;
  double contacts = 0.0, pivots = 0.0, joint_rows = 0.0;
  int64_t steps = 0;
  for (auto _ : state) {
    if (regime.restart_after > 0.0 && x.t > regime.restart_after) x = x0;
    if (regime.cold_start) x.warm_start.resize(0);
    const StepInfo info = sim.Step(p, x, u, &ws, &next);
    if (!info.ok) {
      state.SkipWithError(
          ("step failed at t = " + std::to_string(x.t) + ": " + info.failure).c_str());
      break;
    }
    contacts += info.contacts;
    pivots += info.solver.iterations;
    joint_rows += info.joint_rows;
    ++steps;
    std::swap(x, next);
  }

  using benchmark::Counter;
  state.counters["steps/s"] = Counter(static_cast<double>(steps), Counter::kIsRate);
  const double n = steps > 0 ? static_cast<double>(steps) : 1.0;
  state.counters["contacts"] = Counter(contacts / n);
  state.counters["pivots"] = Counter(pivots / n);
  if (joint_rows > 0.0) state.counters["joint_rows"] = Counter(joint_rows / n);
}

// Ball dropped from 1 m: free fall (~0.43 s), impact, then resting contact; restarted after the
// scene's duration (1 s), so the timed mix is ~43 % free flight and ~57 % one resting contact.
void BM_BallDrop(benchmark::State& state) { RunScene(state, "ball_drop.yaml", Regime{0, 1.0, {}}); }
BENCHMARK(BM_BallDrop);

// Box resting on a floor: four corner contacts, 8 friction directions, steady state.
void BM_BoxOnPlane(benchmark::State& state) {
  RunScene(state, "box_on_plane.yaml", Regime{100, 0.0, {}});
}
BENCHMARK(BM_BoxOnPlane);

// The same without the LCP warm start: every step is a cold Lemke solve.
void BM_BoxOnPlaneColdStart(benchmark::State& state) {
  RunScene(state, "box_on_plane.yaml", Regime{100, 0.0, {}, true});
}
BENCHMARK(BM_BoxOnPlaneColdStart);

// Box at rest on a 0.3 rad incline with μ = 1.05 tan θ (sticking, close to the cone boundary).
void BM_BlockOnIncline(benchmark::State& state) {
  RunScene(state, "block_on_incline.yaml",
           Regime{100, 0.0, {{"mu.default", 1.05 * std::tan(0.3)}}});
}
BENCHMARK(BM_BlockOnIncline);

// Ten stacked 0.2 m cubes, timed in steady state after 0.5 s of settling.
void BM_BoxStack10(benchmark::State& state) {
  RunScene(state, "box_stack.yaml", Regime{500, 0.0, {}});
}
BENCHMARK(BM_BoxStack10);

// The same without the LCP warm start: every step is a cold Lemke solve.
void BM_BoxStack10ColdStart(benchmark::State& state) {
  RunScene(state, "box_stack.yaml", Regime{500, 0.0, {}, true});
}
BENCHMARK(BM_BoxStack10ColdStart);

// Planar 2-bar pendulum released horizontally (no contacts, 4 joint rows); restarted after the
// scene's duration (5 s).
void BM_Pendulum2Bar(benchmark::State& state) {
  RunScene(state, "pendulum_2bar.yaml", Regime{0, 5.0, {}});
}
BENCHMARK(BM_Pendulum2Bar);

}  // namespace
}  // namespace vinci::sim

BENCHMARK_MAIN();
