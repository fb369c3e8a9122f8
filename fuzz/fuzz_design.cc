// Fuzz target: design-spec text → ParseDesignSpec (`vinci design`, docs/design.md) (issue 18,
// deliverable 2). Relative `scene:` paths resolve from examples/design, so the seeds' scenes
// load; the spec's names, bounds, distributions, objective and screening stages are checked
// against the scene (and a stage's formulation by building its simulator).
//
// Bad input must end in std::invalid_argument with a message; anything else — another
// exception, a crash, a hang, a huge allocation, a sanitizer report — is a finding.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "vinci/design/spec.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const vinci::design::DesignSpec spec =
        vinci::design::ParseDesignSpec(text, "fuzz.yaml", VINCI_SOURCE_DIR "/examples/design");
    if (spec.parameters.empty() || spec.samples < 1 || spec.budget < 1) {
      std::fprintf(stderr, "fuzz_design: accepted a spec without parameters, samples or budget\n");
      std::abort();
    }
  } catch (const std::invalid_argument& e) {
    if (std::string(e.what()).empty()) std::abort();  // every rejection says why
  }
  return 0;
}
