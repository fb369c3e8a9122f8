#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "geometrically_implicit_internal.h"
#include "step_util.h"
#include "vinci/sim/formulations/contact.h"
#include "vinci/sim/model/compliance.h"
#include "vinci/sim/model/kinematics.h"

namespace vinci::sim::gi {

Matrix3d Skew(const Vector3d& v) {
  Matrix3d S;
  S << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return S;
}

Matrix3d ExpSO3(const Vector3d& phi) {
  const double a = phi.norm();
  if (a == 0.0) return Matrix3d::Identity();
  return Eigen::AngleAxisd(a, phi / a).toRotationMatrix();
}

// Right Jacobian of SO(3): Exp(φ + δ) ≈ Exp(φ) Exp(J_r(φ) δ).
Matrix3d RightJacobian(const Vector3d& phi) {
  const double a2 = phi.squaredNorm(), a = std::sqrt(a2);
  double c1, c2;  // (1 − cos a)/a², (a − sin a)/a³
  if (a < 1e-4) {
    c1 = 0.5 - a2 / 24.0;
    c2 = 1.0 / 6.0 - a2 / 120.0;
  } else {
    c1 = (1.0 - std::cos(a)) / a2;
    c2 = (a - std::sin(a)) / (a2 * a);
  }
  const Matrix3d S = Skew(phi);
  return Matrix3d::Identity() - c1 * S + c2 * S * S;
}

Vector3d LogSO3(const Matrix3d& R) {
  const Eigen::AngleAxisd aa(R);
  return aa.axis() * aa.angle();
}

// A body at ℓ+1 for a given unknown vector.
int LocalSize(const GiPair& p) { return kLam + p.m_a + p.m_b; }

// Pair k's unknowns from z into *u (every field written).
void ReadPair(const Context& c, int k, const VectorXd& z, PairUnknowns* out) {
  const GiPair& p = c.pairs[k];
  const StepLayout& l = c.layout;
  PairUnknowns& u = *out;
  u.pn = z[l.pn() + k];
  u.pt.setZero();
  for (int j = 0; j < c.nd; ++j) u.pt[j] = z[l.pf() + k * c.nd + j];
  u.sigma = z[l.sigma() + k];
  int o = c.geo[k];
  u.a1.setZero();
  u.a2.setZero();
  u.a1.head(c.d) = z.segment(o, c.d);
  u.a2.head(c.d) = z.segment(o + c.d, c.d);
  u.l1 = z[o + 2 * c.d];
  u.l2 = z[o + 2 * c.d + 1];
  o += 2 * c.d + 2;
  u.lam.setOnes(p.m_a);
  u.mu.setOnes(p.m_b);
  if (p.m_a > 1) {
    u.lam = z.segment(o, p.m_a);
    o += p.m_a;
  }
  if (p.m_b > 1) u.mu = z.segment(o, p.m_b);
}

// The bodies at z into *out (one per scene body).
void BodiesAt(const Context& c, const VectorXd& z, std::vector<BodyAt>* out) {
  const Scene& s = *c.model;
  out->resize(s.bodies.size());
  for (std::size_t i = 0; i < s.bodies.size(); ++i) {
    BodyAt& b = (*out)[i];
    b.dynamic = false;
    b.q_col = b.v_col = -1;
    if (s.bodies[i].kind != BodyKind::kDynamic) {
      b.X = c.moving[i].X_WB;
      b.v = c.moving[i].v_WB;
      b.w = c.moving[i].w_WB;
      continue;
    }
    b.dynamic = true;
    b.q_col = c.layout.q1() + c.pose_offset[i];
    b.v_col = c.layout.v1() + s.index(static_cast<int>(i)).v;
    const auto q = z.segment(b.q_col, c.kq);
    const auto v = z.segment(b.v_col, c.nvb);
    b.P = Matrix6Xd::Zero(6, c.kq);
    b.V = Matrix6Xd::Zero(6, c.nvb);
    if (c.dim == Dim::kPlanar) {
      b.X = PlanarPose(q[0], q[1], q[2]);
      b.v = Vector3d(v[0], v[1], 0.0);
      b.w = Vector3d(0.0, 0.0, v[2]);
      b.P(0, 0) = b.P(1, 1) = b.P(5, 2) = 1.0;
      b.V(0, 0) = b.V(1, 1) = b.V(5, 2) = 1.0;
    } else {
      const Matrix3d& R0 = c.X_start[i].linear();
      const Vector3d phi = q.tail<3>();
      b.X = Isometry3d::Identity();
      b.X.translation() = q.head<3>();
      b.X.linear() = R0 * ExpSO3(phi);
      b.v = v.head<3>();
      b.w = R0 * v.tail<3>();
      b.P.topLeftCorner<3, 3>().setIdentity();
      b.P.bottomRightCorner<3, 3>() = b.X.linear() * RightJacobian(phi);
      b.V.topLeftCorner<3, 3>().setIdentity();
      b.V.bottomRightCorner<3, 3>() = R0;
    }
  }
}

// One implicit function at a world point: value, world gradient and Hessian.
FnAt EvalFn(const ImplicitFunction& fn, const Isometry3d& X_WS, const Vector3d& a_W) {
  const Vector3d xi = X_WS.inverse() * a_W;
  FnAt r;
  Vector3d g_S;
  Matrix3d H_S;
  fn.Evaluate(xi, &r.f, &g_S, &H_S);
  const Matrix3d& R = X_WS.linear();
  r.g = R * g_S;
  r.H = R * H_S * R.transpose();
  return r;
}

// One side of a pair: the normal n_S = Σ λ_i ∇f_i(a) and the values f_i(a), with derivatives
// with respect to the point (column ca), the body displacement (cd) and the multipliers (cl).
void EvalSide(const ImplicitSet& set, const Isometry3d& X_WS, const BodyAt& body, const Vector3d& a,
              const VectorXd& lam, int ca, int cd, int cl, int L, Vector3d* nS, MatrixXd* d_nS,
              VectorXd* f, MatrixXd* d_f) {
  const int m = static_cast<int>(set.functions.size());
  const Vector3d r = a - body.X.translation();
  nS->setZero();
  *d_nS = MatrixXd::Zero(3, L);
  f->resize(m);
  *d_f = MatrixXd::Zero(m, L);
  for (int i = 0; i < m; ++i) {
    const FnAt e = EvalFn(set.functions[i], X_WS, a);
    (*f)[i] = e.f;
    *nS += lam[i] * e.g;
    d_f->block<1, 3>(i, ca) = e.g.transpose();
    d_f->block<1, 3>(i, cd) = -e.g.transpose();
    d_f->block<1, 3>(i, cd + 3) = -r.cross(e.g).transpose();
    d_nS->middleCols<3>(ca) += lam[i] * e.H;
    d_nS->middleCols<3>(cd) -= lam[i] * e.H;
    d_nS->middleCols<3>(cd + 3) += lam[i] * (e.H * Skew(r) - Skew(e.g));
    if (m > 1) d_nS->col(cl + i) += e.g;
  }
}

// Pair k's values and local Jacobians at its unknowns ps->u into ps->e.
void EvalPair(const Context& c, int k, const std::vector<BodyAt>& bodies, PairScratch* ps) {
  const PairUnknowns& u = ps->u;
  PairEval* e = &ps->e;
  const GiPair& p = c.pairs[k];
  const BodyAt& A = bodies[p.body_a];
  const BodyAt& B = bodies[p.body_b];
  const Shape& sa = c.model->bodies[p.body_a].shapes[p.shape_a];
  const Shape& sb = c.model->bodies[p.body_b].shapes[p.shape_b];
  const Isometry3d X_WSA = A.X * sa.X_BS, X_WSB = B.X * sb.X_BS;
  const int L = LocalSize(p);
  const int cl = kLam, cm = kLam + p.m_a;

  Vector3d nA, nB;
  MatrixXd &dnA = ps->dnA, &dnB = ps->dnB;
  EvalSide(c.sets[p.body_a][p.shape_a], X_WSA, A, u.a1, u.lam, kA1, kDA, cl, L, &nA, &dnA, &e->fa,
           &e->d_fa);
  EvalSide(c.sets[p.body_b][p.shape_b], X_WSB, B, u.a2, u.mu, kA2, kDB, cm, L, &nB, &dnB, &e->fb,
           &e->d_fb);
  e->d_side_a = MatrixXd::Zero(1, L);
  e->d_side_b = MatrixXd::Zero(1, L);
  if (p.m_a == 1) {
    e->side_a = e->fa[0];
    e->d_side_a = e->d_fa.row(0);
  } else {
    e->side_a = u.lam.sum() - 1.0;
    e->d_side_a.middleCols(cl, p.m_a).setOnes();
  }
  if (p.m_b == 1) {
    e->side_b = e->fb[0];
    e->d_side_b = e->d_fb.row(0);
  } else {
    e->side_b = u.mu.sum() - 1.0;
    e->d_side_b.middleCols(cm, p.m_b).setOnes();
  }

  // Separation along A's normal, anti-parallel normals, signed distance.
  e->sep = u.a1 - u.a2 + u.l1 * nA;
  e->d_sep = u.l1 * dnA;
  e->d_sep.middleCols<3>(kA1) += Matrix3d::Identity();
  e->d_sep.middleCols<3>(kA2) -= Matrix3d::Identity();
  e->d_sep.col(kL1) += nA;
  e->par = nA + u.l2 * nB;
  e->d_par = dnA + u.l2 * dnB;
  e->d_par.col(kL2) += nB;
  const double nn = nA.norm();
  const Vector3d nhat = nA / nn;
  e->psi = u.l1 * nn;
  ps->row_a.noalias() = u.l1 * nhat.transpose() * dnA;
  e->d_psi = ps->row_a;
  e->d_psi(0, kL1) += nn;

  // Contact frame: n from B to A, tangents.
  e->n = -nhat;
  const Matrix3d proj = Matrix3d::Identity() - e->n * e->n.transpose();
  MatrixXd& dn = ps->dn;
  dn.noalias() = -(proj / nn) * dnA;
  MatrixXd* dt = ps->dt;
  e->T.setZero();
  if (c.dim == Dim::kPlanar) {
    e->T.col(0) = Vector3d::UnitZ().cross(e->n);
    ps->t3a.noalias() = Skew(Vector3d::UnitZ()) * dn;
    dt[0] = ps->t3a;
  } else {
    const Vector3d& ref = p.tangent_reference;
    const Vector3d w = e->n.cross(ref);
    const double wn = w.norm();
    const Vector3d t1 = w / wn;
    const Vector3d t2 = e->n.cross(t1);
    e->T.col(0) = t1;
    e->T.col(1) = t2;
    // (the inner product is evaluated first, as Eigen evaluates a nested product)
    ps->t3a.noalias() = -Skew(ref) * dn;
    ps->t3b.noalias() = ((Matrix3d::Identity() - t1 * t1.transpose()) / wn) * ps->t3a;
    dt[0] = ps->t3b;
    ps->t3a.noalias() = -Skew(t1) * dn;
    ps->t3b.noalias() = Skew(e->n) * dt[0];
    dt[1] = ps->t3a + ps->t3b;
  }

  // Relative velocity of the material points at ℓ+1.
  const Vector3d rA = u.a1 - A.X.translation(), rB = u.a2 - B.X.translation();
  e->vrel = A.v + A.w.cross(rA) - B.v - B.w.cross(rB);
  MatrixXd& dv = ps->dv;
  dv.setZero(3, L);
  dv.middleCols<3>(kVA) = Matrix3d::Identity();
  dv.middleCols<3>(kVA + 3) = -Skew(rA);
  dv.middleCols<3>(kA1) += Skew(A.w);
  dv.middleCols<3>(kDA) -= Skew(A.w);
  dv.middleCols<3>(kVB) = -Matrix3d::Identity();
  dv.middleCols<3>(kVB + 3) = Skew(rB);
  dv.middleCols<3>(kA2) -= Skew(B.w);
  dv.middleCols<3>(kDB) += Skew(B.w);
  e->d_vt = MatrixXd::Zero(2, L);
  e->vt.setZero();
  for (int j = 0; j < c.nd; ++j) {
    e->vt[j] = e->T.col(j).dot(e->vrel);
    ps->row_a.noalias() = e->T.col(j).transpose() * dv;
    ps->row_b.noalias() = e->vrel.transpose() * dt[j];
    e->d_vt.row(j) = ps->row_a + ps->row_b;
  }

  // Impulse on A at a_1 (and −P on B at a_2) and the world wrenches.
  Vector3d P = e->n * u.pn;
  MatrixXd& dP = ps->dP;
  dP = u.pn * dn;
  dP.col(kPn) += e->n;
  for (int j = 0; j < c.nd; ++j) {
    P += e->T.col(j) * u.pt[j];
    dP += u.pt[j] * dt[j];
    dP.col(kPt + j) += e->T.col(j);
  }
  e->WA.head<3>() = P;
  e->WA.tail<3>() = rA.cross(P);
  e->d_WA = MatrixXd::Zero(6, L);
  e->d_WA.topRows<3>() = dP;
  ps->t3a.noalias() = Skew(rA) * dP;
  e->d_WA.bottomRows<3>() = ps->t3a;
  e->d_WA.block<3, 3>(3, kA1) -= Skew(P);
  e->d_WA.block<3, 3>(3, kDA) += Skew(P);
  e->WB.head<3>() = -P;
  e->WB.tail<3>() = -rB.cross(P);
  e->d_WB = MatrixXd::Zero(6, L);
  e->d_WB.topRows<3>() = -dP;
  ps->t3a.noalias() = -Skew(rB) * dP;
  e->d_WB.bottomRows<3>() = ps->t3a;
  e->d_WB.block<3, 3>(3, kA2) += Skew(P);
  e->d_WB.block<3, 3>(3, kDB) -= Skew(P);
}

// Adds local-column Jacobian rows Jl (r × L) into J's rows [row, row + r) at the pair's columns.
// The products go through c.buf.products[r] (Jl is not one of them).
void Scatter(const Context& c, int k, const std::vector<BodyAt>& bodies, const MatrixXd& Jl,
             int row, MatrixXd* J) {
  const GiPair& p = c.pairs[k];
  const int r = static_cast<int>(Jl.rows());
  const StepLayout& l = c.layout;
  const BodyAt& A = bodies[p.body_a];
  const BodyAt& B = bodies[p.body_b];
  if (static_cast<int>(c.buf.products.size()) <= r) c.buf.products.resize(r + 1);
  MatrixXd& prod = c.buf.products[r];
  if (A.dynamic) {
    prod.noalias() = Jl.middleCols<6>(kDA) * A.P;
    J->block(row, A.q_col, r, c.kq) += prod;
    prod.noalias() = Jl.middleCols<6>(kVA) * A.V;
    J->block(row, A.v_col, r, c.nvb) += prod;
  }
  if (B.dynamic) {
    prod.noalias() = Jl.middleCols<6>(kDB) * B.P;
    J->block(row, B.q_col, r, c.kq) += prod;
    prod.noalias() = Jl.middleCols<6>(kVB) * B.V;
    J->block(row, B.v_col, r, c.nvb) += prod;
  }
  J->col(l.pn() + k).segment(row, r) += Jl.col(kPn);
  for (int j = 0; j < c.nd; ++j) J->col(l.pf() + k * c.nd + j).segment(row, r) += Jl.col(kPt + j);
  J->col(l.sigma() + k).segment(row, r) += Jl.col(kSig);
  int o = c.geo[k];
  J->block(row, o, r, c.d) += Jl.middleCols(kA1, c.d);
  J->block(row, o + c.d, r, c.d) += Jl.middleCols(kA2, c.d);
  J->col(o + 2 * c.d).segment(row, r) += Jl.col(kL1);
  J->col(o + 2 * c.d + 1).segment(row, r) += Jl.col(kL2);
  o += 2 * c.d + 2;
  if (p.m_a > 1) {
    J->block(row, o, r, p.m_a) += Jl.middleCols(kLam, p.m_a);
    o += p.m_a;
  }
  if (p.m_b > 1) J->block(row, o, r, p.m_b) += Jl.middleCols(kLam + p.m_a, p.m_b);
}

// Contact wrench rows: F[ν_b] −= V_bᵀ W for both bodies of pair k (with Jacobian).
void AddWrenches(const Context& c, int k, const std::vector<BodyAt>& bodies, PairScratch* ps,
                 int dyn_row0, VectorXd* F, MatrixXd* J) {
  const GiPair& p = c.pairs[k];
  const PairEval& e = ps->e;
  for (int side = 0; side < 2; ++side) {
    const BodyAt& b = bodies[side == 0 ? p.body_a : p.body_b];
    if (!b.dynamic) continue;
    const Vector6d& W = side == 0 ? e.WA : e.WB;
    const MatrixXd& dW = side == 0 ? e.d_WA : e.d_WB;
    const int row = dyn_row0 + (b.v_col - c.layout.v1());
    c.buf.VW.noalias() = b.V.transpose() * W;
    F->segment(row, c.nvb) -= c.buf.VW;
    if (J) {
      ps->wrench.noalias() = b.V.transpose() * dW;
      MatrixXd& jl = ps->rows[c.nvb];
      jl = -ps->wrench;
      Scatter(c, k, bodies, jl, row, J);
    }
  }
}

// Dynamics and kinematics rows (without contacts) into F rows [dyn_row0, +nv) and
// [kin_row0, +nq).
// The kinematics rows are multiplied by kin_scale (the solver uses 1/h: velocity units, so that
// their Jacobian is O(1) in ν).
void BodyRows(const Context& c, const VectorXd& z, int dyn_row0, int kin_row0, double kin_scale,
              VectorXd* F, MatrixXd* J) {
  const StepLayout& l = c.layout;
  VectorXd& v1 = c.buf.v1;
  v1 = z.segment(l.v1(), l.nv);
  // (M (ν − ν_ℓ) evaluated into a buffer first, as Eigen evaluates the product of the sum)
  c.buf.dv = v1 - c.x.v;
  c.buf.Mdv.noalias() = c.M * c.buf.dv;
  F->segment(dyn_row0, l.nv) = c.buf.Mdv - c.p_ext;
  if (J) J->block(dyn_row0, l.v1(), l.nv, l.nv) += c.M;
  const Scene& s = *c.model;
  for (int bi : s.dynamic_bodies()) {
    const int qo = c.pose_offset[bi], vo = s.index(bi).v, qi = s.index(bi).q;
    const int row = kin_row0 + qo;
    const auto q1 = z.segment(l.q1() + qo, c.kq);
    const auto v = v1.segment(vo, c.nvb);
    if (c.dim == Dim::kPlanar) {
      F->segment(row, 3) = q1 - c.x.q.segment(qi, 3) - c.h * v;
    } else {
      F->segment(row, 3) = q1.head<3>() - c.x.q.segment(qi, 3) - c.h * v.head<3>();
      F->segment(row + 3, 3) = q1.tail<3>() - c.h * v.tail<3>();
    }
    F->segment(row, c.kq) *= kin_scale;
    if (J) {
      J->block(row, l.q1() + qo, c.kq, c.kq) += kin_scale * MatrixXd::Identity(c.kq, c.kq);
      J->block(row, l.v1() + vo, c.kq, c.nvb) -= kin_scale * c.h * MatrixXd::Identity(c.kq, c.nvb);
    }
  }
}

// Pair k's storage in c.buf, with room for its local row counts (d, d − 1, 1, ν_b, m_a, m_b).
PairScratch& PairBuffers(const Context& c, int k) {
  const GiPair& p = c.pairs[k];
  return c.buf.Pair(k, std::max({6, p.m_a, p.m_b}));
}

// The solver form of the step: F(z) (in z's order) and its Jacobian.
void SolverResidual(const Context& c, const VectorXd& z, VectorXd* F, MatrixXd* J) {
  const StepLayout& l = c.layout;
  const int nz = l.size();
  F->setZero(nz);
  if (J) J->setZero(nz, nz);
  BodyRows(c, z, l.v1(), l.q1(), 1.0 / c.h, F, J);
  std::vector<BodyAt>& bodies = c.buf.bodies;
  BodiesAt(c, z, &bodies);
  for (int k = 0; k < static_cast<int>(c.pairs.size()); ++k) {
    const GiPair& p = c.pairs[k];
    PairScratch& ps = PairBuffers(c, k);
    ReadPair(c, k, z, &ps.u);
    EvalPair(c, k, bodies, &ps);
    const PairUnknowns& u = ps.u;
    const PairEval& e = ps.e;
    AddWrenches(c, k, bodies, &ps, l.v1(), F, J);
    const int L = LocalSize(p);
    int o = c.geo[k];
    // Local rows passed to Scatter, r × L (the expression it was given, evaluated).
    const auto rows = [&ps](const auto& expr) -> const MatrixXd& {
      MatrixXd& m = ps.rows[expr.rows()];
      m = expr;
      return m;
    };
    // Geometry rows, paired with a_1, a_2, l_1, l_2, λ, μ, divided by h like the kinematics
    // rows: a pose change h Δν then changes them by O(Δν), which keeps the Jacobian well scaled
    // when contact forces trade against tiny velocity changes.
    const double g = 1.0 / c.h;
    // Tie-breaker: + κ_a (a_1 − a_1,start), so that a_1 is unique where the closest points are
    // not (parallel flat faces carrying no load); see kPointTieBreak.
    const PairUnknowns& pu = u;
    F->segment(o, c.d) = g * (e.sep.head(c.d) + kPointTieBreak * (pu.a1 - c.a1_start[k]).head(c.d));
    F->segment(o + c.d, c.d) = g * e.par.head(c.d);
    (*F)[o + 2 * c.d] = g * e.side_a;
    (*F)[o + 2 * c.d + 1] = g * e.side_b;
    if (J) {
      Scatter(c, k, bodies, rows(g * e.d_sep.topRows(c.d)), o, J);
      for (int i = 0; i < c.d; ++i) (*J)(o + i, o + i) += g * kPointTieBreak;
      Scatter(c, k, bodies, rows(g * e.d_par.topRows(c.d)), o + c.d, J);
      Scatter(c, k, bodies, rows(g * e.d_side_a), o + 2 * c.d, J);
      Scatter(c, k, bodies, rows(g * e.d_side_b), o + 2 * c.d + 1, J);
    }
    o += 2 * c.d + 2;
    if (p.m_a > 1) {
      F->segment(o, p.m_a) = -g * e.fa;
      if (J) Scatter(c, k, bodies, rows(-g * e.d_fa), o, J);
      o += p.m_a;
    }
    if (p.m_b > 1) {
      F->segment(o, p.m_b) = -g * e.fb;
      if (J) Scatter(c, k, bodies, rows(-g * e.d_fb), o, J);
    }
    // Normal: 0 ≤ p_n ⊥ ψ + ε_n p_n ≥ 0 (ε_n = h κ_n / r, see kNormalCompliance).
    const double eps_n = c.h * kNormalCompliance / c.scale[k];
    // The row is divided by h (a velocity, like the other rows' scale; complementarity is
    // unchanged by a positive factor).
    const double diag = c.law_diagonal[k] + eps_n;
    (*F)[l.pn() + k] = (e.psi + diag * u.pn + c.law_constant[k]) / c.h;
    if (J) {
      Scatter(c, k, bodies, rows(e.d_psi / c.h), l.pn() + k, J);
      (*J)(l.pn() + k, l.pn() + k) += diag / c.h;
    }
    // Friction (semismooth projection form), rows paired with p_t and σ.
    const int nd = c.nd;
    const double r = c.scale[k];
    const double rho = p.mu * u.pn;
    // v_t + ε p_t: the stick compliance ε = kStickCompliance / r makes statically
    // indeterminate sticking contacts (a sphere in a groove) non-singular.
    const double eps = kStickCompliance / r;
    VectorXd &pt = ps.pt, &vt = ps.vt, &w = ps.w, &wh = ps.wh, &fric = ps.fric;
    pt = u.pt.head(nd);
    vt = e.vt.head(nd) + eps * pt;
    MatrixXd& d_vt = ps.d_vt;
    d_vt = e.d_vt.topRows(nd);
    for (int j = 0; j < nd; ++j) d_vt(j, kPt + j) += eps;
    w = pt - r * vt;
    const double nw = w.norm();
    MatrixXd &d_w = ps.d_w, &d_rho = ps.d_rho, &d_fric = ps.d_fric, &d_sig = ps.d_sig;
    d_w = -r * d_vt;
    d_rho.setZero(1, L);
    for (int j = 0; j < nd; ++j) d_w(j, kPt + j) += 1.0;
    d_rho(0, kPn) = p.mu;
    d_fric.resize(nd, L);
    d_sig.setZero(1, L);
    fric.resize(nd);
    double sig;
    if (rho > 0.0 && nw <= rho) {  // sticking: p_t − w = r v_t
      fric = r * vt;
      d_fric = r * d_vt;
      sig = r * u.sigma;
    } else {  // sliding or no normal impulse: p_t = ρ ŵ, r σ = ‖w‖ − ρ
      if (nw > 0.0) {
        wh = w / nw;
      } else {
        wh.setZero(nd);
      }
      fric = pt - rho * wh;
      sig = r * u.sigma - (nw - rho);
      ps.prod.noalias() = -wh * d_rho;
      d_fric = ps.prod;
      for (int j = 0; j < nd; ++j) d_fric(j, kPt + j) += 1.0;
      if (nw > 0.0) {
        // (ρ/‖w‖) (I − ŵ ŵᵀ) ∂w, its factors evaluated as Eigen evaluates the nested product
        ps.outer.noalias() = wh * wh.transpose();
        ps.proj = MatrixXd::Identity(nd, nd) - ps.outer;
        ps.prod.noalias() = (rho / nw) * ps.proj * d_w;
        d_fric -= ps.prod;
      }
      ps.row_a.noalias() = wh.transpose() * d_w;
      d_sig = -ps.row_a + d_rho;
    }
    d_sig(0, kSig) += r;
    F->segment(l.pf() + k * nd, nd) = fric;
    (*F)[l.sigma() + k] = sig;
    if (J) {
      Scatter(c, k, bodies, d_fric, l.pf() + k * nd, J);
      Scatter(c, k, bodies, d_sig, l.sigma() + k, J);
    }
  }
}

std::string Describe(const Scene& s, int body, int shape) {
  return "body '" + s.bodies[body].name + "' shape '" + s.bodies[body].shapes[shape].name + "'";
}

// Pose at t + h and secant velocity over the step of a non-dynamic body.
BodyKinematics MovingKinematics(const Scene& s, int body, double t, double h) {
  const Body& b = s.bodies[body];
  BodyKinematics k;
  if (b.kind == BodyKind::kStatic) {
    k.X_WB = b.X_WB0;
    return k;
  }
  const bool planar = s.dim == Dim::kPlanar;
  const BodyKinematics k0 = EvaluateMotion(b.motion, b.X_WB0, planar, t);
  k = EvaluateMotion(b.motion, b.X_WB0, planar, t + h);
  k.v_WB = (k.X_WB.translation() - k0.X_WB.translation()) / h;
  k.w_WB = LogSO3(k.X_WB.linear() * k0.X_WB.linear().transpose()) / h;
  return k;
}

StepResiduals EvaluateContext(const Context& c, const Params& params, const VectorXd& z) {
  const Scene& model = *c.model;
  const State& x = c.x;
  StepResiduals r;
  r.layout = c.layout;
  const StepLayout& l = c.layout;
  if (z.size() != l.size())
    throw std::invalid_argument("GeometricallyImplicit::Evaluate: z has " +
                                std::to_string(z.size()) + " entries, the step layout needs " +
                                std::to_string(l.size()));
  if (params.values.size() != model.param_table().size())
    throw std::invalid_argument("GeometricallyImplicit::Evaluate: params do not match the scene");
  std::vector<int> column_of(params.values.size(), -1);
  for (int i = 0; i < model.param_table().size(); ++i) {
    const ParamKind kind = model.param_table().info(i).kind;
    if (kind == ParamKind::kDefaultFriction || kind == ParamKind::kFriction ||
        kind == ParamKind::kMass) {
      column_of[i] = l.size() + static_cast<int>(r.param_columns.size());
      r.param_columns.push_back(i);
    }
  }
  const int nz = l.size(), ncol = nz + static_cast<int>(r.param_columns.size());
  const int nd = c.nd, d = c.d;
  int n_eq = l.nv + l.nq, n_comp = 0;
  for (const GiPair& p : c.pairs) {
    n_eq += 2 * d + 2 + nd;
    n_comp += 2 + (p.m_a > 1 ? p.m_a : 0) + (p.m_b > 1 ? p.m_b : 0);
  }
  r.equality = VectorXd::Zero(n_eq);
  r.comp_a = VectorXd::Zero(n_comp);
  r.comp_b = VectorXd::Zero(n_comp);
  MatrixXd Jeq = MatrixXd::Zero(n_eq, nz);
  r.d_comp_a = MatrixXd::Zero(n_comp, ncol);
  r.d_comp_b = MatrixXd::Zero(n_comp, ncol);
  MatrixXd Jb = MatrixXd::Zero(n_comp, nz);
  BodyRows(c, z, 0, l.nv, 1.0, &r.equality, &Jeq);
  std::vector<BodyAt>& bodies = c.buf.bodies;
  BodiesAt(c, z, &bodies);
  int row = l.nv + l.nq, crow = 0;
  r.d_equality = MatrixXd::Zero(n_eq, ncol);
  for (int k = 0; k < l.nc; ++k) {
    const GiPair& p = c.pairs[k];
    PairScratch& ps = PairBuffers(c, k);
    ReadPair(c, k, z, &ps.u);
    EvalPair(c, k, bodies, &ps);
    const PairUnknowns& pu = ps.u;
    const PairEval& e = ps.e;
    AddWrenches(c, k, bodies, &ps, 0, &r.equality, &Jeq);
    r.equality.segment(row, d) = e.sep.head(d) + kPointTieBreak * (pu.a1 - c.a1_start[k]).head(d);
    Scatter(c, k, bodies, e.d_sep.topRows(d), row, &Jeq);
    for (int i = 0; i < d; ++i) Jeq(row + i, c.geo[k] + i) += kPointTieBreak;
    r.equality.segment(row + d, d) = e.par.head(d);
    Scatter(c, k, bodies, e.d_par.topRows(d), row + d, &Jeq);
    r.equality[row + 2 * d] = e.side_a;
    Scatter(c, k, bodies, e.d_side_a, row + 2 * d, &Jeq);
    r.equality[row + 2 * d + 1] = e.side_b;
    Scatter(c, k, bodies, e.d_side_b, row + 2 * d + 1, &Jeq);
    // §2 friction: μ p_n v_t' + σ p_t = 0 with the solver's v_t' = v_t + (κ_t/r) p_t.
    const int fr = row + 2 * d + 2;
    const double rk = c.scale[k], eps_t = kStickCompliance / rk;
    for (int j = 0; j < nd; ++j) {
      const double vt = e.vt[j] + eps_t * pu.pt[j];
      r.equality[fr + j] = p.mu * pu.pn * vt + pu.sigma * pu.pt[j];
      MatrixXd dl = p.mu * pu.pn * e.d_vt.row(j);
      dl(0, kPn) += p.mu * vt;
      dl(0, kSig) += pu.pt[j];
      dl(0, kPt + j) += pu.sigma + p.mu * pu.pn * eps_t;
      Scatter(c, k, bodies, dl, fr + j, &Jeq);
      r.d_equality(fr + j, column_of[p.mu_param]) = pu.pn * vt;
      // r is the mass of scale_body: ∂/∂m of (κ_t/r) p_t.
      for (int i = 0; i < model.param_table().size(); ++i) {
        const ParamInfo& info = model.param_table().info(i);
        if (info.kind == ParamKind::kMass && info.a == c.scale_body[k])
          r.d_equality(fr + j, column_of[i]) += -p.mu * pu.pn * eps_t / rk * pu.pt[j];
      }
    }
    row += 2 * d + 2 + nd;
    // Complementarity: (p_n, ψ), (σ, μ² p_n² − ‖p_t‖²), (λ_i, −f_i), (μ_j, −g_j).
    r.comp_a[crow] = pu.pn;
    r.d_comp_a(crow, l.pn() + k) = 1.0;
    // ψ + (h κ_n / r + law) p_n + law constant, as the solver's normal row.
    const double eps_n = c.h * kNormalCompliance / rk;
    r.comp_b[crow] = e.psi + (c.law_diagonal[k] + eps_n) * pu.pn + c.law_constant[k];
    Scatter(c, k, bodies, e.d_psi, crow, &Jb);
    Jb(crow, l.pn() + k) += c.law_diagonal[k] + eps_n;
    for (int i = 0; i < model.param_table().size(); ++i) {
      const ParamInfo& info = model.param_table().info(i);
      if (info.kind == ParamKind::kMass && info.a == c.scale_body[k])
        r.d_comp_b(crow, column_of[i]) += -eps_n / rk * pu.pn;
    }
    ++crow;
    r.comp_a[crow] = pu.sigma;
    r.d_comp_a(crow, l.sigma() + k) = 1.0;
    r.comp_b[crow] = p.mu * p.mu * pu.pn * pu.pn - pu.pt.head(nd).squaredNorm();
    Jb(crow, l.pn() + k) = 2.0 * p.mu * p.mu * pu.pn;
    for (int j = 0; j < nd; ++j) Jb(crow, l.pf() + k * nd + j) = -2.0 * pu.pt[j];
    r.d_comp_b(crow, column_of[p.mu_param]) = 2.0 * p.mu * pu.pn * pu.pn;
    ++crow;
    // One side's multipliers (λ or μ, at unknown column o) against its constraints −f.
    int o = c.geo[k] + 2 * d + 2;
    auto side = [&](int m, const auto& mult, const auto& f, const auto& d_f) {
      if (m <= 1) return;
      for (int i = 0; i < m; ++i) {
        r.comp_a[crow + i] = mult[i];
        r.d_comp_a(crow + i, o + i) = 1.0;
      }
      r.comp_b.segment(crow, m) = -f;
      Scatter(c, k, bodies, -d_f, crow, &Jb);
      crow += m;
      o += m;
    };
    side(p.m_a, pu.lam, e.fa, e.d_fa);
    side(p.m_b, pu.mu, e.fb, e.d_fb);
  }
  r.d_equality.leftCols(nz) = Jeq;
  r.d_comp_b.leftCols(nz) = Jb;
  // ∂(dynamics rows)/∂m: M_b and p_ext scale with the mass (inertia ∝ mass).
  for (int i = 0; i < model.param_table().size(); ++i) {
    const ParamInfo& info = model.param_table().info(i);
    if (info.kind != ParamKind::kMass) continue;
    const Body& b = model.bodies[info.a];
    if (b.kind != BodyKind::kDynamic) continue;
    const int o = model.index(info.a).v, nvb = c.nvb, nlin = d;
    const VectorXd dv = z.segment(l.v1() + o, nvb) - x.v.segment(o, nvb);
    VectorXd dm = c.M.block(o, o, nvb, nvb) * dv / b.mass;
    if (b.gravity) dm.head(nlin) -= c.h * model.gravity_W.head(nlin);
    if (model.dim == Dim::kSpatial) {
      const Vector3d w_B = x.v.segment<3>(o + 3);
      dm.tail<3>() += c.h * w_B.cross(b.inertia * w_B) / b.mass;
    }
    r.d_equality.block(o, column_of[i], nvb, 1) = dm;
  }
  return r;
}
}  // namespace vinci::sim::gi
