// `vinci field-design SPEC.yaml --out DIR`: the plate motion whose simulated velocity field best
// matches a target field (docs/planning.md).
#pragma once

#include <CLI/CLI.hpp>
#include <string>

#include "command.h"

namespace vinci::cli {

/// Everything `vinci field-design` takes from the command line.
struct FieldDesignOptions {
  std::string spec_path;
  std::string out;  ///< output folder (required)
  int budget = 0;   ///< field evaluations; 0: the spec's
  int threads = 1;
  bool has_seed = false;
  long long seed = 0;
  bool quiet = false;
  double tolerance = -1.0;       ///< overrides the spec's tolerance if >= 0
  double global_fraction = 0.6;  ///< share of the budget for the global phase
  std::string start;  ///< a plate scene whose motion is the first point (empty: the box middle)
};

/// Adds the `field-design` subcommand to `app`.
Command RegisterFieldDesignCommand(CLI::App& app);

/// Runs `vinci field-design`. Throws std::invalid_argument for bad input. Returns kOk, or
/// kSolveFailed if an evaluation threw (the search stopped; the best so far is written).
ExitCode RunFieldDesignCommand(const FieldDesignOptions& options);

}  // namespace vinci::cli
