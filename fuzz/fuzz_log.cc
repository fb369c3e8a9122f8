// Fuzz target: estimation log text → ParseEpisode (`vinci estimate`, docs/estimation.md) (issue
// 18, deliverable 2), against a planar scene (body `block`) and a spatial one (body `ball`).
//
// Bad input must end in std::invalid_argument; an accepted episode must be what the reader
// promises: strictly increasing finite times, one line per sample, finite poses, unit
// quaternions. Anything else is a finding.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "vinci/estimation/log.h"
#include "vinci/sim/model/scene_file.h"

namespace {

[[noreturn]] void Finding(const char* what) {
  std::fprintf(stderr, "fuzz_log: accepted an episode with %s\n", what);
  std::abort();
}

void Check(const vinci::estimation::Episode& ep, const vinci::sim::Scene& scene) {
  const bool planar = scene.dim == vinci::sim::Dim::kPlanar;
  if (ep.t.empty() || ep.t.size() != ep.lines.size()) Finding("no samples or unmatched lines");
  for (std::size_t i = 0; i < ep.t.size(); ++i) {
    if (!std::isfinite(ep.t[i])) Finding("a non-finite time");
    if (i > 0 && !(ep.t[i] > ep.t[i - 1])) Finding("times that do not increase");
  }
  bool dynamic = false;
  for (const auto& b : ep.bodies) {
    dynamic = dynamic || b.dynamic;
    if (b.body_index < 0 || b.body_index >= static_cast<int>(scene.bodies.size()))
      Finding("a body index outside the scene");
    if (b.pose.rows() != ep.num_samples() || !b.pose.allFinite()) Finding("a bad pose block");
    if (b.velocity.rows() != 0 &&
        (b.velocity.rows() != ep.num_samples() || !b.velocity.allFinite()))
      Finding("a bad velocity block");
    if (!planar && b.has_orientation)
      for (Eigen::Index i = 0; i < b.pose.rows(); ++i)
        if (std::abs(b.pose.row(i).tail<4>().norm() - 1.0) > 1e-9) Finding("a non-unit quaternion");
  }
  if (!dynamic) Finding("no dynamic body");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const vinci::sim::Scene planar =
      vinci::sim::LoadSceneFile(VINCI_SOURCE_DIR "/tests/cli/data/estimate_block.yaml");
  static const vinci::sim::Scene spatial =
      vinci::sim::LoadSceneFile(VINCI_SOURCE_DIR "/examples/scenes/ball_drop.yaml");
  const std::string text(reinterpret_cast<const char*>(data), size);
  for (const vinci::sim::Scene* scene : {&planar, &spatial}) {
    try {
      Check(vinci::estimation::ParseEpisode(text, "fuzz.csv", *scene), *scene);
    } catch (const std::invalid_argument& e) {
      if (std::string(e.what()).empty()) std::abort();
    }
  }
  return 0;
}
