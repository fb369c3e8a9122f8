// The simulator: a scene, its formulation, and pure Step / Rollout functions.
#pragma once

#include <memory>
#include <vector>

#include "vinci/sim/formulations/formulation.h"
#include "vinci/sim/model/scene.h"
#include "vinci/sim/model/state.h"
#include "vinci/sim/simulator/options.h"

namespace vinci::sim {

/// Owns an immutable scene and its formulation. All methods are const and thread-safe; each
/// thread passes its own Workspace. Same arguments → bit-identical results.
class Simulator {
 public:
  /// Finalizes `scene` (see Scene::Finalize) and builds the formulation from its options.
  /// Throws std::invalid_argument if the scene uses a feature the formulation does not
  /// implement (CheckSceneSupported, capabilities.h).
  explicit Simulator(Scene scene);
  /// Runs `scene` with `options` instead of its own (SimulatorOptions::FromScene): the
  /// simulator's copy of the scene holds them (scene().options). Throws std::invalid_argument
  /// for invalid options (SimulatorOptions::Validate) or scene.
  Simulator(Scene scene, const SimulatorOptions& options);

  const Scene& scene() const { return *scene_; }
  /// The options this simulator runs with.
  SimulatorOptions options() const { return SimulatorOptions(scene_->options); }
  const Formulation& formulation() const { return *formulation_; }
  Params DefaultParams() const { return scene_->DefaultParams(); }

  /// The scene's initial state (t = 0).
  State InitialState() const;

  /// One step from x; returns the step's report. On failure *next == x.
  StepInfo Step(const Params& params, const State& x, const StepInput& u, Workspace* ws,
                State* next) const;

  /// Rollout(params, x0, inputs): one step per input. Stops at the first failed step.
  Trajectory Rollout(const Params& params, const State& x0,
                     const std::vector<StepInput>& inputs) const;
  /// Rollout with no inputs for num_steps steps.
  Trajectory Rollout(const Params& params, const State& x0, int num_steps) const;
  /// Rollout with an observer, a stop condition, sparse recording and a warm-start policy
  /// (RolloutOptions). With default options identical to Rollout(params, x0, inputs).
  Trajectory Rollout(const Params& params, const State& x0, const std::vector<StepInput>& inputs,
                     const RolloutOptions& options) const;

  /// The scene with params applied, cached in the workspace.
  const Scene& Resolve(const Params& params, Workspace* ws) const;
  /// Resolve(params) with u.motions applied (ApplyMotionInputs, motion_input.h), cached in the
  /// workspace: the model a step with input u runs on.
  const Scene& ResolveWithInputs(const Params& params, const StepInput& u, Workspace* ws) const;

 private:
  std::shared_ptr<const Scene> scene_;
  std::unique_ptr<Formulation> formulation_;
};

}  // namespace vinci::sim
