// `vinci solve PROBLEM`: solve one LCP read from a plain-text file (docs/lcp-format.md) and
// print z, w = Mz + q and the solver's report.
#pragma once

#include <CLI/CLI.hpp>
#include <string>

#include "command.h"

namespace vinci::cli {

/// Everything `vinci solve` takes from the command line.
struct SolveOptions {
  std::string problem_path;
  std::string solver = "lemke";  ///< a name from sim::LcpSolverNames()
  std::string warm_start_path;   ///< a file of n numbers >= 0; empty: cold start
  bool json = false;             ///< print one JSON object instead of text
};

/// Adds the `solve` subcommand to `app`.
Command RegisterSolveCommand(CLI::App& app);

/// Runs `vinci solve`. Throws std::invalid_argument for bad input (unknown solver, unreadable
/// or malformed problem or warm-start file). Prints the report on stdout and returns kOk if the
/// solver solved the problem, otherwise kSolveFailed (3) after the report and an error message
/// on stderr.
ExitCode RunSolve(const SolveOptions& options);

}  // namespace vinci::cli
