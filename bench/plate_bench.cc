// Parts on a vibrating plate (issue 6, bench/README.md): steps per second of a part on the
// plate, and the wall time of a whole velocity field on 2 threads.
//
//   BM_PlateStep/<scene>      one Simulator::Step of the part on the plate (steps/s)
//   BM_Field21x21/<cycles>    vinci field's computation: 21 × 21 grid, `cycles` cycles per point,
//                             2 threads, real (wall) time; one iteration
#include <benchmark/benchmark.h>

#include <string>

#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/plate/velocity_field.h"
#include "vinci/sim/simulator/simulator.h"

namespace vinci::sim {
namespace {

std::string ScenePath(const std::string& file) {
  return std::string(VINCI_SOURCE_DIR "/examples/scenes/") + file;
}

void BM_PlateStep(benchmark::State& state, const std::string& file) {
  Simulator sim(LoadSceneFile(ScenePath(file)));
  const Params p = sim.DefaultParams();
  const State x0 = sim.InitialState();
  State x = x0, next;
  Workspace ws;
  const StepInput u;
  double contacts = 0.0;
  int64_t steps = 0;
  for (auto _ : state) {
    if (x.t > 1.0) x = x0;  // stay near the start of the plate
    const StepInfo info = sim.Step(p, x, u, &ws, &next);
    if (!info.ok) {
      state.SkipWithError(("step failed: " + info.failure).c_str());
      return;
    }
    contacts += info.contacts;
    ++steps;
    std::swap(x, next);
  }
  state.counters["steps/s"] =
      benchmark::Counter(static_cast<double>(steps), benchmark::Counter::kIsRate);
  if (steps > 0) state.counters["contacts"] = contacts / steps;
}
BENCHMARK_CAPTURE(BM_PlateStep, point_conveyor, std::string("plate_conveyor.yaml"));
BENCHMARK_CAPTURE(BM_PlateStep, point_whirlpool_nd16, std::string("plate_whirlpool.yaml"));
BENCHMARK_CAPTURE(BM_PlateStep, point_tilt_planar, std::string("plate_tilt_planar.yaml"));
BENCHMARK_CAPTURE(BM_PlateStep, box_nd8, std::string("plate_box.yaml"));
BENCHMARK_CAPTURE(BM_PlateStep, tripod_nd8, std::string("plate_tripod.yaml"));

void BM_Field21x21(benchmark::State& state) {
  const std::string path = ScenePath("plate_whirlpool.yaml");
  Simulator sim(LoadSceneFile(path));
  FieldSpec spec = LoadFieldSpec(path, sim.scene());
  spec.nx = spec.ny = 21;
  spec.cycles = static_cast<int>(state.range(0));
  spec.average_cycles = std::min(10, spec.cycles);
  FieldOptions options;
  options.threads = 2;
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
BENCHMARK(BM_Field21x21)->Arg(1)->Arg(50)->Iterations(1)->UseRealTime()->Unit(benchmark::kSecond);

}  // namespace
}  // namespace vinci::sim

BENCHMARK_MAIN();
