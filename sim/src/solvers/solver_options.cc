#include "vinci/sim/solvers/solver_options.h"

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace vinci::sim {
namespace {

// "field = value: expected what" if !ok, else empty.
template <typename T>
std::string Check(bool ok, const char* field, T value, const char* what) {
  if (ok) return {};
  std::ostringstream msg;
  msg << field << " = " << value << ": expected " << what;
  return msg.str();
}

bool Positive(double x) { return x > 0.0 && std::isfinite(x); }
bool NonNegative(double x) { return x >= 0.0 && std::isfinite(x); }

}  // namespace

std::string CheckSolverOptions(const SolverOptions& o) {
  const std::string checks[] = {
      Check(o.lemke.max_pivots >= 0, "lemke.max_pivots", o.lemke.max_pivots,
            "an integer >= 0 (0: 50 n + 100)"),
      Check(Positive(o.lemke.pivot_tolerance), "lemke.pivot_tolerance", o.lemke.pivot_tolerance,
            "a finite number > 0"),
      Check(Positive(o.lemke.residual_tolerance), "lemke.residual_tolerance",
            o.lemke.residual_tolerance, "a finite number > 0"),
      Check(NonNegative(o.lemke.regularization), "lemke.regularization", o.lemke.regularization,
            "a finite number >= 0"),
      Check(o.lemke.refactor_interval >= 0, "lemke.refactor_interval", o.lemke.refactor_interval,
            "an integer >= 0"),
      Check(o.pgs.max_sweeps >= 1, "pgs.max_sweeps", o.pgs.max_sweeps, "an integer >= 1"),
      Check(Positive(o.pgs.tolerance), "pgs.tolerance", o.pgs.tolerance, "a finite number > 0"),
      Check(o.pgs.relaxation > 0.0 && o.pgs.relaxation < 2.0, "pgs.relaxation", o.pgs.relaxation,
            "a number in (0, 2)"),
      Check(o.pgs.polish_interval >= 0, "pgs.polish_interval", o.pgs.polish_interval,
            "an integer >= 0"),
      Check(o.fb_newton.max_iterations >= 1, "fb_newton.max_iterations", o.fb_newton.max_iterations,
            "an integer >= 1"),
      Check(Positive(o.fb_newton.tolerance), "fb_newton.tolerance", o.fb_newton.tolerance,
            "a finite number > 0"),
      Check(o.fb_newton.lambda > 0.0 && o.fb_newton.lambda <= 1.0, "fb_newton.lambda",
            o.fb_newton.lambda, "a number in (0, 1]"),
      Check(o.mcp.max_iterations >= 1, "mcp.max_iterations", o.mcp.max_iterations,
            "an integer >= 1"),
      Check(Positive(o.mcp.tolerance), "mcp.tolerance", o.mcp.tolerance, "a finite number > 0"),
      Check(o.mcp.lambda > 0.0 && o.mcp.lambda <= 1.0, "mcp.lambda", o.mcp.lambda,
            "a number in (0, 1]"),
      Check(o.mcp.nonmonotone_memory >= 1, "mcp.nonmonotone_memory", o.mcp.nonmonotone_memory,
            "an integer >= 1"),
      Check(o.mcp.max_restarts >= 0, "mcp.max_restarts", o.mcp.max_restarts, "an integer >= 0"),
      Check(o.mcp.stall_iterations >= 1, "mcp.stall_iterations", o.mcp.stall_iterations,
            "an integer >= 1"),
  };
  for (const std::string& c : checks)
    if (!c.empty()) return c;
  return {};
}

std::shared_ptr<const LcpSolver> MakeLcpSolver(const std::string& name,
                                               const SolverOptions& options) {
  const std::string bad = CheckSolverOptions(options);
  if (!bad.empty()) throw std::invalid_argument("solver options: " + bad);
  if (name == "lemke") return std::make_shared<LemkeSolver>(options.lemke);
  if (name == "pgs") return std::make_shared<PgsSolver>(options.pgs);
  if (name == "fb-newton") return std::make_shared<FischerBurmeisterSolver>(options.fb_newton);
  return MakeLcpSolver(name);  // throws, listing the known names
}

}  // namespace vinci::sim
