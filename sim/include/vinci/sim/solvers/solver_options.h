// The typed options of every complementarity solver, in one place, for the solver selected by
// name (StepperOptions::solver) and for the formulations' MCP solves.
#pragma once

#include <memory>
#include <string>

#include "vinci/sim/solvers/fischer_burmeister.h"
#include "vinci/sim/solvers/lcp.h"
#include "vinci/sim/solvers/lemke.h"
#include "vinci/sim/solvers/mcp.h"
#include "vinci/sim/solvers/pgs.h"

namespace vinci::sim {

/// Options of each solver; only the selected solver's entry is used. Defaults are each
/// solver's own defaults.
struct SolverOptions {
  LemkeOptions lemke;                  ///< "lemke"
  PgsOptions pgs;                      ///< "pgs"
  FischerBurmeisterOptions fb_newton;  ///< "fb-newton"
  /// The semismooth Newton MCP solver of the NCP formulations (ncp, quasistatic-dqc,
  /// dynamic-dqc, gi); NCP applies its own `sparse` switch per step (ncp.h).
  McpOptions mcp;
};

/// Empty if every entry is admissible; otherwise the first offending field, its value and what
/// is expected, e.g. "pgs.relaxation = 2.5: expected a number in (0, 2)".
std::string CheckSolverOptions(const SolverOptions& options);

/// The LCP solver `name` (LcpSolverNames()) with its options from `options`. Throws
/// std::invalid_argument for an unknown name (listing the known ones) or invalid options
/// (CheckSolverOptions).
std::shared_ptr<const LcpSolver> MakeLcpSolver(const std::string& name,
                                               const SolverOptions& options);

}  // namespace vinci::sim
