// Field design (applications.md §D, docs/planning.md): the plate motion whose simulated velocity
// field best matches a target field on a grid.
//
// Parametrization: every DOF named in the spec moves as one sinusoid A sin(2π f t + φ) of the
// base frequency f, or as a sum of harmonics A_k sin(2π k f t + φ_k) of the orders the spec lists
// (the plate's scene motion is replaced by these DOFs); the free variables are the amplitudes and
// phases with lo < hi, i.e. the scene parameters motion.<plate>.<dof>.amplitude<i> / phase<i>
// (model/params.h; i the harmonic's index within its DOF) of the rewritten scene.
//
// Objective (the field error) over the M grid points, v_i simulated, t_i target:
//   shape (default):  e = √( (1/M) Σ_i |v_i/s_v − t_i/s_t|² ),  s_· = √((1/M) Σ |·_i|²)
//                     (each field scaled to unit RMS speed: directions and relative speeds);
//                     a field with s_v = 0 has e = 1.
//   absolute:         e = √( (1/M) Σ_i |v_i − t_i|² ) / s_t.
// A target with regions (FieldTarget::Region: the circle's inside ρ < R and outside) is scored
// per region, each with its own M and RMS speeds, and e = √(mean over the regions of e_region²):
// each side of the circle counts as a field of its own, so a field that matches outside but
// spirals inward inside (no ring) is not hidden by the inside's small speeds.
// A point whose part left the plate or whose step failed contributes a mismatch of
// kBadPointMismatch (its velocity is excluded from s_v) and is counted. A motion over an
// actuator limit (FieldDesignSpec::max_vertical_acceleration, max_linear_acceleration,
// max_angular_acceleration) is not simulated: its error is kInfeasibleError plus the largest
// relative excess, so the search is pushed back inside.
//
// Search: NLopt GN_CRS2_LM (global, seeded) over the box of the free variables for ~60% of the
// budget, then LN_BOBYQA from the best point with the rest; both stop at the spec's tolerance.
// Phases whose range is the whole circle are periodic in the local phase (no bound to stop at).
// The reported error is always the simulated one. No exception leaves an NLopt callback.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "vinci/planning/field_design_spec.h"
#include "vinci/sim/plate/velocity_field.h"
#include "vinci/sim/simulator/simulator.h"

namespace vinci::planning {

/// Per-point mismatch of a point whose part left the plate or failed (shape units: 2 is the
/// largest mismatch of two unit vectors).
constexpr double kBadPointMismatch = 2.0;
/// Error of a motion over the actuator limit, before adding the relative excess.
constexpr double kInfeasibleError = 10.0;

/// The field error of `field` against `target` (one vector per grid point, grid order).
/// `bad_points` (may be null) receives the points that left the plate or failed. `regions`
/// (empty, or a label per point): the points of each label are scored on their own and
/// e = √(mean over the labels of e_label²) (see the file comment). Throws
/// std::invalid_argument if the sizes differ or the target is zero everywhere (in a region).
double FieldError(const sim::VelocityField& field, const std::vector<Vector2d>& target,
                  bool absolute, int* bad_points = nullptr, const std::vector<int>& regions = {});

/// One evaluated motion.
struct FieldEvaluation {
  int index = 0;         ///< 1-based evaluation count
  std::string phase;     ///< "start", "global", "local"
  VectorXd x;            ///< the free variables (FieldDesignProblem::names order)
  double error = 0.0;    ///< field error (see the file comment)
  bool feasible = true;  ///< within the actuator limit (else not simulated)
  double peak_vertical_acceleration = 0.0;  ///< m/s², the actuator-limit estimate
  double peak_linear_acceleration = 0.0;    ///< m/s², largest of x, y (PeakLinearAcceleration)
  double peak_angular_acceleration = 0.0;   ///< rad/s², largest of roll, pitch, yaw
  int bad_points = 0;                       ///< points that left the plate or failed
  double time_s = 0.0;                      ///< wall time of this evaluation
  sim::VelocityField field;                 ///< empty if not feasible
};

/// The spec turned into a simulator, a field spec, the target and the free variables.
class FieldDesignProblem {
 public:
  /// Loads the scene (its `field:` section names the plate, the part and the plate extent),
  /// replaces the plate's motion by the spec's DOFs (amplitudes and phases at the middle of their
  /// ranges), and sets the grid and cycles. Throws std::invalid_argument (file:line where known).
  explicit FieldDesignProblem(const FieldDesignSpec& spec);

  const FieldDesignSpec& spec() const { return spec_; }
  const sim::Simulator& simulator() const { return *simulator_; }
  const sim::FieldSpec& field_spec() const { return field_spec_; }
  const std::vector<Vector2d>& target() const { return target_; }
  /// The target's region label per grid point (FieldTarget::Region); empty if it has one region.
  const std::vector<int>& regions() const { return regions_; }
  /// Free variables: parameter names (motion.<plate>.<dof>.amplitude<i> | phase<i>) and bounds.
  const std::vector<std::string>& names() const { return names_; }
  const VectorXd& lower() const { return lower_; }
  const VectorXd& upper() const { return upper_; }
  /// The middle of the box.
  VectorXd Start() const { return 0.5 * (lower_ + upper_); }
  /// The scene parameters for free variables x.
  sim::Params ParamsFor(const VectorXd& x) const;
  /// The plate's peak normal acceleration over the grid (m/s²) as the spec estimates it
  /// (FieldDesignSpec::exact_vertical_peak): the bound Σ over the harmonics (2πkf)² (|A_z| +
  /// |A_roll| max|y| + |A_pitch| max|x|), or the peak itself.
  double PeakVerticalAcceleration(const VectorXd& x) const;
  /// max over x, y of Σ over its harmonics (2πkf)² |A| (m/s²): a bound on the peak horizontal
  /// acceleration of each translation.
  double PeakLinearAcceleration(const VectorXd& x) const;
  /// max over roll, pitch, yaw of Σ over its harmonics (2πkf)² |A| (rad/s²).
  double PeakAngularAcceleration(const VectorXd& x) const;
  /// Simulates the field of x (if feasible) and scores it. index/phase are left to the caller.
  FieldEvaluation Evaluate(const VectorXd& x, int threads) const;
  /// The rewritten scene file with x's amplitudes and phases written in (17 digits): a plate
  /// scene that `vinci field` and `vinci simulate` run as is.
  std::string SceneYaml(const VectorXd& x) const;
  /// Amplitude and phase of every spec harmonic (fixed ones included) for x, in the spec's order:
  /// {dof, order k, index within the DOF's harmonics, A, φ}.
  struct DofValue {
    std::string dof;
    int order = 1, index = 0;
    double amplitude = 0.0, phase = 0.0;
  };
  std::vector<DofValue> DofValues(const VectorXd& x) const;
  /// The free variables of the plate motion in the scene file `path` (e.g. a previous
  /// DIR/best.yaml): its plate (the body of this problem's plate name) must move in the spec's
  /// family — every spec DOF the spec's harmonics (orders, in order), no velocity, no other DOF,
  /// no tilt — with the fixed amplitudes and phases equal to the spec's and the free ones within
  /// their bounds. Throws std::invalid_argument naming the file and what differs.
  VectorXd ParametersFromScene(const std::string& path) const;

 private:
  FieldDesignSpec spec_;
  std::string scene_yaml_;  ///< the scene file with the spec's motion (middle values)
  std::unique_ptr<sim::Simulator> simulator_;
  sim::FieldSpec field_spec_;
  std::vector<Vector2d> target_;
  std::vector<int> regions_;
  std::vector<std::string> names_;
  std::vector<int> indices_;         ///< into the scene's ParamTable
  std::vector<int> harmonic_index_;  ///< per spec.dofs entry: its index in the DOF's harmonics
  VectorXd lower_, upper_;
  sim::Params defaults_;
};

struct FieldDesignOptions {
  int budget = 200;              ///< field evaluations in all (the start point included)
  unsigned seed = 1;             ///< NLopt's random seed
  int threads = 1;               ///< field simulation threads
  double global_fraction = 0.6;  ///< share of the budget for the global phase
  /// Called after every evaluation, on the calling thread. An exception from it stops the search
  /// (recorded in FieldDesignResult::errors).
  std::function<void(const FieldEvaluation&)> on_evaluation;
  /// The first evaluated point, from which both phases start; empty: the middle of the box.
  /// Must lie in the box (FieldDesignProblem::ParametersFromScene gives one).
  VectorXd start;
};

struct FieldDesignResult {
  FieldEvaluation best;  ///< lowest error
  int evaluations = 0;
  double time_s = 0.0;
  bool reached_tolerance = false;   ///< best.error ≤ spec.tolerance
  std::vector<std::string> errors;  ///< exceptions caught in the search (then it stopped)
};

/// Runs the search (see the file comment). The start point (options.start, default the middle of
/// the box) is evaluated first; with budget 1 only it is. Deterministic for a given seed and
/// budget, for any thread count.
FieldDesignResult DesignField(const FieldDesignProblem& problem, const FieldDesignOptions& options);

}  // namespace vinci::planning
