#include "vinci/sim/formulations/step_skeleton.h"

#include <cmath>

#include "end_detection.h"
#include "step_util.h"
#include "vinci/sim/formulations/contact.h"

namespace vinci::sim {
namespace {

bool NeedsImplicitContact(const Scene& model) {
  for (const Body& b : model.bodies)
    for (const Shape& s : b.shapes)
      if (RequiresImplicitContact(s.type)) return true;
  return false;
}

// All entries finite, as allFinite() (x − x is 0 for finite x, NaN for ±∞ and NaN), in one
// vectorized pass.
bool AllFinite(const VectorXd& v) { return (v.array() - v.array()).sum() == 0.0; }

}  // namespace

double MinGapAt(const Scene& model, const State& x, double h, double envelope, std::string* where) {
  // Kept per thread between calls (allocation reuse only: both are overwritten by every call).
  thread_local std::vector<BodyKinematics> kin;
  thread_local std::vector<Contact> contacts;
  ComputeBodyKinematics(model, x, &kin);
  for (std::size_t i = 0; i < kin.size(); ++i) {  // as the next step's assembly poses them
    const Body& b = model.bodies[i];
    if (b.kind == BodyKind::kPrescribed && b.motion.pose == PoseRule::kIntegrated)
      kin[i] = EvaluateMotion(b.motion, b.X_WB0, model.dim == Dim::kPlanar, x.t, h);
  }
  FindContacts(model, kin, envelope, &contacts);
  const Contact* min_contact = nullptr;
  const double min_gap = internal::MinGapOf(contacts, &min_contact);
  if (where && min_contact)
    *where = "bodies '" + model.bodies[min_contact->body_a].name + "' and '" +
             model.bodies[min_contact->body_b].name + "'";
  return min_gap;
}

StepInfo RunStep(const Formulation& formulation, const Scene& model, const State& x,
                 const StepInput& u, Workspace* ws, State* next) {
  StepInfo info;
  if (!std::isfinite(x.t) || !AllFinite(x.q) || !AllFinite(x.v)) {
    internal::FailStep(StepStatus::kNonFinite,
                       "non-finite state (t, q or v) at the start of the step", &info);
    *next = x;
    return info;
  }
  if (x.warm_start.size() > 0 && !AllFinite(x.warm_start)) {
    State cold = x;
    cold.warm_start.resize(0);
    formulation.Step(model, cold, u, ws, next, &info);
  } else {
    formulation.Step(model, x, u, ws, next, &info);
  }
  if (!info.ok) {
    if (info.status == StepStatus::kOk) info.status = StepStatus::kSolverFailed;
    *next = x;
    return info;
  }
  if (!std::isfinite(next->t) || !AllFinite(next->q) || !AllFinite(next->v)) {
    internal::FailStep(StepStatus::kNonFinite,
                       std::string("non-finite ") +
                           (!AllFinite(next->q)   ? "positions q"
                            : !AllFinite(next->v) ? "velocities v"
                                                  : "time t") +
                           " after the step",
                       &info);
    *next = x;
    return info;
  }
  const StepperOptions& o = model.options;
  if (!NeedsImplicitContact(model)) {
    // MinGapAt's value; made in one pass with the next step's detection when that is kept
    // (end_detection.h).
    const double gap = internal::EndOfStepMinGap(model, *next, o.dt, -o.max_penetration);
    if (gap < -o.max_penetration) {
      std::string where;  // named only on failure (no string work on the steady path)
      MinGapAt(model, *next, o.dt, -o.max_penetration, &where);
      internal::FailStep(StepStatus::kPenetration,
                         "penetration " + internal::FormatNumber(-gap) + " m (" + where +
                             ") at the end of the step exceeds max_penetration " +
                             internal::FormatNumber(o.max_penetration) + " m",
                         &info);
      *next = x;
      return info;
    }
  }
  info.status = StepStatus::kOk;
  return info;
}

}  // namespace vinci::sim
