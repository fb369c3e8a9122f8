// Named scene parameters: the vector an optimizer or estimator varies without rebuilding
// the scene (friction coefficients, masses, shape sizes, motion amplitudes...).
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
};

struct ParamInfo {
  std::string name;  ///< e.g. "mu.floor.box", "mass.box", "size.ball.s0.radius",
                     ///< "motion.plate.z.amplitude0"
  ParamKind kind = ParamKind::kMass;
  int a = -1, b = -1, c = -1;
  double default_value = 0.0;
  double lower = -1e300, upper = 1e300;  ///< admissible range
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
  /// −1 if unknown.
  int Find(const std::string& name) const;
  Params Defaults() const;

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
