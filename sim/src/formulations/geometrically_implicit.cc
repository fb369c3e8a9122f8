#include "vinci/sim/formulations/geometrically_implicit.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "../geometry/implicit_set_into.h"
#include "../solvers/scratch_lease.h"
#include "geometrically_implicit_internal.h"
#include "step_util.h"
#include "vinci/sim/formulations/contact.h"
#include "vinci/sim/model/compliance.h"
#include "vinci/sim/model/kinematics.h"

namespace vinci::sim {

using namespace gi;  // NOLINT: the stepper's equations (geometrically_implicit_internal.h)

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
