// Heap allocations of steady-state steps (issue 16, deliverable 3: no per-step allocation in Step
// and Rollout). This binary replaces malloc, so it is its own test executable.
// Each test settles a scene, then counts the allocations of the next steps; the README of bench/
// lists the counts of the paths that do not reach zero yet (bench/README.md, "Allocations per
// step").
#include <gtest/gtest.h>

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <utility>
#include <vector>

#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/simulator/simulator.h"

// Every heap allocation goes through malloc (operator new, Eigen's aligned_malloc, std::string):
// this executable's malloc, calloc and realloc count and forward to glibc's (same heap, so glibc's
// free releases them).
extern "C" {
void* __libc_malloc(std::size_t size);
void* __libc_calloc(std::size_t n, std::size_t size);
void* __libc_realloc(void* p, std::size_t size);
}

namespace {
std::atomic<long> g_allocations{0};
}  // namespace

extern "C" {
void* malloc(std::size_t size) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  return __libc_malloc(size);
}
void* calloc(std::size_t n, std::size_t size) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  return __libc_calloc(n, size);
}
void* realloc(void* p, std::size_t size) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  return __libc_realloc(p, size);
}
}

namespace vinci::sim {
namespace {

// Settling steps before counting: every scene here is at rest (or on its periodic orbit) after.
constexpr int kSettle = 400;
// Counted steps.
constexpr int kSteps = 100;

Simulator Load(const std::string& name) {
  return Simulator(LoadSceneFile(std::string(VINCI_SOURCE_DIR) + "/examples/scenes/" + name));
}

// Allocations per step over kSteps steps after kSettle steps of Simulator::Step.
double StepAllocations(const Simulator& sim) {
  const Params params = sim.DefaultParams();
  Workspace ws;
  State x = sim.InitialState(), next;
  const StepInput u;
  for (int i = 0; i < kSettle; ++i) {
    const StepInfo info = sim.Step(params, x, u, &ws, &next);
    EXPECT_TRUE(info.ok) << info.failure;
    std::swap(x, next);
  }
  const long before = g_allocations.load();
  bool ok = true;
  for (int i = 0; i < kSteps; ++i) {
    const StepInfo info = sim.Step(params, x, u, &ws, &next);
    ok = ok && info.ok;
    std::swap(x, next);
  }
  const long count = g_allocations.load() - before;
  EXPECT_TRUE(ok);
  return static_cast<double>(count) / kSteps;
}

// Allocations per step of Simulator::Rollout: the difference between a rollout of 2n and one of
// n steps from the same settled state (each records x0 and its final state only), over n steps.
double RolloutAllocations(const Simulator& sim) {
  const Params params = sim.DefaultParams();
  const Trajectory settle = sim.Rollout(params, sim.InitialState(), kSettle);
  EXPECT_TRUE(settle.ok) << settle.failure;
  const State x0 = settle.states.back();
  RolloutOptions options;
  options.record_every = 1 << 20;
  const std::vector<StepInput> short_inputs(kSteps), long_inputs(2 * kSteps);
  long before = g_allocations.load();
  const Trajectory a = sim.Rollout(params, x0, short_inputs, options);
  const long short_count = g_allocations.load() - before;
  before = g_allocations.load();
  const Trajectory b = sim.Rollout(params, x0, long_inputs, options);
  const long long_count = g_allocations.load() - before;
  EXPECT_TRUE(a.ok && b.ok);
  return static_cast<double>(long_count - short_count) / kSteps;
}

TEST(StepAllocationTest, Report) {
  // Today's counts, printed for bench/README.md.
  for (const char* scene : {"box_on_plane.yaml", "box_stack.yaml", "plate_box.yaml"}) {
    const Simulator sim = Load(scene);
    std::printf("%s: %.2f allocations per Step, %.2f per Rollout step\n", scene,
                StepAllocations(sim), RolloutAllocations(sim));
  }
}

}  // namespace
}  // namespace vinci::sim
