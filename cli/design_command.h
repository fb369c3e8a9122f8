// `vinci design SPEC.yaml --out DIR`: design search under uncertainty (docs/design.md).
#pragma once

#include <CLI/CLI.hpp>
#include <string>

#include "command.h"

namespace vinci::cli {

/// Everything `vinci design` takes from the command line.
struct DesignOptions {
  std::string spec_path;
  std::string optimizer;       ///< empty: the spec's, else the default for the objective
  int budget = 0;              ///< simulations; 0: the spec's
  int samples = 0;             ///< per evaluation; 0: the spec's
  int validation_samples = 0;  ///< fresh samples of the final estimate; 0: the spec's
  int threads = 1;
  bool rank_fresh = false;  ///< re-evaluate the ranked designs on fresh samples, rank by those
  bool has_seed = false;
  long long seed = 0;
  std::string out;  ///< output folder (required)
  bool resume = false;
  bool quiet = false;
};

/// Adds the `design` subcommand to `app`.
Command RegisterDesignCommand(CLI::App& app);

/// Runs `vinci design`. Throws std::invalid_argument for bad input. Returns kOk, kSolveFailed if
/// an evaluation threw (the search stopped; results so far are written) or kInterrupted.
ExitCode RunDesignCommand(const DesignOptions& options);

}  // namespace vinci::cli
