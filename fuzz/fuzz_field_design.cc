// Fuzz target: field-design spec text → ParseFieldDesignSpec → FieldDesignProblem (`vinci
// field-design`, docs/planning.md) (issue 18, deliverable 2). Relative paths resolve from
// examples/field_design, so the seeds' plate scene loads and the spec is checked against it (the
// plate's DOFs, the grid, the target CSV) without running the search.
//
// Bad input must end in std::invalid_argument; anything else is a finding.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "vinci/planning/field_design.h"
#include "vinci/planning/field_design_spec.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const vinci::planning::FieldDesignSpec spec = vinci::planning::ParseFieldDesignSpec(
        text, "fuzz.yaml", VINCI_SOURCE_DIR "/examples/field_design");
    const vinci::planning::FieldDesignProblem problem(spec);
    if (problem.lower().size() != problem.upper().size()) std::abort();
  } catch (const std::invalid_argument& e) {
    if (std::string(e.what()).empty()) std::abort();
  }
  return 0;
}
