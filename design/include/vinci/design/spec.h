// A design job read from YAML (format: docs/design.md): a scene, the numbers that may change
// (the design vector) and their bounds, what is uncertain and how it is distributed, how many
// Monte Carlo samples judge a design, and what success means.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "vinci/sim/model/scene.h"
#include "vinci/sim/simulator/options.h"
#include "vinci/sim/types.h"

namespace vinci::design {

using Eigen::VectorXd;

/// Where a named number is written: a scene parameter (sim::ParamTable: friction, masses, sizes,
/// motions, and the poses of static and prescribed bodies and of every shape within its body,
/// `pose.<body>.<d>` and `pose.<body>.<shape>.<d>`), or an entry of the initial state
/// (`initial.<body>.x|y|z|theta|vx|vy|vz|omega`, uncertain entries only).
enum class TargetKind { kParam, kInitial };

/// A resolved name. `index`: the ParamTable index (kParam); `body`: the body index (kInitial);
/// `coord`: the offset in State::q (0..2, position/θ) or State::v (vx, vy, vz/ω) relative to the
/// body's index.
struct Target {
  TargetKind kind = TargetKind::kParam;
  int index = -1;
  int body = -1;
  int coord = -1;
  bool velocity = false;  ///< kInitial: writes State::v (else State::q)
};

/// One entry of the design vector.
struct DesignParameter {
  std::string name;
  double lower = 0.0, upper = 0.0;
  double start = 0.0;  ///< the spec's `start`, else the scene's value clamped to the bounds
  Target target;
  int line = 0;  ///< in the spec file
};

enum class DistributionType { kUniform, kNormal, kChoice };

/// An uncertain number: drawn per sample, written over the design (the same name cannot be both).
struct Uncertain {
  std::string name;
  DistributionType type = DistributionType::kUniform;
  double a = 0.0, b = 0.0;  ///< uniform [a, b]; normal (mean, std)
  bool truncated = false;   ///< normal only: redrawn until inside [lo, hi]
  double lo = 0.0, hi = 0.0;
  std::vector<double> choices;  ///< kChoice: equally likely values
  Target target;
};

enum class ObjectiveType {
  kSuccess,   ///< maximize P(body in region ∧ |angle error| ≤ tolerance)
  kDistance,  ///< minimize the mean ‖p_body − target‖ at the end
  kMargin,    ///< minimize the mean signed distance to the success set (smooth surrogate)
};

/// `success` objective only: the body must be held between jaws (grip.h).
struct Grip {
  std::vector<std::string> jaws;  ///< body names (≥ 1; two for a parallel-jaw gripper)
  std::vector<int> jaw_indices;   ///< their body indices
  double min_overlap = 0.0;       ///< m: every jaw's overlap with the body is at least this
  double max_overlap = 1e300;     ///< m: and none exceeds this
};

struct Objective {
  ObjectiveType type = ObjectiveType::kSuccess;
  std::string body;
  int body_index = -1;
  bool has_region = false;
  VectorXd region_min, region_max;  ///< size 2 (planar) or 3 (spatial)
  bool has_angle = false;           ///< planar only
  double angle_target = 0.0, angle_tolerance = 0.0;
  double angle_symmetry = 0.0;  ///< > 0: angles equal modulo this (e.g. π for a 2-fold part)
  /// Metres per radian when the margin combines the region distance and the angle error.
  double angle_scale = 0.01;
  bool until = false;     ///< success: reaching the set at any step counts (the rollout stops)
  VectorXd target;        ///< distance: size 2 or 3
  bool has_grip = false;  ///< success: also require the grip condition (grip.h)
  Grip grip;
};

enum class StageType {
  kGeometric,  ///< no overlap at the start (contact detection at t = 0), no simulation
  kShort,      ///< a cheaper simulation: shorter, fewer samples and/or another formulation
};

/// A screening stage (hierarchical design, thesis §4.3): a cheap test every search candidate
/// must pass before the next stage and, after the last, the full Monte Carlo evaluation. A
/// candidate that fails is given the worst success rate (0) without running full dynamics.
struct ScreeningStage {
  StageType type = StageType::kGeometric;
  int line = 0;  ///< in the spec file
  /// kGeometric: the deepest penetration accepted between two bodies at the start (m).
  double tolerance = 1e-4;
  /// kGeometric: starts checked, samples [0, samples) of the search stream with their uncertain
  /// numbers drawn; 0: the scene's own start (nothing drawn). kShort: samples per candidate.
  int samples = 0;
  double duration = 0.0;          ///< kShort: simulated time per sample (s)
  double min_success = 0.0;       ///< kShort: the candidate passes iff its success rate ≥ this
  Objective objective;            ///< kShort: success at the stage's horizon (default: the spec's)
  sim::SimulatorOptions options;  ///< kShort: the scene's options, with `formulation` if given
};

/// Limits every spec is checked against (docs/scene-format.md, "Limits"), each with a file:line
/// message: they keep sample counts and budgets within int and a rollout's step count
/// (duration / dt) finite and bounded, so that a typo cannot start a job of years.
struct DesignLimits {
  static constexpr long long kMaxSamples = 10000000;   ///< samples, validation and stage samples
  static constexpr long long kMaxBudget = 1000000000;  ///< simulations of the search
  static constexpr double kMaxRolloutSteps = 1e8;      ///< duration / dt of one rollout
  static constexpr int kMaxScreeningStages = 100;      ///< each may build a simulator
  static constexpr std::size_t kMaxChoices = 1000000;  ///< values of one `choice` distribution
};

/// The whole job. Names were checked against the scene.
struct DesignSpec {
  std::string source;      ///< the spec file (for messages)
  std::string scene_path;  ///< resolved against the spec file's folder
  std::string scene_text;  ///< the scene file's text (best.yaml is written from it)
  sim::Scene scene;
  std::vector<DesignParameter> parameters;
  std::vector<Uncertain> uncertain;
  int samples = 100;
  int validation_samples = 0;  ///< fresh samples for the final estimate; 0: `samples`
  std::uint64_t seed = 1;
  double duration = 1.0;
  Objective objective;
  std::string optimizer;                  ///< empty: the default for the objective (optimize.h)
  int budget = 2000;                      ///< simulations (rollouts), not evaluations
  std::vector<ScreeningStage> screening;  ///< in order; empty: every candidate runs in full
};

/// Parses a spec from YAML text; `base_dir` resolves `scene:`. Throws std::invalid_argument
/// "<source>:<line>: <field>: expected ..., got ..." for every error (unknown keys, wrong types,
/// unknown parameter or body names, bounds not ordered, a start outside the bounds, ...).
DesignSpec ParseDesignSpec(const std::string& yaml_text, const std::string& source_name,
                           const std::string& base_dir);

/// Reads and parses a spec file (its scene path is relative to the file's folder).
DesignSpec LoadDesignSpec(const std::string& path);

/// Resolves a design-parameter name against `scene` (a ParamTable entry, poses included).
/// Returns false if unknown.
bool ResolveDesignName(const sim::Scene& scene, const std::string& name, Target* target);

/// Resolves an uncertain name (ParamTable entry or `initial.<body>.<c>`). False if unknown.
bool ResolveUncertainName(const sim::Scene& scene, const std::string& name, Target* target);

}  // namespace vinci::design
