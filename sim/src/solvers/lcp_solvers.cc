// The LCP solver registry: solvers selected by name from scene files and the CLI.
#include <stdexcept>

#include "vinci/sim/solvers/fischer_burmeister.h"
#include "vinci/sim/solvers/lcp.h"
#include "vinci/sim/solvers/lemke.h"
#include "vinci/sim/solvers/pgs.h"

namespace vinci::sim {

std::vector<std::string> LcpSolverNames() { return {"lemke", "pgs", "fb-newton"}; }

std::shared_ptr<const LcpSolver> MakeLcpSolver(const std::string& name) {
  if (name == "lemke") return std::make_shared<LemkeSolver>();
  if (name == "pgs") return std::make_shared<PgsSolver>();
  if (name == "fb-newton") return std::make_shared<FischerBurmeisterSolver>();
  std::string known;
  for (const std::string& n : LcpSolverNames()) known += (known.empty() ? "" : ", ") + n;
  throw std::invalid_argument("unknown LCP solver '" + name + "'; expected one of: " + known);
}

}  // namespace vinci::sim
