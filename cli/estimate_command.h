// `vinci estimate SCENE.yaml LOG.csv... --param NAME --out result.json`: estimation of scene
// parameters (friction, masses) from logged trajectories (docs/estimation.md).
#pragma once

#include <CLI/CLI.hpp>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "command.h"
#include "vinci/estimation/holdout.h"
#include "vinci/estimation/least_squares.h"
#include "vinci/estimation/log.h"
#include "vinci/sim/simulator/simulator.h"
#include "vinci/sim/types.h"

namespace vinci::cli {

/// Everything `vinci estimate` takes from the command line.
struct EstimateOptions {
  std::string scene_path;
  std::vector<std::string> logs;
  std::vector<std::string> params;
  std::string method = "lsq";
  double noise = 0.0;  ///< stated measurement noise σ (m); 0: estimated from the residuals
  int threads = 1;
  /// Solver iterations at most; empty: each method's default (lsq: Ceres' 100 iterations; mpec:
  /// Ipopt's 3 000 per NLP). The filter has none.
  std::optional<int> max_iterations;
  bool fixed_initial_state = false;
  std::string shooting = "single";  ///< lsq: single | multiple
  int segment_samples = 20;         ///< lsq multiple shooting: samples per segment
  int lsq_horizon = 0;  ///< lsq single shooting: first horizon in samples (0: the whole log)
  std::optional<double> lsq_horizon_growth;  ///< its growth factor; empty: the library's
  int holdout = 0;  ///< K: every K-th episode held out of the fit (0: none)
  std::string out;
  bool quiet = false;
  std::string complementarity = "scholtes";  ///< mpec: scholtes | penalty
  double process_noise = 0.0;                ///< mpec: σ_Q (N, N·m); 0: 1% of the weight
  /// mpec: MpecSolverOptions::complementarity_tolerance; empty: not given (its default).
  std::optional<double> complementarity_tolerance;
  int bootstrap = 0;           ///< mpec: B bootstrap resamples over episodes (0: reduced Hessian)
  std::string jacobian;        ///< lsq: sensitivity | fd ("": sensitivity)
  std::string lsq_std_errors;  ///< lsq: linearized | profile ("": the library's)
  std::string lsq_episode_restarts;  ///< lsq: on | off ("": the library's, on)
  /// mpec: steps per log interval (MpecOptions::substeps; 0: the scene's dt); −1: not given.
  int mpec_substeps = -1;
  std::string mpec_episodes;  ///< "" (joint), "joint" or "decomposed"; mpec only
  std::string mpec_ordering;  ///< "" (auto), "auto", "scotch" or "qamd"; mpec only
  std::string mpec_start;     ///< "" or "auto", "log" or "lsq" (MpecOptions::least_squares_start)
};

/// Adds the `estimate` subcommand to `app`.
Command RegisterEstimateCommand(CLI::App& app);

/// Runs `vinci estimate`. Throws std::invalid_argument for bad input (including a method that
/// is not implemented). Returns kOk, or kSolveFailed if the estimator did not converge (the
/// result is still written, with the reason).
ExitCode RunEstimateCommand(const EstimateOptions& options);

/// `--method mpec` (estimate_mpec.cc): same contract as RunEstimateCommand.
ExitCode RunEstimateMpec(const EstimateOptions& options);

/// The `"holdout_error": {...},` member of a method's result.json object (indented for it).
std::string HoldoutJson(const EstimateOptions& options, const estimation::HoldoutResult& holdout);

/// The one-line hold-out summary printed on stdout.
std::string HoldoutSummary(const estimation::HoldoutResult& holdout);

/// Throws std::invalid_argument naming --out if `path` cannot be opened for writing (checked
/// before the work, so a bad path does not cost a fit).
void CheckOutWritable(const std::string& path);

/// Writes `text` to `path`, truncating it; throws std::invalid_argument naming --out on failure.
void WriteOut(const std::string& path, const std::string& text);

/// The fitted model's hold-out rollout errors: the scene's default parameters with `names` set
/// to `estimates`, rolled out on `held_out`'s episodes. Null when --holdout is off.
std::unique_ptr<estimation::HoldoutResult> FittedHoldout(const EstimateOptions& options,
                                                         const sim::Simulator& simulator,
                                                         const std::vector<std::string>& names,
                                                         const sim::VectorXd& estimates,
                                                         const estimation::Log& held_out);

/// One line per parameter, "name = value ± s.e. (from initial)", printed on stdout, then a
/// warning line per parameter whose standard error exceeds |value| (not determined by the logs).
std::string EstimateLines(const std::vector<std::string>& names, const sim::VectorXd& estimates,
                          const sim::VectorXd& std_errors, const sim::VectorXd& initial_values);

/// The line naming the episodes that fit far worse than the others
/// (estimation::PoorlyFittingEpisodes), or "" if there are none.
std::string PoorEpisodesLine(const std::vector<estimation::EpisodeEstimate>& episodes);

}  // namespace vinci::cli
