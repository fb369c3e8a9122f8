// Named scene parameters: the vector an optimizer or estimator varies without rebuilding
// the scene (friction coefficients, masses, shape sizes and poses, motion amplitudes...).
//
// Names (Scene::Finalize builds the table; <d> is a pose component, below):
//   mu.default, mu.<material>.<material>       friction coefficients
//   support_mu.<body>                          2.5D support friction μ_s (support.h)
//   mass.<body>                                dynamic bodies
//   size.<body>.<shape>.radius | half_length | half_extents.x|y|z | scale
//   pose.<body>.<d>                            static and prescribed bodies (X_WB0)
//   pose.<body>.<shape>.<d>                    every shape of every body (X_BS)
//   motion.<body>.<dof>.velocity | amplitude<k> | frequency<k> | phase<k>
//   motion.<body>.tilt.amplitude | frequency | phase | depth   (TiltMotion, motion.h)
// with <d> = x, y, theta (planar) or x, y, z, roll, pitch, yaw (spatial; the rotation is
// Rz(yaw) Ry(pitch) Rx(roll), the scene file's `rpy`). A dynamic body's pose is not a
// parameter: it is the state (State::q, model/state_util.h).
//
// Differentiable parameters (ParamInfo::differentiable): friction coefficients, support
// friction and masses. They enter the step equations smoothly for a fixed contact set, and
// every formulation's Evaluate has a Jacobian column for them (StepResiduals::param_columns).
// Sizes, poses and motion parameters are not: they move the contact set, the gaps ψ_n and the
// prescribed velocities in ∂ψ/∂t, so the step map is only piecewise smooth in them, and no
// formulation differentiates through collision detection. Vary them through the simulator
// (finite differences of rollouts) or with derivative-free optimizers.
#pragma once

#include <string>
#include <vector>

#include "vinci/sim/types.h"

namespace vinci::sim {

/// What a parameter writes to. Indices (a, b, c) are interpreted per kind.
enum class ParamKind {
  kDefaultFriction,  ///< Scene::default_mu
  kFriction,         ///< Scene::mu[(a, b)] (material indices, a ≤ b)
  kMass,             ///< bodies[a].mass (inertia scales with it)
  kShapeRadius,      ///< bodies[a].shapes[b].radius
  kShapeHalfExtent,  ///< bodies[a].shapes[b].half_extents[c]
  kShapeHalfLength,  ///< bodies[a].shapes[b].half_length
  kShapeScale,       ///< bodies[a].shapes[b].vertices scaled by value (default 1)
  kMotionVelocity,   ///< bodies[a].motion.dofs[b].velocity
  kMotionAmplitude,  ///< bodies[a].motion.dofs[b].harmonics[c].amplitude
  kMotionFrequency,  ///< bodies[a].motion.dofs[b].harmonics[c].frequency
  kMotionPhase,      ///< bodies[a].motion.dofs[b].harmonics[c].phase
  kSupportFriction,  ///< bodies[a].support.mu (μ_s of its support points, support.h)
  /// Pose component c of bodies[a].X_WB0 (b = −1) or of bodies[a].shapes[b].X_BS (b ≥ 0):
  /// planar c = 0, 1, 2 for x, y, θ; spatial c = 0…5 for x, y, z, roll, pitch, yaw. The
  /// components of one pose are consecutive in the table, c = 0 first.
  kPose,
  kTiltAmplitude,  ///< bodies[a].motion.tilt.amplitude
  kTiltFrequency,  ///< bodies[a].motion.tilt.frequency
  kTiltPhase,      ///< bodies[a].motion.tilt.phase
  kTiltDepth,      ///< bodies[a].motion.tilt.depth
};

struct ParamInfo {
  std::string name;  ///< e.g. "mu.floor.box", "mass.box", "size.ball.s0.radius",
                     ///< "motion.plate.z.amplitude0"
  ParamKind kind = ParamKind::kMass;
  int a = -1, b = -1, c = -1;
  double default_value = 0.0;
  double lower = -1e300, upper = 1e300;  ///< admissible range
  /// true if the step equations are differentiable in it and Formulation::Evaluate has a
  /// Jacobian column for it (see the file comment): friction, support friction, mass.
  bool differentiable = false;
};

/// A parameter vector laid out by its scene's ParamTable.
struct Params {
  VectorXd values;
  bool operator==(const Params& o) const {
    return values.size() == o.values.size() && (values.array() == o.values.array()).all();
  }
};

/// The list of a scene's parameters.
class ParamTable {
 public:
  void Add(ParamInfo info);
  int size() const { return static_cast<int>(info_.size()); }
  const ParamInfo& info(int i) const { return info_[i]; }
  const std::vector<ParamInfo>& all() const { return info_; }
  /// Index of a parameter; throws std::invalid_argument listing close names if unknown.
  int Index(const std::string& name) const;
  /// −1 if unknown. A friction pair's `mu.<a>.<b>` is also found as `mu.<b>.<a>`.
  int Find(const std::string& name) const;
  Params Defaults() const;
  /// Names of the parameters with `differentiable` set, in table order.
  std::vector<std::string> DifferentiableNames() const;

 private:
  std::vector<ParamInfo> info_;
};

/// A subset of parameters chosen by name, for optimizers: maps a small vector x to a full
/// Params by overwriting the chosen entries of a base vector.
class ParamSelection {
 public:
  ParamSelection(const ParamTable& table, const std::vector<std::string>& names);
  int size() const { return static_cast<int>(indices_.size()); }
  const std::vector<int>& indices() const { return indices_; }
  VectorXd Get(const Params& p) const;
  Params Set(const Params& base, const VectorXd& x) const;
  VectorXd lower() const { return lower_; }
  VectorXd upper() const { return upper_; }

 private:
  std::vector<int> indices_;
  VectorXd lower_, upper_;
};

}  // namespace vinci::sim
