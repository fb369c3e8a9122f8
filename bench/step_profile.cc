// A plain driver for profilers (perf, callgrind): a resting k-box stack (or the 100-box pile of
// vinci_vs_mujoco, or a scene file), settled, then N timed steps; prints CPU µs per step,
// contacts, LCP size and Lemke pivots per step and operator-new allocations per step (Eigen's own
// malloc calls are not counted: callgrind's call counts of malloc have those). No benchmark
// framework, so a profile shows only the simulator.
//
//   step_profile [--k K [--gap G] | --pile] [--settle N] [--steps N] [--digits D]
//   step_profile --scene FILE.yaml [--mu MU] [--settle N] [--steps N]
//   valgrind --tool=callgrind --toggle-collect='Timed*' step_profile --k 10 [--dense]
//   (counts the timed steps only, not the settling ones)
//
// --scene: the scene file's own formulation, stepped by Simulator::Step (as vinci_vs_mujoco and
// the velocity field step it: the end-of-step penetration check included); --mu sets the
// parameter mu.default (block_on_incline.yaml sticks with --mu 0.3248 = 1.05 tan 0.3).
//
// --digits D: the start poses written with D significant digits (default 17: exact).
// --dense: the step through the dense LCP (as before the structured warm-basis solve and the
// sparse Lemke). --gap G: the cubes start G m apart (and above the floor), so the stack settles
// through impacts (Lemke pivots).
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <memory>
#include <new>
#include <string>
#include <utility>

#include "box_scenes.h"
#include "vinci/sim/formulations/stewart_trinkle.h"
#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/simulator/simulator.h"
#include "vinci/sim/solvers/lemke.h"

// Counts heap allocations (operator new) so that the program can report allocations per step.
namespace {
std::atomic<long> g_allocations{0};
}  // namespace

void* operator new(std::size_t size) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(size > 0 ? size : 1)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }

namespace {

// Lemke under another type: StewartTrinkle then always builds and solves the dense LCP (its
// structured warm-basis path is for LemkeSolver only): the step as it was before issue 16's
// structured solve, for comparisons in one binary.
class DenseLemke final : public vinci::sim::LcpSolver {
 public:
  std::string_view name() const override { return "lemke"; }
  vinci::sim::SolverReport Solve(const vinci::sim::LcpProblem& problem,
                                 const Eigen::VectorXd* warm_start,
                                 Eigen::VectorXd* z) const override {
    return lemke_.Solve(problem, warm_start, z);
  }

 private:
  vinci::sim::LemkeSolver lemke_;
};

double CpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

}  // namespace

// One timed step (not inlined, so that callgrind can count only these:
// --toggle-collect=TimedStep*).
__attribute__((noinline)) vinci::sim::StepInfo TimedStep(const vinci::sim::StewartTrinkle& stepper,
                                                         const vinci::sim::Scene& model,
                                                         const vinci::sim::State& x,
                                                         vinci::sim::Workspace* ws,
                                                         vinci::sim::State* next) {
  vinci::sim::StepInfo info;
  stepper.Step(model, x, vinci::sim::StepInput{}, ws, next, &info);
  return info;
}

// One timed Simulator::Step (--scene).
__attribute__((noinline)) vinci::sim::StepInfo TimedSimStep(const vinci::sim::Simulator& sim,
                                                            const vinci::sim::Params& params,
                                                            const vinci::sim::State& x,
                                                            vinci::sim::Workspace* ws,
                                                            vinci::sim::State* next) {
  return sim.Step(params, x, vinci::sim::StepInput{}, ws, next);
}

namespace {

// --scene: settle, then `steps` timed Simulator::Step calls.
int RunScene(const std::string& file, double mu, int settle, int steps) {
  using namespace vinci::sim;
  const Simulator sim(LoadSceneFile(file));
  Params params = sim.DefaultParams();
  if (!std::isnan(mu)) params.values[sim.scene().param_table().Index("mu.default")] = mu;
  State x = sim.InitialState(), next;
  Workspace ws;
  for (int i = 0; i < settle; ++i) {
    const StepInfo info = sim.Step(params, x, StepInput{}, &ws, &next);
    if (!info.ok) {
      std::fprintf(stderr, "settling failed at t = %g: %s\n", x.t, info.failure.c_str());
      return 1;
    }
    std::swap(x, next);
  }
  double contacts = 0.0, pivots = 0.0;
  const long allocations0 = g_allocations.load();
  const double t0 = CpuSeconds();
  for (int i = 0; i < steps; ++i) {
    const StepInfo info = TimedSimStep(sim, params, x, &ws, &next);
    if (!info.ok) {
      std::fprintf(stderr, "step failed at t = %g: %s\n", x.t, info.failure.c_str());
      return 1;
    }
    contacts += info.contacts;
    pivots += info.solver.iterations;
    std::swap(x, next);
  }
  const double t1 = CpuSeconds();
  const double allocations =
      static_cast<double>(g_allocations.load() - allocations0) / static_cast<double>(steps);
  std::printf("%s: %.2f CPU us/step, %.1f contacts, %.3f pivots/step, %.1f allocations/step\n",
              file.c_str(), 1e6 * (t1 - t0) / steps, contacts / steps, pivots / steps, allocations);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  int k = 10, settle = 300, steps = 1000, digits = 17;
  bool pile = false, dense = false;
  double gap = 0.0, mu = std::nan("");
  std::string scene;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--scene" && i + 1 < argc) {
      scene = argv[++i];
    } else if (a == "--mu" && i + 1 < argc) {
      mu = std::atof(argv[++i]);
    } else if (a == "--k" && i + 1 < argc) {
      k = std::atoi(argv[++i]);
    } else if (a == "--pile") {
      pile = true;
    } else if (a == "--gap" && i + 1 < argc) {
      gap = std::atof(argv[++i]);
    } else if (a == "--dense") {
      dense = true;
    } else if (a == "--settle" && i + 1 < argc) {
      settle = std::atoi(argv[++i]);
    } else if (a == "--digits" && i + 1 < argc) {
      digits = std::atoi(argv[++i]);
    } else if (a == "--steps" && i + 1 < argc) {
      steps = std::atoi(argv[++i]);
    } else {
      std::fprintf(
          stderr,
          "usage: step_profile [--k K [--gap G] | --pile | --scene FILE [--mu MU]] [--settle N] "
          "[--steps N] [--digits D] [--dense]\n");
      return 2;
    }
  }
  if (k < 1 || settle < 0 || steps < 1 || digits < 1 || digits > 17) {
    std::fprintf(stderr,
                 "step_profile: expected k >= 1, settle >= 0, steps >= 1, 1 <= digits <= 17\n");
    return 2;
  }
  if (!scene.empty()) return RunScene(scene, mu, settle, steps);
  using namespace vinci::sim;
  const Simulator sim(
      ParseScene(pile ? vinci::bench::PileYaml(digits) : vinci::bench::StackYaml(k, digits, gap),
                 "step_profile"));
  const Scene model = sim.scene().ApplyParams(sim.DefaultParams());
  std::shared_ptr<const LcpSolver> solver;
  if (dense)
    solver = std::make_shared<DenseLemke>();
  else
    solver = std::make_shared<LemkeSolver>();
  const StewartTrinkle stepper(model.options, solver);
  State x = sim.InitialState(), next;
  Workspace ws;
  const StepInput u;
  const auto step = [&]() {
    StepInfo info;
    stepper.Step(model, x, u, &ws, &next, &info);
    return info;
  };
  for (int i = 0; i < settle; ++i) {
    const StepInfo info = step();
    if (!info.ok) {
      std::fprintf(stderr, "settling failed at t = %g: %s\n", x.t, info.failure.c_str());
      return 1;
    }
    std::swap(x, next);
  }
  double contacts = 0.0, pivots = 0.0, lcp = 0.0;
  int changes = 0, last_contacts = -1;  // steps whose contact count differs from the previous
  const long allocations0 = g_allocations.load();
  const double t0 = CpuSeconds();
  for (int i = 0; i < steps; ++i) {
    const StepInfo info = TimedStep(stepper, model, x, &ws, &next);
    if (!info.ok) {
      std::fprintf(stderr, "step failed at t = %g: %s\n", x.t, info.failure.c_str());
      return 1;
    }
    contacts += info.contacts;
    changes += last_contacts >= 0 && info.contacts != last_contacts;
    last_contacts = info.contacts;
    pivots += info.solver.iterations;
    lcp += static_cast<double>(next.warm_start.size());
    std::swap(x, next);
  }
  const double t1 = CpuSeconds();
  const double allocations =
      static_cast<double>(g_allocations.load() - allocations0) / static_cast<double>(steps);
  const long basis = (x.warm_start.array() > 0.0).count();
  std::printf(
      "%s: %.2f CPU us/step, %.1f contacts, LCP size %.0f, %.3f pivots/step, last basis %ld, %.1f "
      "allocations/step, contact count changed in %d steps\n",
      pile ? "pile of 100" : (std::to_string(k) + "-box stack").c_str(), 1e6 * (t1 - t0) / steps,
      contacts / steps, lcp / steps, pivots / steps, basis, allocations, changes);
  return 0;
}
