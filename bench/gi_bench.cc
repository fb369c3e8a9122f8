// Geometrically implicit (GI) stepper vs Stewart–Trinkle on the same scenes (issue 4 §7;
// bench/README.md): step time and solver iterations per step (GI: semismooth Newton iterations
// of the step's mixed NCP; Stewart–Trinkle: Lemke pivots).
//
// One benchmark iteration = one Simulator::Step. Scenes:
// - disc on a plane (examples/scenes/disc_on_plane.yaml, h = 1e-3): the GI disc vs N-gon discs
//   (N = 20, 100) under Stewart–Trinkle, sliding then rolling, restarted after 1 s;
// - sphere on two spheres (examples/scenes/sphere_on_two_spheres.yaml): drop, impact and rest,
//   restarted after 1 s; Stewart–Trinkle on the same spheres (its sphere–sphere contact is exact);
// - box resting on a plane (examples/scenes/box_on_plane.yaml): GI with the box as 6 half-spaces
//   (one contact point per shape pair) vs Stewart–Trinkle with four corner contacts.
// Counters: iters/step (solver iterations), contacts (per step), steps/s.
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdint>
#include <functional>
#include <string>
#include <utility>

#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/simulator/simulator.h"

namespace vinci::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;

Scene LoadExampleScene(const std::string& file) {
  return LoadSceneFile(std::string(VINCI_SOURCE_DIR "/examples/scenes/") + file);
}

void RunScene(benchmark::State& state, Scene scene, int settle_steps, double restart_after) {
  const Simulator sim(std::move(scene));
  const Params p = sim.DefaultParams();
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
  double contacts = 0.0, iterations = 0.0;
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
    ++steps;
    std::swap(x, next);
  }
  using benchmark::Counter;
  const double n = steps > 0 ? static_cast<double>(steps) : 1.0;
  state.counters["steps/s"] = Counter(static_cast<double>(steps), Counter::kIsRate);
  state.counters["iters/step"] = Counter(iterations / n);
  state.counters["contacts"] = Counter(contacts / n);
}

// The disc of disc_on_plane.yaml replaced by an N-gon (vertices on the circle, an edge down).
Scene NGonScene(int n) {
  Scene s = LoadExampleScene("disc_on_plane.yaml");
  Body& b = s.bodies[s.FindBody("disc")];
  Shape& sh = b.shapes[0];
  const double r = sh.radius;
  sh.type = ShapeType::kPolygon;
  for (int k = 0; k < n; ++k) {
    const double a = -kPi / 2 + kPi / n + 2.0 * kPi * k / n;
    sh.vertices.emplace_back(r * std::cos(a), r * std::sin(a), 0.0);
  }
  b.X_WB0.translation().y() = r * std::cos(kPi / n);
  s.options.formulation = FormulationType::kStewartTrinkle;
  return s;
}

Scene WithFormulation(const std::string& file, FormulationType f) {
  Scene s = LoadExampleScene(file);
  s.options.formulation = f;
  return s;
}

void BM_DiscOnPlaneGi(benchmark::State& state) {
  RunScene(state, LoadExampleScene("disc_on_plane.yaml"), 0, 1.0);
}
BENCHMARK(BM_DiscOnPlaneGi);

void BM_DiscOnPlaneNGonStewartTrinkle(benchmark::State& state) {
  RunScene(state, NGonScene(static_cast<int>(state.range(0))), 0, 1.0);
}
BENCHMARK(BM_DiscOnPlaneNGonStewartTrinkle)->Arg(20)->Arg(100);

void BM_SphereOnTwoSpheresGi(benchmark::State& state) {
  RunScene(state, LoadExampleScene("sphere_on_two_spheres.yaml"), 0, 1.0);
}
BENCHMARK(BM_SphereOnTwoSpheresGi);

void BM_SphereOnTwoSpheresStewartTrinkle(benchmark::State& state) {
  RunScene(state, WithFormulation("sphere_on_two_spheres.yaml", FormulationType::kStewartTrinkle),
           0, 1.0);
}
BENCHMARK(BM_SphereOnTwoSpheresStewartTrinkle);

void BM_BoxOnPlaneGi(benchmark::State& state) {
  RunScene(state, WithFormulation("box_on_plane.yaml", FormulationType::kGeometricallyImplicit),
           100, 0.0);
}
BENCHMARK(BM_BoxOnPlaneGi);

void BM_BoxOnPlaneStewartTrinkle(benchmark::State& state) {
  RunScene(state, LoadExampleScene("box_on_plane.yaml"), 100, 0.0);
}
BENCHMARK(BM_BoxOnPlaneStewartTrinkle);

}  // namespace
}  // namespace vinci::sim

BENCHMARK_MAIN();
