// `vinci field PLATE.yaml`: the friction-induced velocity field of a part on a vibrating plate
// (docs/field.md), written as CSV.
#pragma once

#include <CLI/CLI.hpp>
#include <optional>
#include <string>

#include "command.h"

namespace vinci::cli {

/// Everything `vinci field` takes from the command line.
struct FieldOptions {
  std::string scene_path;
  std::optional<std::string> grid;    ///< "NXxNY" (planar: "N" or "Nx1"); overrides the file
  std::optional<int> cycles;          ///< overrides field.cycles
  std::optional<int> average_cycles;  ///< overrides field.average_cycles
  std::optional<double> dt;           ///< s; overrides stepper.dt
  int threads = 1;                    ///< worker threads
  std::string out;                    ///< CSV path (required)
  std::string theory;                 ///< CSV path for the point-part theory; empty: none
  bool quiet = false;                 ///< no progress, no summary
};

/// Adds the `field` subcommand to `app`.
Command RegisterFieldCommand(CLI::App& app);

/// Runs `vinci field`. Throws std::invalid_argument for bad input (scene file, its `field:`
/// section, flag values, an output path that cannot be written). Returns kOk, or kSolveFailed
/// if a step failed at some grid point (the CSV is still written, those rows have failed = 1).
ExitCode RunField(const FieldOptions& options);

}  // namespace vinci::cli
