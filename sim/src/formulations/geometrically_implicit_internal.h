// Internal to the GI stepper (geometrically_implicit.cc, geometrically_implicit_eval.cc): the
// step's equations — the context a step's equations need, the unknowns read per pair, and the
// evaluation of the residuals and Jacobians (the solver form and the Formulation::Evaluate form).
#pragma once

#include <string>
#include <vector>

#include "vinci/sim/formulations/geometrically_implicit.h"
#include "vinci/sim/model/kinematics.h"

namespace vinci::sim::gi {

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

struct FnAt {
  double f = 0.0;
  Vector3d g = Vector3d::Zero();
  Matrix3d H = Matrix3d::Zero();
};

// SO(3) exponential and logarithm (rotation vectors).
Matrix3d ExpSO3(const Vector3d& phi);
Vector3d LogSO3(const Matrix3d& R);

// Pair k's unknowns read from z.
void ReadPair(const Context& c, int k, const VectorXd& z, PairUnknowns* out);
// Every body's pose, velocity and their derivatives with respect to z at ℓ+1.
void BodiesAt(const Context& c, const VectorXd& z, std::vector<BodyAt>* out);
// An implicit function's value, gradient and Hessian at the world point a_W.
FnAt EvalFn(const ImplicitFunction& fn, const Isometry3d& X_WS, const Vector3d& a_W);
// Pair k's values and local Jacobians (into ps->e) from ps->u and the bodies.
void EvalPair(const Context& c, int k, const std::vector<BodyAt>& bodies, PairScratch* ps);
// Pair k's storage in c.buf.
PairScratch& PairBuffers(const Context& c, int k);
// The solver form's residual F(z) and its Jacobian J (either may be null).
void SolverResidual(const Context& c, const VectorXd& z, VectorXd* F, MatrixXd* J);
std::string Describe(const Scene& s, int body, int shape);
// A non-dynamic body's pose at t + h and its secant velocity over the step.
BodyKinematics MovingKinematics(const Scene& s, int body, double t, double h);
// The Formulation::Evaluate form of the step's equations at z.
StepResiduals EvaluateContext(const Context& c, const Params& params, const VectorXd& z);

}  // namespace vinci::sim::gi
