#include "vinci/sim/simulator/simulator.h"

#include <algorithm>
#include <stdexcept>

#include "../formulations/end_detection.h"
#include "../formulations/step_record.h"
#include "vinci/sim/formulations/capabilities.h"
#include "vinci/sim/formulations/first_order.h"
#include "vinci/sim/formulations/geometrically_implicit.h"
#include "vinci/sim/formulations/ncp.h"
#include "vinci/sim/formulations/quasistatic.h"
#include "vinci/sim/formulations/step_skeleton.h"
#include "vinci/sim/formulations/stewart_trinkle.h"
#include "vinci/sim/model/kinematics.h"
#include "vinci/sim/model/motion_input.h"
#include "vinci/sim/solvers/lemke.h"

namespace vinci::sim {

std::unique_ptr<Formulation> MakeFormulation(const StepperOptions& options) {
  if (options.formulation == FormulationType::kNcp) {
    NcpOptions ncp;
    ncp.mcp = options.solver_options.mcp;
    return std::make_unique<NcpStepper>(options, ncp);
  }
  if (options.formulation == FormulationType::kFirstOrder) return MakeFirstOrder(options);
  if (options.formulation == FormulationType::kQuasistaticDlc ||
      options.formulation == FormulationType::kQuasistaticDqc ||
      options.formulation == FormulationType::kDynamicDqc)
    return std::make_unique<Quasistatic>(options, options.solver_options.mcp);  // §5, §6
  if (options.formulation == FormulationType::kGeometricallyImplicit) {
    // GI solves one mixed NCP with the semismooth Newton MCP solver; `solver` keeps its LCP
    // default ("lemke"), which is accepted and unused here.
    const std::vector<std::string> names = SolverNames(options.formulation);
    if (std::find(names.begin(), names.end(), options.solver) == names.end())
      throw std::invalid_argument("formulation gi uses the MCP solver 'semismooth-newton', not '" +
                                  options.solver + "'");
    return std::make_unique<GeometricallyImplicit>(options, options.solver_options.mcp);
  }
  return std::make_unique<StewartTrinkle>(options,
                                          MakeLcpSolver(options.solver, options.solver_options));
}

Simulator::Simulator(Scene scene) : Simulator(scene, SimulatorOptions::FromScene(scene)) {}

Simulator::Simulator(Scene scene, const SimulatorOptions& options) {
  options.Validate();
  scene.options = options;
  scene.Finalize();
  scene_ = std::make_shared<const Scene>(std::move(scene));
  formulation_ = MakeFormulation(scene_->options);
  CheckSceneSupported(*scene_, scene_->options.formulation, formulation_->capabilities());
}

State Simulator::InitialState() const {
  const Scene& s = *scene_;
  State x;
  x.t = 0.0;
  x.q = VectorXd::Zero(s.num_positions());
  x.v = VectorXd::Zero(s.num_velocities());
  for (int bi : s.dynamic_bodies()) {
    const Body& b = s.bodies[bi];
    PoseToQ(s.dim, b.X_WB0, x.q.data() + s.index(bi).q);
    VelocityToV(s.dim, b.X_WB0, b.v0_W, b.w0_W, x.v.data() + s.index(bi).v);
  }
  return x;
}

const Scene& Simulator::Resolve(const Params& params, Workspace* ws) const {
  if (!ws->model || !(ws->resolved_for == params)) {
    ws->model = std::make_shared<const Scene>(scene_->ApplyParams(params));
    ws->resolved_for = params;
  }
  return *ws->model;
}

const Scene& Simulator::ResolveWithInputs(const Params& params, const StepInput& u,
                                          Workspace* ws) const {
  const Scene& model = Resolve(params, ws);
  if (u.motions.empty()) return model;
  // One copy per segment: consecutive steps of a segment carry the same motions.
  if (!ws->motion_model || ws->motion_base != ws->model ||
      !SameMotionInputs(ws->motions_for, u.motions)) {
    auto with_inputs = std::make_shared<const Scene>(ApplyMotionInputs(model, u.motions));
    // An input motion may use a feature the formulation lacks (e.g. pose: integrated).
    CheckSceneSupported(*with_inputs, scene_->options.formulation, formulation_->capabilities());
    ws->motion_model = std::move(with_inputs);
    ws->motion_base = ws->model;
    ws->motions_for = u.motions;
  }
  return *ws->motion_model;
}

StepInfo Simulator::Step(const Params& params, const State& x, const StepInput& u, Workspace* ws,
                         State* next) const {
  if (!ws || !next) throw std::invalid_argument("Simulator::Step: null workspace or output");
  if (x.q.size() != scene_->num_positions() || x.v.size() != scene_->num_velocities())
    throw std::invalid_argument(
        "Simulator::Step: state has " + std::to_string(x.q.size()) + " positions / " +
        std::to_string(x.v.size()) + " velocities; the scene needs " +
        std::to_string(scene_->num_positions()) + " / " + std::to_string(scene_->num_velocities()));
  if (u.generalized_force.size() != 0 && u.generalized_force.size() != scene_->num_velocities())
    throw std::invalid_argument("Simulator::Step: input force has the wrong size");
  const Scene& model = ResolveWithInputs(params, u, ws);
  internal::ClearStepRecord();
  const std::shared_ptr<const Scene>& owner = u.motions.empty() ? ws->model : ws->motion_model;
  StepInfo info;
  {
    // The step's contact detections are of the workspace's scene (end_detection.h).
    const internal::StepSceneScope scope(owner);
    info = RunStep(*formulation_, model, x, u, ws, next);
  }
  // The step's assembly is now known to be of the workspace's scene (step_record.h).
  internal::StampStepOwner(owner);
  return info;
}

Trajectory Simulator::Rollout(const Params& params, const State& x0,
                              const std::vector<StepInput>& inputs) const {
  return Rollout(params, x0, inputs, RolloutOptions{});
}

Trajectory Simulator::Rollout(const Params& params, const State& x0,
                              const std::vector<StepInput>& inputs,
                              const RolloutOptions& options) const {
  options.Validate();
  const bool cold = options.warm_start == WarmStartPolicy::kCold;
  const int every = options.record_every;
  Workspace ws;
  Trajectory traj;
  traj.record_every = every;
  traj.states.reserve(inputs.size() / static_cast<std::size_t>(every) + 2);
  traj.steps.reserve(inputs.size());
  traj.states.push_back(x0);
  // x: the current state, recorded or not. Cold: x steps without a warm start; `held` keeps
  // the one its step produced, for the record.
  State x = x0, next;
  VectorXd held;
  if (cold) {
    held.swap(x.warm_start);
    x.warm_start.resize(0);
  }
  for (std::size_t k = 0; k < inputs.size(); ++k) {
    StepInfo info = Step(params, x, inputs[k], &ws, &next);
    const bool ok = info.ok;
    const int step = static_cast<int>(k);
    if (options.observer) options.observer(step, next, info);
    traj.steps.push_back(std::move(info));
    if (!ok) {
      traj.ok = false;
      traj.failure = "step " + std::to_string(k) + " (t = " + std::to_string(x.t) +
                     " s): " + traj.steps.back().failure;
      if (k % static_cast<std::size_t>(every) != 0) {  // x, the final state, is not recorded
        traj.states.push_back(x);
        if (cold) traj.states.back().warm_start = held;
      }
      break;
    }
    const bool stop = options.stop && options.stop(step, next);
    std::swap(x, next);
    if (stop || k + 1 == inputs.size() || (k + 1) % static_cast<std::size_t>(every) == 0)
      traj.states.push_back(x);
    if (cold) {
      held.swap(x.warm_start);
      x.warm_start.resize(0);
    }
    if (stop) {
      traj.stopped = true;
      break;
    }
  }
  return traj;
}

Trajectory Simulator::Rollout(const Params& params, const State& x0, int num_steps) const {
  return Rollout(params, x0, std::vector<StepInput>(static_cast<std::size_t>(num_steps)));
}

}  // namespace vinci::sim
