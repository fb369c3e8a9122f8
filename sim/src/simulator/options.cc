#include "vinci/sim/simulator/options.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <utility>

namespace vinci::sim {
namespace {

std::string Join(const std::vector<std::string>& names) {
  std::string s;
  for (const std::string& n : names) s += (s.empty() ? "" : ", ") + n;
  return s;
}

template <typename T>
[[noreturn]] void Fail(const char* field, T value, const std::string& expected) {
  std::ostringstream msg;
  msg << "simulator options: " << field << " = " << value << ": expected " << expected;
  throw std::invalid_argument(msg.str());
}

}  // namespace

std::vector<std::string> AllSolverNames() {
  std::vector<std::string> all;
  for (const auto& [name, type] : FormulationTable())
    for (const std::string& s : SolverNames(type))
      if (std::find(all.begin(), all.end(), s) == all.end()) all.push_back(s);
  return all;
}

void SimulatorOptions::Validate() const {
  if (!(dt > 0.0) || !std::isfinite(dt)) Fail("dt", dt, "a finite number > 0 (s)");
  if (!(duration > 0.0) || !std::isfinite(duration))
    Fail("duration", duration, "a finite number > 0 (s)");
  if (friction_directions < 2 || friction_directions % 2 != 0)
    Fail("friction_directions", friction_directions, "an even integer >= 2");
  if (!(envelope >= 0.0) || !std::isfinite(envelope))
    Fail("envelope", envelope, "a finite number >= 0 (m)");
  if (!(max_penetration > 0.0) || !std::isfinite(max_penetration))
    Fail("max_penetration", max_penetration, "a finite number > 0 (m)");
  const std::vector<std::string> names = SolverNames(formulation);
  if (std::find(names.begin(), names.end(), solver) == names.end())
    Fail(
        "solver", "'" + solver + "'",
        "a solver of formulation " + std::string(ToString(formulation)) + " (" + Join(names) + ")");
  const std::string bad = CheckSolverOptions(solver_options);
  if (!bad.empty()) throw std::invalid_argument("simulator options: solver_options." + bad);
}

void RolloutOptions::Validate() const {
  if (record_every < 1)
    throw std::invalid_argument("rollout options: record_every = " + std::to_string(record_every) +
                                ": expected an integer >= 1");
}

}  // namespace vinci::sim
