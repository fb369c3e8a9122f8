// `vinci simulate SCENE`: run a scene forward in time and write its trajectory as CSV.
#pragma once

#include <CLI/CLI.hpp>
#include <optional>
#include <string>
#include <vector>

#include "command.h"

namespace vinci::cli {

/// Everything `vinci simulate` takes from the command line.
struct SimulateOptions {
  std::string scene_path;
  std::optional<double> duration;     ///< s; overrides stepper.duration
  std::optional<double> dt;           ///< s; overrides stepper.dt
  std::optional<std::string> solver;  ///< overrides stepper.solver
  std::string out;                    ///< CSV path; empty: no CSV
  bool quiet = false;                 ///< no progress, no summary (errors are still printed)
  /// Overrides stepper.formulation: a name from sim::FormulationNames().
  std::optional<std::string> formulation;
  /// Parameters to differentiate the trajectory by (sim/simulator/sensitivity.h): adds the
  /// columns d(<column>)/d(<name>) of every dynamic body and sensitivity_status.
  std::vector<std::string> sensitivity;
};

/// Adds the `simulate` subcommand to `app`.
Command RegisterSimulateCommand(CLI::App& app);

/// Runs `vinci simulate`. Throws std::invalid_argument for bad input (scene file, flag values,
/// an output file that cannot be opened). Returns kOk, or kSolveFailed if a step failed (the CSV
/// then holds the states up to and including the last good one).
ExitCode RunSimulate(const SimulateOptions& options);

}  // namespace vinci::cli
