// `vinci plan PLAN.yaml --out plan.json`: a sequence of plate-motion primitives that carries the
// parts to their goal poses, planned with OMPL and re-simulated (docs/planning.md).
#pragma once

#include <CLI/CLI.hpp>
#include <string>

#include "command.h"

namespace vinci::cli {

/// Everything `vinci plan` takes from the command line.
struct PlanOptions {
  std::string spec_path;
  std::string out;          ///< plan.json (required)
  std::string trajectory;   ///< re-simulation CSV; empty: `out` with its extension replaced by .csv
  std::string planner;      ///< empty: the spec's
  double time_limit = 0.0;  ///< s per planner call; 0: the spec's
  bool has_seed = false;
  long long seed = 0;
  int replan = -1;                  ///< -1: the spec's
  long long max_propagations = -1;  ///< -1: the spec's
  bool quiet = false;
};

/// Adds the `plan` subcommand to `app`.
Command RegisterPlanCommand(CLI::App& app);

/// Runs `vinci plan`. Throws std::invalid_argument for bad input. Returns kOk if solved (an exact
/// solution whose re-simulation reaches the goal), kSolveFailed otherwise (plan.json and the
/// trajectory are still written).
ExitCode RunPlanCommand(const PlanOptions& options);

}  // namespace vinci::cli
