// The 100-box pile of vinci_vs_mujoco (bench/box_scenes.h, PileYaml) stepped from exact
// contact: per-step diagnostics of its rest (largest body speed, deepest penetration, how the
// LCP was solved), every `--every` steps and at every step not solved on the warm basis.
//
//   pile_rest [--steps N] [--every K] [--layers L --side S] [--digits D] [--gap G]
//
// --digits D: the start poses written with D significant digits (default 17: exact contact;
// fewer: small gaps and overlaps). --gap G: each layer starts G m above the one below (and the
// first above the floor), so the pile settles through impacts and contact changes.
// Prints one line per reported step: step, t, CPU ms of the step, contacts, pivots, the largest
// body speed (m/s, the 6-vector norm), the deepest gap (m), the solver message; at the end the
// number of failed steps, the worst speed and gap and the mean CPU ms per step after step 0.
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <string>
#include <utility>

#include "box_scenes.h"
#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/simulator/simulator.h"

namespace {

double CpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

}  // namespace

int main(int argc, char** argv) {
  int steps = 1000, every = 50, layers = 4, side = 5, digits = 17;
  double gap = 0.0;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--steps" && i + 1 < argc) {
      steps = std::atoi(argv[++i]);
    } else if (a == "--every" && i + 1 < argc) {
      every = std::atoi(argv[++i]);
    } else if (a == "--layers" && i + 1 < argc) {
      layers = std::atoi(argv[++i]);
    } else if (a == "--side" && i + 1 < argc) {
      side = std::atoi(argv[++i]);
    } else if (a == "--gap" && i + 1 < argc) {
      gap = std::atof(argv[++i]);
    } else if (a == "--digits" && i + 1 < argc) {
      digits = std::atoi(argv[++i]);
    } else {
      std::fprintf(stderr,
                   "usage: pile_rest [--steps N] [--every K] [--layers L --side S] [--digits D] "
                   "[--gap G]\n");
      return 2;
    }
  }
  if (steps < 1 || every < 1 || layers < 1 || side < 1 || digits < 1 || digits > 17) {
    std::fprintf(stderr,
                 "pile_rest: expected positive --steps, --every, --layers, --side and 1 <= "
                 "--digits <= 17\n");
    return 2;
  }
  using namespace vinci::sim;
  const Simulator sim(ParseScene(vinci::bench::PileYaml(digits, layers, side, gap), "pile_rest"));
  const Scene& s = sim.scene();
  const Params params = sim.DefaultParams();
  Workspace ws;
  State x = sim.InitialState(), next;
  int failed = 0;
  double worst_speed = 0.0, worst_gap = 0.0, cpu_after_first = 0.0;
  for (int k = 0; k < steps; ++k) {
    const double t0 = CpuSeconds();
    const StepInfo info = sim.Step(params, x, StepInput{}, &ws, &next);
    const double cpu = CpuSeconds() - t0;
    if (k > 0) cpu_after_first += cpu;
    if (!info.ok) {
      ++failed;
      std::printf("step %d t=%.3f FAILED (%.1f ms): %s\n", k, x.t, 1e3 * cpu, info.failure.c_str());
      break;
    }
    std::swap(x, next);
    double speed = 0.0;
    for (int b : s.dynamic_bodies()) speed = std::max(speed, x.v.segment<6>(s.index(b).v).norm());
    worst_speed = std::max(worst_speed, speed);
    worst_gap = std::min(worst_gap, info.min_gap);
    const bool warm = info.solver.iterations == 0 && info.solver.message == "warm basis";
    if (k % every == 0 || !warm)
      std::printf("step %d t=%.3f %.2f ms contacts %d pivots %d speed %.2e gap %.2e: %s\n", k, x.t,
                  1e3 * cpu, info.contacts, info.solver.iterations, speed, info.min_gap,
                  info.solver.message.substr(0, 160).c_str());
  }
  std::printf("failed %d, worst speed %.2e m/s, worst gap %.2e m, %.3f CPU ms/step after step 0\n",
              failed, worst_speed, worst_gap, 1e3 * cpu_after_first / std::max(1, steps - 1));
  return failed > 0 ? 1 : 0;
}
