// Hold-out validation (docs/estimation.md, `vinci estimate --holdout K`): every K-th episode is
// kept out of the fit, and the fitted model's rollouts are compared with those episodes.
//
// Rollout error of one episode: the simulator is run with the given parameters from the log's
// initial state (InitialStateFromLog: first pose and the quadratic-fit velocity) over the whole
// log, and compared at the logged times (rollout interpolated as in least squares):
//   position error  e_p = mean over samples and observed dynamic bodies of ‖p_log − p_sim‖ (m),
//                   also in % of the body's size (the diagonal of its shapes' bounding box in
//                   its own frame; averaged over bodies);
//   orientation error  e_R = mean rotation angle between logged and simulated orientation (deg;
//                   only where the log has orientations, else NaN).
// Two baselines: the body does not move (every sample predicted by the first logged pose), and
// the rollout with the initial-guess parameters (the scene's values).
#pragma once

#include <string>
#include <vector>

#include "vinci/estimation/log.h"
#include "vinci/sim/simulator/simulator.h"

namespace vinci::estimation {

/// Mean rollout error over some episodes.
struct RolloutError {
  double position_m = 0.0;        ///< mean ‖Δp‖ (m)
  double position_percent = 0.0;  ///< mean ‖Δp‖ / body size × 100
  double orientation_deg = 0.0;   ///< mean rotation angle (deg); NaN without logged orientations
  int samples = 0;                ///< samples compared
  int failed_rollouts = 0;        ///< episodes whose rollout failed (left out of the means)
};

struct HoldoutResult {
  std::vector<std::string> files;  ///< held-out episodes
  RolloutError fitted;             ///< with the fitted parameters
  RolloutError stationary;         ///< baseline: the body stays at its first logged pose
  RolloutError initial_guess;      ///< baseline: with the scene's parameter values
};

/// Splits `log`: the K-th, 2K-th, ... episodes (1-based) go to *held_out, the rest to *fit.
/// Throws std::invalid_argument if k < 2 or if either part would be empty (naming --holdout,
/// the value and the number of episodes).
void SplitHoldout(const Log& log, int k, Log* fit, Log* held_out);

/// The size of a body: the diagonal of its shapes' bounding box in its own frame (m); 0 for a
/// body without bounded shapes.
double BodySize(const sim::Scene& scene, int body_index);

/// Rollout errors (see the file comment) of `params` and of the stationary baseline over the
/// episodes. `stationary` may be null.
RolloutError EvaluateRollouts(const sim::Simulator& simulator, const sim::Params& params,
                              const Log& log, RolloutError* stationary);

/// The hold-out report: fitted parameters vs. the two baselines on `held_out`.
HoldoutResult EvaluateHoldout(const sim::Simulator& simulator, const sim::Params& fitted,
                              const Log& held_out);

}  // namespace vinci::estimation
