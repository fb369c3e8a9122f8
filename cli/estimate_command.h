// `vinci estimate SCENE.yaml LOG.csv... --param NAME --out result.json`: estimation of scene
// parameters (friction, masses) from logged trajectories (docs/estimation.md).
#pragma once

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "command.h"
#include "vinci/estimation/holdout.h"

namespace vinci::cli {

/// Everything `vinci estimate` takes from the command line.
struct EstimateOptions {
  std::string scene_path;
  std::vector<std::string> logs;
  std::vector<std::string> params;
  std::string method = "lsq";
  double noise = 0.0;  ///< stated measurement noise σ (m); 0: estimated from the residuals
  int threads = 1;
  int max_iterations = 100;
  bool fixed_initial_state = false;
  std::string shooting = "single";  ///< lsq: single | multiple
  int segment_samples = 20;         ///< lsq multiple shooting: samples per segment
  int holdout = 0;                  ///< K: every K-th episode held out of the fit (0: none)
  std::string out;
  bool quiet = false;
  std::string complementarity = "scholtes";  ///< mpec: scholtes | penalty
  double process_noise = 0.0;                ///< mpec: σ_Q (N, N·m); 0: 1% of the weight
  int bootstrap = 0;     ///< mpec: B bootstrap resamples over episodes (0: reduced Hessian)
  std::string jacobian;  ///< lsq: sensitivity | fd ("": sensitivity)
  /// mpec: steps per log interval (MpecOptions::substeps; 0: the scene's dt); −1: not given.
  int mpec_substeps = -1;
  std::string mpec_episodes;  ///< "" (joint), "joint" or "decomposed"; mpec only
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

}  // namespace vinci::cli
