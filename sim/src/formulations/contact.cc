#include "vinci/sim/formulations/contact.h"

#include <algorithm>
#include <functional>
#include <iterator>
#include <utility>

#include "../geometry/half_space_contacts.h"
#include "end_detection.h"

namespace vinci::sim {

void ComputeBodyKinematics(const Scene& scene, const State& x, std::vector<BodyKinematics>* out) {
  const std::size_t n = scene.bodies.size();
  out->resize(n);
  BodyKinematics* k = out->data();
  for (std::size_t i = 0; i < n; ++i) {
    const Body& b = scene.bodies[i];
    switch (b.kind) {
      case BodyKind::kDynamic: {
        const BodyIndex& idx = scene.index(static_cast<int>(i));
        KinematicsFromQV(scene.dim, x.q.data() + idx.q, x.v.data() + idx.v, &k[i]);
        break;
      }
      case BodyKind::kStatic:  // BodyKinematics{} at X_WB0
        k[i].X_WB = b.X_WB0;
        k[i].v_WB.setZero();
        k[i].w_WB.setZero();
        break;
      case BodyKind::kPrescribed:
        k[i] = EvaluateMotion(b.motion, b.X_WB0, scene.dim == Dim::kPlanar, x.t);
        break;
    }
  }
}

std::vector<BodyKinematics> ComputeBodyKinematics(const Scene& scene, const State& x) {
  std::vector<BodyKinematics> out;
  ComputeBodyKinematics(scene, x, &out);
  return out;
}

bool BodiesJointed(const Scene& scene, int a, int b) {
  for (const Joint& j : scene.joints)
    if ((j.body_a == a && j.body_b == b) || (j.body_a == b && j.body_b == a)) return true;
  return false;
}

int FrictionParamIndex(const Scene& scene, int ma, int mb) {
  const auto key = std::make_pair(std::min(ma, mb), std::max(ma, mb));
  const auto it = scene.mu.find(key);
  // ParamTable layout (Scene::Finalize): 0 = mu.default, then the pairs in map order.
  return it == scene.mu.end() ? 0 : 1 + static_cast<int>(std::distance(scene.mu.begin(), it));
}

namespace {

// FindContacts' scratch, kept per thread between calls so that a steady-state step allocates
// nothing here. Every entry read by a call is written by it first: no result depends on what a
// previous call (or another thread) left in it.
struct FindContactsScratch {
  std::vector<ContactPoint> points;
  std::vector<int> shape_begin;         // body i's shapes are [shape_begin[i], shape_begin[i + 1])
  std::vector<Aabb> boxes;              // world AABB of every shape, flattened (statics: unused)
  std::vector<Isometry3d> poses;        // world pose of every shape, flattened (statics: unused)
  std::vector<const Aabb*> body_boxes;  // body i's shape boxes (here or in the statics)
  std::vector<const Isometry3d*> body_poses;  // body i's shape poses (here or in the statics)
  std::vector<Aabb> body_box;
  std::vector<int> order;
  std::vector<std::pair<int, int>> pairs;
};

// Sorts [first, last) by `less`, a strict total order (so any sort gives the same order):
// insertion sort for the few elements of a small scene, std::sort (no allocation) otherwise.
template <typename It, typename Less>
void SortSmall(It first, It last, Less less) {
  if (last - first > 16) {
    std::sort(first, last, less);
    return;
  }
  for (It i = first + (first != last); i < last; ++i) {
    auto value = *i;
    It j = i;
    for (; j != first && less(value, *(j - 1)); --j) *j = *(j - 1);
    *j = value;
  }
}

// The narrow phase of shape A (at X_WA) with shape B (at X_WB) at `envelope` into *points
// (cleared first): CollideShapes, then, for per-edge constraints, every corner split in two (the
// second edge's contact appended after the pair's other contacts).
void CollidePoints(const Scene& scene, const Shape& A, const Isometry3d& X_WA, const Shape& B,
                   const Isometry3d& X_WB, double envelope,
                   std::vector<ContactPoint>* points_buffer) {
  std::vector<ContactPoint>& points = *points_buffer;
  points.clear();
  CollideShapes(A, X_WA, B, X_WB, envelope, &points);
  if (!scene.options.nonconvex_corners) {  // per-edge constraints: split every corner
    const std::size_t n_points = points.size();
    for (std::size_t k = 0; k < n_points; ++k) {
      if (!points[k].corner) continue;
      points[k].corner = false;
      ContactPoint second;
      second.p_A_W = points[k].p2_A_W;
      second.p_B_W = points[k].p2_B_W;
      second.n_W = points[k].n2_W;
      second.gap = points[k].gap2;
      points.push_back(second);
    }
  }
}

// Appends to *out, in order, the contacts of shape sa of body a with shape sb of body b (a, b
// oriented as FindContacts orients them) among `points` — all of them if `all`, else those with
// gap ≤ envelope (the narrow phase's own test: a point is dropped iff gap > envelope).
void AppendContacts(const Scene& scene, int a, int b, std::size_t sa, std::size_t sb,
                    const std::vector<ContactPoint>& points, bool all, double envelope,
                    std::vector<Contact>* out) {
  if (points.empty()) return;
  const int ma = scene.bodies[a].shapes[sa].material, mb = scene.bodies[b].shapes[sb].material;
  const double mu = scene.Mu(ma, mb);
  const int mu_param = FrictionParamIndex(scene, ma, mb);
  Contact c;  // copied per point (no value-initialization of each new element)
  c.body_a = a;
  c.body_b = b;
  c.shape_a = static_cast<int>(sa);
  c.shape_b = static_cast<int>(sb);
  c.mu = mu;
  c.mu_param = mu_param;
  for (const ContactPoint& p : points) {
    if (!all && p.gap > envelope) continue;
    c.point = p;
    out->push_back(c);
  }
}

}  // namespace

void FindContacts(const Scene& scene, const std::vector<BodyKinematics>& bodies, double envelope,
                  std::vector<Contact>* out) {
  internal::FindContactsAt(scene, bodies, envelope, out, envelope, nullptr);
}

namespace internal {

void FindContactsAt(const Scene& scene, const std::vector<BodyKinematics>& bodies, double envelope,
                    std::vector<Contact>* out, double check_envelope, std::vector<Contact>* check,
                    const StaticShapes* statics) {
  out->clear();
  if (check) check->clear();
  // The broad phase runs once, at the larger envelope; each list then keeps the body and shape
  // pairs whose boxes overlap within its own envelope: exactly the pairs a run at that envelope
  // keeps (Aabb::Overlaps is monotone in the margin, and the sweep's early exit below only
  // skips pairs that Overlaps rejects).
  const double sweep = check ? std::max(envelope, check_envelope) : envelope;
  const bool filter_out = envelope != sweep;
  const bool filter_check = check && check_envelope != sweep;
  const std::size_t n = scene.bodies.size();
  thread_local FindContactsScratch scratch;
  // Broad phase: world poses and AABBs of every shape, computed once (a static body's kept).
  std::vector<int>& shape_begin = scratch.shape_begin;
  shape_begin.resize(n + 1);
  int n_shapes = 0;
  for (std::size_t i = 0; i < n; ++i) {
    shape_begin[i] = n_shapes;
    n_shapes += static_cast<int>(scene.bodies[i].shapes.size());
  }
  shape_begin[n] = n_shapes;
  scratch.boxes.resize(n_shapes);
  scratch.poses.resize(n_shapes);
  scratch.body_boxes.resize(n);
  scratch.body_poses.resize(n);
  const Aabb** body_boxes = scratch.body_boxes.data();
  const Isometry3d** body_poses = scratch.body_poses.data();
  for (std::size_t i = 0; i < n; ++i) {
    const Body& b = scene.bodies[i];
    const int begin = shape_begin[i];
    if (statics != nullptr && b.kind == BodyKind::kStatic) {  // the same values, kept
      body_boxes[i] = statics->boxes.data() + begin;
      body_poses[i] = statics->poses.data() + begin;
      continue;
    }
    Aabb* boxes = scratch.boxes.data() + begin;
    Isometry3d* poses = scratch.poses.data() + begin;
    body_boxes[i] = boxes;
    body_poses[i] = poses;
    const std::size_t ns = b.shapes.size();
    for (std::size_t s = 0; s < ns; ++s) {
      poses[s] = bodies[i].X_WB * b.shapes[s].X_BS;
      boxes[s] = ComputeAabb(b.shapes[s], poses[s]);
    }
  }
  // Candidate body pairs: sweep and prune along x on each body's box (the union of its shapes'),
  // O(n log n + pairs) instead of all n² pairs, then in index order (ia < ib) as the contact
  // order requires. A shape-pair overlap implies a body-box overlap, so no contact is lost.
  std::vector<Aabb>& body_box = scratch.body_box;
  body_box.resize(n);  // entries are written before they are read (bodies in `order`)
  std::vector<int>& order = scratch.order;
  order.clear();
  for (std::size_t i = 0; i < n; ++i) {
    const int ns = shape_begin[i + 1] - shape_begin[i];
    if (ns == 0) continue;
    const Aabb* boxes = body_boxes[i];
    Aabb bb = boxes[0];
    for (int s = 1; s < ns; ++s) {  // (the union with boxes[0] itself changes nothing)
      bb.lo = bb.lo.cwiseMin(boxes[s].lo);
      bb.hi = bb.hi.cwiseMax(boxes[s].hi);
    }
    if (bb.lo.hasNaN() || bb.hi.hasNaN()) continue;  // overlaps nothing (as before)
    body_box[i] = bb;
    order.push_back(static_cast<int>(i));
  }
  // The narrow phase of body pair (ia, ib), ia < ib, whose boxes overlap within `sweep`.
  const auto detect_pair = [&](int ia, int ib) {
    const bool to_out = !filter_out || body_box[ia].Overlaps(body_box[ib], envelope);
    const bool to_check =
        check && (!filter_check || body_box[ia].Overlaps(body_box[ib], check_envelope));
    if (!to_out && !to_check) return;
    if (BodiesJointed(scene, ia, ib)) return;
    // Orient each pair so the dynamic body (or the first dynamic body) is A.
    const bool swap = scene.bodies[ia].kind != BodyKind::kDynamic;
    const int a = swap ? ib : ia, b = swap ? ia : ib;
    const Body& BA = scene.bodies[a];
    const Body& BB = scene.bodies[b];
    const std::size_t na = BA.shapes.size(), nb = BB.shapes.size();
    for (std::size_t sa = 0; sa < na; ++sa) {
      const Aabb& box_a = body_boxes[a][sa];
      const Isometry3d& X_WA = body_poses[a][sa];
      for (std::size_t sb = 0; sb < nb; ++sb) {
        const Aabb& box_b = body_boxes[b][sb];
        const Isometry3d& X_WB = body_poses[b][sb];
        const bool in_out = to_out && box_a.Overlaps(box_b, envelope);
        const bool in_check = to_check && box_a.Overlaps(box_b, check_envelope);
        if ((in_out || in_check) && BA.shapes[sa].type == ShapeType::kBox &&
            BB.shapes[sb].type == ShapeType::kHalfSpace) {
          // CollideShapes' box–half-space pass (no corner to split) straight into the lists, at
          // the larger envelope when both want it (EnvelopeOnlyFilters).
          const double e_max = !in_check ? envelope
                               : !in_out ? check_envelope
                                         : std::max(envelope, check_envelope);
          Contact proto;
          bool proto_set = false;
          const Vector3d n_W = X_WB.linear().col(2);
          const auto append = [&](std::vector<Contact>* list, const Vector3d& p_A,
                                  const Vector3d& p_B, double gap) {
            if (!proto_set) {  // AppendContacts' fields
              const int ma = BA.shapes[sa].material, mb = BB.shapes[sb].material;
              proto.body_a = a;
              proto.body_b = b;
              proto.shape_a = static_cast<int>(sa);
              proto.shape_b = static_cast<int>(sb);
              proto.mu = scene.Mu(ma, mb);
              proto.mu_param = FrictionParamIndex(scene, ma, mb);
              proto_set = true;
            }
            list->push_back(proto);
            ContactPoint& c = list->back().point;  // {p_A, p_B, n, gap} and the defaults
            c.p_A_W = p_A;
            c.p_B_W = p_B;
            c.n_W = n_W;
            c.gap = gap;
          };
          collision_internal::BoxHalfSpaceTo(
              BA.shapes[sa].half_extents, X_WA, X_WB, e_max,
              [&](const Vector3d& p_A, const Vector3d& p_B, double gap) {
                for (int l = 0; l < 2; ++l) {  // out, then check (one call site: inlined)
                  if (!(l == 0 ? in_out : in_check)) continue;
                  if (gap > (l == 0 ? envelope : check_envelope)) continue;
                  append(l == 0 ? out : check, p_A, p_B, gap);
                }
              });
          continue;
        }
        if (in_out && in_check && EnvelopeOnlyFilters(BA.shapes[sa].type, BB.shapes[sb].type)) {
          // One narrow phase at the larger envelope; the other list keeps the contacts its own
          // envelope keeps (EnvelopeOnlyFilters: the same contacts, in order).
          const bool out_larger = envelope >= check_envelope;
          CollidePoints(scene, BA.shapes[sa], X_WA, BB.shapes[sb], X_WB,
                        out_larger ? envelope : check_envelope, &scratch.points);
          AppendContacts(scene, a, b, sa, sb, scratch.points, out_larger, envelope, out);
          AppendContacts(scene, a, b, sa, sb, scratch.points, !out_larger, check_envelope, check);
          continue;
        }
        if (in_out) {
          CollidePoints(scene, BA.shapes[sa], X_WA, BB.shapes[sb], X_WB, envelope, &scratch.points);
          AppendContacts(scene, a, b, sa, sb, scratch.points, true, envelope, out);
        }
        if (in_check) {
          CollidePoints(scene, BA.shapes[sa], X_WA, BB.shapes[sb], X_WB, check_envelope,
                        &scratch.points);
          AppendContacts(scene, a, b, sa, sb, scratch.points, true, check_envelope, check);
        }
      }
    }
  };
  const std::size_t n_order = order.size();
  if (n_order <= 8) {
    // A few bodies: every pair in index order (what the sweep below keeps, without sorting: its
    // early exit only skips pairs that Overlaps rejects).
    for (std::size_t p = 0; p < n_order; ++p) {
      const int i = order[p];
      const bool i_dynamic = scene.bodies[i].kind == BodyKind::kDynamic;
      for (std::size_t q = p + 1; q < n_order; ++q) {
        const int j = order[q];
        if (!i_dynamic && scene.bodies[j].kind != BodyKind::kDynamic) continue;
        if (body_box[i].Overlaps(body_box[j], sweep)) detect_pair(i, j);
      }
    }
    return;
  }
  // By the box's low x, ties in index order (what a stable sort of the index-ordered list gives).
  SortSmall(order.begin(), order.end(), [&](int i, int j) {
    return body_box[i].lo.x() < body_box[j].lo.x() ||
           (body_box[i].lo.x() == body_box[j].lo.x() && i < j);
  });
  std::vector<std::pair<int, int>>& pairs = scratch.pairs;
  pairs.clear();
  for (std::size_t p = 0; p < n_order; ++p) {
    const int i = order[p];
    const bool i_dynamic = scene.bodies[i].kind == BodyKind::kDynamic;
    for (std::size_t q = p + 1; q < n_order; ++q) {
      const int j = order[q];
      if (body_box[j].lo.x() - sweep > body_box[i].hi.x()) break;  // and every later body
      if (!i_dynamic && scene.bodies[j].kind != BodyKind::kDynamic) continue;
      if (!body_box[i].Overlaps(body_box[j], sweep)) continue;
      pairs.emplace_back(std::min(i, j), std::max(i, j));
    }
  }
  SortSmall(pairs.begin(), pairs.end(), std::less<std::pair<int, int>>());
  for (const auto& [ia, ib] : pairs) detect_pair(ia, ib);
}

}  // namespace internal

}  // namespace vinci::sim
