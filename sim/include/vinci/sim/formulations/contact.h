// Scene-level contact detection: body kinematics, broad phase, narrow phase.
#pragma once

#include <vector>

#include "vinci/sim/geometry/shape.h"
#include "vinci/sim/model/kinematics.h"
#include "vinci/sim/model/scene.h"
#include "vinci/sim/model/state.h"

namespace vinci::sim {

/// A contact between bodies A and B: A is pushed along +n, B along −n.
struct Contact {
  int body_a = -1, body_b = -1;
  int shape_a = -1, shape_b = -1;
  ContactPoint point;  ///< witness points, normal (B → A) and gap ψ_n
  double mu = 0.0;     ///< friction coefficient of the material pair
  int mu_param = -1;   ///< index in the scene's ParamTable of the parameter giving μ
};

/// True if a joint connects bodies a and b (their shapes do not collide).
bool BodiesJointed(const Scene& scene, int a, int b);

/// Index in the scene's ParamTable of the friction coefficient of materials (ma, mb): the pair's
/// `mu.<a>.<b>` entry, or 0 (`mu.default`) for a pair without its own coefficient.
int FrictionParamIndex(const Scene& scene, int ma, int mb);

/// World kinematics of every body at state x (dynamic: from q, v; prescribed: from the motion
/// at x.t; static: initial pose).
std::vector<BodyKinematics> ComputeBodyKinematics(const Scene& scene, const State& x);
/// The same into *out (resized to the body count; its storage is reused).
void ComputeBodyKinematics(const Scene& scene, const State& x, std::vector<BodyKinematics>* out);

/// All contacts with ψ_n ≤ envelope between shapes of different bodies, at least one of them
/// dynamic, excluding pairs of bodies connected by a joint. Deterministic order (by body, shape
/// pair, then the narrow phase's order). Corner contacts (ContactPoint::corner) are kept as one
/// contact, or, if scene.options.nonconvex_corners is false, split into two ordinary contacts
/// (the second edge's appended after the pair's other contacts).
void FindContacts(const Scene& scene, const std::vector<BodyKinematics>& bodies, double envelope,
                  std::vector<Contact>* out);

}  // namespace vinci::sim
