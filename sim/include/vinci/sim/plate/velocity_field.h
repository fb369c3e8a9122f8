// Friction-induced velocity fields of a part on a vibrating plate (applications.md §C).
//
// For every point of a grid on the plate, the part is placed there (its scene pose gives the
// height and orientation relative to the plate; the grid point replaces its in-plane position),
// simulated for K cycles of the plate motion, and its velocity is averaged over the last N
// cycles. Coordinates and velocities are in the plate's initial frame P (spatial: the plate
// surface is P's z = 0 plane, in-plane axes x, y; planar: the surface is P's y = 0 line, the
// in-plane axis x and "vy" the average normal velocity). ω is the angular velocity about the
// plate normal. Grid points are simulated in parallel (BatchMap, simulator/batch.h); each point
// is an independent pure rollout, so the result is bit-identical for any thread count.
#pragma once

#include <functional>
#include <iosfwd>
#include <string>
#include <vector>

#include "vinci/sim/simulator/simulator.h"

namespace vinci::sim {

/// Limits of a field run (docs/scene-format.md, "Limits"): grid points nx·ny, and simulated
/// steps per point (steps per cycle × cycles), both enforced by FieldSpec::Validate.
constexpr long long kMaxFieldPoints = 1000000;
constexpr long long kMaxFieldStepsPerPoint = 1000000000;

/// What to compute (the scene file's `field:` section, docs/field.md).
struct FieldSpec {
  int plate = -1;                   ///< body index of the prescribed plate
  int part = -1;                    ///< body index of the dynamic part
  double frequency = 0.0;           ///< base frequency of the plate motion (Hz); cycle T = 1/f
  double x_min = 0.0, x_max = 0.0;  ///< grid extent, plate frame (m)
  double y_min = 0.0, y_max = 0.0;  ///< (spatial only)
  int nx = 21, ny = 21;             ///< grid points per axis (planar: ny = 1)
  int cycles = 50;                  ///< K simulated cycles
  int average_cycles = 10;          ///< N last cycles averaged (1 ≤ N ≤ K)
  /// The plate's extent (plate frame, m): a part whose origin leaves it has left the plate; its
  /// run stops there.
  double plate_x_min = -1e300, plate_x_max = 1e300;
  double plate_y_min = -1e300, plate_y_max = 1e300;
  /// Throws std::invalid_argument naming the field if the spec does not fit `scene`, or if it
  /// exceeds the limits above with the scene's time step (fewer than 1 or more than
  /// kMaxFieldStepsPerPoint steps per cycle, nx·ny > kMaxFieldPoints, ...).
  void Validate(const Scene& scene) const;
  /// Steps per cycle, round(T/h); throws std::invalid_argument if that is < 1 or above
  /// kMaxFieldStepsPerPoint (T/h overflowing an int used to give 1 silently).
  int StepsPerCycle(double h) const;
};

/// The averaged motion of the part started at one grid point.
struct FieldPoint {
  double x = 0.0, y = 0.0;    ///< start, plate frame (m)
  double vx = 0.0, vy = 0.0;  ///< average velocity, plate frame (m/s)
  double omega = 0.0;         ///< average angular velocity about the plate normal (rad/s)
  bool left_plate = false;    ///< the part left the plate extent (averages: see ComputePoint)
  bool failed = false;        ///< a step failed (averages up to the failure)
  std::string failure;
  double averaged_time = 0.0;  ///< length of the averaging window actually used (s)
  /// Mean position of the part over that window, plate frame (m): where the averaged velocity
  /// was measured (the part drifts from (x, y) in a non-uniform field).
  double x_mean = 0.0, y_mean = 0.0;
};

/// A computed field: points row by row (y outer, x inner).
struct VelocityField {
  FieldSpec spec;
  std::vector<FieldPoint> points;
  int left_plate = 0;  ///< points whose part left the plate
  int failed = 0;      ///< points with a failed step
};

struct FieldOptions {
  int threads = 1;  ///< worker threads (≥ 1)
  /// Called as points finish with (points done, total), on the calling thread (BatchOptions).
  /// May be empty.
  std::function<void(int, int)> progress;
};

/// The start point (x, y) of grid point i (row by row: y outer, x inner; planar y = 0), plate
/// frame (m): evenly spaced from min to max, the middle for a single point.
Vector2d FieldGridPoint(const FieldSpec& spec, int i);

/// Simulates the part from plate point (x, y). The average is over the last N cycles; if the
/// part leaves the plate (or a step fails) before that window, over the last complete cycle
/// before leaving, or over everything simulated if no cycle completed.
FieldPoint ComputeFieldPoint(const Simulator& sim, const Params& params, const FieldSpec& spec,
                             double x, double y);
/// As above with the caller's workspace (one per thread).
FieldPoint ComputeFieldPoint(const Simulator& sim, const Params& params, const FieldSpec& spec,
                             double x, double y, Workspace* ws);

/// The whole grid, in parallel. Bit-identical for any options.threads. An exception inside a
/// point (bad input, e.g. a parameter out of range) stops the run after joining every thread
/// and is rethrown: the one of the lowest-index failing point, as with one thread.
VelocityField ComputeVelocityField(const Simulator& sim, const Params& params,
                                   const FieldSpec& spec, const FieldOptions& options = {});

/// CSV: header `x,y,vx,vy,omega,left_plate,failed,x_mean,y_mean` and one row per point (17
/// significant digits, round-trip exact).
void WriteFieldCsv(const VelocityField& field, std::ostream& out);

/// Reads the `field:` section of the scene file at `path` (format: docs/field.md) for `scene`
/// (already loaded from the same file). Throws std::invalid_argument as
/// "path:line: field.key: expected ..., got ...".
FieldSpec LoadFieldSpec(const std::string& path, const Scene& scene);

}  // namespace vinci::sim
