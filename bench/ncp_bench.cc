// NCP (quadratic friction cone, semismooth Newton MCP) vs Stewart–Trinkle (linearized cone,
// Lemke LCP): time per Simulator::Step and solver iterations per step on shared example scenes
// (bench/README.md, "NCP vs Stewart–Trinkle").
//
// One benchmark iteration = one step, continuing the trajectory (restarting from the initial
// state after `restart_after` s). Counters: steps/s, contacts per step, iterations per step
// (Lemke pivots for Stewart–Trinkle, Newton/gradient iterations for NCP, over all restarts), and
// for NCP the fraction of steps that needed the LCP-restart fallback.
#include <benchmark/benchmark.h>

#include <cstdint>
#include <string>
#include <utility>

#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/simulator/simulator.h"

namespace vinci::sim {
namespace {

void RunStep(benchmark::State& state, const std::string& file, FormulationType formulation,
             int settle_steps, double restart_after, double mu) {
  Scene scene = LoadSceneFile(std::string(VINCI_SOURCE_DIR "/examples/scenes/") + file);
  scene.options.formulation = formulation;
  Simulator sim(scene);
  Params p = sim.DefaultParams();
  if (mu >= 0.0) p.values[sim.scene().param_table().Index("mu.default")] = mu;
  const State x0 = sim.InitialState();
  State x = x0, next;
  Workspace ws;
  for (int k = 0; k < settle_steps; ++k) {
    const StepInfo info = sim.Step(p, x, StepInput{}, &ws, &next);
    if (!info.ok) {
      state.SkipWithError(("settling failed: " + info.failure).c_str());
      return;
    }
    std::swap(x, next);
  }
  const StepInput u;
  double contacts = 0.0, iterations = 0.0, fallbacks = 0.0;
  int64_t steps = 0;
  for (auto _ : state) {
    if (restart_after > 0.0 && x.t > restart_after) x = x0;
    const StepInfo info = sim.Step(p, x, u, &ws, &next);
    if (!info.ok) {
      state.SkipWithError(
          ("step failed at t = " + std::to_string(x.t) + ": " + info.failure).c_str());
      break;
    }
    contacts += info.contacts;
    iterations += info.solver.iterations;
    fallbacks += info.solver.message.find("retried") != std::string::npos ? 1.0 : 0.0;
    ++steps;
    std::swap(x, next);
  }
  using benchmark::Counter;
  const double n = steps > 0 ? static_cast<double>(steps) : 1.0;
  state.counters["steps/s"] = Counter(static_cast<double>(steps), Counter::kIsRate);
  state.counters["contacts"] = Counter(contacts / n);
  state.counters["iters/step"] = Counter(iterations / n);
  if (formulation == FormulationType::kNcp) state.counters["fallback"] = Counter(fallbacks / n);
}

#define VINCI_NCP_BENCH(Name, file, settle, restart, mu)                     \
  void BM_St_##Name(benchmark::State& s) {                                   \
    RunStep(s, file, FormulationType::kStewartTrinkle, settle, restart, mu); \
  }                                                                          \
  void BM_Ncp_##Name(benchmark::State& s) {                                  \
    RunStep(s, file, FormulationType::kNcp, settle, restart, mu);            \
  }                                                                          \
  BENCHMARK(BM_St_##Name)->Unit(benchmark::kMicrosecond);                    \
  BENCHMARK(BM_Ncp_##Name)->Unit(benchmark::kMicrosecond);

// A resting box: four redundant corner contacts.
VINCI_NCP_BENCH(BoxOnPlane, "box_on_plane.yaml", 10, 0.0, -1.0)
// A block sliding down the incline (μ = 0.2 < tan 0.3), restarted every 0.5 s.
VINCI_NCP_BENCH(BlockOnInclineSliding, "block_on_incline.yaml", 10, 0.5, -1.0)
// The same block sticking (μ = 0.5 ≥ tan 0.3).
VINCI_NCP_BENCH(BlockOnInclineSticking, "block_on_incline.yaml", 10, 0.0, 0.5)
// Ten stacked boxes after 100 settling steps: 40 contacts.
VINCI_NCP_BENCH(BoxStack, "box_stack.yaml", 100, 0.0, -1.0)
// The box (four redundant corners) on the vibrating conveyor plate, sliding and sticking
// within each 30 Hz cycle, restarted every 0.5 s (NCP failed here before the MCP scaling and
// LM step; docs/field.md).
VINCI_NCP_BENCH(PlateBox, "plate_box.yaml", 10, 0.5, -1.0)

}  // namespace
}  // namespace vinci::sim

BENCHMARK_MAIN();
