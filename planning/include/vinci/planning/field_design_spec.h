// The field-design spec (docs/planning.md): a plate scene, a target velocity field on a grid, the
// plate-motion parametrization searched (per DOF one sinusoid at the base frequency, or several
// harmonics of it, amplitude and phase bounds) and its actuator limit, the simulation length and
// the search budget.
//
// Errors are std::invalid_argument as "file:line: field: expected ..., got ...".
#pragma once

#include <limits>
#include <string>
#include <vector>

#include "vinci/sim/types.h"

namespace vinci::planning {

using Eigen::Vector2d;
using Eigen::VectorXd;

/// The target field's family. At a grid point p with r = p − center, ρ = |r|, R = radius,
/// d = direction (unit), n = ẑ × d, s = speed:
///   sink      v = −s r / R            source  v = s r / R
///   whirlpool v = s ẑ × r / R  (counter-clockwise; `clockwise: true` flips it)
///   circle    v = s (ẑ × r + (1 − q)/(1 + q) r) / R, q = ρ²/R²: the whirlpool plus a radial part
///             that is the source near the centre, vanishes on the circle ρ = R and tends to the
///             sink far outside (radial/tangential = (1 − q)/(1 + q) ∈ (−1, 1]): around the
///             circle at speed s, drawn onto it from both sides, smooth and 0 at the centre
///   saddle    v = s ((r·d) d − (r·n) n) / R: repelling along d, attracting along n
///   line_sink v = −s (r·n) n / R: drawn onto the line through the centre along d
///   shear     v = s (r·n) d / R: along d, growing with the signed distance from that line
///   conveyor  v = s d (uniform)
///   csv       the velocities of a CSV file, one row per grid point.
enum class TargetType {
  kSink,
  kSource,
  kWhirlpool,
  kCircle,
  kSaddle,
  kLineSink,
  kShear,
  kConveyor,
  kCsv
};

struct FieldTarget {
  TargetType type = TargetType::kConveyor;
  Vector2d center = Vector2d::Zero();      ///< m, plate frame
  double radius = 1.0;                     ///< R (m): required for circle
  Vector2d direction = Vector2d::UnitX();  ///< unit
  double speed = 1.0;                      ///< s (m/s); only the shape matters unless absolute
  bool clockwise = false;                  ///< whirlpool / circle
  /// type kCsv: the target velocity of every grid point (y outer, x inner).
  std::vector<Vector2d> velocities;
  /// The target velocity at plate point p (not for kCsv).
  Vector2d At(const Vector2d& p) const;
  /// The region of plate point p that the field error scores on its own (FieldError): for a
  /// circle 0 inside (ρ < R) and 1 outside, so that both sides of the ring count equally; 0
  /// for every other type.
  int Region(const Vector2d& p) const;
};

/// One searched harmonic of a plate DOF: A sin(2π k f t + φ), k = order, A ∈ [amplitude_lo,
/// amplitude_hi] (m or rad), φ ∈ [phase_lo, phase_hi] (rad). A bound with lo == hi fixes that
/// value (not searched). A DOF with several harmonics has one DofRange per harmonic, consecutive,
/// orders strictly increasing.
struct DofRange {
  std::string dof;  ///< x, y, z, roll, pitch, yaw
  int order = 1;    ///< k ≥ 1: the harmonic of the base frequency
  double amplitude_lo = 0.0, amplitude_hi = 0.0;
  double phase_lo = 0.0, phase_hi = 0.0;
};

struct FieldDesignSpec {
  std::string path;        ///< the spec file ("<string>" when parsed from text)
  std::string scene_path;  ///< the plate scene (relative paths: from the spec's folder)
  FieldTarget target;
  double frequency = 0.0;      ///< base frequency f (Hz)
  std::vector<DofRange> dofs;  ///< in the scene file's DOF order, then by order
  /// Actuator limit (m/s²): the peak normal acceleration of the plate over the grid, bounded by
  /// Σ_harmonics (2πkf)² (|A_z| + |A_roll| max|y| + |A_pitch| max|x|), must stay below it.
  /// ∞: no limit.
  double max_vertical_acceleration = std::numeric_limits<double>::infinity();
  /// How that peak is estimated (`motion.vertical_peak`): false (`bound`, the default) the bound
  /// above; true (`exact`) the peak itself, max over the grid's four corners (the normal
  /// acceleration is affine in the plate point) and over one base period (sampled) of
  /// |Σ_harmonics (2πkf)² (A_z sin_k + A_roll y sin_k − A_pitch x sin_k)|, sin_k = sin(2πkft + φ).
  /// The bound adds the DOFs' peaks as if they were in phase: for a wobble (roll and pitch in
  /// quadrature, equal angular accelerations) it is (max|x| + max|y|) / |corner| times the
  /// peak, √2 on a square grid.
  bool exact_vertical_peak = false;
  /// Actuator limits of the horizontal translations (m/s²) and of the rotations (rad/s²): for each
  /// of x, y (linear) and roll, pitch, yaw (angular) the bound Σ_harmonics (2πkf)² |A| of its
  /// peak acceleration must stay below it. ∞: no limit.
  double max_linear_acceleration = std::numeric_limits<double>::infinity();
  double max_angular_acceleration = std::numeric_limits<double>::infinity();
  double x_min = 0.0, x_max = 0.0, y_min = 0.0, y_max = 0.0;  ///< grid extent (m)
  int nx = 11, ny = 11;
  int cycles = 20;         ///< simulated cycles per grid point
  int average_cycles = 5;  ///< last cycles averaged (≤ cycles)
  bool absolute = false;   ///< objective: `shape` (default) or `absolute` speed
  double tolerance = 0.1;  ///< field error counted as a match (reported, and stops the search)
  int budget = 200;        ///< field evaluations
  unsigned seed = 1;
};

/// Reads a spec file. Throws std::invalid_argument ("file:line: field: expected ..., got ...").
FieldDesignSpec LoadFieldDesignSpec(const std::string& path);
/// Parses spec text; relative `scene:` and `target.csv:` paths are resolved from `base_dir`.
FieldDesignSpec ParseFieldDesignSpec(const std::string& text, const std::string& source_name,
                                     const std::string& base_dir);

/// The CSV target: header with at least x, y, vx, vy (other columns ignored, so a `vinci field`
/// CSV is a target), one row per grid point in grid order (y outer, x inner) with x, y equal to
/// the grid point's within 1e-9 of the grid size. Throws "file:line: ..." on a mismatch.
std::vector<Vector2d> ReadTargetCsv(const std::string& path, const FieldDesignSpec& spec);

/// The grid point k (y outer, x inner).
Vector2d GridPoint(const FieldDesignSpec& spec, int k);

}  // namespace vinci::planning
