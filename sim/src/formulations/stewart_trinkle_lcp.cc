// StewartTrinkle::BuildLcp / BuildLcpInto: the step's LCP (M = Gᵀ M⁻¹ G per body block, the
// joint elimination and the corner rows) from an assembly; VelocityAfter / VelocityAfterInto:
// ν_{ℓ+1} = ν* + M⁻¹ G z (with the joints' correction) from its solution.
#include <algorithm>
#include <cmath>
#include <vector>

#include "dense_solve.h"
#include "stewart_trinkle_internal.h"
#include "vinci/sim/formulations/joint.h"
#include "vinci/sim/formulations/stewart_trinkle.h"

namespace vinci::sim {
namespace {

// The entries of column `col` of G in rows [o, o + n) into out[0..n) (zeros elsewhere).
void GatherColumn(const SparseMatrixd& G, int col, int o, int n, double* out) {
  std::fill(out, out + n, 0.0);
  for (SparseMatrixd::InnerIterator it(G, col); it; ++it)
    if (it.row() >= o && it.row() < o + n) out[it.row() - o] = it.value();
}

}  // namespace

LcpProblem StewartTrinkle::BuildLcp(const Scene& model, const Assembly& a, const VectorXd& v,
                                    VectorXd* v_star, JointElimination* joints) const {
  LcpProblem lcp;
  BuildLcpInto(model, a, v, v_star, joints, &lcp);
  return lcp;
}

namespace {

// BuildLcpInto's per-thread buffers (allocation reuse only: every call overwrites what it uses).
struct DenseLcpScratch {
  // One body's contact columns G_b (nvb × k), M_b⁻¹ G_b and G_bᵀ M_b⁻¹ G_b: one set per column
  // count k, so that bodies with different counts do not reallocate each other's.
  struct BodyBlocks {
    MatrixXd Gb_cols, MinvG, block;
  };
  std::vector<std::vector<int>> columns;
  std::vector<BodyBlocks> by_count;
  VectorXd Minv_p, Gv_n, Gv_f;
  // Joint elimination and corner rows: G_b dense, S's matrix, the right-hand sides and products.
  MatrixXd Gb_dense, S_matrix, GbMinvGc, solved, correction, D, WD, GbtD;
  MatrixXd product_n, product_f, product_s;
  VectorXd rhs, solved_rhs, v_correction, col_1, col_n, e, Dv;
};

}  // namespace

void StewartTrinkle::BuildLcpInto(const Scene& model, const Assembly& a, const VectorXd& v,
                                  VectorXd* v_star, JointElimination* joints,
                                  LcpProblem* lcp_out) const {
  thread_local DenseLcpScratch scratch;
  LcpProblem& lcp = *lcp_out;
  const double h = options_.dt;
  const int nc = static_cast<int>(a.contacts.size());
  const int nd = a.nd;
  const int nf = nc * nd;
  const int nb = static_cast<int>(a.psi_b.size());
  const int nk = static_cast<int>(a.corner_contact.size());
  const int nvb = VelocitySize(model.dim);
  // Support friction: p_s (nps columns) and σ_s (ns points) follow (p_n, p_f, σ).
  const SupportRows& sup = a.support;
  const int ns = sup.points(), nps = sup.columns(), s0 = nc + nf + nc;
  // Corner unknowns c (nk) come last: z = [p_n; p_f; σ; p_s; σ_s; c].
  const int m = nc + nf + nc + nps + ns + nk;

  a.M_inv.Multiply(a.p_ext, &scratch.Minv_p);
  *v_star = v + scratch.Minv_p;
  lcp.M.setZero(m, m);
  lcp.q.setZero(m);

  // G_cᵀ M⁻¹ G_c from per-body blocks: M⁻¹ is block diagonal and each contact column touches at
  // most two bodies, so only columns sharing a body interact (O(Σ_b k_b²) instead of dense).
  std::vector<std::vector<int>>& columns = scratch.columns;
  columns.resize(model.bodies.size());
  for (std::vector<int>& cols : columns) cols.clear();
  for (int c = 0; c < nc; ++c) {
    for (int body : {a.contacts[c].body_a, a.contacts[c].body_b}) {
      if (model.bodies[body].kind != BodyKind::kDynamic) continue;
      std::vector<int>& cols = columns[body];
      cols.push_back(c);
      for (int j = 0; j < nd; ++j) cols.push_back(nc + c * nd + j);
    }
  }
  for (int k = 0; k < ns; ++k)
    for (int j = 0; j < sup.count[k]; ++j) columns[sup.body[k]].push_back(s0 + sup.first[k] + j);
  for (int body : model.dynamic_bodies()) {
    const std::vector<int>& cols = columns[body];
    if (cols.empty()) continue;
    const int o = model.index(body).v, k = static_cast<int>(cols.size());
    if (scratch.by_count.size() <= static_cast<std::size_t>(k)) scratch.by_count.resize(k + 1);
    MatrixXd &Gb_cols = scratch.by_count[k].Gb_cols, &MinvG = scratch.by_count[k].MinvG,
             &block = scratch.by_count[k].block;
    Gb_cols.resize(nvb, k);
    for (int i = 0; i < k; ++i) {
      if (cols[i] < nc)
        GatherColumn(a.G_n, cols[i], o, nvb, Gb_cols.col(i).data());
      else if (cols[i] < nc + nf)
        GatherColumn(a.G_f, cols[i] - nc, o, nvb, Gb_cols.col(i).data());
      else
        Gb_cols.col(i) = sup.G_s.block(o, cols[i] - s0, nvb, 1);
    }
    MinvG.noalias() = a.M_inv.BlockAt(o) * Gb_cols;
    block.noalias() = Gb_cols.transpose() * MinvG;
    for (int i = 0; i < k; ++i)
      for (int j = 0; j < k; ++j) lcp.M(cols[i], cols[j]) += block(i, j);
  }

  if (nb > 0) {
    // Eliminate p_b with S = G_bᵀ M⁻¹ G_b:
    //   S p_b = −(G_bᵀ ν* + ψ_b/h + ∂ψ_b/∂t + G_bᵀ M⁻¹ G_c p_c),
    // which subtracts (G_bᵀM⁻¹G_c)ᵀ S⁻¹ (G_bᵀM⁻¹G_c) from the contact block.
    // Every product is formed into a buffer before it is summed or subtracted, and the LDLᵀ
    // solves run in place (dense_solve.h): the operations and their order of the plain
    // expressions (Eigen evaluates a product inside a sum into a temporary), in kept storage.
    scratch.Gb_dense = a.G_b;
    a.M_inv.Multiply(scratch.Gb_dense, &joints->MinvGb);
    scratch.S_matrix.noalias() = a.G_b.transpose() * joints->MinvGb;
    joints->S.compute(scratch.S_matrix);
    VectorXd& rhs = scratch.rhs;
    rhs.noalias() = a.G_b.transpose() * *v_star;
    rhs += a.dpsi_b;
    if (options_.joint_stabilization) rhs += a.psi_b / h;
    internal::LdltSolveInto(joints->S, rhs, &scratch.solved_rhs);
    scratch.v_correction.noalias() = joints->MinvGb * scratch.solved_rhs;
    *v_star -= scratch.v_correction;
    MatrixXd& GbMinvGc = scratch.GbMinvGc;
    if (nc > 0 && nps == 0) {
      GbMinvGc.resize(nb, nc + nf);
      GbMinvGc.leftCols(nc).noalias() = joints->MinvGb.transpose() * a.G_n;
      GbMinvGc.rightCols(nf).noalias() = joints->MinvGb.transpose() * a.G_f;
      internal::LdltSolveInto(joints->S, GbMinvGc, &scratch.solved);
      scratch.correction.noalias() = GbMinvGc.transpose() * scratch.solved;
      lcp.M.topLeftCorner(nc + nf, nc + nf) -= scratch.correction;
    } else if (nps > 0) {
      // Same correction over the impulse columns (p_n, p_f, p_s), skipping the σ rows/columns.
      GbMinvGc.resize(nb, nc + nf + nps);
      GbMinvGc.leftCols(nc).noalias() = joints->MinvGb.transpose() * a.G_n;
      GbMinvGc.middleCols(nc, nf).noalias() = joints->MinvGb.transpose() * a.G_f;
      GbMinvGc.rightCols(nps).noalias() = joints->MinvGb.transpose() * sup.G_s;
      internal::LdltSolveInto(joints->S, GbMinvGc, &scratch.solved);
      MatrixXd& C = scratch.correction;
      C.noalias() = GbMinvGc.transpose() * scratch.solved;
      const auto at = [&](int i) { return i < nc + nf ? i : i + nc; };
      for (int i = 0; i < nc + nf + nps; ++i)
        for (int j = 0; j < nc + nf + nps; ++j) lcp.M(at(i), at(j)) -= C(i, j);
    }
  }

  for (int c = 0; c < nc; ++c) {
    for (int j = 0; j < nd; ++j) {
      lcp.M(nc + c * nd + j, nc + nf + c) = 1.0;   // E
      lcp.M(nc + nf + c, nc + c * nd + j) = -1.0;  // −Eᵀ
    }
    lcp.M(nc + nf + c, c) = a.mu[c];  // U
  }
  // Blocks for block-iterative solvers: one per contact patch (LcpBlocks).
  LcpBlocksInto(a, LcpBlocking::kContactPatch, &lcp.blocks, &lcp.block_parts);
  // The sparse products into a buffer, then the sums (what Eigen does for the whole expression,
  // without its temporary).
  VectorXd& Gv_n = scratch.Gv_n;
  Gv_n.noalias() = a.G_n.transpose() * *v_star;
  lcp.q.head(nc) = Gv_n + a.dpsi_n;
  if (!velocity_level_) lcp.q.head(nc) += a.psi_n / h;
  for (int c = 0; c < nc; ++c) {
    const CompliantNormalRow& law = a.compliance[c];
    if (!law.compliant) continue;
    lcp.q[c] =
        a.G_n.col(c).dot(*v_star) + a.dpsi_n[c] + law.vel_psi * a.psi_n[c] + law.vel_constant;
    lcp.M(c, c) += law.vel_diagonal;
  }
  VectorXd& Gv_f = scratch.Gv_f;
  Gv_f.noalias() = a.G_f.transpose() * *v_star;
  lcp.q.segment(nc, nf) = Gv_f + a.dpsi_f;

  // Corner contacts (header comment): c_k are the last unknowns. With D = G_1 − G_2 and
  // e = (ψ_1 − ψ_2)/h + ∂ψ_1/∂t − ∂ψ_2/∂t, row k is c_k − Dᵀ(ν* + W G_c p_c) − e, and c_k adds to
  // its contact's normal row.
  if (nk > 0) {
    const int o = m - nk;  // the corner unknowns are the last nk
    // (Buffers as the joint elimination above: the same operations as the plain expressions.)
    MatrixXd& D = scratch.D;
    VectorXd& e = scratch.e;
    D.resize(a.G_1.rows(), nk);
    e.resize(nk);
    for (int k = 0; k < nk; ++k) {
      const int c = a.corner_contact[k];
      scratch.col_1 = a.G_1.col(k);  // toDense()
      scratch.col_n = a.G_n.col(c);
      D.col(k) = scratch.col_1 - scratch.col_n;
      e[k] = (a.psi_1[k] - a.psi_n[c]) / h + a.dpsi_1[k] - a.dpsi_n[c];
    }
    // Dᵀ W G = (W D)ᵀ G (W symmetric): W D is dense nv × nk, G stays sparse.
    MatrixXd& WD = scratch.WD;
    a.M_inv.Multiply(D, &WD);
    if (nb > 0) {
      scratch.GbtD.noalias() = joints->MinvGb.transpose() * D;
      internal::LdltSolveInto(joints->S, scratch.GbtD, &scratch.solved);
      scratch.correction.noalias() = joints->MinvGb * scratch.solved;
      WD -= scratch.correction;
    }
    scratch.product_n.noalias() = a.G_n.transpose() * WD;
    lcp.M.block(o, 0, nk, nc) = -scratch.product_n.transpose();
    scratch.product_f.noalias() = a.G_f.transpose() * WD;
    lcp.M.block(o, nc, nk, nf) = -scratch.product_f.transpose();
    if (nps > 0) {  // ν also depends on the support impulses p_s
      scratch.product_s.noalias() = -WD.transpose() * sup.G_s;
      lcp.M.block(o, s0, nk, nps) = scratch.product_s;
    }
    for (int k = 0; k < nk; ++k) {
      lcp.M(o + k, o + k) = 1.0;
      lcp.M(a.corner_contact[k], o + k) = 1.0;
      // Anitescu–Potra: corner rows stay position-level (header comment).
      if (velocity_level_) lcp.q[a.corner_contact[k]] += a.psi_n[a.corner_contact[k]] / h;
    }
    scratch.Dv.noalias() = D.transpose() * *v_star;
    lcp.q.segment(o, nk) = -(scratch.Dv + e);
  }
  // Support friction rows: 0 ≤ p_s ⊥ G_sᵀν + E_s σ_s, 0 ≤ σ_s ⊥ h μ_s N − E_sᵀ p_s.
  for (int k = 0; k < ns; ++k) {
    for (int j = 0; j < sup.count[k]; ++j) {
      const int row = s0 + sup.first[k] + j;
      lcp.M(row, s0 + nps + k) = 1.0;   // E_s
      lcp.M(s0 + nps + k, row) = -1.0;  // −E_sᵀ
    }
  }
  if (nps > 0) {
    lcp.q.segment(s0, nps).noalias() = sup.G_s.transpose() * *v_star;
    lcp.q.segment(s0 + nps, ns) = sup.limit;
  }
}

namespace internal {

// ν_ℓ+1 = ν* + W G_c p_c into *v1, with the intermediate vectors in *impulse, *product and *dv
// (their storage reused).
void VelocityAfterWith(const StewartTrinkle::Assembly& a, const VectorXd& v_star, const VectorXd& z,
                       const StewartTrinkle::JointElimination& joints, VectorXd* impulse,
                       VectorXd* product, VectorXd* dv, VectorXd* v1) {
  const int nc = static_cast<int>(a.contacts.size());
  const int nf = nc * a.nd;
  // impulse = G_n p_n + G_f p_f (+ G_s p_s), evaluated as Eigen evaluates that expression:
  // G_f p_f accumulated into G_n p_n, G_s p_s formed whole, then added.
  impulse->noalias() = a.G_n * z.head(nc);
  impulse->noalias() += a.G_f * z.segment(nc, nf);
  if (a.support.columns() > 0) {
    product->noalias() = a.support.G_s * z.segment(nc + nf + nc, a.support.columns());
    *impulse += *product;
  }
  a.M_inv.Multiply(*impulse, dv);
  if (a.psi_b.size() > 0) {
    // The products into buffers, the solve in place (as BuildLcpInto's joint elimination).
    thread_local VectorXd gb_impulse, solved, correction;
    gb_impulse.noalias() = joints.MinvGb.transpose() * *impulse;
    internal::LdltSolveInto(joints.S, gb_impulse, &solved);
    correction.noalias() = joints.MinvGb * solved;
    *dv -= correction;
  }
  *v1 = v_star + *dv;
}

void PlainLcpAtInto(const StewartTrinkle& st, const StewartTrinkle::Assembly& a, const State& x,
                    const VectorXd& z, VectorXd* w, VectorXd* v1) {
  thread_local VectorXd minv_p, impulse, dv;
  const StepperOptions& o = st.options();
  const int nc = static_cast<int>(a.contacts.size()), nd = a.nd, nf = nc * nd;
  const int nv = static_cast<int>(a.M_inv.rows());
  // ν* = ν_ℓ + M⁻¹ p_ext (first order: no ν_ℓ).
  a.M_inv.Multiply(a.p_ext, &minv_p);
  // ν_after = ν* + W (G_n p_n + G_f p_f (+ G_s p_s)), G's columns accumulated directly (a
  // column whose impulse is zero skipped).
  impulse.setZero(nv);
  const auto add_columns = [&](const SparseMatrixd& g, int first) {
    for (int j = 0; j < g.outerSize(); ++j) {
      const double zj = z[first + j];
      if (zj == 0.0) continue;
      for (SparseMatrixd::InnerIterator it(g, j); it; ++it) impulse[it.row()] += it.value() * zj;
    }
  };
  add_columns(a.G_n, 0);
  add_columns(a.G_f, nc);
  if (a.support.columns() > 0)
    impulse.noalias() += a.support.G_s * z.segment(nc + nf + nc, a.support.columns());
  a.M_inv.Multiply(impulse, &dv);
  if (o.formulation == FormulationType::kFirstOrder)
    *v1 = minv_p + dv;
  else
    *v1 = x.v + minv_p + dv;
  // BuildLcpInto's rows M z + q through ν_after: G_iᵀ ν_after + ψ̇_i (+ ψ_n / h), the friction
  // rows' E σ, the cone rows μ p_n − Eᵀ p_f.
  w->resize(nc + nf + nc);
  const auto dots = [&](const SparseMatrixd& g, const VectorXd& offset, int first) {
    for (int j = 0; j < g.outerSize(); ++j) {
      double sum = offset[j];
      for (SparseMatrixd::InnerIterator it(g, j); it; ++it) sum += it.value() * (*v1)[it.row()];
      (*w)[first + j] = sum;
    }
  };
  dots(a.G_n, a.dpsi_n, 0);
  if (o.formulation != FormulationType::kAnitescuPotra)
    for (int c = 0; c < nc; ++c) (*w)[c] += a.psi_n[c] / o.dt;
  dots(a.G_f, a.dpsi_f, nc);
  for (int c = 0; c < nc; ++c) {
    double sum = 0.0;
    for (int j = 0; j < nd; ++j) {
      (*w)[nc + c * nd + j] += z[nc + nf + c];
      sum += z[nc + c * nd + j];
    }
    (*w)[nc + nf + c] = a.mu[c] * z[c] - sum;
  }
}

}  // namespace internal

VectorXd StewartTrinkle::VelocityAfter(const Assembly& a, const VectorXd& v_star, const VectorXd& z,
                                       const JointElimination& joints) const {
  VectorXd impulse, product, dv, v1;
  internal::VelocityAfterWith(a, v_star, z, joints, &impulse, &product, &dv, &v1);
  return v1;
}

void StewartTrinkle::VelocityAfterInto(const Assembly& a, const VectorXd& v_star, const VectorXd& z,
                                       const JointElimination& joints, VectorXd* v1) const {
  thread_local VectorXd impulse, product, dv;
  internal::VelocityAfterWith(a, v_star, z, joints, &impulse, &product, &dv, v1);
}
}  // namespace vinci::sim
