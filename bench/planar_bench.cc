// Quasistatic vs dynamic step cost on the pushing scene (bench/README.md, "Planar models").
//
// examples/scenes/planar_pushing.yaml: a disc pusher pushes a slider with four support points
// (2.5D support friction, n_d = 16 for the linearized disks). One benchmark iteration = one
// Simulator::Step, restarting from the initial state every 50 steps so every step is a push
// (pusher in contact from the first step). Formulations: quasistatic-dqc (MCP), quasistatic-dlc
// (split LCP, Lemke), stewart-trinkle (dynamic LCP, Lemke) and dynamic-dqc (dynamics with the
// exact disks, MCP), each warm-started from the previous step as in a rollout.
#include <benchmark/benchmark.h>

#include <string>

#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/simulator/simulator.h"

namespace vinci::sim {
namespace {

void PushingStep(benchmark::State& state, FormulationType type) {
  Scene scene = LoadSceneFile(VINCI_SOURCE_DIR "/examples/scenes/planar_pushing.yaml");
  scene.options.formulation = type;
  const Simulator sim(scene);
  const Params p = sim.DefaultParams();
  const State x0 = sim.InitialState();
  State x = x0, next;
  Workspace ws;
  double iterations = 0.0, contacts = 0.0;
  int64_t steps = 0;
  for (auto _ : state) {
    if (x.t > 0.5 - 1e-9) x = x0;
    const StepInfo info = sim.Step(p, x, StepInput{}, &ws, &next);
    if (!info.ok) {
      state.SkipWithError(("step failed: " + info.failure).c_str());
      return;
    }
    iterations += info.solver.iterations;
    contacts += info.contacts;
    ++steps;
    std::swap(x, next);
  }
  state.counters["steps/s"] =
      benchmark::Counter(static_cast<double>(steps), benchmark::Counter::kIsRate);
  state.counters["solver_iters"] = iterations / std::max<int64_t>(steps, 1);
  state.counters["contacts"] = contacts / std::max<int64_t>(steps, 1);
}

void BM_PushingQuasistaticDqc(benchmark::State& s) {
  PushingStep(s, FormulationType::kQuasistaticDqc);
}
void BM_PushingQuasistaticDlc(benchmark::State& s) {
  PushingStep(s, FormulationType::kQuasistaticDlc);
}
void BM_PushingDynamicStewartTrinkle(benchmark::State& s) {
  PushingStep(s, FormulationType::kStewartTrinkle);
}
BENCHMARK(BM_PushingQuasistaticDqc);
BENCHMARK(BM_PushingQuasistaticDlc);
void BM_PushingDynamicDqc(benchmark::State& s) { PushingStep(s, FormulationType::kDynamicDqc); }
BENCHMARK(BM_PushingDynamicStewartTrinkle);
BENCHMARK(BM_PushingDynamicDqc);

}  // namespace
}  // namespace vinci::sim

BENCHMARK_MAIN();
