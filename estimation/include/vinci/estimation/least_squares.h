// Least-squares estimation of scene parameters with the simulator in the loop (Ceres).
//
// Unknowns: θ, the chosen parameters (differentiable entries of the ParamTable, e.g.
// mu.default), and optionally each episode's initial state s_e: per observed dynamic body its
// pose and world velocity (planar x, y, θ, vx, vy, ω; spatial position, a rotation vector δ
// with R = exp(δ) R̂ (R̂ the first logged orientation), v_W, w_W). Unobserved dynamic bodies
// start from the scene's initial state.
//
//   min_{θ, s}  ½ Σ_e Σ_i ‖ y_ei − h(x_e(t_ei; θ, s_e)) ‖²
//
// where x_e(t; θ, s_e) is the simulator's rollout from s_e at the log's first time with the
// scene's dt, linearly interpolated between steps at the logged times t_ei (any sampling), and
// h returns the positions of the observed dynamic bodies plus, where the log has them, their
// orientations as angle errors times `orientation_length` (so every residual is in metres).
// Single shooting: one rollout per episode over its whole log. Multiple shooting: each episode
// is cut into segments of `segment_samples` samples, each simulated from its own start state
// s_ej (unknowns too, guessed from the log at the segment's first sample), with the continuity
// defects w c ⊙ (x(t_e,j+1; θ, s_ej) − s_e,j+1) as extra residuals (c: 1 for positions,
// orientation_length for angles, the segment's duration for velocities, so they are in metres;
// w = continuity_weight ≫ 1, a penalty that makes them constraints to O(1/w²)). Rollouts are
// short and start near the data, so the fit is much less prone to local minima.
// Jacobians (`jacobian`): central finite differences of rollouts (default), or forward step
// sensitivities propagated along each rollout (sim/simulator/sensitivity.h; one-sided at
// degenerate stick–slip steps; finite differences where the formulation has none — the
// geometrically implicit stepper — or a step's derivative fails). Standard errors: σ √diag(I⁻¹), I
// the Gauss–Newton information about θ with each episode's free initial-state components profiled
// out, I = Σ_e Jθᵀ (1 − P_s) Jθ (P_s the projector on the columns of J_s), J the Jacobian of the
// episode's measured residuals with respect to (θ, s_e,0); for multiple shooting J chains the
// segments through the continuity constraints as exact (ds_j+1 = ∂x_end/∂θ dθ + ∂x_end/∂s_j
// ds_j, the end-state derivatives being the continuity rows' over w c), so single and multiple
// shooting report the same standard error at the same solution. σ = max(stated σ, σ̂), σ̂² =
// Σ r² / (m − n) over the measured residuals (n: parameters + free initial-state components):
// a fit that does not reach the noise level (a stall at a stick–slip kink, model mismatch)
// widens its standard errors instead of reporting the stated noise's; if Σ r² / σ² exceeds
// its χ² mean (m − n) by 4 standard deviations the result is not `converged` (reason says so).
// Initial-state components with a zero Jacobian column at the start (a velocity into a resting
// contact, which the first step removes) are held at the log's values. The log's initial velocity
// (the starting guess, or the value used without estimate_initial_state and without velocity
// columns) is the slope at t0 of a least-squares quadratic through the first 8 samples.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "vinci/estimation/log.h"
#include "vinci/sim/simulator/simulator.h"

namespace vinci::estimation {

/// Single shooting (one rollout per episode) or multiple shooting (segments with continuity).
enum class Shooting { kSingle, kMultiple };
/// "single" / "multiple".
const char* ToString(Shooting s);

/// How the residuals' Jacobians are computed.
enum class LeastSquaresJacobian {
  /// Forward step sensitivities along the rollout (sim::PropagateStep): exact where the contact
  /// mode is fixed, directional (one-sided) at degenerate steps; one rollout per evaluation.
  /// Falls back to finite differences for a formulation without step sensitivities (GI) and
  /// for an evaluation whose step derivative failed.
  kSensitivity,
  /// Central differences of whole rollouts (2 rollouts per unknown; one-sided at a bound).
  kFiniteDifference,
};
/// "sensitivity" / "fd".
const char* ToString(LeastSquaresJacobian j);
/// Parses "sensitivity" or "fd"; throws std::invalid_argument naming the value otherwise.
LeastSquaresJacobian ParseLeastSquaresJacobian(const std::string& name);

/// How least squares' standard errors are computed.
enum class LeastSquaresStdErrors {
  /// σ √diag of the Gauss–Newton covariance at the solution: the local curvature.
  kLinearized,
  /// From the profile of the cost in each parameter (the other parameters and the initial
  /// states fitted again at each value): the interval where Δχ² = 2 Δcost / σ² ≤ 9, its wider
  /// side divided by 3. Where a log sticks and slips the cost is not quadratic in μ: a kink at
  /// the solution makes the local curvature steep, and the linearized standard error covered the
  /// truth in 1 of 4 such fits (docs/estimation.md); the profile reads the curvature at the scale
  /// a 3-standard-error interval is judged at. 2–4 extra fits per side and parameter. A profile
  /// point cheaper than the solution by Δχ² > 1 makes the result not converged (a local minimum).
  /// Not with multiple shooting (its later segments' states would restart from the log).
  kProfile,
};
/// "linearized" / "profile".
const char* ToString(LeastSquaresStdErrors s);
/// Parses "linearized" or "profile"; throws std::invalid_argument naming the value otherwise.
LeastSquaresStdErrors ParseLeastSquaresStdErrors(const std::string& name);

struct EstimateResult;

struct LeastSquaresOptions {
  std::vector<std::string> params;  ///< names in the scene's ParamTable, differentiable
  /// Estimate each episode's initial state (else it is taken from the log's first sample, with
  /// the logged velocity or, without velocity columns, a finite difference of the first samples).
  bool estimate_initial_state = true;
  double noise_sigma = 0.0;  ///< measurement noise σ (m); 0: estimated from residuals
  Shooting shooting = Shooting::kSingle;
  int segment_samples = 20;  ///< multiple shooting: logged samples per segment (≥ 2)
  /// Single shooting: a growing-horizon continuation. 0: each episode's whole log in one fit.
  /// H ≥ 2: first fit each episode's first H samples, then ⌈g H⌉, ⌈g ⌈g H⌉⌉, … (g =
  /// horizon_growth, at least one sample more each time) and finally the whole log, each fit
  /// started from the one before (every episode's initial state, and θ after a geometric line
  /// search of each positive parameter: ×2^{±1/2}, 2^{±1}, repeated from an end point, by the
  /// new horizon's rollout cost at those initial states). A rollout over a short horizon is a
  /// smooth function of the initial state and θ; over a long one it may not be (impacts that
  /// tumble a body), and a fit started far from the data then stops in a local minimum. A
  /// parameter a fit leaves undetermined (standard error ≥ its magnitude, or none) keeps its
  /// value from before that fit.
  /// With noise_sigma and one episode: a fit whose residuals contradict the noise
  /// (EpisodeContradictsNoise) where the last kept fit's agreed with it, over a step of ≥ 2
  /// samples, is discarded (θ and the initial state back to the kept fit's) and the horizon is
  /// approached in halved steps (down to one sample; then kept as it is): a new impact taken in
  /// over many samples at once can leave the initial state in a local minimum that smaller
  /// steps avoid (measured on a tossed cube: 48 → 58 samples stalled at σ̂ 47 µm for 30 µm;
  /// steps of 1.1 fitted at the noise). Not with several episodes (measured on 50 tossed cubes:
  /// no better, docs/estimation.md).
  /// Horizons too short for the unknowns are skipped. Not with multiple shooting (its segments
  /// are short already).
  int horizon_samples = 0;
  /// The halved steps above after a fit that loses the log's agreement with the noise (false:
  /// every fit kept; the MPEC's rough start, which is fitted again carefully if its end
  /// contradicts the noise, measured 0.5 s slower with them on a 500-sample log).
  bool horizon_refinement = true;
  /// With noise_sigma, several episodes and single shooting: after the fit, each episode whose
  /// residuals contradict the noise (EpisodeContradictsNoise) is fitted alone (θ free, the
  /// horizon above), then with θ held at the joint θ̂ from there, and (with the horizon) over
  /// the growing horizon with θ held at the joint θ̂ throughout; where the better of the two fits
  /// it better than the joint fit, its initial state replaces the joint fit's and the whole log is
  /// fitted again from the new states, kept if cheaper (reason: "episodes … started again from
  /// their own fits"). The shared θ can hold an episode's initial state in a local minimum that the
  /// episode alone leaves (measured on 50 tossed cubes: toss 27 at 42 µm rms jointly for 30 µm
  /// noise, 30 µm alone; docs/estimation.md, "Episode restarts").
  bool episode_restarts = true;
  /// g > 1 of horizon_samples. Measured on tossed cubes (docs/estimation.md): g = 2 let the
  /// first impact in at once and stalled more often than 1.2.
  double horizon_growth = 1.2;
  /// Multiple shooting: weight w of the continuity residuals relative to the measurements.
  double continuity_weight = 1e3;
  double orientation_length = 0.1;  ///< m per rad for orientation residuals
  int threads = 1;                  ///< segments evaluated in parallel (same bits for any count)
  int max_iterations = 100;
  double function_tolerance = 1e-12;
  double parameter_tolerance = 1e-10;
  double gradient_tolerance = 1e-14;
  /// Finite differences by default: the sensitivity Jacobians disagree with them after a
  /// sliding block stops (by one step's dt in ∂x/∂v0) and on a box resting on four redundant
  /// corners (tilt columns), docs/estimation.md; opt in with kSensitivity.
  LeastSquaresJacobian jacobian = LeastSquaresJacobian::kFiniteDifference;
  double fd_relative_step = 1e-6;  ///< central-difference step, relative (absolute ≥ this)
  LeastSquaresStdErrors std_errors = LeastSquaresStdErrors::kLinearized;
  /// Called after every solver iteration with its number (0 = the starting point), the cost
  /// ½ Σ r² (m²) and the current parameter values. May be empty. Must not throw.
  std::function<void(int iteration, double cost, const sim::VectorXd& params)> progress;
  /// With horizon_samples: called after each horizon's fit (but the last) with the samples per
  /// episode it fitted, its result and the episodes (indices) whose fit was discarded, the
  /// horizon then approached in smaller steps (empty: kept). May be empty. Must not throw.
  std::function<void(int horizon, const EstimateResult& fit, const std::vector<int>& discarded)>
      horizon_progress;
  /// Throws std::invalid_argument naming the first invalid field.
  void Validate() const;
};

/// Estimated initial state of one episode (world frame).
struct EpisodeEstimate {
  std::string file;
  sim::State x0;  ///< the estimated (or log-derived) initial state, at the log's first time
  double rms_residual = 0.0;   ///< m
  int num_residuals = 0;       ///< measured residual rows of the episode
  int num_state_unknowns = 0;  ///< free initial-state components fitted (0 if not estimated)
};

/// Σ r² of the episode beyond the χ² test of the stated σ (p < 1e-4; degrees of freedom: its
/// residual rows less its free initial-state components). False without σ > 0, a finite
/// residual, or degrees of freedom.
bool EpisodeContradictsNoise(const EpisodeEstimate& episode, double sigma);

/// The episodes (indices, in order) whose rms residual exceeds `factor` times the median of all
/// episodes' (and 1 nm) — a fit far worse than the others': a wrong local solution, a log problem
/// or a different model (measured: one of 50 tossed cubes fitted at 3.4× the median rms residual,
/// at μ̂ = 0.13 where the others gave ~0.4, and pulled the shared estimate down). Empty with fewer
/// than 3 episodes or a non-finite residual. factor > 1. `median`: that median (NaN when empty
/// is returned for those reasons).
std::vector<int> PoorlyFittingEpisodes(const std::vector<EpisodeEstimate>& episodes,
                                       double factor = 3.0, double* median = nullptr);

struct EstimateResult {
  std::string method = "lsq";  ///< "lsq", "filter"
  std::vector<std::string> names;
  sim::VectorXd estimates, std_errors;  ///< std_errors NaN where the covariance failed
  /// LeastSquaresStdErrors::kProfile (else empty): the linearized standard errors, and the
  /// profile's interval Δχ² ≤ 9 per parameter (a side NaN where the profile did not reach 9
  /// within 512 linearized standard errors or a bound, or a fit failed; the standard error is
  /// then NaN). `std_error_method`: "profile", else empty (linearized).
  sim::VectorXd linearized_std_errors, profile_low, profile_high;
  std::string std_error_method;
  sim::VectorXd initial_values;
  /// Solver iterations, summed over the horizons of a continuation and the profile's fits.
  int iterations = 0;
  double time_s = 0.0;
  bool converged = false;
  std::string reason;  ///< the solver's termination message (and any rollout failure)
  /// ½ Σ r² (m²) over the whole log: at the start of its fit (with horizon_samples, the start
  /// of the last horizon's fit) and at the solution.
  double initial_cost = 0.0, final_cost = 0.0;
  /// Samples per episode of each fit of a horizon continuation, in order, discarded fits
  /// included (empty without one); the last is the whole log (its longest episode).
  std::vector<int> horizons;
  int num_residuals = 0, num_unknowns = 0;  ///< unknowns: parameters + free state components
  int num_segments = 0;  ///< shooting segments over all episodes (= episodes for single shooting)
  int num_continuity_residuals = 0;  ///< multiple shooting: continuity rows (not in num_residuals)
  /// Multiple shooting: largest continuity defect |x(t_j+1) − s_j+1| ⊙ c at the solution (m).
  double continuity_defect = 0.0;
  /// Initial-state components held at the log's values because no residual depends on them at
  /// the start (zero Jacobian column: e.g. a velocity into a resting contact, removed by the
  /// first step).
  int frozen_state_components = 0;
  /// σ used for the standard errors: the larger of the stated noise and sigma_residual (the
  /// residual estimate alone if no noise is stated).
  double sigma = 0.0;
  /// σ̂ = √(Σ r² / (m − n)) over the measured residuals (n: parameters and free initial-state
  /// components; segment start states are tied by the continuity constraints). NaN if m ≤ n.
  double sigma_residual = 0.0;
  /// How the Jacobians were computed: "sensitivity", "fd" (asked for, or the formulation has
  /// no step sensitivities: jacobian_note says why), "" for methods without Jacobians.
  std::string jacobian;
  std::string jacobian_note;
  /// kSensitivity: Jacobian evaluations that fell back to finite differences (a step's
  /// derivative failed), and steps whose derivative was one-sided (degenerate) or crossed a
  /// contact-set change, summed over all Jacobian evaluations.
  int jacobian_fallbacks = 0;
  long long degenerate_steps = 0, mode_change_steps = 0;
  std::vector<EpisodeEstimate> episodes;
};

/// Runs the estimation from the scene's values of the parameters. Throws std::invalid_argument
/// for an unknown or non-differentiable parameter, invalid options, or too few samples
/// (CheckEnoughSamples); numerical trouble (failed rollouts, no convergence) is reported in
/// the result, never thrown.
EstimateResult EstimateLeastSquares(const sim::Simulator& simulator, const Log& log,
                                    const LeastSquaresOptions& options);

/// Simulated observations of one episode at its logged times for the given parameters and
/// initial state: rows = samples, columns as the episode's residuals (ResidualsPerSample; the
/// orientation entries are the rotation angles from the logged ones times orientation_length,
/// i.e. measured minus simulated). Returns false if the rollout failed. For tests and tools.
bool EpisodeResiduals(const sim::Simulator& simulator, const sim::Params& params,
                      const Episode& episode, const sim::State& x0, double orientation_length,
                      sim::VectorXd* residuals, std::string* failure);

/// One shooting segment's residuals and Jacobian, for tests and tools: the episode's samples
/// first..last rolled out with the parameters `theta` (of options.params, the others at the
/// scene's values) from the segment's state unknowns *s (if s is empty on entry, the log's guess
/// at sample first is used and returned). Rows: the residuals of samples first..last−1 (all of
/// first..last if last is the episode's last sample) and, if not, the continuity rows
/// c ⊙ (x(t_last) − s_last) with weight 1 and s_last the log's guess at sample last. Columns:
/// θ, then s. The Jacobian by options.jacobian (JacobianNote says how it was obtained). Returns
/// false if the rollout failed (*note says why).
bool SegmentJacobian(const sim::Simulator& simulator, const Log& log, int episode, int first,
                     int last, const sim::VectorXd& theta, const LeastSquaresOptions& options,
                     sim::VectorXd* s, sim::VectorXd* residuals, sim::MatrixXd* jacobian,
                     std::string* note);

/// The initial state the log suggests for an episode: the scene's initial state with the
/// observed dynamic bodies at their first logged pose and velocity (logged, or a finite
/// difference over the first samples), t = the log's first time.
sim::State InitialStateFromLog(const sim::Simulator& simulator, const Episode& episode);

}  // namespace vinci::estimation
