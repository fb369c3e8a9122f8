// Fuzz target: scene text → ParseScene → Simulator → a few steps (issue 18, deliverable 2).
//
// Bad input must end in std::invalid_argument (the loader's or a formulation's rejection);
// numerical trouble in a step is a status. Anything else — another exception, a crash, a hang,
// a sanitizer report — is a finding. Built with libFuzzer (-DVINCI_FUZZ=ON, clang) and, without
// it, into the corpus replay test (replay_main.cc).
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/simulator/simulator.h"

namespace {
// Keeps each execution short: larger scenes are parsed but not stepped.
constexpr std::size_t kMaxSteppedBodies = 16;
constexpr int kSteps = 5;
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  vinci::sim::Scene scene;
  try {
    scene = vinci::sim::ParseScene(text, "fuzz.yaml");
  } catch (const std::invalid_argument&) {
    return 0;
  }
  if (scene.bodies.size() > kMaxSteppedBodies) return 0;
  try {
    const vinci::sim::Simulator sim(std::move(scene));
    const vinci::sim::Params params = sim.DefaultParams();
    vinci::sim::State x = sim.InitialState();
    vinci::sim::Workspace ws;
    for (int k = 0; k < kSteps; ++k) {
      vinci::sim::State next;
      const vinci::sim::StepInfo info = sim.Step(params, x, vinci::sim::StepInput{}, &ws, &next);
      if (!info.ok) break;
      x = std::move(next);
    }
  } catch (const std::invalid_argument&) {
    // A formulation that cannot honour the scene rejects it: fine.
  }
  return 0;
}
