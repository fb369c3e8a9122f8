// What a Simulator runs with (SimulatorOptions) and how a rollout runs (RolloutOptions),
// separate from the Scene: one scene can be run at two fidelities (a quasistatic screening,
// then dynamics with a finer step) without copying or editing it.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "vinci/sim/model/scene.h"
#include "vinci/sim/model/state.h"

namespace vinci::sim {

/// The simulator's options: every field of StepperOptions (formulation, dt, friction
/// directions, envelope, joint stabilization, solver name and its typed options in
/// `solver_options`, max penetration, prescribed-velocity rule, non-convex corners; `duration`
/// is the CLI's default simulated time and unused by the Simulator). They default to a scene's
/// own options (its file's `stepper:` section):
///
///   SimulatorOptions o = SimulatorOptions::FromScene(scene);
///   o.formulation = FormulationType::kQuasistaticDlc;
///   o.dt = 0.01;
///   Simulator screening(scene, o), dynamics(scene);
struct SimulatorOptions : StepperOptions {
  SimulatorOptions() = default;
  explicit SimulatorOptions(const StepperOptions& stepper) : StepperOptions(stepper) {}
  /// The scene's own options (Scene::options).
  static SimulatorOptions FromScene(const Scene& scene) { return SimulatorOptions(scene.options); }
  /// Throws std::invalid_argument naming the first invalid field, its value and what is
  /// expected: dt, duration and max_penetration finite and > 0; envelope finite and ≥ 0;
  /// friction_directions even and ≥ 2; a solver this formulation accepts (SolverNames); typed
  /// solver options as CheckSolverOptions.
  void Validate() const;
};

/// (The formulation names: FormulationNames(), ParseFormulation() and ToString() in model/scene.h.)
/// Every solver name some formulation accepts (the union of SolverNames), for `--help`.
std::vector<std::string> AllSolverNames();

/// How a rollout treats State::warm_start, the previous step's complementarity solution, which
/// each formulation uses as the starting point of its solve when its size matches the step's
/// problem: Stewart–Trinkle, Anitescu–Potra, first order (the LCP z = (p_n, p_f, σ, …) in the
/// order of StepLayout, for the LCP solver's warm start: Lemke's starting basis, PGS's and
/// FB-Newton's first iterate), NCP ((p_n, p_t, p_o, σ) per contact, the MCP's first start),
/// quasistatic-dlc/-dqc and dynamic-dqc (the mixed LCP/MCP unknowns y), GI (per contact pair: the
/// pair's identity and its unknowns, matched by pair; also used to map a step to its unknowns).
/// A warm start that does not fit the step (another contact count; for GI, pairs not found
/// again) is ignored, entirely or for those entries. Solvers are deterministic, so a step is a
/// pure function of (params, x including x.warm_start, input).
enum class WarmStartPolicy {
  /// Each step starts from x.warm_start (x0's for the first step, then the previous step's
  /// solution). Fastest. A replay is bit-identical when it starts from a state that carries
  /// its warm start (a State stored by a rollout), not from one rebuilt from (t, q, v) only.
  kKeep,
  /// Each step starts cold (x.warm_start is ignored; the solvers start from their default
  /// point). Every step is then a function of (params, t, q, v, input) alone: a replay from any
  /// state with the same (t, q, v) is bit-identical, e.g. after a state was set by hand
  /// (state_util.h) or saved without its warm start. The recorded states still carry each
  /// step's solution in warm_start (the step's unknowns, for estimators).
  kCold,
};

/// Per-rollout options.
struct RolloutOptions {
  /// Called after every step k (0-based; also a failed one) with the state after it (on
  /// failure the state before it, Simulator::Step) and the step's report. May be empty.
  /// Exceptions propagate out of Rollout.
  std::function<void(int step, const State& next, const StepInfo& info)> observer;
  /// Asked after every successful step k with the state after it; true ends the rollout there
  /// (Trajectory::stopped, ok stays true). May be empty.
  std::function<bool(int step, const State& next)> stop;
  /// Keep every record_every-th state (≥ 1): Trajectory::states holds x_0, x_k, x_2k, … and
  /// always the final state. Every step's StepInfo is kept.
  int record_every = 1;
  WarmStartPolicy warm_start = WarmStartPolicy::kKeep;
  /// Throws std::invalid_argument for record_every < 1.
  void Validate() const;
};

}  // namespace vinci::sim
