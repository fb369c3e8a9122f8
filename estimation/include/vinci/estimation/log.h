// Logged trajectories for estimation (docs/estimation.md): CSV files whose header uses the
// trajectory column names of `vinci simulate --out`.
//
//   t, then per observed body planar <body>.x, .y[, .theta][, .vx, .vy, .omega]
//   or spatial <body>.x, .y, .z[, .qw, .qx, .qy, .qz][, .vx, .vy, .vz, .wx, .wy, .wz]
//
// The report columns of `vinci simulate` (step, contacts, solver_iterations, residual, min_gap,
// status) are allowed and ignored, so any `vinci simulate` output is a valid log. Lines starting
// with `#` (and blank lines) are comments. Sampling may be irregular; times must increase
// strictly. Columns of static and prescribed bodies are read and checked but not fitted (those
// bodies are known from the scene). One file is one episode.
#pragma once

#include <string>
#include <vector>

#include "vinci/sim/model/scene.h"
#include "vinci/sim/types.h"

namespace vinci::estimation {

/// The samples of one body in one episode.
struct BodyTrack {
  std::string body;
  int body_index = -1;  ///< in Scene::bodies
  bool dynamic = false;
  /// Per sample, the pose: planar (x, y, θ) or spatial (x, y, z, qw, qx, qy, qz); rows =
  /// samples. Columns not in the log are zero and flagged false in has_orientation.
  sim::MatrixXd pose;
  bool has_orientation = false;  ///< .theta or the four .q? columns are present
  /// Per sample, the world-frame velocity: planar (vx, vy, ω) or spatial (v_W, w_W); empty
  /// (0 rows) if the log has no velocity columns for this body.
  sim::MatrixXd velocity;
};

/// One log file.
struct Episode {
  std::string file;
  std::vector<double> t;          ///< sample times (s), strictly increasing
  std::vector<int> lines;         ///< the file line of each sample (1-based)
  std::vector<BodyTrack> bodies;  ///< in column order of first appearance
  int num_samples() const { return static_cast<int>(t.size()); }
};

/// Several episodes estimated together (shared parameters, per-episode initial states).
struct Log {
  std::vector<Episode> episodes;
};

/// Largest accepted | ‖q‖ − 1 | of a logged quaternion.
constexpr double kQuaternionNormTolerance = 1e-3;

/// Reads one log file against `scene` (finalized). Throws std::invalid_argument "file:line:
/// what" for: an unreadable or empty file, a missing `t` column, an unknown column (not t, a
/// report column, or <body>.<component> of the scene's dimension), a body not in the scene, a
/// duplicated column, a body without all its position columns or with only some quaternion /
/// velocity columns, a row with the wrong number of fields, a value that is not a number, NaN
/// or ±inf, a duplicated or decreasing time, a quaternion whose norm differs from 1 by more than
/// kQuaternionNormTolerance, no sample, or no dynamic body observed.
Episode ReadEpisode(const std::string& path, const sim::Scene& scene);

/// As ReadEpisode, from the log's text; `path` names it in messages and in Episode::file. The
/// file itself is limited to sim::kMaxInputFileBytes (solvers/input_file.h).
Episode ParseEpisode(const std::string& text, const std::string& path, const sim::Scene& scene);

/// Reads every file as one episode (ReadEpisode).
Log ReadLog(const std::vector<std::string>& paths, const sim::Scene& scene);

/// Throws std::invalid_argument "file:line: ..." (line = the episode's last sample) if an
/// episode has fewer residuals (samples × ResidualsPerSample) than its own unknowns
/// `episode_unknowns[e]` (its initial state), or if all episodes together have fewer residuals
/// than all unknowns (theirs plus the `shared_unknowns` parameters; named at the last file).
void CheckEnoughSamples(const Log& log, sim::Dim dim, int shared_unknowns,
                        const std::vector<int>& episode_unknowns);

/// Residuals one episode contributes per sample: per observed dynamic body its position (2 or 3)
/// plus its orientation (1 planar, 3 spatial) if logged.
int ResidualsPerSample(const Episode& episode, sim::Dim dim);

}  // namespace vinci::estimation
