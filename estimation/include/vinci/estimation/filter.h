// Recursive baseline: an augmented-state unscented Kalman filter (UKF) with the simulator as
// the process model (docs/estimation.md, thesis §7.2).
//
// The filter state is z = (s, θ): s the observed dynamic bodies' states in the coordinates of
// the least-squares unknowns (planar x, y, θ, vx, vy, ω; spatial p, δ, v_W, w_W with the
// rotation vector δ relative to the latest logged orientation, re-anchored every sample), θ the
// chosen parameters (a random walk with standard deviation `param_drift` per √s, 0 by
// default: constant). Between samples every sigma point is simulated on the scene's time grid
// with its own θ (clamped to the parameter bounds); the prediction at a logged time is the
// rollout interpolated linearly between the bracketing steps, as in least squares, and the
// filter state lives at the grid time at or after the sample. Scaled sigma points
// (Wan & van der Merwe: α, β = 2, κ = 0):
//
//   Z_0 = z̄,  Z_±i = z̄ ± √(n + λ) (√P)_i,  λ = α² n − n,
//   predicted mean/covariance by the weights, plus process noise Q (white acceleration of
//   spectral density a²: positions a² Δt³/3, velocities a² Δt, angles and angular velocities
//   the same divided by orientation_length²),
//   update with the innovation ν = Σ w_i (y − h(Z_i)) (measured minus simulated, the rotation
//   error for spatial orientations) and R = σ² I (angles (σ / orientation_length)²).
//
// Episodes are filtered in turn: each starts from its log's initial state (first pose, the
// quadratic-fit velocity, covariance from σ and the fit) with θ's posterior from the episode
// before. Estimates are the posterior mean of θ after the last sample, standard errors the
// square roots of its posterior variances. Unobserved dynamic bodies follow the central sigma
// point.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "vinci/estimation/least_squares.h"
#include "vinci/estimation/log.h"
#include "vinci/sim/simulator/simulator.h"

namespace vinci::estimation {

struct FilterOptions {
  std::vector<std::string> params;  ///< names in the scene's ParamTable, differentiable
  /// Measurement noise σ (m); 0: estimated from the log (the scatter of each position about a
  /// local quadratic, at least 1e-6 m).
  double noise_sigma = 0.0;
  double orientation_length = 0.1;  ///< m per rad for orientation measurements
  /// Prior standard deviation of each parameter around the scene's value; 0: max(0.5 |θ0|, 0.1).
  double param_prior_sigma = 0.0;
  double param_drift = 0.0;    ///< random-walk standard deviation of θ per √s
  double process_noise = 0.1;  ///< white-acceleration density a (m s^-1.5)
  double alpha = 0.5;          ///< sigma-point spread (0, 1]
  /// Called after every update with the sample number (over all episodes) and the mean of θ.
  std::function<void(int sample, const sim::VectorXd& params)> progress;
  /// Throws std::invalid_argument naming the first invalid field.
  void Validate() const;
};

/// Runs the filter over all episodes. Throws std::invalid_argument for an unknown or
/// non-differentiable parameter or invalid options; a failed rollout of a sigma point or a
/// covariance that is not positive definite ends the run with converged = false and the reason.
/// result.iterations is the number of measurement updates; sigma the σ used; initial/final_cost
/// ½ Σ (measured − predicted)² over the updates (m²), before/after each update.
EstimateResult EstimateFilter(const sim::Simulator& simulator, const Log& log,
                              const FilterOptions& options);

/// The measurement noise σ the log suggests: the RMS scatter of each logged position coordinate
/// about a least-squares quadratic through 7-sample windows, corrected for the fit's degrees of
/// freedom. For tools and as the filter's default.
double EstimateNoiseFromLog(const Log& log, sim::Dim dim);

}  // namespace vinci::estimation
