// Heap allocations of steady-state steps (issue 16, deliverable 3: no per-step allocation in Step
// and Rollout). This binary replaces malloc, so it is its own test executable.
// Each test settles a scene, then counts the allocations of the next steps. bench/README.md
// ("Allocations per step") lists the counts and what remains on the paths that are not at zero.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <utility>
#include <vector>

#include "box_scenes.h"
#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/simulator/batch.h"
#include "vinci/sim/simulator/sensitivity.h"
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

Simulator Load(const std::string& path) {
  return Simulator(LoadSceneFile(std::string(VINCI_SOURCE_DIR) + "/" + path));
}

// Allocations of kSteps steps of Simulator::Step after kSettle steps.
long StepAllocations(const Simulator& sim, const Params& params) {
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
  return count;
}
long StepAllocations(const Simulator& sim) { return StepAllocations(sim, sim.DefaultParams()); }

// StepAllocations of a scene file run with another formulation (SimulatorOptions).
long StepAllocations(const std::string& path, FormulationType formulation) {
  const Scene scene = LoadSceneFile(std::string(VINCI_SOURCE_DIR) + "/" + path);
  SimulatorOptions options = SimulatorOptions::FromScene(scene);
  options.formulation = formulation;
  return StepAllocations(Simulator(scene, options));
}

// Allocations of kSteps steps of Simulator::Rollout: the difference between a rollout of 2·kSteps
// and one of kSteps steps from the same settled state (what a rollout allocates once — its
// workspace, the params-resolved scene, the trajectory's vectors — cancels). `record_every` as
// RolloutOptions.
long RolloutAllocations(const Simulator& sim, int record_every) {
  const Params params = sim.DefaultParams();
  const Trajectory settle = sim.Rollout(params, sim.InitialState(), kSettle);
  EXPECT_TRUE(settle.ok) << settle.failure;
  const State x0 = settle.states.back();
  RolloutOptions options;
  options.record_every = record_every;
  const std::vector<StepInput> short_inputs(kSteps), long_inputs(2 * kSteps);
  long before = g_allocations.load();
  const Trajectory a = sim.Rollout(params, x0, short_inputs, options);
  const long short_count = g_allocations.load() - before;
  before = g_allocations.load();
  const Trajectory b = sim.Rollout(params, x0, long_inputs, options);
  const long long_count = g_allocations.load() - before;
  EXPECT_TRUE(a.ok && b.ok);
  return long_count - short_count;
}

// Records only x0 and the final state.
constexpr int kNoRecording = 1 << 20;

TEST(StepAllocationTest, RestingBoxStepAllocatesNothing) {
  EXPECT_EQ(StepAllocations(Load("examples/scenes/box_on_plane.yaml")), 0);
}

// The block on the 0.3 rad incline with μ = 1.05 tan θ: it sticks (as vinci_vs_mujoco's incline).
TEST(StepAllocationTest, StickingBlockOnInclineStepAllocatesNothing) {
  const Simulator sim = Load("examples/scenes/block_on_incline.yaml");
  Params params = sim.DefaultParams();
  params.values[sim.scene().param_table().Index("mu.default")] = 1.05 * std::tan(0.3);
  EXPECT_EQ(StepAllocations(sim, params), 0);
}

TEST(StepAllocationTest, SlidingBlockOnInclineStepAllocatesNothing) {
  // The scene's own μ = 0.2 < tan 0.3: the block slides, and every step's warm-start basis is
  // refused (the LCP of a sliding four-corner contact is degenerate; Lemke pivots ~8 times a
  // step), so every step takes the dense path (BuildLcpInto, LemkeSolver): its buffers are kept
  // per thread (and per basis size), so it allocates nothing either.
  EXPECT_EQ(StepAllocations(Load("examples/scenes/block_on_incline.yaml")), 0);
}

TEST(StepAllocationTest, TenBoxStackStepAllocatesNothing) {
  EXPECT_EQ(StepAllocations(Load("examples/scenes/box_stack.yaml")), 0);
}

// Bases above kDenseWarmBasisMax (80 and 160 normals): the sparse semidefinite LDLᵀ of M_BB
// keeps its analysis while the basis is unchanged.
TEST(StepAllocationTest, TallStackStepsAllocateNothing) {
  for (int k : {20, 40}) {
    const Simulator sim(ParseScene(bench::StackYaml(k), "stack"));
    EXPECT_EQ(StepAllocations(sim), 0) << k << "-box stack";
  }
}

TEST(StepAllocationTest, RolloutStepAllocatesNothing) {
  EXPECT_EQ(RolloutAllocations(Load("examples/scenes/box_on_plane.yaml"), kNoRecording), 0);
  EXPECT_EQ(RolloutAllocations(Load("examples/scenes/box_stack.yaml"), kNoRecording), 0);
}

TEST(StepAllocationTest, BatchRolloutStepAllocatesNothing) {
  // RunRollout, the unit of work of BatchRollouts, with one workspace as a batch thread keeps:
  // the difference between a 2·kSteps and a kSteps rollout from a settled state.
  const Simulator sim = Load("examples/scenes/box_stack.yaml");
  const Trajectory settle = sim.Rollout(sim.DefaultParams(), sim.InitialState(), kSettle);
  ASSERT_TRUE(settle.ok);
  BatchRolloutOptions options;
  options.state_stride = 0;
  Workspace ws;
  RolloutResult result;
  RolloutTask task;
  task.x0 = settle.states.back();
  // Run 0 warms the workspace (the params-resolved scene) up; runs 1 and 2 are compared.
  long count[3];
  for (int i = 0; i < 3; ++i) {
    task.num_steps = (i == 2 ? 2 : 1) * kSteps;
    const long before = g_allocations.load();
    RunRollout(sim, task, options, &ws, &result);
    count[i] = g_allocations.load() - before;
    EXPECT_TRUE(result.trajectory.ok);
  }
  EXPECT_EQ(count[2] - count[1], 0);
}

TEST(StepAllocationTest, RecordingAllocatesOnlyTheRecordedStates) {
  // Each recorded State holds three vectors (q, v, warm start): 3 allocations per record.
  EXPECT_EQ(RolloutAllocations(Load("examples/scenes/box_stack.yaml"), 1), 3 * kSteps);
}

TEST(StepAllocationTest, PlateBoxStepAllocatesNothing) {
  // The part on the vibrating plate changes its active set during every plate period: some
  // steps refuse the warm-start basis and take the dense path, and the warm-basis steps between
  // them see the basis size change (one warm-basis scratch per basis size).
  EXPECT_EQ(StepAllocations(Load("examples/scenes/plate_box.yaml")), 0);
}

TEST(StepAllocationTest, FeederPartStepAllocatesNothing) {
  // The feeder's U part (examples/design/feeder_scene.yaml: 2.5D support friction, a concave
  // polygon against the chute's polygons): support rows and the concave collision's polygons
  // are assembled into per-thread storage.
  EXPECT_EQ(StepAllocations(Load("examples/design/feeder_scene.yaml")), 0);
}

// Joints (the dense path's joint elimination S = G_bᵀ M⁻¹ G_b, its LDLᵀ solves and the velocity
// correction): two revolute joints without contact; a pendulum on a block (a revolute joint on
// a body in contact); the full planar model (joints, contacts, a prescribed pusher).
TEST(StepAllocationTest, JointStepsAllocateNothing) {
  for (const char* path :
       {"examples/scenes/pendulum_2bar.yaml", "examples/scenes/pendulum_on_block.yaml",
        "examples/scenes/full_planar.yaml"})
    EXPECT_EQ(StepAllocations(Load(path)), 0) << path;
}

// Corner contacts (docs/formulations.md §7): a block at rest with its bottom-left vertex on the
// convex top corner of a trench in a concave floor (the corner rows D = G_1 − G_2 and W D).
TEST(StepAllocationTest, CornerContactStepsAllocateNothing) {
  const std::string yaml = R"(name: corner
dimension: 2
gravity: [0, -9.81]
stepper: {formulation: FORMULATION, dt: 0.001, duration: 1.0, envelope: 0.002}
friction: {default: 0.3}
bodies:
  - name: ground
    kind: static
    shapes:
      - type: concave_polygon
        vertices: [[-5, -1], [5, -1], [5, 0], [0.5, 0], [0.5, -0.3], [-0.5, -0.3], [-0.5, 0],
                   [-5, 0]]
  - name: block
    mass: 1.0
    pose: {position: [2.0, 0.1]}
    shapes: [{type: polygon, vertices: [[-1.5, -0.1], [1.5, -0.1], [1.5, 0.1], [-1.5, 0.1]]}]
)";
  for (const char* formulation : {"stewart-trinkle", "anitescu-potra"}) {
    std::string text = yaml;
    text.replace(text.find("FORMULATION"), 11, formulation);
    const Simulator sim(ParseScene(text, "corner"));
    // The block rests on the vertex: the step has a corner contact (its LCP has one unknown
    // beyond the 4 per planar contact).
    const State x = sim.Rollout(sim.DefaultParams(), sim.InitialState(), 10).states.back();
    ASSERT_NE(x.warm_start.size() % 4, 0) << formulation << ": no corner contact";
    EXPECT_EQ(StepAllocations(sim), 0) << formulation;
  }
}

// Anitescu–Potra with 2.5D support friction and a concave part (the feeder).
TEST(StepAllocationTest, AnitescuPotraSupportStepAllocatesNothing) {
  EXPECT_EQ(StepAllocations("examples/design/feeder_scene.yaml", FormulationType::kAnitescuPotra),
            0);
}

// First order (M → h C, inverted in place) on its pushing scene.
TEST(StepAllocationTest, FirstOrderStepAllocatesNothing) {
  EXPECT_EQ(StepAllocations(Load("examples/scenes/first_order_push.yaml")), 0);
}

// The statically indeterminate pile: SpreadIndeterminateNormals' SVD per contact pair.
TEST(StepAllocationTest, PileStepAllocatesNothing) {
  EXPECT_EQ(StepAllocations(Load("examples/scenes/box_pile.yaml")), 0);
}

// NCP (quadratic cone, the dense semismooth Newton MCP): a box pushed diagonally (sliding), the
// box at rest, a pendulum on a block (joints).
TEST(StepAllocationTest, NcpStepsAllocateNothing) {
  EXPECT_EQ(StepAllocations(Load("examples/scenes/box_diagonal_push.yaml")), 0);
  EXPECT_EQ(StepAllocations("examples/scenes/box_on_plane.yaml", FormulationType::kNcp), 0);
  EXPECT_EQ(StepAllocations("examples/scenes/pendulum_on_block.yaml", FormulationType::kNcp), 0);
}

// The geometrically implicit stepper (one MCP a step whose function builds each pair's local
// Jacobian blocks: kept per thread and per pair): a disc rolling on a plane, an ellipsoid at rest,
// a sphere held by two spheres, and a resting box and a sliding block (planar and spatial boxes:
// six functions against a half-space) run as gi.
TEST(StepAllocationTest, GeometricallyImplicitStepsAllocateNothing) {
  for (const char* path :
       {"examples/scenes/disc_on_plane.yaml", "examples/scenes/ellipsoid_drop.yaml",
        "examples/scenes/sphere_on_two_spheres.yaml"})
    EXPECT_EQ(StepAllocations(Load(path)), 0) << path;
  for (const char* path :
       {"examples/scenes/box_on_plane.yaml", "examples/scenes/block_on_incline.yaml"})
    EXPECT_EQ(StepAllocations(path, FormulationType::kGeometricallyImplicit), 0) << path;
}

// NCP with at least NcpOptions::sparse_min_contacts contacts takes the sparse MCP path (the
// 10-box stack as ncp: 40 contacts). The Jacobian is refilled in place and H's pattern and its
// SparseLU analysis are kept while the pattern holds; what remains is inside Eigen's SparseLU,
// which allocates its work storage in every factorize (uncompress, column permutation, memInit,
// work vectors) and solve: 18.2 per Newton iteration measured (bench/README.md, alloc12), bounded
// here by kSparseLuAllocations per iteration (the per-evaluation triplet Jacobian this replaced
// made it 120).
TEST(StepAllocationTest, SparseNcpStepAllocatesOnlyInSparseLu) {
  constexpr long kSparseLuAllocations = 25;
  const Scene scene =
      LoadSceneFile(std::string(VINCI_SOURCE_DIR) + "/examples/scenes/box_stack.yaml");
  SimulatorOptions options = SimulatorOptions::FromScene(scene);
  options.formulation = FormulationType::kNcp;
  const Simulator sim(scene, options);
  const Params params = sim.DefaultParams();
  Workspace ws;
  State x = sim.InitialState(), next;
  const StepInput u;
  for (int i = 0; i < kSettle; ++i) {
    const StepInfo info = sim.Step(params, x, u, &ws, &next);
    ASSERT_TRUE(info.ok) << info.failure;
    std::swap(x, next);
  }
  long iterations = 0, allocations = 0;
  for (int i = 0; i < kSteps; ++i) {
    const long before = g_allocations.load();
    const StepInfo info = sim.Step(params, x, u, &ws, &next);
    allocations += g_allocations.load() - before;
    ASSERT_TRUE(info.ok) << info.failure;
    ASSERT_EQ(info.contacts, 40);
    iterations += info.solver.iterations;
    std::swap(x, next);
  }
  std::printf("sparse NCP: %ld allocations, %ld Newton iterations in %d steps\n", allocations,
              iterations, kSteps);
  EXPECT_LE(allocations, kSparseLuAllocations * iterations);
}

// Quasistatic DQC (an MCP) and DLC (an LCP) with support friction, and dynamic DQC with joints.
TEST(StepAllocationTest, QuasistaticStepsAllocateNothing) {
  EXPECT_EQ(StepAllocations(Load("examples/scenes/fence_particle.yaml")), 0);
  EXPECT_EQ(StepAllocations(Load("examples/scenes/planar_pushing.yaml")), 0);
  EXPECT_EQ(
      StepAllocations("examples/scenes/planar_pushing.yaml", FormulationType::kQuasistaticDlc), 0);
  EXPECT_EQ(StepAllocations("examples/scenes/planar_pushing.yaml", FormulationType::kDynamicDqc),
            0);
  EXPECT_EQ(StepAllocations("examples/scenes/pendulum_on_block.yaml", FormulationType::kDynamicDqc),
            0);
}

// Allocations of each one-parameter forward step derivative (PropagateStep with the step's
// workspace, as RolloutForward) along a rollout whose active set does not change: every
// derivative after the first allocates the same count (the per-thread linearization and the
// directional evaluations' assembly keep their storage; nothing accumulates from step to step).
std::vector<long> DerivativeAllocations(const std::string& path, const std::string& param) {
  const Simulator sim = Load(path);
  const Params p = sim.DefaultParams();
  const ParamSelection one(sim.scene().param_table(), {param});
  constexpr int kWarm = 100, kDerivatives = 40;  // the box has landed and rests after kWarm
  const Trajectory tr =
      sim.Rollout(p, sim.InitialState(), std::vector<StepInput>(kWarm + kDerivatives));
  EXPECT_TRUE(tr.ok) << tr.failure;
  const int nx = static_cast<int>(tr.states[0].q.size() + tr.states[0].v.size());
  MatrixXd S = MatrixXd::Zero(nx, 1), S_next;
  S(0, 0) = 1.0;
  Workspace ws;
  const StepInput u;
  std::vector<long> counts;
  for (int k = kWarm; k < kWarm + kDerivatives; ++k) {
    const long before = g_allocations.load();
    const StepSensitivity st =
        PropagateStep(sim, p, one, tr.states[k], u, tr.states[k + 1], S, &S_next, {}, &ws);
    counts.push_back(g_allocations.load() - before);
    EXPECT_NE(st.status, SensitivityStatus::kFailed) << st.message;
  }
  return counts;
}

TEST(StepAllocationTest, StepDerivativeAllocationsDoNotGrow) {
  // A column that needs the sensitivity LCP of the degenerate pairs (a Lemke solve, its K⁻¹ E_D)
  // allocates a few more on its step (the resting box, now and then).
  constexpr long kLcpBranch = 8;
  for (const auto& [path, param] : std::vector<std::pair<std::string, std::string>>{
           {"examples/scenes/block_sliding.yaml", "mu.default"},
           {"examples/scenes/box_on_plane.yaml", "mu.default"}}) {
    const std::vector<long> counts = DerivativeAllocations(path, param);
    ASSERT_GE(counts.size(), 4u);
    // After the first derivative (the per-thread storage sized): the same steady count in the
    // first and the second half, never more than the LCP branch above it.
    const std::size_t half = counts.size() / 2;
    const long first = *std::min_element(counts.begin() + 1, counts.begin() + half);
    const long second = *std::min_element(counts.begin() + half, counts.end());
    std::printf("%s: %ld allocations per derivative\n", path.c_str(), second);
    EXPECT_EQ(second, first) << path;
    for (std::size_t k = 1; k < counts.size(); ++k)
      EXPECT_LE(counts[k], first + kLcpBranch) << path << ", derivative " << k;
  }
}

}  // namespace
}  // namespace vinci::sim
