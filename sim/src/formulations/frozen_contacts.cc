#include "frozen_contacts.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "vinci/sim/geometry/shape.h"
#include "vinci/sim/model/motion.h"

namespace vinci::sim::internal {
namespace {

// Body poses as the contact detection of the Stewart–Trinkle assembly sees them: dynamic bodies
// from q, prescribed ones from their motion at x.t (an integrated pose with step h).
// `k`: ComputeBodyKinematics(model, x). Into *out (its storage reused).
void DetectionKinematicsInto(const Scene& model, const State& x, double h,
                             const std::vector<BodyKinematics>& k,
                             std::vector<BodyKinematics>* out) {
  *out = k;
  for (std::size_t i = 0; i < k.size(); ++i) {
    const Body& b = model.bodies[i];
    if (b.kind == BodyKind::kPrescribed && b.motion.pose == PoseRule::kIntegrated)
      (*out)[i] = EvaluateMotion(b.motion, b.X_WB0, model.dim == Dim::kPlanar, x.t, h);
  }
}

// The contact of shapes (c.shape_a, c.shape_b) at poses `k` nearest the rigidly moved `moved`
// (header comment): the collision routine re-run, so witness points slide over smooth surfaces
// (a rolling disc's contact stays at its bottom) and normals follow the face that carries them.
// False if no candidate is within 10× the witness points' rigid displacement `disp` (another
// feature would be taken): the rigid motion is kept then.
// `side`: a polytope vertex–face contact keeps its vertex (ClassifyPolytopeContact): only
// candidates whose witness on that side is the rigidly moved vertex and whose normal is
// `face_n_W` (the face normal moved with the face's body) are taken, so the features cannot
// switch with the direction of the move (flush boxes, where a's vertex on b's face and b's vertex
// on a's face coincide, and a vertex just past the face's edge also has vertex–edge candidates).
// `candidates`: storage for the collision routine's contacts (reused).
bool Recollide(const Scene& model, const std::vector<BodyKinematics>& k, const Contact& c,
               const ContactPoint& moved, double disp, VertexSide side, const Vector3d& face_n_W,
               std::vector<ContactPoint>* candidates, ContactPoint* out) {
  const Shape& sa = model.bodies[c.body_a].shapes[c.shape_a];
  const Shape& sb = model.bodies[c.body_b].shapes[c.shape_b];
  const double envelope = model.options.envelope + std::max(0.0, moved.gap) + disp;
  std::vector<ContactPoint>& points = *candidates;
  points.clear();
  CollideShapes(sa, k[c.body_a].X_WB * sa.X_BS, sb, k[c.body_b].X_WB * sb.X_BS, envelope, &points);
  const std::size_t n = points.size();
  for (std::size_t i = 0; i < n; ++i) {  // both edges of a corner, as FindContacts splits them
    if (!points[i].corner) continue;
    ContactPoint second;
    second.p_A_W = points[i].p2_A_W;
    second.p_B_W = points[i].p2_B_W;
    second.n_W = points[i].n2_W;
    second.gap = points[i].gap2;
    points[i].corner = false;
    points.push_back(second);
  }
  double best = std::numeric_limits<double>::infinity();
  const double scale = moved.p_A_W.norm() + moved.p_B_W.norm();
  const double vertex_tol = 1e-9 * (1.0 + scale);
  for (const ContactPoint& p : points) {
    if (side == VertexSide::kA && (p.p_A_W - moved.p_A_W).norm() > vertex_tol) continue;
    if (side == VertexSide::kB && (p.p_B_W - moved.p_B_W).norm() > vertex_tol) continue;
    if (side != VertexSide::kNone && (p.n_W - face_n_W).norm() > 1e-9) continue;
    const double d = (p.p_A_W - moved.p_A_W).norm() + (p.p_B_W - moved.p_B_W).norm();
    if (d < best && p.n_W.dot(moved.n_W) > 0.9) {
      best = d;
      *out = p;
    }
  }
  return best <= 10.0 * disp + 1e-12 * scale;
}

// The rigid motion rate of each body along the state direction s at the poses k0 (x_ℓ): dynamic
// bodies from s's q block (planar [x, y, θ]; spatial [p, raw quaternion Q], R(Q/|Q|), so
// ω = 2 vec(u̇ ⊗ ū) with u̇ = (I − u uᵀ) Q̇ / |Q|), prescribed and static ones at rest (time is
// fixed at the freeze).
std::vector<BodyRate> BodyRates(const Scene& model, const State& x0,
                                const std::vector<BodyKinematics>& k0, const VectorXd& s) {
  std::vector<BodyRate> rates(model.bodies.size());
  for (std::size_t i = 0; i < rates.size(); ++i) rates[i].o_W = k0[i].X_WB.translation();
  for (int bi : model.dynamic_bodies()) {
    const int o = model.index(bi).q;
    BodyRate& r = rates[bi];
    if (model.dim == Dim::kPlanar) {
      r.v_W = Vector3d(s[o], s[o + 1], 0.0);
      r.w_W = Vector3d(0.0, 0.0, s[o + 2]);
      continue;
    }
    r.v_W = s.segment<3>(o);
    const Eigen::Vector4d Q = x0.q.segment<4>(o + 3), dQ = s.segment<4>(o + 3);
    const double norm = Q.norm();
    const Eigen::Vector4d u = Q / norm, du = (dQ - u * u.dot(dQ)) / norm;
    const Quaterniond uq(u[0], u[1], u[2], u[3]), duq(du[0], du[1], du[2], du[3]);
    r.w_W = 2.0 * (duq * uq.conjugate()).vec();
  }
  return rates;
}

}  // namespace

// The frozen contacts moved to x (header comment): witness points and normals as the collision
// routine finds them for the same features at x (Recollide; rigidly with the bodies where it
// finds none, and for corner contacts), gaps by the change of n·(p_A − p_B); μ from `model`. At
// the freeze pose the contacts are returned unchanged.
// `k0`: ComputeBodyKinematics(model, x0), if the caller has it (null: computed here).
// `sides`: per frozen contact, the vertex it keeps (FrozenSides; null: none).
std::vector<Contact> MoveContacts(const Scene& model, const std::vector<Contact>& frozen,
                                  const State& x0, const State& x, double h,
                                  const std::vector<BodyKinematics>* k0_known,
                                  const std::vector<PolytopeFeature>* sides) {
  std::vector<Contact> out;
  MoveContactsInto(model, frozen, x0, x, h, k0_known, sides, &out);
  return out;
}

namespace {

// MoveContactsInto's transient storage, kept per thread (allocation reuse only: every call
// overwrites what it reads).
struct MoveScratch {
  std::vector<BodyKinematics> k0, k1, detect;
  std::vector<Isometry3d> T;
  std::vector<ContactPoint> candidates;
};

}  // namespace

void MoveContactsInto(const Scene& model, const std::vector<Contact>& frozen, const State& x0,
                      const State& x, double h, const std::vector<BodyKinematics>* k0_known,
                      const std::vector<PolytopeFeature>* sides, std::vector<Contact>* moved) {
  std::vector<Contact>& out = *moved;
  out = frozen;
  for (Contact& c : out)
    c.mu = model.Mu(model.bodies[c.body_a].shapes[c.shape_a].material,
                    model.bodies[c.body_b].shapes[c.shape_b].material);
  if (SamePose(x0, x)) return;
  thread_local MoveScratch scratch;
  if (!k0_known) ComputeBodyKinematics(model, x0, &scratch.k0);
  const std::vector<BodyKinematics>& k0 = k0_known ? *k0_known : scratch.k0;
  std::vector<BodyKinematics>& k1 = scratch.k1;
  ComputeBodyKinematics(model, x, &k1);
  std::vector<BodyKinematics>& detect = scratch.detect;
  DetectionKinematicsInto(model, x, h, k1, &detect);
  std::vector<Isometry3d>& T = scratch.T;
  T.assign(model.bodies.size(), Isometry3d::Identity());
  for (int bi : model.dynamic_bodies()) T[bi] = k1[bi].X_WB * k0[bi].X_WB.inverse();
  const auto move = [](const Isometry3d& Ta, const Isometry3d& Tb, Vector3d* pa, Vector3d* pb,
                       Vector3d* n, double* gap) {
    const double before = n->dot(*pa - *pb);
    *pa = Ta * *pa;
    *pb = Tb * *pb;
    *n = Tb.linear() * *n;
    *gap += n->dot(*pa - *pb) - before;
  };
  for (std::size_t i = 0; i < out.size(); ++i) {
    Contact& c = out[i];
    ContactPoint& p = c.point;
    const Isometry3d& Ta = T[c.body_a];
    const Isometry3d& Tb = T[c.body_b];
    if (p.corner) {
      move(Ta, Tb, &p.p_A_W, &p.p_B_W, &p.n_W, &p.gap);
      move(Ta, Tb, &p.p2_A_W, &p.p2_B_W, &p.n2_W, &p.gap2);
      continue;
    }
    const ContactPoint before = p;
    move(Ta, Tb, &p.p_A_W, &p.p_B_W, &p.n_W, &p.gap);
    const double disp = (p.p_A_W - before.p_A_W).norm() + (p.p_B_W - before.p_B_W).norm();
    ContactPoint found;
    const VertexSide side = sides ? (*sides)[i].side : VertexSide::kNone;
    // The face normal moves with the body carrying the face (b's for a's vertex, a's for b's).
    const Vector3d face_n = (side == VertexSide::kB ? Ta : Tb).linear() * before.n_W;
    if (!Recollide(model, detect, c, p, disp, side, face_n, &scratch.candidates, &found)) continue;
    p.p_A_W = found.p_A_W;
    p.p_B_W = found.p_B_W;
    p.n_W = found.n_W;
    p.gap = before.gap + found.n_W.dot(found.p_A_W - found.p_B_W) -
            before.n_W.dot(before.p_A_W - before.p_B_W);
  }
}

// The frozen contacts at x = x0 + t s: those whose shape pair has a closed-form rate
// (geometry/contact_rate.h) moved to first order, c + t ċ (central differences along s then
// give the derivative of the re-collided contacts to O(t²)); the others as MoveContacts. μ from
// `model`. `k0`: ComputeBodyKinematics(model, x0).
std::vector<Contact> MoveContactsAlong(const Scene& model, const std::vector<Contact>& frozen,
                                       const State& x0, const State& x, const VectorXd& s, double t,
                                       double h, const std::vector<BodyKinematics>& k0,
                                       const std::vector<PolytopeFeature>& sides) {
  const std::vector<BodyRate> rates = BodyRates(model, x0, k0, s);
  std::vector<Contact> out = frozen;
  std::vector<char> moved(out.size(), 0);
  bool all = true;
  for (std::size_t i = 0; i < out.size(); ++i) {
    Contact& c = out[i];
    const Shape& sa = model.bodies[c.body_a].shapes[c.shape_a];
    const Shape& sb = model.bodies[c.body_b].shapes[c.shape_b];
    c.mu = model.Mu(sa.material, sb.material);
    ContactPointRate d;
    if (!VertexFaceRate(sides[i].side, c.point, rates[c.body_a], rates[c.body_b], &d) &&
        !EdgeEdgeRate(sides[i], c.point, rates[c.body_a], rates[c.body_b], &d) &&
        !ContactRate(sa, sb, c.point, rates[c.body_a], rates[c.body_b], &d)) {
      all = false;
      continue;
    }
    ContactPoint& p = c.point;
    p.p_A_W += t * d.p_A_W;
    p.p_B_W += t * d.p_B_W;
    p.n_W += t * d.n_W;
    p.gap += t * d.gap;
    moved[i] = 1;
  }
  if (all) return out;
  const std::vector<Contact> recollided = MoveContacts(model, frozen, x0, x, h, &k0, &sides);
  for (std::size_t i = 0; i < out.size(); ++i)
    if (!moved[i]) out[i] = recollided[i];
  return out;
}

// Per frozen contact at the poses k0: the vertex a polytope vertex–face contact keeps
// (ClassifyPolytopeContact); *near counts those whose face witness lies within kNearFeature of
// its face's boundary (the features switch within that move: a kink of the step in x_ℓ).
constexpr double kNearFeature = 1e-6;  // m; the state columns' near-kink radius (sensitivity.h)
void FrozenSidesInto(const Scene& model, const std::vector<Contact>& contacts,
                     const std::vector<BodyKinematics>& k0, std::vector<PolytopeFeature>* out,
                     int* near) {
  std::vector<PolytopeFeature>& sides = *out;
  sides.resize(contacts.size());
  *near = 0;
  for (std::size_t i = 0; i < contacts.size(); ++i) {
    const Contact& c = contacts[i];
    const Shape& sa = model.bodies[c.body_a].shapes[c.shape_a];
    const Shape& sb = model.bodies[c.body_b].shapes[c.shape_b];
    const PolytopeFeature f = ClassifyPolytopeContact(
        sa, k0[c.body_a].X_WB * sa.X_BS, sb, k0[c.body_b].X_WB * sb.X_BS, c.point, kNearFeature);
    sides[i] = f;
    *near += f.near_face_boundary;
  }
}

std::vector<PolytopeFeature> FrozenSides(const Scene& model, const std::vector<Contact>& contacts,
                                         const std::vector<BodyKinematics>& k0, int* near) {
  std::vector<PolytopeFeature> sides;
  FrozenSidesInto(model, contacts, k0, &sides, near);
  return sides;
}

}  // namespace vinci::sim::internal
