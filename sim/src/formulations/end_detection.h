// One contact detection per step (internal header). The end-of-step penetration check (RunStep)
// and the next step's assembly (StewartTrinkle::AssembleInto) detect contacts at the same state:
// the next step starts at the end state, and both pose the prescribed bodies at (t, h). So the
// check detects once, with the envelope the assembly uses, and keeps the result (the body
// kinematics and the contacts) in the calling thread's EndDetection; the next assembly takes it
// only if it is keyed by exactly its own inputs, and detects afresh otherwise.
//
// The key: the scene's owner (Simulator::Step names it for the duration of the step with a
// StepSceneScope: a scene is identified by its owner, not by its address, which a later scene
// may reuse; an owned scene is immutable, and a changed parameter or input motion resolves to
// another owner), t, q and ν bitwise, the step h that poses the prescribed bodies and the
// envelope. Kinematics and contacts are functions of these alone (ComputeBodyKinematics,
// EvaluateMotion, FindContacts), so a taken detection equals, bit for bit and in order, the one
// the assembly would make. Outside a Simulator::Step (no scope) nothing is kept or taken.
#pragma once

#include <memory>
#include <vector>

#include "vinci/sim/formulations/contact.h"
#include "vinci/sim/model/kinematics.h"
#include "vinci/sim/model/scene.h"
#include "vinci/sim/model/state.h"

namespace vinci::sim::internal {

/// World poses X_WB0 X_BS and AABBs of the static bodies' shapes of one scene, indexed by the
/// scene's flattened shape index (body by body; other bodies' entries unused).
struct StaticShapes {
  std::vector<Isometry3d> poses;
  std::vector<Aabb> boxes;
};

/// FindContacts(scene, bodies, envelope, out) and, if `check` is not null, FindContacts(scene,
/// bodies, check_envelope, check), in one pass: one broad phase (at the larger envelope), the
/// narrow phase per list only for the pairs that list's envelope keeps. Each list is exactly
/// what its own FindContacts call returns. `statics` (may be null): the scene's StaticShapes,
/// used for the static bodies when bodies[i].X_WB == X_WB0 for each (as ComputeBodyKinematics
/// gives) — the same values FindContacts computes for them.
void FindContactsAt(const Scene& scene, const std::vector<BodyKinematics>& bodies, double envelope,
                    std::vector<Contact>* out, double check_envelope, std::vector<Contact>* check,
                    const StaticShapes* statics = nullptr);

/// Names `scene` as the calling thread's step scene for the scope's lifetime (Simulator::Step,
/// around RunStep; the scope holds its own reference); the previous one is restored on exit.
class StepSceneScope {
 public:
  explicit StepSceneScope(std::shared_ptr<const Scene> scene);
  ~StepSceneScope();
  StepSceneScope(const StepSceneScope&) = delete;
  StepSceneScope& operator=(const StepSceneScope&) = delete;

 private:
  std::shared_ptr<const Scene> scene_;
  const std::shared_ptr<const Scene>* previous_;
};

/// The assembly's detection at x: body kinematics (ComputeBodyKinematics with the integrated
/// prescribed poses at (x.t, h)) into *kin and FindContacts(model, *kin, envelope) into
/// *contacts. Takes the thread's kept end detection if its key matches (swapping buffers, no
/// copy), else computes. Either way, inside a step scope on `model`, notes (model, h, envelope)
/// as what the step's end detection should produce.
void DetectAtStart(const Scene& model, const State& x, double h, double envelope,
                   std::vector<BodyKinematics>* kin, std::vector<Contact>* contacts);

/// RunStep's end-of-step check: the smallest gap (m) over FindContacts(model, k, check_envelope)
/// at state x (a corner contact counts max(ψ_1, ψ_2)), +∞ if there is none, k being the
/// kinematics at x with the prescribed bodies posed at (x.t, h) — MinGapAt's value. If the step's
/// assembly asked for it (DetectAtStart in this scope, same h) the detection at its envelope is
/// made in the same pass and kept for the next step's DetectAtStart.
double EndOfStepMinGap(const Scene& model, const State& x, double h, double check_envelope);

/// The smallest gap over `contacts` (a corner contact counts max(ψ_1, ψ_2)), +∞ if none; *where
/// (may be null) = the first contact with that gap, or null.
double MinGapOf(const std::vector<Contact>& contacts, const Contact** where);

/// The contacts of the calling thread's kept end detection if it is keyed by exactly `model`
/// (its owner alive and that owner's scene), x (t, q, ν bitwise), h and `envelope` — the list
/// FindContacts(model, kinematics at (x.t, h), envelope) returns — else null. Needs no step
/// scope; reads only (the next step's DetectAtStart may still take it).
const std::vector<Contact>* KeptEndContacts(const Scene& model, const State& x, double h,
                                            double envelope);

/// Whether the calling thread holds a kept end detection (tests).
bool HoldsEndDetection();

}  // namespace vinci::sim::internal
