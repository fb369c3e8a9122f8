// The Stewart–Trinkle assembly's contact column writers (internal header of stewart_trinkle.cc):
// a contact's normal and friction columns of G_n and G_f written straight into compressed
// storage, per dynamic side, with the same IEEE operations in the same order as
// JacobianColumns' zeroed block plus sign · PointVelocityRow (so the same bits), friction
// columns two at a time where the contact allows it.
#pragma once

#include <cstring>
#include <vector>

#include "vinci/sim/formulations/stewart_trinkle.h"
#include "vinci/sim/model/kinematics.h"

namespace vinci::sim::internal::contact_columns {

// One side (body) of a contact for Scatter's work over its normal and friction columns: whether
// the body is dynamic, its ν offset, or (non-dynamic) the velocity of the contact point, computed
// once per contact instead of once per column (the same values, so the same bits).
struct ContactSide {
  bool dynamic = false;
  // A static side (v = ω = +0, so v_p = +0 for a finite p − o_WB) opposite a dynamic side, with a
  // finite normal: each of its terms ±d·v_p is ±0, added to ∂ψ/∂t = +0, which stays +0, so the
  // terms are not formed.
  bool zero_term = false;
  int o = 0;
  Vector3d v_p = Vector3d::Zero();
};

// The side without v_p, which Fill forms only where a term uses it (not dynamic, not zero_term).
inline ContactSide MakeContactSide(const Scene& model, int body) {
  ContactSide side;
  side.dynamic = model.bodies[body].kind == BodyKind::kDynamic;
  if (side.dynamic) side.o = model.index(body).v;
  return side;
}

// PointVelocityRow(dim, X_WB, p, d) into row[0..N), N = ν block size, given r = p − o_WB (the
// same operations, so the same bits).
// Spatial: row[3..6) = R_WBᵀ (r × d), each entry (R_0i c_0 + R_1i c_1) + R_2i c_2 with
// c = r × d: the operations and order of Eigen's `X_WB.linear().transpose() * r.cross(d)`
// (fixed-size 3 × 3 lazy product), hence its bits, without its expression overhead.
template <int N>
[[gnu::always_inline]] inline void PointVelocityRowInto(const Isometry3d& X_WB, const Vector3d& r,
                                                        const Vector3d& d, double* row) {
  if constexpr (N == 3) {
    row[0] = d.x();
    row[1] = d.y();
    row[2] = r.x() * d.y() - r.y() * d.x();
  } else {
    row[0] = d.x();
    row[1] = d.y();
    row[2] = d.z();
    const double c0 = r.y() * d.z() - r.z() * d.y();
    const double c1 = r.z() * d.x() - r.x() * d.z();
    const double c2 = r.x() * d.y() - r.y() * d.x();
    const double* R = X_WB.matrix().data();  // column major 4 × 4: R_ki = R[4 i + k]
    row[3] = (R[0] * c0 + R[1] * c1) + R[2] * c2;
    row[4] = (R[4] * c0 + R[5] * c1) + R[6] * c2;
    row[5] = (R[8] * c0 + R[9] * c1) + R[10] * c2;
  }
}

// A dynamic side's block of a contact column, written straight into compressed storage: the
// entries JacobianColumns forms for it (a zeroed block plus sign · row, so the same bits), rows
// o..o+N−1. `merge`: the contact's other side is the same body (one block, sides a then b).
struct DynamicSide {
  const BodyKinematics* k;
  Vector3d r;  // p − o_WB
  double sign;
  int o;
  int rows[6];  // o, o + 1, …, o + N − 1 (the block's row indices, copied per column)
};

inline DynamicSide MakeDynamicSide(const BodyKinematics* k, const Vector3d& r, double sign, int o) {
  DynamicSide side{k, r, sign, o, {}};
  using V4i = int __attribute__((vector_size(16)));  // GCC/Clang vector extension
  const V4i first = V4i{o, o, o, o} + V4i{0, 1, 2, 3};
  std::memcpy(side.rows, &first, sizeof(first));
  side.rows[4] = o + 4;
  side.rows[5] = o + 5;
  return side;
}

template <int N>
[[gnu::always_inline]] inline void WriteSideBlock(const DynamicSide& side, const DynamicSide* merge,
                                                  const Vector3d& d, int* inner, double* value) {
  using Row = Eigen::Array<double, N, 1>;
  alignas(16) double row[N];
  PointVelocityRowInto<N>(side.k->X_WB, side.r, d, row);
  std::memcpy(inner, side.rows, sizeof(int) * N);
  // value_i = 0 + sign · row_i, entry by entry (packed: the same IEEE operations per entry).
  Eigen::Map<Row> out(value);
  out = side.sign * Eigen::Map<const Row, Eigen::Aligned16>(row) + 0.0;
  if (!merge) return;
  PointVelocityRowInto<N>(merge->k->X_WB, merge->r, d, row);
#pragma GCC unroll 6
  for (int i = 0; i < N; ++i) value[i] += merge->sign * row[i];
}

// Friction directions by pairs for WriteSidePairs6: pair q holds (d_2q.x, d_2q+1.x, d_2q.y,
// d_2q+1.y, d_2q.z, d_2q+1.z) at pairs[6q..6q+6) (an odd nd's last direction is not in it).
inline void PackDirectionPairs(const std::vector<Vector3d>& dirs, std::vector<double>* pairs) {
  const std::size_t np = dirs.size() / 2;
  pairs->resize(6 * np);
  double* out = pairs->data();
  for (std::size_t q = 0; q < np; ++q, out += 6) {
    const Vector3d& d0 = dirs[2 * q];
    const Vector3d& d1 = dirs[2 * q + 1];
    out[0] = d0.x();
    out[1] = d1.x();
    out[2] = d0.y();
    out[3] = d1.y();
    out[4] = d0.z();
    out[5] = d1.z();
  }
}

// One dynamic side's (N = 6) blocks of the friction columns 2q, 2q + 1, q < npairs, two at a
// time: lane l of each two-lane vector is column 2q + l, and each lane gets exactly the IEEE
// operations of WriteSideBlock<6> without a merged side (value_i = 0 + sign · row_i, row from
// PointVelocityRowInto<6>), so the same bits. Column 2q's block is at value/inner + 2q·stride,
// column 2q + 1's at + stride further.
// kSign = side.sign = ±1: 0 + 1·x is formed as x + 0 and 0 + (−1)·x as 0 − x, the same value for
// every x (−x + 0 = 0 − x: −x for x ≠ 0, +0 for x = ±0, a NaN x propagated by either).
template <int kSign>
void WriteSidePairs6(const DynamicSide& side, const double* pairs, int npairs, int stride,
                     int* inner, double* value) {
  // A GCC/Clang vector extension: elementwise IEEE double operations on two lanes.
  using V2 = double __attribute__((vector_size(16)));
  const auto splat = [](double x) { return V2{x, x}; };
  const V2 rx = splat(side.r.x()), ry = splat(side.r.y()), rz = splat(side.r.z());
  const double* R = side.k->X_WB.matrix().data();  // column major 4 × 4: R_ki = R[4 i + k]
  const V2 R0 = splat(R[0]), R1 = splat(R[1]), R2 = splat(R[2]);
  const V2 R4 = splat(R[4]), R5 = splat(R[5]), R6 = splat(R[6]);
  const V2 R8 = splat(R[8]), R9 = splat(R[9]), R10 = splat(R[10]);
  const V2 zero = splat(0.0);
  // 0 + sign · x.
  const auto signed_ = [&](V2 x) {
    if constexpr (kSign > 0)
      return x + zero;
    else
      return zero - x;
  };
  int rows[6];
  std::memcpy(rows, side.rows, sizeof(rows));
  for (int q = 0; q < npairs; ++q, pairs += 6, inner += 2 * stride, value += 2 * stride) {
    V2 dx, dy, dz;
    std::memcpy(&dx, pairs, sizeof(V2));
    std::memcpy(&dy, pairs + 2, sizeof(V2));
    std::memcpy(&dz, pairs + 4, sizeof(V2));
    const V2 c0 = ry * dz - rz * dy;
    const V2 c1 = rz * dx - rx * dz;
    const V2 c2 = rx * dy - ry * dx;
    const V2 v[6] = {signed_(dx),
                     signed_(dy),
                     signed_(dz),
                     signed_((R0 * c0 + R1 * c1) + R2 * c2),
                     signed_((R4 * c0 + R5 * c1) + R6 * c2),
                     signed_((R8 * c0 + R9 * c1) + R10 * c2)};
#pragma GCC unroll 6
    for (int i = 0; i < 6; ++i) {  // lane 0 into column 2q, lane 1 into column 2q + 1
      value[i] = v[i][0];
      value[stride + i] = v[i][1];
    }
    std::memcpy(inner, rows, sizeof(rows));
    std::memcpy(inner + stride, rows, sizeof(rows));
  }
}

// A contact's sides for its columns: the dynamic ones in ν order (`blocks` blocks; `merged`: one
// body on both sides) and both sides as MakeContactSide gives them; dpsi_a / dpsi_b: whether side
// a's / b's term d·v_p enters ∂ψ/∂t (a non-dynamic side without zero_term).
struct ContactColumns {
  const DynamicSide* sides;
  int blocks;
  bool merged;
  const ContactSide* side_a;
  const ContactSide* side_b;
  bool dpsi_a, dpsi_b;
};

// One column of direction d at entry k of a compressed G: the dynamic blocks, then the
// non-dynamic sides' ∂ψ/∂t (a, then b) into *dpsi. Returns the entry after the column.
template <int N>
[[gnu::always_inline]] inline int WriteContactColumn(const ContactColumns& cc, const Vector3d& d,
                                                     int* outer, int* inner, double* value, int k,
                                                     double* dpsi) {
  *outer = k;
  const DynamicSide* merge = cc.merged ? &cc.sides[1] : nullptr;
  if (cc.blocks == 1) {
    WriteSideBlock<N>(cc.sides[0], merge, d, inner + k, value + k);
    k += N;
  } else {
    for (int b = 0; b < cc.blocks; ++b, k += N)
      WriteSideBlock<N>(cc.sides[b], merge, d, inner + k, value + k);
  }
  if (cc.dpsi_a) *dpsi += d.dot(cc.side_a->v_p);
  if (cc.dpsi_b) *dpsi += -1.0 * d.dot(cc.side_b->v_p);
  return k;
}

// Contact c's normal column (direction n) into a->G_n and its nd friction columns (dirs) into
// a->G_f, at entries *k_n and *k_f.
// pairs: dirs by pairs (PackDirectionPairs), used for N = 6 columns without a merged side or
// ∂ψ/∂t terms (the same entries as the column-by-column writer).
template <int N>
void WriteContactColumns(const ContactColumns& cc, const Vector3d& n,
                         const std::vector<Vector3d>& dirs, const std::vector<double>& pairs, int c,
                         int nd, StewartTrinkle::Assembly* a, int* k_n, int* k_f) {
  *k_n = WriteContactColumn<N>(cc, n, a->G_n.outerIndexPtr() + c, a->G_n.innerIndexPtr(),
                               a->G_n.valuePtr(), *k_n, &a->dpsi_n[c]);
  int* outer = a->G_f.outerIndexPtr() + c * nd;
  int* inner = a->G_f.innerIndexPtr();
  double* value = a->G_f.valuePtr();
  double* dpsi = a->dpsi_f.data() + c * nd;
  const Vector3d* d = dirs.data();
  int k = *k_f;
  int j = 0;
  if constexpr (N == 6) {
    // (A dynamic side's sign is ±1, MakeDynamicSide's callers.)
    if (!cc.merged && !cc.dpsi_a && !cc.dpsi_b) {
      const int stride = cc.blocks * N;
      const int npairs = nd / 2;
      for (int b = 0; b < cc.blocks; ++b) {
        const DynamicSide& side = cc.sides[b];
        if (side.sign > 0.0)
          WriteSidePairs6<1>(side, pairs.data(), npairs, stride, inner + k + N * b,
                             value + k + N * b);
        else
          WriteSidePairs6<-1>(side, pairs.data(), npairs, stride, inner + k + N * b,
                              value + k + N * b);
      }
      // outer[j] = k + j·stride, four at a time (a GCC/Clang vector extension).
      using V4i = int __attribute__((vector_size(16)));
      V4i first = V4i{k, k, k, k} + V4i{0, stride, 2 * stride, 3 * stride};
      const V4i step = V4i{4 * stride, 4 * stride, 4 * stride, 4 * stride};
      for (; j + 4 <= 2 * npairs; j += 4, first += step)
        std::memcpy(outer + j, &first, sizeof(first));
      for (; j < 2 * npairs; ++j) outer[j] = k + j * stride;
      k += j * stride;
    }
  }
  for (; j < nd; ++j) k = WriteContactColumn<N>(cc, d[j], outer + j, inner, value, k, dpsi + j);
  *k_f = k;
}

}  // namespace vinci::sim::internal::contact_columns
