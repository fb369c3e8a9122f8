// The part-transport plan spec (docs/planning.md, `vinci plan`): a plate scene with the parts at
// their start poses, the plate-motion primitives the planner may apply (each for a whole number
// of cycles), the goal pose of every part and the planner settings.
//
// Errors are std::invalid_argument as "file:line: field: expected ..., got ...".
#pragma once

#include <string>
#include <vector>

#include "vinci/sim/types.h"

namespace vinci::planning {

/// One plate motion the planner may apply: `motion` is the YAML text of a scene-format motion
/// map for the plate (docs/scene-format.md, "Prescribed motion"), checked against the scene by
/// PlanProblem.
struct PlanPrimitive {
  std::string name;
  std::string motion_yaml;  ///< the `motion:` map, re-emitted as YAML
  int line = 0;             ///< line of `motion:` in the spec (for error messages)
};

/// Where one part must end: within `tolerance` (m) of `position` (plate frame), and if
/// `has_angle`, its yaw within `angle_tolerance` (rad) of `angle`.
struct PartGoal {
  std::string part;  ///< a dynamic body of the scene
  Eigen::Vector2d position = Eigen::Vector2d::Zero();
  double tolerance = 0.005;
  bool has_angle = false;
  double angle = 0.0;
  double angle_tolerance = 0.2;
  int line = 0;
};

/// Control planners of OMPL the spec may name.
enum class PlannerType { kKpiece1, kSst, kRrt };

/// "kpiece1", "sst", "rrt".
const char* PlannerName(PlannerType t);
/// The planner named `name` (as PlannerName); throws std::invalid_argument otherwise.
PlannerType ParsePlannerName(const std::string& name, const std::string& where);

/// Limits of a plan spec (docs/scene-format.md, "Limits"), each checked with a file:line message.
struct PlanLimits {
  static constexpr int kMaxPrimitives = 1000;  ///< each is checked through the scene loader
  static constexpr int kMaxCycles = 100000;    ///< cycles, settle_cycles
  static constexpr int kMaxReplan = 1000;
  static constexpr double kMaxTimeLimit = 1e6;  ///< s per planner call (OMPL's clock overflows)
  /// Time steps of one primitive application (max cycles × steps per cycle) and of one settle
  /// phase (settle_cycles × steps per cycle): checked by PlanProblem against the scene's dt.
  static constexpr long long kMaxStepsPerApplication = 1000000000;
};

struct PlanSpec {
  std::string path;        ///< the spec file ("<string>" when parsed from text)
  std::string scene_path;  ///< plate + parts (relative paths: from the spec's folder)
  std::string plate;       ///< the prescribed plate body; empty: the scene's only prescribed body
  int plate_line = 0;
  /// The plate area (plate frame, m): a part whose origin leaves it has left the plate; it also
  /// bounds the planner's state space.
  double x_min = 0.0, x_max = 0.0, y_min = 0.0, y_max = 0.0;
  std::vector<PlanPrimitive> primitives;
  int min_cycles = 1, max_cycles = 10;  ///< cycles of one primitive application
  /// Cycles (of the primitive's frequency) the plate then rests at its pose so that the parts
  /// come to rest before the next primitive (the planner's model starts every primitive from
  /// rest). 0: primitives follow each other directly.
  int settle_cycles = 2;
  std::vector<PartGoal> goals;  ///< one per dynamic body, in spec order
  int goal_line = 0;
  PlannerType planner = PlannerType::kRrt;
  double time_limit = 10.0;        ///< s of planning per attempt
  long long max_propagations = 0;  ///< propagations per attempt, 0: no limit
  unsigned seed = 1;               ///< ompl::RNG::setSeed
  int replan = 0;                  ///< re-plans after the first plan (closed loop), ≥ 0
};

/// Reads a spec file. Throws std::invalid_argument ("file:line: field: expected ..., got ...").
PlanSpec LoadPlanSpec(const std::string& path);
/// Parses spec text; a relative `scene:` path is resolved from `base_dir`.
PlanSpec ParsePlanSpec(const std::string& text, const std::string& source_name,
                       const std::string& base_dir);

}  // namespace vinci::planning
