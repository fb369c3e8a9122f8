// The one step skeleton every formulation's step runs in (Simulator::Step calls it): input
// checks, the warm-start policy, the formulation's Step, then the checks every step gets.
#pragma once

#include <string>

#include "vinci/sim/formulations/formulation.h"

namespace vinci::sim {

/// One step of `formulation` from x on `model` (the scene with params applied):
///  0. A non-finite start state (t, q or v) fails with StepStatus::kNonFinite before the
///     formulation sees it.
///  1. Warm start: x.warm_start is the previous step's solution of the same formulation; a
///     formulation uses it only if its size matches this step's problem. A non-finite warm start
///     is dropped (cold start).
///  2. formulation.Step (which checks the start-of-step penetration and the solver).
///  3. The end state: t, q and v finite (else StepStatus::kNonFinite), and no contact deeper
///     than max_penetration at the END state (else kPenetration), so the last state of a run is
///     checked too. The end-state contacts are found by FindContacts with the next step's
///     prescribed poses; scenes with smooth implicit shapes rely on the geometrically implicit
///     stepper's own end-of-step check of its pairs. Inside Simulator::Step this detection is
///     made once, with the assembly's envelope as well, and kept for the next step's assembly,
///     which takes it only at exactly the same scene, state and step (one detection per step;
///     the same bits as detecting afresh).
/// On failure the report says why (info.status, info.failure) and *next == x.
StepInfo RunStep(const Formulation& formulation, const Scene& model, const State& x,
                 const StepInput& u, Workspace* ws, State* next);

/// The smallest gap (m) over the contacts with ψ ≤ `envelope` at state x (a corner contact counts
/// max(ψ_1, ψ_2)), +∞ if there is none; `where` (may be null) names the pair of bodies. A negative
/// envelope (RunStep passes −max_penetration) lets the broad phase skip every pair that cannot
/// overlap that deeply, so resting contacts cost no narrow phase. Prescribed bodies are posed at
/// x.t by their pose rule with step `h`. Throws std::invalid_argument for shapes that need
/// implicit contact (RequiresImplicitContact).
double MinGapAt(const Scene& model, const State& x, double h, double envelope, std::string* where);

}  // namespace vinci::sim
