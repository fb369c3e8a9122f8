// Batch scaling (simulator/batch.h, issue 12 item 7; bench/README.md): wall time of the same batch
// on 1 and 2 threads.
//
//   BM_BatchField/<threads>     a 7 × 7 velocity field of plate_whirlpool.yaml, 4 cycles per point
//                               (ComputeVelocityField = BatchMap over the points)
//   BM_BatchRollouts/<threads>  100 rollouts of block_sliding.yaml (300 steps each, μ varied),
//                               final state kept (state_stride 0)
// Real (wall) time and process CPU time (all threads); speedup = time(1) / time(2). steps/s
// counts simulated steps of all tasks per wall second.
#include <benchmark/benchmark.h>

#include <string>

#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/plate/velocity_field.h"
#include "vinci/sim/simulator/batch.h"
#include "vinci/sim/simulator/simulator.h"

namespace vinci::sim {
namespace {

std::string ScenePath(const std::string& file) {
  return std::string(VINCI_SOURCE_DIR "/examples/scenes/") + file;
}

void BM_BatchField(benchmark::State& state) {
  const std::string path = ScenePath("plate_whirlpool.yaml");
  const Simulator sim(LoadSceneFile(path));
  FieldSpec spec = LoadFieldSpec(path, sim.scene());
  spec.nx = spec.ny = 7;
  spec.cycles = 4;
  spec.average_cycles = 2;
  FieldOptions options;
  options.threads = static_cast<int>(state.range(0));
  int64_t steps = 0;
  for (auto _ : state) {
    const VelocityField f = ComputeVelocityField(sim, sim.DefaultParams(), spec, options);
    benchmark::DoNotOptimize(f.points.data());
    steps += static_cast<int64_t>(f.points.size()) * spec.cycles *
             spec.StepsPerCycle(sim.scene().options.dt);
  }
  state.counters["steps/s"] =
      benchmark::Counter(static_cast<double>(steps), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_BatchField)
    ->Arg(1)
    ->Arg(2)
    ->MeasureProcessCPUTime()
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

void BM_BatchRollouts(benchmark::State& state) {
  const Simulator sim(LoadSceneFile(ScenePath("block_sliding.yaml")));
  const int mu = sim.scene().param_table().Index("mu.default");
  constexpr int kRollouts = 100, kSteps = 300;
  std::vector<RolloutTask> tasks(kRollouts);
  for (int i = 0; i < kRollouts; ++i) {
    Params p = sim.DefaultParams();
    p.values[mu] = 0.1 + 0.005 * i;
    tasks[i].params = p;
    tasks[i].num_steps = kSteps;
  }
  BatchRolloutOptions options;
  options.threads = static_cast<int>(state.range(0));
  options.state_stride = 0;
  options.step_reports = false;
  int64_t steps = 0;
  for (auto _ : state) {
    const std::vector<RolloutResult> r = BatchRollouts(sim, tasks, options);
    for (const RolloutResult& x : r) {
      if (x.status != TaskStatus::kOk || !x.trajectory.ok) {
        state.SkipWithError("a rollout failed");
        return;
      }
      steps += x.steps_done;
    }
  }
  state.counters["steps/s"] =
      benchmark::Counter(static_cast<double>(steps), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_BatchRollouts)
    ->Arg(1)
    ->Arg(2)
    ->MeasureProcessCPUTime()
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace vinci::sim

BENCHMARK_MAIN();
