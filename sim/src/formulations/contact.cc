#include "vinci/sim/formulations/contact.h"

#include <algorithm>
#include <iterator>
#include <utility>

#include "end_detection.h"

namespace vinci::sim {

void ComputeBodyKinematics(const Scene& scene, const State& x, std::vector<BodyKinematics>* out) {
  out->resize(scene.bodies.size());
  for (std::size_t i = 0; i < scene.bodies.size(); ++i) {
    const Body& b = scene.bodies[i];
    switch (b.kind) {
      case BodyKind::kDynamic: {
        const BodyIndex& idx = scene.index(static_cast<int>(i));
        (*out)[i] = KinematicsFromQV(scene.dim, x.q.data() + idx.q, x.v.data() + idx.v);
        break;
      }
      case BodyKind::kStatic:
        (*out)[i] = BodyKinematics{};
        (*out)[i].X_WB = b.X_WB0;
        break;
      case BodyKind::kPrescribed:
        (*out)[i] = EvaluateMotion(b.motion, b.X_WB0, scene.dim == Dim::kPlanar, x.t);
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
// nothing here. Every buffer is cleared and refilled by each call: no result depends on what a
// previous call (or another thread) left in it.
struct FindContactsScratch {
  std::vector<ContactPoint> points;
  std::vector<int> shape_begin;   // body i's shapes are [shape_begin[i], shape_begin[i + 1])
  std::vector<Aabb> boxes;        // world AABB of every shape, flattened
  std::vector<Isometry3d> poses;  // world pose of every shape, flattened
  std::vector<Aabb> body_box;
  std::vector<int> order;
  std::vector<std::pair<int, int>> pairs;
};

// The contacts of shape sa of body a with shape sb of body b (a, b oriented as FindContacts
// orients them) with ψ ≤ envelope, appended to *out in FindContacts' order.
void AppendShapePair(const Scene& scene, int a, int b, std::size_t sa, std::size_t sb,
                     const Isometry3d& X_WA, const Isometry3d& X_WB, double envelope,
                     std::vector<ContactPoint>* points_buffer, std::vector<Contact>* out) {
  const Body& BA = scene.bodies[a];
  const Body& BB = scene.bodies[b];
  std::vector<ContactPoint>& points = *points_buffer;
  points.clear();
  CollideShapes(BA.shapes[sa], X_WA, BB.shapes[sb], X_WB, envelope, &points);
  const int ma = BA.shapes[sa].material, mb = BB.shapes[sb].material;
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
  if (points.empty()) return;
  const double mu = scene.Mu(ma, mb);
  const int mu_param = FrictionParamIndex(scene, ma, mb);
  for (const ContactPoint& p : points) {
    Contact& c = out->emplace_back();
    c.body_a = a;
    c.body_b = b;
    c.shape_a = static_cast<int>(sa);
    c.shape_b = static_cast<int>(sb);
    c.point = p;
    c.mu = mu;
    c.mu_param = mu_param;
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
  const int n = static_cast<int>(scene.bodies.size());
  thread_local FindContactsScratch scratch;
  // Broad phase: world AABBs of every shape, computed once.
  std::vector<int>& shape_begin = scratch.shape_begin;
  std::vector<Aabb>& boxes_flat = scratch.boxes;
  std::vector<Isometry3d>& poses_flat = scratch.poses;
  shape_begin.clear();
  boxes_flat.clear();
  poses_flat.clear();
  for (int i = 0; i < n; ++i) {
    const Body& b = scene.bodies[i];
    shape_begin.push_back(static_cast<int>(poses_flat.size()));
    if (statics != nullptr && b.kind == BodyKind::kStatic) {  // the same values, kept
      for (std::size_t s = 0; s < b.shapes.size(); ++s) {
        poses_flat.push_back(statics->poses[poses_flat.size()]);
        boxes_flat.push_back(statics->boxes[boxes_flat.size()]);
      }
      continue;
    }
    for (const Shape& s : b.shapes) {
      poses_flat.push_back(bodies[i].X_WB * s.X_BS);
      boxes_flat.push_back(ComputeAabb(s, poses_flat.back()));
    }
  }
  shape_begin.push_back(static_cast<int>(poses_flat.size()));
  const auto box = [&](int body, std::size_t shape) -> const Aabb& {
    return boxes_flat[static_cast<std::size_t>(shape_begin[body]) + shape];
  };
  const auto pose = [&](int body, std::size_t shape) -> const Isometry3d& {
    return poses_flat[static_cast<std::size_t>(shape_begin[body]) + shape];
  };
  // Candidate body pairs: sweep and prune along x on each body's box (the union of its shapes'),
  // O(n log n + pairs) instead of all n² pairs, then in index order (ia < ib) as the contact
  // order requires. A shape-pair overlap implies a body-box overlap, so no contact is lost.
  std::vector<Aabb>& body_box = scratch.body_box;
  body_box.resize(n);  // entries are written before they are read (bodies in `order`)
  std::vector<int>& order = scratch.order;
  order.clear();
  for (int i = 0; i < n; ++i) {
    if (shape_begin[i] == shape_begin[i + 1]) continue;
    Aabb bb = box(i, 0);
    for (int s = shape_begin[i]; s < shape_begin[i + 1]; ++s) {
      bb.lo = bb.lo.cwiseMin(boxes_flat[s].lo);
      bb.hi = bb.hi.cwiseMax(boxes_flat[s].hi);
    }
    if (bb.lo.hasNaN() || bb.hi.hasNaN()) continue;  // overlaps nothing (as before)
    body_box[i] = bb;
    order.push_back(i);
  }
  // By the box's low x, ties in index order (what a stable sort of the index-ordered list gives;
  // std::sort does not allocate).
  std::sort(order.begin(), order.end(), [&](int i, int j) {
    return body_box[i].lo.x() < body_box[j].lo.x() ||
           (body_box[i].lo.x() == body_box[j].lo.x() && i < j);
  });
  std::vector<std::pair<int, int>>& pairs = scratch.pairs;
  pairs.clear();
  for (std::size_t p = 0; p < order.size(); ++p) {
    const int i = order[p];
    for (std::size_t q = p + 1; q < order.size(); ++q) {
      const int j = order[q];
      if (body_box[j].lo.x() - sweep > body_box[i].hi.x()) break;  // and every later body
      if (scene.bodies[i].kind != BodyKind::kDynamic && scene.bodies[j].kind != BodyKind::kDynamic)
        continue;
      if (!body_box[i].Overlaps(body_box[j], sweep)) continue;
      pairs.emplace_back(std::min(i, j), std::max(i, j));
    }
  }
  std::sort(pairs.begin(), pairs.end());
  for (const auto& [ia, ib] : pairs) {
    const bool to_out = !filter_out || body_box[ia].Overlaps(body_box[ib], envelope);
    const bool to_check =
        check && (!filter_check || body_box[ia].Overlaps(body_box[ib], check_envelope));
    if (!to_out && !to_check) continue;
    if (BodiesJointed(scene, ia, ib)) continue;
    // Orient each pair so the dynamic body (or the first dynamic body) is A.
    const bool swap = scene.bodies[ia].kind != BodyKind::kDynamic;
    const int a = swap ? ib : ia, b = swap ? ia : ib;
    const std::size_t na = scene.bodies[a].shapes.size(), nb = scene.bodies[b].shapes.size();
    for (std::size_t sa = 0; sa < na; ++sa) {
      for (std::size_t sb = 0; sb < nb; ++sb) {
        const Aabb& box_a = box(a, sa);
        const Aabb& box_b = box(b, sb);
        if (to_out && box_a.Overlaps(box_b, envelope))
          AppendShapePair(scene, a, b, sa, sb, pose(a, sa), pose(b, sb), envelope, &scratch.points,
                          out);
        if (to_check && box_a.Overlaps(box_b, check_envelope))
          AppendShapePair(scene, a, b, sa, sb, pose(a, sa), pose(b, sb), check_envelope,
                          &scratch.points, check);
      }
    }
  }
}

}  // namespace internal

}  // namespace vinci::sim
