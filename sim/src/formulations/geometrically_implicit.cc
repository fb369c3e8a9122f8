#include "vinci/sim/formulations/geometrically_implicit.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "../geometry/implicit_set_into.h"
#include "../solvers/scratch_lease.h"
#include "step_util.h"
#include "vinci/sim/formulations/contact.h"
#include "vinci/sim/model/compliance.h"
#include "vinci/sim/model/kinematics.h"

namespace vinci::sim {
namespace {

using Matrix6Xd = Eigen::Matrix<double, 6, Eigen::Dynamic>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

// Local columns of one pair's kernel: virtual displacements (δp, δω) of A and B, world
// velocities (v, ω) of A and B, p_n, p_t (2 slots), σ, a_1, a_2 (3 each, planar z unused), l_1,
// l_2, then λ (m_A) and μ (m_B).
constexpr int kDA = 0, kDB = 6, kVA = 12, kVB = 18, kPn = 24, kPt = 25, kSig = 27, kA1 = 28,
              kA2 = 31, kL1 = 34, kL2 = 35, kLam = 36;

// Compliances of the solver form, relative to the pair's mass scale r (1/kg). Tangential:
// sticking means v_t = −(κ_t / r) p_t, a creep below 3e-8 m/s for p_t ≤ μ m g h (h = 1e-3).
// Normal: the row is ψ + (h κ_n / r) p_n, an overlap below 1e-11 m per N·s of impulse. They make
// statically indeterminate contacts (a sphere held by two spheres: more constraints than degrees
// of freedom, a one-parameter family of normal/friction splits) non-singular; κ_t ≫ κ_n selects
// the split with the least friction, strictly inside the cone.
constexpr double kStickCompliance = 1e-5;
constexpr double kNormalCompliance = 1e-8;
// Weight of the solver form's contact-point tie-breaker (dimensionless): the separation row
// becomes a_1 − a_2 + l_1 n_A + κ_a (a_1 − a_1,start). It selects the closest points nearest the
// step's starting guess where they are not unique (a flat face parallel to another and not
// loaded: with p_n > 0 the torque balance fixes a_1); it shifts a_2 by at most κ_a ‖a_1 −
// a_1,start‖ (≤ 1e-9 m for a 0.1 m move).
constexpr double kPointTieBreak = 1e-8;
// A step whose end pose penetrates a candidate pair deeper than this (m, by ClosestPoints) is
// rejected: the solver converged to a spurious branch of the contact equations.
constexpr double kEndPenetrationCheck = 1e-6;

// Warm-start record: ids (4), m_A, m_B, p_n, p_t (2), σ, a_1 (3), a_2 (3), l_1, l_2, λ, μ.
constexpr int kRecordFixed = 20;

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
struct BodyAt {
  bool dynamic = false;
  int q_col = -1, v_col = -1;  // columns of its pose and velocity unknowns in z
  Isometry3d X = Isometry3d::Identity();
  Vector3d v = Vector3d::Zero(), w = Vector3d::Zero();  // world, at ℓ+1
  Matrix6Xd P, V;  // (δp, δω) per pose unknown; (v, ω) per ν entry
};

// The pair's unknowns read from z (3D embedding; λ ≡ 1 for a single function).
struct PairUnknowns {
  double pn = 0.0, sigma = 0.0, l1 = 0.0, l2 = 0.0;
  Vector2d pt = Vector2d::Zero();
  Vector3d a1 = Vector3d::Zero(), a2 = Vector3d::Zero();
  VectorXd lam, mu;
};

// Values and local Jacobians of one pair's geometric, kinematic and wrench quantities.
struct PairEval {
  Vector3d sep, par, n, vrel;
  double psi = 0.0, side_a = 0.0, side_b = 0.0;
  Eigen::Matrix<double, 3, 2> T = Eigen::Matrix<double, 3, 2>::Zero();
  Vector2d vt = Vector2d::Zero();
  VectorXd fa, fb;
  Vector6d WA, WB;
  MatrixXd d_sep, d_par, d_psi, d_vt, d_fa, d_fb, d_side_a, d_side_b, d_WA, d_WB;
};

using Matrix3Xd = Eigen::Matrix<double, 3, Eigen::Dynamic>;

// One pair's storage for an evaluation of the step's equations: its unknowns, values and local
// Jacobians, and EvalPair's and SolverResidual's intermediate products, each of the type Eigen
// gives the temporary it replaces (so every product is evaluated by the same kernel). Kept per
// pair: the local column count L differs between pairs.
struct PairScratch {
  PairUnknowns u;
  PairEval e;
  MatrixXd dnA, dnB, dn, dv, dP, dt[2];
  Matrix3Xd t3a, t3b;
  Eigen::RowVectorXd row_a, row_b;
  VectorXd pt, vt, w, wh, fric;
  MatrixXd d_vt, d_w, d_rho, d_fric, d_sig, outer, proj, prod, wrench;
  std::vector<MatrixXd> rows;  // local rows passed to Scatter, by row count
};

// The storage of the evaluations of one step's equations (Context::buf): reused by every
// evaluation of the step's solve and, in the stepper's per-thread scratch, by later steps.
// Allocation reuse only: every buffer is written before it is read.
struct EvalBuffers {
  std::vector<BodyAt> bodies;
  std::vector<PairScratch> pairs;  // grows only
  std::vector<MatrixXd> products;  // Scatter's products (r × k_q), by row count r
  VectorXd v1, dv, Mdv, VW;
  // Pair k's storage with room for local rows of up to `max_rows` rows.
  PairScratch& Pair(int k, int max_rows) {
    if (static_cast<int>(pairs.size()) <= k) pairs.resize(k + 1);
    PairScratch& ps = pairs[k];
    if (static_cast<int>(ps.rows.size()) <= max_rows) ps.rows.resize(max_rows + 1);
    if (static_cast<int>(products.size()) <= max_rows) products.resize(max_rows + 1);
    return ps;
  }
};

// Everything a step's equations need besides the unknowns.
struct Context {
  const Scene* model = nullptr;
  Dim dim = Dim::kPlanar;
  int d = 2, nd = 1, kq = 3, nvb = 3;
  double h = 0.0;
  State x;
  std::vector<GiPair> pairs;
  std::vector<std::vector<ImplicitSet>> sets;  // per body, per shape
  StepLayout layout;
  std::vector<int> geo;                // per pair: offset of its geometric unknowns in z
  std::vector<int> pose_offset;        // per body: offset in the pose block (−1 if not dynamic)
  std::vector<Isometry3d> X_start;     // per body at ℓ
  std::vector<BodyKinematics> moving;  // non-dynamic bodies: pose at t+h, secant velocity
  std::vector<double> scale;           // r per pair (kg)
  std::vector<int> scale_body;         // the body whose mass is r
  std::vector<Vector3d> a1_start;      // a_1 of the starting point per pair (solver form)
  // Normal law per pair: 0 ≤ p_n ⊥ ψ + law_diagonal p_n + law_constant ≥ 0. Rigid: 0, 0.
  // Quasi-rigid contact (docs/formulations.md §4) fills them from the pair's linearized law
  // (compliance.h, LinearizeNormalLaw: pos_diagonal and pos_psi0 ψ_ℓ + pos_constant).
  std::vector<double> law_diagonal, law_constant;
  std::vector<bool> compliant;  // per pair: the law is not rigid
  MatrixXd M;
  VectorXd p_ext;
  mutable EvalBuffers buf;  // evaluation storage (one thread evaluates a Context at a time)
};

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
struct FnAt {
  double f = 0.0;
  Vector3d g = Vector3d::Zero();
  Matrix3d H = Matrix3d::Zero();
};

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

}  // namespace

GeometricallyImplicit::GeometricallyImplicit(StepperOptions options, McpOptions mcp)
    : options_(std::move(options)), mcp_(mcp) {}

namespace {

// The storage of a step's candidate-pair search (PairsInto), reused between steps.
struct PairSearch {
  std::vector<BodyKinematics> kin;
  std::vector<double> speed, spin, accel;
};

void CheckNoJoints(const Scene& model) {
  if (!model.joints.empty())
    throw std::invalid_argument(
        "formulation gi: joints are not supported by the geometrically implicit stepper (joint '" +
        model.joints[0].name + "')");
}

// The implicit sets of every body's shapes into *sets (per body, per shape).
void ImplicitSetsInto(const Scene& model, std::vector<std::vector<ImplicitSet>>* sets) {
  const int n = static_cast<int>(model.bodies.size());
  sets->resize(n);
  for (int i = 0; i < n; ++i) {
    const Body& b = model.bodies[i];
    (*sets)[i].resize(b.shapes.size());
    for (std::size_t s = 0; s < b.shapes.size(); ++s) {
      try {
        MakeImplicitSetInto(b.shapes[s], &(*sets)[i][s]);
      } catch (const std::invalid_argument& e) {
        throw std::invalid_argument("formulation gi: " + Describe(model, i, static_cast<int>(s)) +
                                    " has no implicit form: " + e.what());
      }
    }
  }
}

// GeometricallyImplicit::Pairs with the scene's implicit sets given (ImplicitSetsInto), into
// *pairs, with its storage in *search.
void PairsInto(const GeometricallyImplicit& gi, const Scene& model, const State& x,
               const std::vector<std::vector<ImplicitSet>>& sets, std::string* failure,
               PairSearch* search, std::vector<GiPair>* pairs_out) {
  const int n = static_cast<int>(model.bodies.size());
  const double h = gi.options().dt;
  ComputeBodyKinematics(model, x, &search->kin);
  const std::vector<BodyKinematics>& kin = search->kin;
  std::vector<double>&speed = search->speed, &spin = search->spin, &accel = search->accel;
  speed.assign(n, 0.0);
  spin.assign(n, 0.0);
  accel.assign(n, 0.0);
  for (int i = 0; i < n; ++i) {
    const Body& b = model.bodies[i];
    if (b.kind == BodyKind::kDynamic) {
      speed[i] = kin[i].v_WB.norm();
      spin[i] = kin[i].w_WB.norm();
      accel[i] = (b.gravity ? model.gravity_W.norm() : 0.0) + b.applied_force_W.norm() / b.mass;
    } else if (b.kind == BodyKind::kPrescribed) {
      const BodyKinematics m = MovingKinematics(model, i, x.t, h);
      speed[i] = m.v_WB.norm();
      spin[i] = m.w_WB.norm();
    }
  }
  const auto bound = [&](int body, double radius) {
    const double rho = std::isfinite(radius) ? radius : 0.0;
    return 2.0 * h * (speed[body] + spin[body] * rho) + h * h * accel[body];
  };
  std::vector<GiPair>& pairs = *pairs_out;
  pairs.clear();
  for (int ia = 0; ia < n; ++ia) {
    for (int ib = ia + 1; ib < n; ++ib) {
      const Body& BA0 = model.bodies[ia];
      const Body& BB0 = model.bodies[ib];
      if (BA0.kind != BodyKind::kDynamic && BB0.kind != BodyKind::kDynamic) continue;
      if (BodiesJointed(model, ia, ib)) continue;
      const bool swap = BA0.kind != BodyKind::kDynamic;
      const int a = swap ? ib : ia, b = swap ? ia : ib;
      const Body& BA = model.bodies[a];
      const Body& BB = model.bodies[b];
      for (std::size_t sa = 0; sa < BA.shapes.size(); ++sa) {
        for (std::size_t sb = 0; sb < BB.shapes.size(); ++sb) {
          const ImplicitSet& A = sets[a][sa];
          const ImplicitSet& B = sets[b][sb];
          const double ra = A.bounding_radius, rb = B.bounding_radius;
          if (!std::isfinite(ra) && !std::isfinite(rb)) continue;  // two half-spaces
          const Isometry3d X_WA = kin[a].X_WB * BA.shapes[sa].X_BS;
          const Isometry3d X_WB = kin[b].X_WB * BB.shapes[sb].X_BS;
          const double margin = gi.options().envelope + bound(a, ra) + bound(b, rb);
          if (std::isfinite(ra) && std::isfinite(rb) &&
              (X_WA.translation() - X_WB.translation()).norm() - ra - rb > margin)
            continue;
          const ImplicitProximity prox = ClosestPoints(A, X_WA, B, X_WB);
          if (!prox.ok) {
            if (failure && failure->empty())
              *failure = "closest points of " + Describe(model, a, static_cast<int>(sa)) + " and " +
                         Describe(model, b, static_cast<int>(sb)) +
                         " did not converge at t = " + std::to_string(x.t);
            continue;
          }
          if (prox.distance > margin) continue;
          GiPair p;
          p.body_a = a;
          p.shape_a = static_cast<int>(sa);
          p.body_b = b;
          p.shape_b = static_cast<int>(sb);
          p.m_a = static_cast<int>(A.functions.size());
          p.m_b = static_cast<int>(B.functions.size());
          const int ma = BA.shapes[sa].material, mb = BB.shapes[sb].material;
          p.mu = model.Mu(ma, mb);
          p.mu_param = FrictionParamIndex(model, ma, mb);
          p.start = prox;
          int axis = 0;
          prox.n_W.cwiseAbs().minCoeff(&axis);
          p.tangent_reference = Vector3d::Unit(axis);
          pairs.push_back(p);
        }
      }
    }
  }
}

}  // namespace

std::vector<GiPair> GeometricallyImplicit::Pairs(const Scene& model, const State& x,
                                                 std::string* failure) const {
  CheckNoJoints(model);
  std::vector<std::vector<ImplicitSet>> sets;
  ImplicitSetsInto(model, &sets);
  PairSearch search;
  std::vector<GiPair> pairs;
  PairsInto(*this, model, x, sets, failure, &search, &pairs);
  return pairs;
}

namespace {

// The step's context at x into *out (every field but the evaluation buffers written, reusing
// the storage of its vectors); `frozen` (the frozen step model) gives the pairs instead of
// Pairs(x), with μ re-read from `model` (its parameters may differ from the freeze's).
void FillContext(const GeometricallyImplicit& gi, const Scene& model, const State& x,
                 const StepInput& u, std::string* failure, const std::vector<GiPair>* frozen,
                 PairSearch* search, Context* out) {
  Context& c = *out;
  c.model = &model;
  c.dim = model.dim;
  c.d = model.dim == Dim::kPlanar ? 2 : 3;
  c.nd = c.d - 1;
  c.kq = model.dim == Dim::kPlanar ? 3 : 6;
  c.nvb = VelocitySize(model.dim);
  c.h = gi.options().dt;
  c.x = x;
  if (!frozen) CheckNoJoints(model);
  ImplicitSetsInto(model, &c.sets);
  if (frozen) {
    c.pairs = *frozen;
    for (GiPair& p : c.pairs)
      p.mu = model.Mu(model.bodies[p.body_a].shapes[p.shape_a].material,
                      model.bodies[p.body_b].shapes[p.shape_b].material);
  } else {
    PairsInto(gi, model, x, c.sets, failure, search, &c.pairs);
  }
  const int n = static_cast<int>(model.bodies.size());
  c.pose_offset.assign(n, -1);
  c.X_start.assign(n, Isometry3d::Identity());
  c.moving.assign(n, BodyKinematics{});
  int nq = 0;
  for (int i = 0; i < n; ++i) {
    if (model.bodies[i].kind == BodyKind::kDynamic) {
      c.pose_offset[i] = nq;
      nq += c.kq;
      c.X_start[i] = PoseFromQ(model.dim, x.q.data() + model.index(i).q);
    } else {
      c.moving[i] = MovingKinematics(model, i, x.t, c.h);
    }
  }
  StepLayout& l = c.layout;
  l.nq = nq;
  l.nv = model.num_velocities();
  l.nc = static_cast<int>(c.pairs.size());
  l.nd = c.nd;
  l.nb = 0;
  for (const GiPair& p : c.pairs) l.nb += p.GeometrySize(model.dim);
  c.geo.clear();
  c.compliant.clear();
  c.law_diagonal.clear();
  c.law_constant.clear();
  c.scale.clear();
  c.scale_body.clear();
  c.a1_start.clear();
  int o = l.pb();
  for (const GiPair& p : c.pairs) {
    c.geo.push_back(o);
    o += p.GeometrySize(model.dim);
    // Normal law (compliance.h, position form): 0 ≤ p_n ⊥ ψ + a p_n + b ψ_ℓ + e ≥ 0 with
    // a = pos_diagonal, b = pos_psi0, e = pos_constant of the pair's law linearized about
    // ψ_ℓ = the signed distance at q_ℓ (ClosestPoints). Rigid pairs: a = b = e = 0.
    const CompliantNormalRow law = LinearizeNormalLaw(
        CombineCompliance(model.bodies[p.body_a].compliance, model.bodies[p.body_b].compliance),
        p.start.distance, c.h);
    c.compliant.push_back(law.compliant);
    c.law_diagonal.push_back(law.compliant ? law.pos_diagonal : 0.0);
    c.law_constant.push_back(law.compliant ? law.pos_psi0 * p.start.distance + law.pos_constant
                                           : 0.0);
    double r = std::numeric_limits<double>::infinity();
    int rb = -1;
    for (int b : {p.body_a, p.body_b}) {
      if (model.bodies[b].kind == BodyKind::kDynamic && model.bodies[b].mass < r) {
        r = model.bodies[b].mass;
        rb = b;
      }
    }
    c.scale.push_back(r);
    c.scale_body.push_back(rb);
  }

  // Mass matrix and external impulses (as in the Stewart–Trinkle stepper).
  const int nv = l.nv;
  const double h = c.h;
  c.M = MatrixXd::Zero(nv, nv);
  c.p_ext = VectorXd::Zero(nv);
  for (int bi : model.dynamic_bodies()) {
    const Body& b = model.bodies[bi];
    const int vo = model.index(bi).v;
    const Vector3d f =
        b.applied_force_W + (b.gravity ? Vector3d(b.mass * model.gravity_W) : Vector3d::Zero());
    if (model.dim == Dim::kPlanar) {
      c.M(vo, vo) = c.M(vo + 1, vo + 1) = b.mass;
      c.M(vo + 2, vo + 2) = b.inertia(2, 2);
      c.p_ext.segment<3>(vo) = h * Vector3d(f.x(), f.y(), b.applied_torque_W.z());
    } else {
      c.M.block<3, 3>(vo, vo) = b.mass * Matrix3d::Identity();
      c.M.block<3, 3>(vo + 3, vo + 3) = b.inertia;
      const Matrix3d& R = c.X_start[bi].linear();
      const Vector3d w_B = x.v.segment<3>(vo + 3);
      c.p_ext.segment<3>(vo) = h * f;
      c.p_ext.segment<3>(vo + 3) =
          h * (R.transpose() * b.applied_torque_W - w_B.cross(b.inertia * w_B));
    }
  }
  if (u.generalized_force.size() == nv) c.p_ext += h * u.generalized_force;
}

// FillContext into a new Context.
Context MakeContext(const GeometricallyImplicit& gi, const Scene& model, const State& x,
                    const StepInput& u, std::string* failure,
                    const std::vector<GiPair>* frozen = nullptr) {
  Context c;
  PairSearch search;
  FillContext(gi, model, x, u, failure, frozen, &search, &c);
  return c;
}

// Starting point into *z_out: ν_ℓ, q_ℓ + h ν_ℓ, pair records from the warm start or closest
// points at ℓ. *record_at is storage.
void InitialGuessInto(const Context& c, std::vector<int>* record_at_out, VectorXd* z_out) {
  const StepLayout& l = c.layout;
  const Scene& s = *c.model;
  VectorXd& z = *z_out;
  z.setZero(l.size());
  z.segment(l.v1(), l.nv) = c.x.v;
  for (int bi : s.dynamic_bodies()) {
    const int qo = l.q1() + c.pose_offset[bi];
    const auto q = c.x.q.segment(s.index(bi).q, PositionSize(c.dim));
    const auto v = c.x.v.segment(s.index(bi).v, c.nvb);
    if (c.dim == Dim::kPlanar) {
      z.segment(qo, 3) = q + c.h * v;
    } else {
      z.segment(qo, 3) = q.head<3>() + c.h * v.head<3>();
      z.segment(qo + 3, 3) = c.h * v.tail<3>();
    }
  }
  // Index the warm-start records by pair identity.
  const VectorXd& ws = c.x.warm_start;
  std::vector<int>& record_at = *record_at_out;
  record_at.clear();
  if (ws.size() >= 1) {
    const int count = static_cast<int>(ws[0]);
    int o = 1;
    for (int i = 0; i < count && o + kRecordFixed <= ws.size(); ++i) {
      const int len = kRecordFixed + static_cast<int>(ws[o + 4]) + static_cast<int>(ws[o + 5]);
      if (len < kRecordFixed || o + len > ws.size()) break;
      record_at.push_back(o);
      o += len;
    }
  }
  for (int k = 0; k < l.nc; ++k) {
    const GiPair& p = c.pairs[k];
    int rec = -1;
    for (int o : record_at) {
      if (static_cast<int>(ws[o]) == p.body_a && static_cast<int>(ws[o + 1]) == p.shape_a &&
          static_cast<int>(ws[o + 2]) == p.body_b && static_cast<int>(ws[o + 3]) == p.shape_b &&
          static_cast<int>(ws[o + 4]) == p.m_a && static_cast<int>(ws[o + 5]) == p.m_b) {
        rec = o;
        break;
      }
    }
    const int g = c.geo[k];
    int o = g + 2 * c.d + 2;
    if (rec >= 0) {
      z[l.pn() + k] = ws[rec + 6];
      for (int j = 0; j < c.nd; ++j) z[l.pf() + k * c.nd + j] = ws[rec + 7 + j];
      z[l.sigma() + k] = ws[rec + 9];
      for (int j = 0; j < c.d; ++j) {
        z[g + j] = ws[rec + 10 + j];
        z[g + c.d + j] = ws[rec + 13 + j];
      }
      z[g + 2 * c.d] = ws[rec + 16];
      z[g + 2 * c.d + 1] = ws[rec + 17];
      int r = rec + kRecordFixed;
      if (p.m_a > 1) {
        z.segment(o, p.m_a) = ws.segment(r, p.m_a);
        o += p.m_a;
      }
      r += p.m_a;
      if (p.m_b > 1) z.segment(o, p.m_b) = ws.segment(r, p.m_b);
      continue;
    }
    // New pair: closest points at ℓ, multiplier 1 on the active functions.
    const ImplicitProximity& pr = p.start;
    z.segment(g, c.d) = pr.a1_W.head(c.d);
    z.segment(g + c.d, c.d) = pr.a2_W.head(c.d);
    const Shape& sa = s.bodies[p.body_a].shapes[p.shape_a];
    const Shape& sb = s.bodies[p.body_b].shapes[p.shape_b];
    const auto pose = [&](int body) {
      return s.bodies[body].kind == BodyKind::kDynamic
                 ? c.X_start[body]
                 : EvaluateMotion(s.bodies[body].motion, s.bodies[body].X_WB0,
                                  c.dim == Dim::kPlanar, c.x.t)
                       .X_WB;
    };
    const int ia = std::max(pr.active_a, 0), ib = std::max(pr.active_b, 0);
    const ImplicitSet& set_a = c.sets[p.body_a][p.shape_a];
    const ImplicitSet& set_b = c.sets[p.body_b][p.shape_b];
    const Isometry3d X_WA = pose(p.body_a) * sa.X_BS, X_WB = pose(p.body_b) * sb.X_BS;
    // Face on face (both active functions flat): any point of the common face is a closest
    // point; start from the one below A's centre (where a resting load puts it) if it lies on
    // both faces.
    const auto flat = [](ImplicitType t) {
      return t == ImplicitType::kHalfspace || t == ImplicitType::kHalfPlane;
    };
    if (flat(set_a.functions[ia].type) && flat(set_b.functions[ib].type)) {
      const Vector3d n = pr.n_W;
      const Vector3d shift =
          (Matrix3d::Identity() - n * n.transpose()) * (X_WA * set_a.center_S - pr.a1_W);
      const Vector3d a1 = pr.a1_W + shift, a2 = pr.a2_W + shift;
      const double tol_a =
          1e-9 * (1.0 + (std::isfinite(set_a.bounding_radius) ? set_a.bounding_radius : 0.0));
      const double tol_b =
          1e-9 * (1.0 + (std::isfinite(set_b.bounding_radius) ? set_b.bounding_radius : 0.0));
      if (set_a.Contains(X_WA.inverse() * a1, tol_a) &&
          set_b.Contains(X_WB.inverse() * a2, tol_b)) {
        z.segment(g, c.d) = a1.head(c.d);
        z.segment(g + c.d, c.d) = a2.head(c.d);
      }
    }
    const Vector3d a1_start = Vector3d(z[g], z[g + 1], c.d == 3 ? z[g + 2] : 0.0);
    const Vector3d a2_start = Vector3d(z[g + c.d], z[g + c.d + 1], c.d == 3 ? z[g + c.d + 2] : 0.0);
    const FnAt fa = EvalFn(set_a.functions[ia], X_WA, a1_start);
    const FnAt fb = EvalFn(set_b.functions[ib], X_WB, a2_start);
    const double na = std::max(fa.g.norm(), 1e-12), nb = std::max(fb.g.norm(), 1e-12);
    z[g + 2 * c.d] = pr.distance / na;
    z[g + 2 * c.d + 1] = na / nb;
    if (p.m_a > 1) {
      z[o + ia] = 1.0;
      o += p.m_a;
    }
    if (p.m_b > 1) z[o + ib] = 1.0;
  }
}

VectorXd InitialGuess(const Context& c) {
  std::vector<int> record_at;
  VectorXd z;
  InitialGuessInto(c, &record_at, &z);
  return z;
}

// The warm-start vector of the solution z (format in the header) into *ws_out.
void WarmStartOfInto(const Context& c, const VectorXd& z, VectorXd* ws_out) {
  int len = 1;
  for (const GiPair& p : c.pairs) len += kRecordFixed + p.m_a + p.m_b;
  VectorXd& ws = *ws_out;
  ws.setZero(len);
  ws[0] = static_cast<double>(c.pairs.size());
  int o = 1;
  for (int k = 0; k < c.layout.nc; ++k) {
    const GiPair& p = c.pairs[k];
    PairUnknowns& u = PairBuffers(c, k).u;
    ReadPair(c, k, z, &u);
    ws[o] = p.body_a;
    ws[o + 1] = p.shape_a;
    ws[o + 2] = p.body_b;
    ws[o + 3] = p.shape_b;
    ws[o + 4] = p.m_a;
    ws[o + 5] = p.m_b;
    ws[o + 6] = u.pn;
    ws.segment<2>(o + 7) = u.pt;
    ws[o + 9] = u.sigma;
    ws.segment<3>(o + 10) = u.a1;
    ws.segment<3>(o + 13) = u.a2;
    ws[o + 16] = u.l1;
    ws[o + 17] = u.l2;
    ws.segment(o + kRecordFixed, p.m_a) = u.lam;
    ws.segment(o + kRecordFixed + p.m_a, p.m_b) = u.mu;
    o += kRecordFixed + p.m_a + p.m_b;
  }
}

VectorXd WarmStartOf(const Context& c, const VectorXd& z) {
  VectorXd ws;
  WarmStartOfInto(c, z, &ws);
  return ws;
}

// The step's MCP bounds into *prob (its evaluate is left to the caller).
void FillBounds(const Context* c, McpProblem* out) {
  McpProblem& prob = *out;
  const StepLayout& l = c->layout;
  const int n = l.size();
  const double inf = std::numeric_limits<double>::infinity();
  prob.lower.setConstant(n, -inf);
  prob.upper.setConstant(n, inf);
  prob.lower.segment(l.pn(), l.nc).setZero();
  for (int k = 0; k < l.nc; ++k) {
    const GiPair& p = c->pairs[k];
    // l_2 ≥ 0: anti-parallel normals. l_2 < 0 (parallel normals) is a spurious branch, e.g. a
    // box below a floor touching it with its top face; l_2 = 0 is never a solution (n_A ≠ 0).
    prob.lower[c->geo[k] + 2 * c->d + 1] = 0.0;
    int o = c->geo[k] + 2 * c->d + 2;
    if (p.m_a > 1) {
      prob.lower.segment(o, p.m_a).setZero();
      o += p.m_a;
    }
    if (p.m_b > 1) prob.lower.segment(o, p.m_b).setZero();
  }
}

McpProblem MakeProblem(std::shared_ptr<const Context> c) {
  McpProblem prob;
  FillBounds(c.get(), &prob);
  prob.evaluate = [c](const VectorXd& z, VectorXd* F, MatrixXd* J) { SolverResidual(*c, z, F, J); };
  return prob;
}

}  // namespace

// Fills the solver form's tie-breaker reference from the starting point.
static void SetStart(Context* c, const VectorXd& z0) {
  c->a1_start.assign(c->pairs.size(), Vector3d::Zero());
  for (int k = 0; k < c->layout.nc; ++k) c->a1_start[k].head(c->d) = z0.segment(c->geo[k], c->d);
}

McpProblem GeometricallyImplicit::StepProblem(const Scene& model, const State& x,
                                              const StepInput& u, VectorXd* z0) const {
  std::string failure;
  auto c = std::make_shared<Context>(MakeContext(*this, model, x, u, &failure));
  const VectorXd guess = InitialGuess(*c);
  SetStart(c.get(), guess);
  if (z0) *z0 = guess;
  return MakeProblem(c);
}

StepLayout GeometricallyImplicit::Layout(const Scene& model, const State& x) const {
  std::string failure;
  return MakeContext(*this, model, x, StepInput{}, &failure).layout;
}

namespace {
// GeometricallyImplicit::Step's storage, one per thread (scratch_lease.h).
struct GiStepScratch {
  Context c;
  PairSearch search;
  std::vector<int> record_at;
  VectorXd z;
  McpProblem prob;
};
}  // namespace

void GeometricallyImplicit::Step(const Scene& model, const State& x, const StepInput& u,
                                 Workspace* ws, State* next, StepInfo* info) const {
  internal::BeginStep(x, next, info);
  std::string failure;
  internal::ScratchLease<GiStepScratch> lease;
  GiStepScratch& scratch = lease.get();
  Context* c = &scratch.c;
  FillContext(*this, model, x, u, &failure, nullptr, &scratch.search, c);
  const StepLayout& l = c->layout;
  info->contacts = l.nc;
  info->min_gap = 0.0;
  for (int k = 0; k < l.nc; ++k)
    info->min_gap =
        k == 0 ? c->pairs[k].start.distance : std::min(info->min_gap, c->pairs[k].start.distance);
  if (!failure.empty()) {
    internal::FailStep(StepStatus::kGeometryFailed, failure, info);
    return;
  }
  if (!internal::CheckStartPenetration(l.nc, options_.max_penetration, info)) return;
  VectorXd& z = scratch.z;
  InitialGuessInto(*c, &scratch.record_at, &z);
  if (!z.allFinite()) {  // e.g. q_ℓ + h ν_ℓ beyond the range of doubles
    internal::FailStep(StepStatus::kNonFinite,
                       "geometrically implicit step: non-finite starting point (the predicted "
                       "state q + h v is not finite)",
                       info);
    return;
  }
  SetStart(c, z);
  McpProblem& prob = scratch.prob;
  FillBounds(c, &prob);
  // Bound to this thread's context (a pointer: the std::function holds it without allocating).
  prob.evaluate = [c](const VectorXd& zi, VectorXd* F, MatrixXd* J) {
    SolverResidual(*c, zi, F, J);
  };
  info->solver = McpSolver(mcp_).Solve(prob, &z);
  if (!info->solver.ok() && x.warm_start.size() > 0) {
    // Retry from a cold start (closest points at ℓ for every pair, ν_ℓ): a warm start from the
    // previous step can sit in the wrong basin when a contact jumps (a rocking box landing flat).
    // The tie-breaker keeps the first start's reference, so the equations solved are the same.
    Context cold = *c;
    cold.x.warm_start.resize(0);
    VectorXd z_cold = InitialGuess(cold);
    if (!z_cold.allFinite()) z_cold = z;  // (finite: checked above)
    const SolverReport first = info->solver;
    info->solver = McpSolver(mcp_).Solve(prob, &z_cold);
    info->solver.iterations += first.iterations;
    info->solver.time_s += first.time_s;
    if (info->solver.ok()) z = z_cold;
  }
  if (!info->solver.ok()) {
    internal::SolverFailed("geometrically implicit step: MCP solver", info);
    info->failure += " after " + std::to_string(info->solver.iterations) +
                     " iterations, residual " + internal::FormatNumber(info->solver.residual);
    return;
  }
  // Next state: ν, and the pose the constraints were solved at.
  next->t = x.t + c->h;
  next->v = z.segment(l.v1(), l.nv);
  for (int bi : model.dynamic_bodies()) {
    const int qo = l.q1() + c->pose_offset[bi];
    double* q = next->q.data() + model.index(bi).q;
    if (model.dim == Dim::kPlanar) {
      for (int i = 0; i < 3; ++i) q[i] = z[qo + i];
    } else {
      Isometry3d X = Isometry3d::Identity();
      X.translation() = z.segment<3>(qo);
      X.linear() = c->X_start[bi].linear() * ExpSO3(z.segment<3>(qo + 3));
      PoseToQ(model.dim, X, q);
      // Keep the quaternion's sign continuous with q_ℓ.
      const Eigen::Vector4d q0 = x.q.segment<4>(model.index(bi).q + 3);
      Eigen::Map<Eigen::Vector4d> q1(q + 3);
      if (q0.dot(q1) < 0.0) q1 = -q1;
    }
  }
  if (!next->v.allFinite() || !next->q.allFinite()) {
    *next = x;
    internal::FailStep(StepStatus::kNonFinite, "non-finite state after the step", info);
    return;
  }
  // Safety net: a converged solve on a spurious branch of the contact equations (closest points
  // that are not the closest pair) would let bodies pass through each other; check the pairs'
  // distance at ℓ+1 independently.
  for (int k = 0; k < l.nc; ++k) {
    const GiPair& p = c->pairs[k];
    const auto pose = [&](int b) {
      return model.bodies[b].kind == BodyKind::kDynamic
                 ? PoseFromQ(model.dim, next->q.data() + model.index(b).q)
                 : c->moving[b].X_WB;
    };
    const ImplicitProximity end =
        ClosestPoints(c->sets[p.body_a][p.shape_a],
                      pose(p.body_a) * model.bodies[p.body_a].shapes[p.shape_a].X_BS,
                      c->sets[p.body_b][p.shape_b],
                      pose(p.body_b) * model.bodies[p.body_b].shapes[p.shape_b].X_BS);
    // A compliant pair may overlap by its law's overlap a p_n + b ψ_ℓ + e at the solution.
    const double law_overlap =
        c->compliant[k] ? std::max(0.0, c->law_diagonal[k] * z[l.pn() + k] + c->law_constant[k])
                        : 0.0;
    if (end.ok && end.distance < -(law_overlap + kEndPenetrationCheck)) {
      internal::FailStep(StepStatus::kPenetration,
                         "geometrically implicit step: the solution penetrates by " +
                             internal::FormatNumber(-end.distance) +
                             " m at the end of the step (pair of bodies '" +
                             model.bodies[p.body_a].name + "' and '" + model.bodies[p.body_b].name +
                             "'): a spurious branch of the contact equations",
                         info);
      *next = x;
      return;
    }
  }
  WarmStartOfInto(*c, z, &next->warm_start);
  if (ws) {
    ws->contacts.clear();
    std::vector<BodyAt>& bodies = c->buf.bodies;
    BodiesAt(*c, z, &bodies);
    for (int k = 0; k < l.nc; ++k) {
      const GiPair& p = c->pairs[k];
      PairScratch& ps = PairBuffers(*c, k);
      ReadPair(*c, k, z, &ps.u);
      EvalPair(*c, k, bodies, &ps);
      const PairUnknowns& pu = ps.u;
      const PairEval& e = ps.e;
      Contact ct;
      ct.body_a = p.body_a;
      ct.body_b = p.body_b;
      ct.shape_a = p.shape_a;
      ct.shape_b = p.shape_b;
      ct.point.p_A_W = pu.a1;
      ct.point.p_B_W = pu.a2;
      ct.point.n_W = e.n;
      ct.point.gap = e.psi;
      ct.mu = p.mu;
      ct.mu_param = p.mu_param;
      ws->contacts.push_back(ct);
    }
  }
  info->ok = true;
  info->status = StepStatus::kOk;
}

namespace {
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
    int o = c.geo[k] + 2 * d + 2;
    if (p.m_a > 1) {
      for (int i = 0; i < p.m_a; ++i) {
        r.comp_a[crow + i] = pu.lam[i];
        r.d_comp_a(crow + i, o + i) = 1.0;
      }
      r.comp_b.segment(crow, p.m_a) = -e.fa;
      Scatter(c, k, bodies, -e.d_fa, crow, &Jb);
      crow += p.m_a;
      o += p.m_a;
    }
    if (p.m_b > 1) {
      for (int j = 0; j < p.m_b; ++j) {
        r.comp_a[crow + j] = pu.mu[j];
        r.d_comp_a(crow + j, o + j) = 1.0;
      }
      r.comp_b.segment(crow, p.m_b) = -e.fb;
      Scatter(c, k, bodies, -e.d_fb, crow, &Jb);
      crow += p.m_b;
    }
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
}  // namespace

namespace {
VectorXd UnknownsOf(const Context& c, const Scene& model, const State& next) {
  const StepLayout& l = c.layout;
  if (next.v.size() != l.nv || next.q.size() != model.num_positions())
    throw std::invalid_argument("UnknownsFromStep: next state has the wrong size");
  VectorXd z = VectorXd::Zero(l.size());
  z.segment(l.v1(), l.nv) = next.v;
  for (int bi : model.dynamic_bodies()) {
    const int qo = l.q1() + c.pose_offset[bi];
    const auto q = next.q.segment(model.index(bi).q, PositionSize(model.dim));
    if (model.dim == Dim::kPlanar) {
      z.segment(qo, 3) = q;
    } else {
      const Isometry3d X = PoseFromQ(model.dim, q.data());
      z.segment(qo, 3) = q.head<3>();
      z.segment(qo + 3, 3) = LogSO3(c.X_start[bi].linear().transpose() * X.linear());
    }
  }
  // Pair unknowns from next.warm_start, which must hold exactly x's pairs in order.
  Context cn = c;
  cn.x.warm_start = next.warm_start;
  const VectorXd guess = InitialGuess(cn);
  const VectorXd& ws = next.warm_start;
  if (ws.size() < 1 || static_cast<int>(ws[0]) != l.nc)
    throw std::invalid_argument(
        "UnknownsFromStep: next.warm_start does not hold the pairs of this step");
  z.tail(l.size() - l.pn()) = guess.tail(l.size() - l.pn());
  return z;
}
}  // namespace

VectorXd GeometricallyImplicit::UnknownsFromStep(const Scene& model, const State& x,
                                                 const State& next) const {
  std::string failure;
  const Context c = MakeContext(*this, model, x, StepInput{}, &failure);
  return UnknownsOf(c, model, next);
}

StepResiduals GeometricallyImplicit::Evaluate(const Scene& model, const Params& params,
                                              const State& x, const StepInput& u,
                                              const VectorXd& z) const {
  std::string failure;
  Context c = MakeContext(*this, model, x, u, &failure);
  SetStart(&c, InitialGuess(c));  // the tie-breaker's reference, as in Step (from x.warm_start)
  return EvaluateContext(c, params, z);
}

GeometricallyImplicit::FrozenPairs GeometricallyImplicit::FreezePairs(const Scene& model,
                                                                      const State& x) const {
  std::string failure;
  Context c = MakeContext(*this, model, x, StepInput{}, &failure);
  if (!failure.empty())
    throw std::invalid_argument("GeometricallyImplicit::FreezePairs: " + failure);
  SetStart(&c, InitialGuess(c));
  return {c.pairs, c.a1_start, c.layout};
}

StepResiduals GeometricallyImplicit::EvaluateFrozen(const Scene& model, const Params& params,
                                                    const FrozenPairs& frozen, const State& x,
                                                    const StepInput& u, const VectorXd& z) const {
  std::string failure;
  Context c = MakeContext(*this, model, x, u, &failure, &frozen.pairs);
  c.a1_start = frozen.a1_start;
  return EvaluateContext(c, params, z);
}

VectorXd GeometricallyImplicit::UnknownsFromStep(const Scene& model, const FrozenPairs& frozen,
                                                 const State& x, const State& next) const {
  std::string failure;
  const Context c = MakeContext(*this, model, x, StepInput{}, &failure, &frozen.pairs);
  return UnknownsOf(c, model, next);
}

State GeometricallyImplicit::StateFromUnknowns(const Scene& model, const FrozenPairs& frozen,
                                               const State& x, const VectorXd& z) const {
  std::string failure;
  const Context c = MakeContext(*this, model, x, StepInput{}, &failure, &frozen.pairs);
  const StepLayout& l = c.layout;
  if (z.size() != l.size())
    throw std::invalid_argument("GeometricallyImplicit::StateFromUnknowns: z has " +
                                std::to_string(z.size()) + " entries, the step layout needs " +
                                std::to_string(l.size()));
  State next = x;
  next.t = x.t + c.h;
  next.v = z.segment(l.v1(), l.nv);
  for (int bi : model.dynamic_bodies()) {  // as Step writes the pose
    const int qo = l.q1() + c.pose_offset[bi];
    double* q = next.q.data() + model.index(bi).q;
    if (model.dim == Dim::kPlanar) {
      for (int i = 0; i < 3; ++i) q[i] = z[qo + i];
    } else {
      Isometry3d X = Isometry3d::Identity();
      X.translation() = z.segment<3>(qo);
      X.linear() = c.X_start[bi].linear() * ExpSO3(z.segment<3>(qo + 3));
      PoseToQ(model.dim, X, q);
      const Eigen::Vector4d q0 = x.q.segment<4>(model.index(bi).q + 3);
      Eigen::Map<Eigen::Vector4d> q1(q + 3);
      if (q0.dot(q1) < 0.0) q1 = -q1;
    }
  }
  next.warm_start = WarmStartOf(c, z);
  return next;
}

}  // namespace vinci::sim
