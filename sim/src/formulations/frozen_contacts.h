// The frozen step model's contacts at a moved start state (internal to step_model.cc and
// step_model_mcp.cc): the
// contact set found once at x_ℓ, its witness points, normals and gaps moved to x (re-collided
// for the same features, or along closed-form rates), and the vertex each polytope contact
// keeps. The equations are in step_model.h's header comment.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "sparse_rows.h"
#include "vinci/sim/formulations/contact.h"
#include "vinci/sim/formulations/ncp.h"
#include "vinci/sim/formulations/step_model.h"
#include "vinci/sim/geometry/contact_rate.h"
#include "vinci/sim/model/kinematics.h"
#include "vinci/sim/model/scene.h"

namespace vinci::sim::internal {

/// Same time and positions, bitwise.
inline bool SamePose(const State& a, const State& b) {
  return a.t == b.t && a.q.size() == b.q.size() && (a.q.array() == b.q.array()).all();
}

/// x and u are bitwise the freeze state and input (the assembly made there can be reused).
inline bool SameStateAndInput(const State& x, const StepInput& u, const State& x0,
                              const StepInput& u0) {
  return SamePose(x, x0) && x.v.size() == x0.v.size() && (x.v.array() == x0.v.array()).all() &&
         u.generalized_force.size() == u0.generalized_force.size() &&
         (u.generalized_force.array() == u0.generalized_force.array()).all();
}

/// The frozen models' size error: "<what>has <got> entries; the frozen step needs <want>".
inline std::string SizeMismatch(const char* what, Eigen::Index got, Eigen::Index want) {
  return std::string(what) + "has " + std::to_string(got) + " entries; the frozen step needs " +
         std::to_string(want);
}

/// The frozen contacts moved to x: witness points and normals as the collision routine finds
/// them for the same features at x (rigidly with the bodies where it finds none, and for corner
/// contacts), gaps by the change of n·(p_A − p_B); μ from `model`. At the freeze pose the
/// contacts are returned unchanged. `k0_known`: ComputeBodyKinematics(model, x0), if the caller
/// has it (null: computed here). `sides`: per frozen contact, the vertex it keeps (FrozenSides;
/// null: none).
std::vector<Contact> MoveContacts(const Scene& model, const std::vector<Contact>& frozen,
                                  const State& x0, const State& x, double h,
                                  const std::vector<BodyKinematics>* k0_known = nullptr,
                                  const std::vector<PolytopeFeature>* sides = nullptr);

/// MoveContacts into *out, its storage reused (the same contacts).
void MoveContactsInto(const Scene& model, const std::vector<Contact>& frozen, const State& x0,
                      const State& x, double h, const std::vector<BodyKinematics>* k0_known,
                      const std::vector<PolytopeFeature>* sides, std::vector<Contact>* out);

/// The frozen contacts at x = x0 + t s: those whose shape pair has a closed-form rate moved to
/// first order, c + t ċ; the others as MoveContacts. `k0`: ComputeBodyKinematics(model, x0).
std::vector<Contact> MoveContactsAlong(const Scene& model, const std::vector<Contact>& frozen,
                                       const State& x0, const State& x, const VectorXd& s, double t,
                                       double h, const std::vector<BodyKinematics>& k0,
                                       const std::vector<PolytopeFeature>& sides);

/// Per frozen contact at the poses k0: the vertex a polytope vertex–face contact keeps; *near
/// counts those at a feature switch (StepModel::feature_kinks()).
void FrozenSidesInto(const Scene& model, const std::vector<Contact>& contacts,
                     const std::vector<BodyKinematics>& k0, std::vector<PolytopeFeature>* out,
                     int* near);
std::vector<PolytopeFeature> FrozenSides(const Scene& model, const std::vector<Contact>& contacts,
                                         const std::vector<BodyKinematics>& k0, int* near);

/// Freeze (step_model.h) for the MCP formulations — NCP, quasistatic DLC / DQC, geometrically
/// implicit (step_model_mcp.cc) — or null for any other formulation.
std::unique_ptr<StepModel> FreezeMcp(const Formulation& formulation,
                                     std::shared_ptr<const Scene> scene, const Params& params,
                                     const State& x, const StepInput& u);

/// FreezeInto (step_record.h) for the NCP stepper: *frozen = Freeze(ncp, scene, params, x, u),
/// an NCP model already there refrozen in its storage, the assembly copied from the thread's
/// last step where that step was this one. The inputs are checked by the caller.
void FreezeNcpInto(const NcpStepper& ncp, std::shared_ptr<const Scene> scene, const Params& params,
                   const State& x, const StepInput& u, std::unique_ptr<StepModel>* frozen);
/// internal::EvaluateResidualsInto (step_record.h) for a frozen NCP model at its freeze's state
/// and input: the Jacobians by rows directly (no dense matrices); false (nothing written) for any
/// other model or point.
bool McpFreezeResidualsInto(const StepModel& m, const VectorXd& z, const Params& theta,
                            const State& x, const StepInput& u, StepResiduals* out,
                            SparseJacobians* jac);

}  // namespace vinci::sim::internal
