// Part transport on a vibrating plate (applications.md §D, docs/planning.md `vinci plan`): a
// sequence of plate-motion primitives, each applied for a whole number of cycles, that carries
// one or several parts from their start poses to goal poses.
//
// Model the planner sees. The state is the planar pose (x, y, θ) of every part in the plate's
// initial frame P (θ the yaw of the part relative to its scene orientation's tilt). A control
// (primitive i, cycles k) simulates, from the parts at those poses AT REST (scene height and
// tilt, zero velocity) and the plate at its scene pose, the plate moving by primitive i
// phase-locked from τ = 0 (motion_input.h, PhaseLockedSegment) for k cycles; the result is the
// parts' poses after it. A failed step or a part whose origin leaves the plate extent makes the
// result invalid. Whole cycles return a periodic plate motion to its start pose, so primitives
// chain.
//
// Closed loop. The plan is then re-simulated end to end from the scene's initial state, the
// segments chained (each from the time and plate pose where the previous one ended, velocities
// carried over), which is what executing it does; the re-simulated final poses are reported
// against the goal. The planner's rest-start model differs from that (the part's velocity at a
// primitive switch), so the error can exceed the tolerance: RunPlan then re-plans from the
// re-simulated poses, up to PlanRunOptions::replan times.
//
// Goal distance of poses P: d(P) = max over parts of max(|p − g| / tol, |wrap(θ − θ_g)| / θ_tol)
// (the angle term only when the goal gives an angle); the goal is reached iff d ≤ 1.
#pragma once

#include <functional>
#include <iosfwd>
#include <memory>
#include <string>
#include <vector>

#include "vinci/planning/plan_spec.h"
#include "vinci/sim/simulator/simulator.h"

namespace vinci::planning {

/// A part's planar pose in the plate's initial frame (m, m, rad).
struct PartPose {
  double x = 0.0, y = 0.0, theta = 0.0;
};
/// One pose per part, in the spec's goal order.
using PartPoses = std::vector<PartPose>;

/// One planner propagation's outcome.
struct Propagation {
  PartPoses poses;          ///< after the primitive (the last valid poses if !valid)
  bool valid = false;       ///< no failed step and every part stayed on the plate
  bool left_plate = false;  ///< a part left the plate extent
  std::string failure;      ///< the failed step's reason
};

/// The spec checked against its scene: simulator, plate, parts and primitives.
class PlanProblem {
 public:
  /// Loads the scene, finds the plate and the parts (every dynamic body must have a goal),
  /// parses every primitive's motion with the scene loader (the scene with the plate's motion
  /// replaced), each needing a frequency. Throws std::invalid_argument (file:line).
  explicit PlanProblem(const PlanSpec& spec);

  const PlanSpec& spec() const { return spec_; }
  const sim::Simulator& simulator() const { return *simulator_; }
  int plate() const { return plate_; }
  /// Body indices of the parts, in goal order.
  const std::vector<int>& parts() const { return parts_; }
  int num_parts() const { return static_cast<int>(parts_.size()); }
  int num_primitives() const { return static_cast<int>(motions_.size()); }
  const sim::PrescribedMotion& primitive_motion(int i) const { return motions_.at(i); }
  /// Steps of one cycle of primitive i: max(1, round(1/(f h))).
  int steps_per_cycle(int i) const { return steps_per_cycle_.at(i); }

  /// The parts' poses in state x (plate frame P).
  PartPoses PosesOf(const sim::State& x) const;
  /// The scene's initial state's poses.
  PartPoses StartPoses() const { return PosesOf(simulator_->InitialState()); }
  /// The scene's initial state with the parts at `poses` (scene height and tilt), at rest.
  sim::State StateAt(const PartPoses& poses) const;
  /// Whether every part's origin is inside the plate extent.
  bool OnPlate(const PartPoses& poses) const;
  /// The planner's propagation (see the file comment). ws: the calling thread's workspace.
  Propagation Propagate(const PartPoses& from, int primitive, int cycles, sim::Workspace* ws) const;
  /// d(P) of the file comment (≤ 1: goal reached).
  double GoalDistance(const PartPoses& poses) const;
  /// Per part: position error (m) and angle error (rad, wrapped; 0 without a goal angle).
  std::vector<double> PositionErrors(const PartPoses& poses) const;
  std::vector<double> AngleErrors(const PartPoses& poses) const;

 private:
  PlanSpec spec_;
  std::unique_ptr<sim::Simulator> simulator_;
  sim::Params params_;
  int plate_ = -1;
  std::vector<int> parts_;
  std::vector<sim::PrescribedMotion> motions_;
  std::vector<int> steps_per_cycle_;
  std::vector<sim::StepInput> inputs_;  ///< primitive i from t0 = 0 at the plate's scene pose
  sim::State initial_;
  sim::Isometry3d X_WP_;             ///< plate's initial frame
  std::vector<double> height_;       ///< part origin height in P
  std::vector<sim::Matrix3d> tilt_;  ///< part rotation in P with its yaw removed
};

/// One primitive application of a plan.
struct PlanStep {
  int primitive = 0;
  int cycles = 0;
  int round = 0;  ///< 0: the first plan, r: the r-th re-plan
};

/// One planner call.
struct PlanAttempt {
  PartPoses start;
  bool exact = false;          ///< OMPL found an exact solution (goal region reached in the model)
  bool approximate = false;    ///< only an approximate one (closest state kept)
  double goal_distance = 0.0;  ///< d of the path's end in the planner's model
  double solve_time_s = 0.0;
  long long propagations = 0;
  std::vector<PlanStep> steps;
  std::string planner_status;  ///< OMPL's PlannerStatus text
};

/// The chained re-simulation of a step sequence.
struct Resimulation {
  std::vector<sim::State> states;          ///< states[0] the start, one per step after it
  std::vector<sim::StepInfo> infos;        ///< one per step
  std::vector<int> segment_of_step;        ///< index into `segments`
  std::vector<sim::MotionInput> segments;  ///< the plate motion input of each applied step
  bool ok = true;                          ///< no failed step
  bool left_plate = false;                 ///< a part left the plate extent (stopped there)
  std::string failure;
};

/// Applies `steps` to the state `x` (chained phase-locked segments, velocities carried over),
/// appending to *out (whose last state must be x if it is not empty). Stops at a failed step or
/// a part leaving the plate (out->ok / out->left_plate).
void Resimulate(const PlanProblem& problem, const std::vector<PlanStep>& steps, Resimulation* out);

/// The `vinci simulate` trajectory columns of a re-simulation: step, t, per body (spatial) x, y,
/// z, qw, qx, qy, qz, vx, vy, vz, wx, wy, wz (prescribed bodies from the applied motion input),
/// contacts, solver_iterations, residual, min_gap, status.
void WriteResimulationCsv(const PlanProblem& problem, const Resimulation& r, std::ostream& out);

struct PlanRunOptions {
  PlannerType planner = PlannerType::kRrt;
  double time_limit = 10.0;  ///< s per planner call
  int replan = 0;            ///< re-plans allowed when the re-simulated error exceeds tolerance
  long long max_propagations = 0;  ///< per planner call, 0: no limit (PlanOnce)
  /// Called after each planner call and its re-simulation (may be empty).
  std::function<void(const PlanAttempt&, const PartPoses& resimulated)> on_attempt;
};

/// The plan and its closed loop.
struct PlanResult {
  std::vector<PlanAttempt> attempts;  ///< the first plan and every re-plan
  std::vector<PlanStep> steps;        ///< every executed step (all attempts)
  Resimulation resimulation;          ///< from the scene's initial state
  PartPoses final_poses;              ///< of the re-simulation
  std::vector<double> final_position_errors, final_angle_errors;
  double final_goal_distance = 0.0;
  bool reached = false;  ///< the re-simulation ends in the goal region
  /// The last attempt found an exact solution and the re-simulation reaches the goal.
  bool solved = false;
  double solve_time_s = 0.0;  ///< summed over attempts
};

/// Plans from the scene's start, re-simulates, and re-plans from the re-simulated poses while
/// the goal is not reached and re-plans remain (an attempt with no solution at all — no step —
/// ends the loop). Seed OMPL first (ompl::RNG::setSeed) for reproducible runs.
PlanResult RunPlan(const PlanProblem& problem, const PlanRunOptions& options);

}  // namespace vinci::planning
