// The grip condition of a `success` objective (docs/design.md, `grip:`): the part is held —
// squeezed between every jaw — rather than merely somewhere in a region.
//
// At a state s, the overlap of the objective body P with a jaw J is the depth of their deepest
// contact, δ_J = max(0, max_c −ψ_c) over the contacts c between shapes of P and J (ψ the signed
// gap; a corner contact's depth is −max(ψ, ψ₂), docs/formulations.md §7), 0 if they do not touch.
// The part is gripped iff min_J δ_J ≥ min_overlap (every jaw presses on it) and
// max_J δ_J ≤ max_overlap (no jaw crushes it). With compliant jaws (a Kelvin–Voigt layer of
// stiffness k, docs/scene-format.md) the layer's force at rest is k·δ, so the overlap window is a
// window on the grip force: [k·min_overlap, k·max_overlap].
#pragma once

#include <vector>

#include "vinci/design/spec.h"
#include "vinci/sim/model/scene.h"
#include "vinci/sim/model/state.h"

namespace vinci::design {

/// δ_J for each jaw in `jaws` (body indices), in that order, at state s of `model` (a scene
/// with the sample's parameters applied: Simulator::Resolve).
std::vector<double> JawOverlaps(const sim::Scene& model, const sim::State& s, int body,
                                const std::vector<int>& jaws);

/// True iff the grip condition holds (file comment). `overlaps` = JawOverlaps(...).
bool IsGripped(const Grip& grip, const std::vector<double>& overlaps);

}  // namespace vinci::design
