// The frozen step model's contacts at a moved start state (internal to step_model.cc): the
// contact set found once at x_ℓ, its witness points, normals and gaps moved to x (re-collided
// for the same features, or along closed-form rates), and the vertex each polytope contact
// keeps. The equations are in step_model.h's header comment.
#pragma once

#include <vector>

#include "vinci/sim/formulations/contact.h"
#include "vinci/sim/geometry/contact_rate.h"
#include "vinci/sim/model/kinematics.h"
#include "vinci/sim/model/scene.h"

namespace vinci::sim::internal {

/// Same time and positions, bitwise.
inline bool SamePose(const State& a, const State& b) {
  return a.t == b.t && a.q.size() == b.q.size() && (a.q.array() == b.q.array()).all();
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

}  // namespace vinci::sim::internal
