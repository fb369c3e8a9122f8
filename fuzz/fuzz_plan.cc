// Fuzz target: plan-spec text → ParsePlanSpec → PlanProblem (`vinci plan`, docs/planning.md)
// (issue 18, deliverable 2). Relative paths resolve from examples/plan; PlanProblem checks the
// spec against its scene: the plate, a goal per part, and every primitive's motion through the
// scene loader (without planning).
//
// Bad input must end in std::invalid_argument; anything else is a finding.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "vinci/planning/plan.h"
#include "vinci/planning/plan_spec.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const vinci::planning::PlanSpec spec =
        vinci::planning::ParsePlanSpec(text, "fuzz.yaml", VINCI_SOURCE_DIR "/examples/plan");
    const vinci::planning::PlanProblem problem(spec);
    if (problem.num_primitives() < 1 || problem.num_parts() < 1) std::abort();
  } catch (const std::invalid_argument& e) {
    if (std::string(e.what()).empty()) std::abort();
  }
  return 0;
}
