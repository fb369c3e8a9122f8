#include "vinci/sim/formulations/step_model.h"

#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

#include "../solvers/scratch_lease.h"
#include "frozen_contacts.h"
#include "sparse_lcp.h"
#include "step_record.h"
#include "step_util.h"
#include "stewart_trinkle_internal.h"
#include "vinci/sim/formulations/contact.h"
#include "vinci/sim/formulations/stewart_trinkle.h"
#include "vinci/sim/geometry/contact_rate.h"
#include "vinci/sim/model/kinematics.h"

namespace vinci::sim {
namespace {

using internal::FrozenSidesInto;
using internal::MoveContacts;
using internal::MoveContactsAlong;
using internal::SameStateAndInput;
using internal::SizeMismatch;

// [w]×: [w]× v = w × v.
Matrix3d Skew(const Vector3d& w) {
  Matrix3d S;
  S << 0.0, -w.z(), w.y(), w.z(), 0.0, -w.x(), -w.y(), w.x(), 0.0;
  return S;
}

// --- Stewart–Trinkle, Anitescu–Potra, first order -----------------------------------------------

class StewartTrinkleModel final : public StepModel {
 public:
  // `assembled`: st.AssembleInto(*model, x, u) made by the step (step_record.h), or null.
  StewartTrinkleModel(const StewartTrinkle& st, std::shared_ptr<const Scene> model, Params params,
                      State x, StepInput u, const StewartTrinkle::Assembly* assembled)
      : StepModel(std::move(model), std::move(params), std::move(x), std::move(u), st.options().dt),
        st_(st) {
    Build(assembled);
  }
  const StewartTrinkle& formulation() const { return st_; }
  // The model frozen at (model, params, x, u) in this object's storage: every member a new
  // model sets is overwritten.
  void Refreeze(std::shared_ptr<const Scene> model, const Params& params, const State& x,
                const StepInput& u, const StewartTrinkle::Assembly* assembled) {
    model_ = std::move(model);
    params_ = params;
    x_ = x;
    u_ = u;
    dt_ = st_.options().dt;
    Build(assembled);
  }

 protected:
  StepResiduals Residuals(const Scene& model, const Params& theta, const State& x,
                          const StepInput& u, const VectorXd& z, bool jacobians) const override {
    if (&model == model_.get() && SameStateAndInput(x, u, x_, u_))
      return st_.EvaluateAssembly(model, theta, freeze_, x, z, jacobians);
    return st_.EvaluateAssembly(model, theta, AssembleAt(model, x, u), x, z, jacobians);
  }
  void ResidualsInto(const Scene& model, const Params& theta, const State& x, const StepInput& u,
                     const VectorXd& z, bool jacobians, StepResiduals* out) const override {
    if (&model == model_.get() && SameStateAndInput(x, u, x_, u_)) {
      internal::EvaluateAssemblyInto(st_, model, theta, freeze_, x, z, jacobians, out);
      return;
    }
    // Residuals' numbers in the calling thread's assembly storage (as AlongInto).
    internal::ScratchLease<StewartTrinkle::Assembly> lease;
    StewartTrinkle::Assembly& a = lease.get();
    internal::MoveContactsInto(model, contacts_, x_, x, dt_, &k0_, &sides_, &a.contacts);
    st_.AssembleAtInto(model, x, u, /*select_corner_edges=*/false, &a);
    internal::EvaluateAssemblyInto(st_, model, theta, a, x, z, jacobians, out);
  }
  // The step equations read ν_ℓ only in the dynamics rows (EvaluateAssemblyInto, Fill): the
  // term −M ν_ℓ and, for a spatial body, the gyroscopic impulse −h ω_ℓ × (I ω_ℓ) of p_ext (ω_ℓ
  // the body-frame angular velocity). The contacts (MoveContacts: poses only), G, ψ, ∂ψ/∂t (the
  // non-dynamic bodies' velocities), the joints and the support rows do not; the corner edges
  // are not re-selected. First order: neither term (ν_ℓ = 0, the gyroscopic impulse cancelled).
  bool VelocityColumns(const Scene& model, const State& x, int col, MatrixXd* De, MatrixXd*,
                       MatrixXd*) const override {
    if (st_.options().formulation == FormulationType::kFirstOrder) return true;
    const double h = dt_;
    for (int bi : model.dynamic_bodies()) {
      const Body& b = model.bodies[bi];
      const int o = model.index(bi).v;
      if (model.dim == Dim::kPlanar) {
        (*De)(o, col + o) = -b.mass;
        (*De)(o + 1, col + o + 1) = -b.mass;
        (*De)(o + 2, col + o + 2) = -b.inertia(2, 2);
        continue;
      }
      for (int k = 0; k < 3; ++k) (*De)(o + k, col + o + k) = -b.mass;
      const Vector3d w = x.v.segment<3>(o + 3);
      const Matrix3d& I = b.inertia;
      // ∂(ω × Iω)/∂ω = [ω]× I − [Iω]×.
      const Matrix3d d_gyro = Skew(w) * I - Skew(I * w);
      De->block<3, 3>(o + 3, col + o + 3) = -I + h * d_gyro;
    }
    return true;
  }
  StepResiduals ResidualsAlong(const VectorXd& z, const StepInput& u, const VectorXd& s,
                               double t) const override {
    StepResiduals r;
    AlongInto(z, u, s, t, &r);
    return r;
  }

 public:
  // EvaluateResiduals(z, θ, x, u, true) into *out (Jacobians by rows into *jac), if θ, x and u
  // are the freeze's (bitwise): else false (nothing written).
  bool FreezeResidualsInto(const VectorXd& z, const Params& theta, const State& x,
                           const StepInput& u, StepResiduals* out,
                           internal::SparseJacobians* jac) const {
    if (z.size() != layout_.size() || !(theta == params_) || !SameStateAndInput(x, u, x_, u_))
      return false;
    internal::EvaluateAssemblyInto(st_, *model_, theta, freeze_, x, z, true, out, jac);
    return true;
  }
  const StewartTrinkle::Assembly& freeze_assembly() const { return freeze_; }
  // Frozen at (scene, params, x, u), bitwise (the model holds its scene: the address names it).
  bool FrozenAt(const Scene* scene, const Params& params, const State& x,
                const StepInput& u) const {
    return model_.get() == scene && params_ == params && SameStateAndInput(x, u, x_, u_);
  }
  // internal::PlainLcpAlongInto (step_record.h); the model's assembly has no joints, corners,
  // support points or compliant pairs.
  void PlainLcpAlongInto(const StepInput& u, const VectorXd& s, double t, const VectorXd& z,
                         VectorXd* w, VectorXd* v1) const {
    struct Along {
      State x;
      StewartTrinkle::Assembly a;
    };
    if (t == 0.0) {
      internal::PlainLcpAtInto(st_, freeze_, x_, z, w, v1);
      return;
    }
    internal::ScratchLease<Along> lease;
    Along& sc = lease.get();
    AssembleAlong(u, s, t, &sc.x, &sc.a);
    internal::PlainLcpAtInto(st_, sc.a, sc.x, z, w, v1);
  }
  // The frozen contacts moved to x_ℓ + t s (MoveContactsAlong) and assembled there, into *x and
  // *a (their storage reused).
  void AssembleAlong(const StepInput& u, const VectorXd& s, double t, State* x,
                     StewartTrinkle::Assembly* a) const {
    x->t = x_.t;
    x->q = x_.q + t * s.head(x_.q.size());
    x->v = x_.v + t * s.tail(s.size() - x_.q.size());
    x->warm_start = x_.warm_start;
    a->contacts = MoveContactsAlong(*model_, contacts_, x_, *x, s, t, dt_, k0_, sides_);
    st_.AssembleAtInto(*model_, *x, u, /*select_corner_edges=*/false, a);
  }
  // ResidualsAlong into *out (values only), in the calling thread's storage.
  void AlongInto(const VectorXd& z, const StepInput& u, const VectorXd& s, double t,
                 StepResiduals* out) const {
    internal::ScratchLease<State> x_lease;
    State& x = x_lease.get();
    // The calling thread's assembly storage (same values as a fresh AssembleAt).
    internal::ScratchLease<StewartTrinkle::Assembly> lease;
    StewartTrinkle::Assembly& a = lease.get();
    AssembleAlong(u, s, t, &x, &a);
    internal::EvaluateAssemblyInto(st_, *model_, params_, a, x, z, false, out);
  }

 protected:
  VectorXd Unknowns(const State& next) const override {
    const StepLayout& l = layout_;
    const VectorXd& w = next.warm_start;
    if (w.size() != lcp_size_)
      throw std::invalid_argument("StepModel::UnknownsFromStep: next.warm_start " +
                                  SizeMismatch("", w.size(), lcp_size_) +
                                  " (the LCP solution of this contact set)");
    VectorXd z = VectorXd::Zero(l.size());
    z.segment(l.q1(), l.nq) = next.q;
    z.segment(l.v1(), l.nv) = next.v;
    const int head = l.nc * (2 + l.nd), tail = l.nps + l.ns + l.nk;
    z.segment(l.pn(), head) = w.head(head);  // p_n, p_f, σ
    z.segment(l.ps(), tail) = w.tail(tail);  // p_s, σ_s, c
    RecoverJointImpulses(G_b_, &z);
    return z;
  }
  VectorXd WarmStart(const VectorXd& z) const override {
    const StepLayout& l = layout_;
    const int head = l.nc * (2 + l.nd), tail = l.nps + l.ns + l.nk;
    VectorXd w(head + tail);
    w << z.segment(l.pn(), head), z.segment(l.ps(), tail);
    return w;
  }

 private:
  StewartTrinkle::Assembly AssembleAt(const Scene& model, const State& x,
                                      const StepInput& u) const {
    return st_.AssembleAt(model, x, u, MoveContacts(model, contacts_, x_, x, dt_, &k0_, &sides_),
                          /*select_corner_edges=*/false);
  }
  void Build(const StewartTrinkle::Assembly* assembled) {
    // Assemble() selects each corner's edge in its contacts: AssembleAt of those contacts
    // (without selection) is the same assembly, kept for evaluations at the freeze point. Built
    // (or copied from the step's) in place: assigning Assemble()'s result would copy its sparse
    // matrices (Eigen 3.4's SparseMatrix has no move assignment).
    if (assembled)
      freeze_ = *assembled;
    else
      st_.AssembleInto(*model_, x_, u_, &freeze_);
    contacts_ = freeze_.contacts;
    ComputeBodyKinematics(*model_, x_, &k0_);
    FrozenSidesInto(*model_, contacts_, k0_, &sides_, &feature_kinks_);
    const StewartTrinkle::Assembly& a = freeze_;
    lcp_size_ = a.psi_n.size() * (2 + a.nd) + a.support.points() + a.support.columns() +
                static_cast<Eigen::Index>(a.corner_contact.size());
    G_b_ = a.G_b;
    // The layout and θ columns straight from the assembly (no evaluation at z = 0).
    param_columns_.clear();
    internal::DifferentiableParamColumns(model_->param_table(), 0, &param_columns_);
    layout_ = StewartTrinkle::LayoutOf(*model_, a);
  }
  const StewartTrinkle& st_;
  std::vector<Contact> contacts_;
  std::vector<BodyKinematics> k0_;      // at x_
  std::vector<PolytopeFeature> sides_;  // per contact: the vertex a box–box contact keeps
  StewartTrinkle::Assembly freeze_;     // at (model_, x_, u_)
  Eigen::Index lcp_size_ = 0;
  MatrixXd G_b_;
};

// *S = D.sparseView(0, 0) (the entries that are not exactly 0, column by column), its storage
// reused.
void SparseFromDense(const Eigen::Ref<const MatrixXd>& D, SparseMatrixXd* S) {
  const Eigen::Index rows = D.rows(), cols = D.cols();
  Eigen::Index nnz = 0;
  for (Eigen::Index j = 0; j < cols; ++j)
    for (Eigen::Index i = 0; i < rows; ++i) nnz += !(std::abs(D(i, j)) <= 0.0);
  S->resize(rows, cols);  // compressed and empty; the entry storage is kept
  S->resizeNonZeros(nnz);
  int* outer = S->outerIndexPtr();
  int* inner = S->innerIndexPtr();
  double* value = S->valuePtr();
  int k = 0;
  for (Eigen::Index j = 0; j < cols; ++j) {
    outer[j] = k;
    for (Eigen::Index i = 0; i < rows; ++i) {
      const double v = D(i, j);
      if (std::abs(v) <= 0.0) continue;
      inner[k] = static_cast<int>(i);
      value[k++] = v;
    }
  }
  outer[cols] = k;
}

// *S = rows × cols with no entries (storage kept).
void SparseEmpty(Eigen::Index rows, Eigen::Index cols, SparseMatrixXd* S) {
  if (S->rows() == rows && S->cols() == cols && S->isCompressed() && S->nonZeros() == 0) return;
  S->resize(rows, cols);
}

// *S = the rows × cols matrix whose first n diagonal entries are v (storage kept).
void SparseDiagonal(Eigen::Index rows, Eigen::Index cols, int n, double v, SparseMatrixXd* S) {
  S->resize(rows, cols);
  S->resizeNonZeros(n);
  int* outer = S->outerIndexPtr();
  for (int j = 0; j <= cols; ++j) outer[j] = std::min(j, n);
  for (int j = 0; j < n; ++j) {
    S->innerIndexPtr()[j] = j;
    S->valuePtr()[j] = v;
  }
}

void AppendRows(const MatrixXd& J, int nz, int np, StepModelJacobian* out) {
  SparseFromDense(J.leftCols(nz), &out->d_z);
  SparseFromDense(J.middleCols(nz, np), &out->d_theta);
}

bool SameBits(const VectorXd& a, const VectorXd& b) {
  return a.size() == b.size() &&
         (a.size() == 0 || std::memcmp(a.data(), b.data(), sizeof(double) * a.size()) == 0);
}

// The scene `base` with θ applied, kept per thread for the next evaluation with the same scene
// (the same live object) and bitwise the same θ: an estimator evaluates every step at one θ, and
// ApplyParams copies the scene. Allocation reuse only (ApplyParams is a function of the scene
// and θ); a nested use on the same thread gets its own scene.
class AppliedScene {
 public:
  AppliedScene() = default;
  AppliedScene(const AppliedScene&) = delete;
  AppliedScene& operator=(const AppliedScene&) = delete;
  ~AppliedScene() {
    if (held_) held_->in_use = false;
  }
  const Scene& Get(const std::shared_ptr<const Scene>& base, const Params& theta) {
    thread_local Cache cache;
    if (cache.in_use) {
      own_ = base->ApplyParams(theta);
      return own_;
    }
    cache.in_use = true;
    held_ = &cache;
    const std::shared_ptr<const Scene> cached = cache.base.lock();
    if (!cached || cached.get() != base.get() || !SameBits(cache.theta, theta.values)) {
      cache.applied = base->ApplyParams(theta);
      cache.base = base;
      cache.theta = theta.values;
    }
    return cache.applied;
  }

 private:
  struct Cache {
    std::weak_ptr<const Scene> base;  // expired once that scene is gone: never matches then
    VectorXd theta;
    Scene applied;
    bool in_use = false;
  };
  Cache* held_ = nullptr;
  Scene own_;
};

// Evaluate's transient storage, kept per thread (allocation reuse only: all overwritten).
struct EvaluateScratch {
  StepResiduals r, plus, minus;
  State xp, xm;
  MatrixXd De, Da, Db;
};

}  // namespace

double StepModelValues::Violation() const {
  double v = equality.size() ? equality.cwiseAbs().maxCoeff() : 0.0;
  for (int i = 0; i < comp_a.size(); ++i) v = std::max(v, std::abs(std::min(comp_a[i], comp_b[i])));
  return v;
}

StepModel::StepModel(std::shared_ptr<const Scene> model, Params params, State x, StepInput u,
                     double dt)
    : model_(std::move(model)),
      params_(std::move(params)),
      x_(std::move(x)),
      u_(std::move(u)),
      dt_(dt) {}

void StepModel::Init(int num_unknowns) {
  const StepResiduals r = Residuals(*model_, params_, x_, u_, VectorXd::Zero(num_unknowns), true);
  layout_ = r.layout;
  param_columns_ = r.param_columns;
}

void StepModel::InitLayout(StepLayout layout, std::vector<int> param_columns) {
  layout_ = layout;
  param_columns_ = std::move(param_columns);
}

StepModelValues StepModel::Evaluate(const VectorXd& z, const Params& theta, const State& x,
                                    const StepModelOptions& options) const {
  return Evaluate(z, theta, x, u_, options);
}

StepModelValues StepModel::Evaluate(const VectorXd& z, const Params& theta, const State& x,
                                    const StepInput& u, const StepModelOptions& options) const {
  StepModelValues out;
  EvaluateInto(z, theta, x, u, options, &out);
  return out;
}

void StepModel::EvaluateInto(const VectorXd& z, const Params& theta, const State& x,
                             const StepInput& u, const StepModelOptions& options,
                             StepModelValues* values) const {
  const Scene& s0 = *model_;
  if (z.size() != layout_.size())
    throw std::invalid_argument("StepModel::Evaluate: z " +
                                SizeMismatch("", z.size(), layout_.size()));
  if (theta.values.size() != s0.param_table().size())
    throw std::invalid_argument("StepModel::Evaluate: θ " +
                                SizeMismatch("", theta.values.size(), s0.param_table().size()));
  if (x.q.size() != s0.num_positions() || x.v.size() != s0.num_velocities())
    throw std::invalid_argument(
        "StepModel::Evaluate: x_ℓ has " + std::to_string(x.q.size()) + " positions / " +
        std::to_string(x.v.size()) + " velocities; the scene needs " +
        std::to_string(s0.num_positions()) + " / " + std::to_string(s0.num_velocities()));
  if (x.t != x_.t)
    throw std::invalid_argument("StepModel::Evaluate: x_ℓ.t = " + std::to_string(x.t) +
                                " differs from the freeze time " + std::to_string(x_.t) +
                                " (prescribed bodies are frozen at that time)");
  const int nv = s0.num_velocities();
  if (u.generalized_force.size() != 0 && u.generalized_force.size() != nv)
    throw std::invalid_argument("StepModel::Evaluate: input force " +
                                SizeMismatch("", u.generalized_force.size(), nv));
  if (!(options.state_step > 0.0))
    throw std::invalid_argument("StepModel::Evaluate: state_step must be > 0");
  AppliedScene applied;
  const Scene* model = &s0;
  if (!(theta == params_)) model = &applied.Get(model_, theta);
  internal::ScratchLease<EvaluateScratch> lease;
  EvaluateScratch& s = lease.get();
  const StepResiduals& r = s.r;
  ResidualsInto(*model, theta, x, u, z, options.jacobians, &s.r);
  StepModelValues& out = *values;
  out.equality = r.equality;
  out.comp_a = r.comp_a;
  out.comp_b = r.comp_b;
  const Eigen::Index ne = r.equality.size(), na = r.comp_a.size(), nb = r.comp_b.size();
  if (!options.jacobians) {
    for (StepModelJacobian* J : {&out.d_equality, &out.d_comp_a, &out.d_comp_b})
      for (SparseMatrixXd* M : {&J->d_z, &J->d_theta, &J->d_x, &J->d_u}) SparseEmpty(0, 0, M);
    return;
  }
  const int nz = layout_.size(), np = static_cast<int>(param_columns_.size());
  AppendRows(r.d_equality, nz, np, &out.d_equality);
  AppendRows(r.d_comp_a, nz, np, &out.d_comp_a);
  AppendRows(r.d_comp_b, nz, np, &out.d_comp_b);
  // Input: every formulation's dynamics rows (the first nv equalities) carry −h u.
  SparseDiagonal(ne, nv, nv, -dt_, &out.d_equality.d_u);
  SparseEmpty(na, nv, &out.d_comp_a.d_u);
  SparseEmpty(nb, nv, &out.d_comp_b.d_u);

  const int nq = static_cast<int>(x.q.size()), nx = nq + nv;
  if (!options.state_jacobian) {
    SparseEmpty(ne, nx, &out.d_equality.d_x);
    SparseEmpty(na, nx, &out.d_comp_a.d_x);
    SparseEmpty(nb, nx, &out.d_comp_b.d_x);
    return;
  }
  MatrixXd &De = s.De, &Da = s.Da, &Db = s.Db;
  De.setZero(ne, nx);
  Da.setZero(na, nx);
  Db.setZero(nb, nx);
  // ν_ℓ in closed form where the model has it: central differences for q_ℓ only then.
  const bool velocity =
      options.closed_form_velocity && VelocityColumns(*model, x, nq, &De, &Da, &Db);
  const int nfd = velocity ? nq : nx;
  for (int j = 0; j < nfd; ++j) {
    State &xp = s.xp, &xm = s.xm;
    xp = x;
    xm = x;
    double& cp = j < nq ? xp.q[j] : xp.v[j - nq];
    double& cm = j < nq ? xm.q[j] : xm.v[j - nq];
    const double step = options.state_step * std::max(1.0, std::abs(cp));
    cp += step;
    cm -= step;
    const StepResiduals& rp = s.plus;
    const StepResiduals& rm = s.minus;
    ResidualsInto(*model, theta, xp, u, z, false, &s.plus);
    ResidualsInto(*model, theta, xm, u, z, false, &s.minus);
    De.col(j) = (rp.equality - rm.equality) / (2 * step);
    Da.col(j) = (rp.comp_a - rm.comp_a) / (2 * step);
    Db.col(j) = (rp.comp_b - rm.comp_b) / (2 * step);
  }
  SparseFromDense(De, &out.d_equality.d_x);
  SparseFromDense(Da, &out.d_comp_a.d_x);
  SparseFromDense(Db, &out.d_comp_b.d_x);
}

void StepModel::ResidualsInto(const Scene& model, const Params& theta, const State& x,
                              const StepInput& u, const VectorXd& z, bool jacobians,
                              StepResiduals* out) const {
  *out = Residuals(model, theta, x, u, z, jacobians);
}

bool StepModel::VelocityColumns(const Scene&, const State&, int, MatrixXd*, MatrixXd*,
                                MatrixXd*) const {
  return false;
}

State StepModel::StateAlong(const VectorXd& s, double t) const {
  State x = x_;
  const Eigen::Index nq = x.q.size();
  x.q += t * s.head(nq);
  x.v += t * s.tail(s.size() - nq);
  return x;
}

StepResiduals StepModel::ResidualsAlong(const VectorXd& z, const StepInput& u, const VectorXd& s,
                                        double t) const {
  return Residuals(*model_, params_, StateAlong(s, t), u, z, false);
}

StepResiduals StepModel::StateDirectionalDerivative(const VectorXd& z, const StepInput& u,
                                                    const VectorXd& s, double step) const {
  if (z.size() != layout_.size())
    throw std::invalid_argument("StepModel::StateDirectionalDerivative: z " +
                                SizeMismatch("", z.size(), layout_.size()));
  if (s.size() != x_.q.size() + x_.v.size())
    throw std::invalid_argument("StepModel::StateDirectionalDerivative: s " +
                                SizeMismatch("", s.size(), x_.q.size() + x_.v.size()));
  if (!(step > 0.0))
    throw std::invalid_argument("StepModel::StateDirectionalDerivative: step must be > 0");
  StepResiduals p = ResidualsAlong(z, u, s, step);
  const StepResiduals m = ResidualsAlong(z, u, s, -step);
  p.equality = (p.equality - m.equality) / (2 * step);
  p.comp_a = (p.comp_a - m.comp_a) / (2 * step);
  p.comp_b = (p.comp_b - m.comp_b) / (2 * step);
  return p;
}

StepResiduals StepModel::EvaluateResiduals(const VectorXd& z, const Params& theta, const State& x,
                                           const StepInput& u, bool jacobians) const {
  if (z.size() != layout_.size())
    throw std::invalid_argument("StepModel::EvaluateResiduals: z " +
                                SizeMismatch("", z.size(), layout_.size()));
  if (!(theta == params_))
    throw std::invalid_argument(
        "StepModel::EvaluateResiduals: θ must be the freeze parameters (use Evaluate)");
  if (x.q.size() != x_.q.size() || x.v.size() != x_.v.size() || x.t != x_.t)
    throw std::invalid_argument(
        "StepModel::EvaluateResiduals: x must have the freeze state's sizes and time");
  return Residuals(*model_, theta, x, u, z, jacobians);
}

VectorXd StepModel::UnknownsFromStep(const State& next) const {
  if (next.q.size() != model_->num_positions() || next.v.size() != model_->num_velocities())
    throw std::invalid_argument("StepModel::UnknownsFromStep: next state has the wrong size");
  return Unknowns(next);
}

State StepModel::StateFromUnknowns(const VectorXd& z) const {
  if (z.size() != layout_.size())
    throw std::invalid_argument("StepModel::StateFromUnknowns: z " +
                                SizeMismatch("", z.size(), layout_.size()));
  return EndState(z, x_);
}

State StepModel::StateFromUnknowns(const VectorXd& z, const State& x) const {
  if (z.size() != layout_.size())
    throw std::invalid_argument("StepModel::StateFromUnknowns: z " +
                                SizeMismatch("", z.size(), layout_.size()));
  if (x.q.size() != x_.q.size() || x.v.size() != x_.v.size() || x.t != x_.t)
    throw std::invalid_argument(
        "StepModel::StateFromUnknowns: x must have the freeze state's sizes and time");
  return EndState(z, x);
}

State StepModel::EndState(const VectorXd& z, const State& x) const {
  State next;
  next.t = x.t + dt_;
  next.q = z.segment(layout_.q1(), layout_.nq);
  next.v = z.segment(layout_.v1(), layout_.nv);
  next.warm_start = WarmStart(z);
  return next;
}

void StepModel::RecoverJointImpulses(const MatrixXd& G_b, VectorXd* z) const {
  const StepLayout& l = layout_;
  if (l.nb == 0) return;
  z->segment(l.pb(), l.nb).setZero();
  // Dynamics rows with p_b = 0: r₀ = M(ν − ν_ℓ) − G_c p_c − p_ext = G_b p_b at the solution.
  const StepResiduals r = Residuals(*model_, params_, x_, u_, *z, false);
  z->segment(l.pb(), l.nb) = G_b.colPivHouseholderQr().solve(r.equality.head(l.nv));
}

std::unique_ptr<StepModel> Freeze(const Formulation& formulation, const Scene& model,
                                  const Params& params, const State& x, const StepInput& u) {
  return Freeze(formulation, std::make_shared<const Scene>(model), params, x, u);
}

namespace {

void CheckFreezeInputs(const Scene* model, const Params& params, const State& x) {
  if (!model) throw std::invalid_argument("Freeze: null scene");
  if (params.values.size() != model->param_table().size())
    throw std::invalid_argument(
        "Freeze: params " + SizeMismatch("", params.values.size(), model->param_table().size()));
  if (x.q.size() != model->num_positions() || x.v.size() != model->num_velocities())
    throw std::invalid_argument("Freeze: x has the wrong size for the scene");
}

}  // namespace

namespace internal {

void FreezeInto(const Formulation& formulation, std::shared_ptr<const Scene> scene,
                const Params& params, const State& x, const StepInput& u,
                std::unique_ptr<StepModel>* frozen) {
  const auto* st = dynamic_cast<const StewartTrinkle*>(&formulation);
  if (const auto* ncp = dynamic_cast<const NcpStepper*>(&formulation)) {
    CheckFreezeInputs(scene.get(), params, x);
    FreezeNcpInto(*ncp, std::move(scene), params, x, u, frozen);
    return;
  }
  if (!st) {
    *frozen = Freeze(formulation, std::move(scene), params, x, u);
    return;
  }
  CheckFreezeInputs(scene.get(), params, x);
  const StewartTrinkle::Assembly* assembled = StepAssembly(*st, scene, x, u);
  auto* reuse = dynamic_cast<StewartTrinkleModel*>(frozen->get());
  // Frozen at these already (the model holds its scene: the address names it).
  if (reuse && &reuse->formulation() == st && reuse->FrozenAt(scene.get(), params, x, u)) return;
  if (reuse && &reuse->formulation() == st) {
    reuse->Refreeze(std::move(scene), params, x, u, assembled);
    return;
  }
  *frozen = std::make_unique<StewartTrinkleModel>(*st, std::move(scene), params, x, u, assembled);
}

void EvaluateResidualsInto(const StepModel& m, const VectorXd& z, const Params& theta,
                           const State& x, const StepInput& u, StepResiduals* out,
                           SparseJacobians* jac) {
  const auto* st = dynamic_cast<const StewartTrinkleModel*>(&m);
  if (st && st->FreezeResidualsInto(z, theta, x, u, out, jac)) return;
  if (McpFreezeResidualsInto(m, z, theta, x, u, out, jac)) return;
  *out = m.EvaluateResiduals(z, theta, x, u, true);
  jac->equality.FromDense(out->d_equality);
  jac->comp_a.FromDense(out->d_comp_a);
  jac->comp_b.FromDense(out->d_comp_b);
}

const StewartTrinkle::Assembly* FrozenAssembly(const StepModel& m) {
  const auto* st = dynamic_cast<const StewartTrinkleModel*>(&m);
  return st ? &st->freeze_assembly() : nullptr;
}

bool PlainLcpAlongInto(const StepModel& m, const StepInput& u, const VectorXd& s, double t,
                       const VectorXd& z, VectorXd* w, VectorXd* v1) {
  const auto* st = dynamic_cast<const StewartTrinkleModel*>(&m);
  const State& x0 = m.x_freeze();
  if (!st || s.size() != x0.q.size() + x0.v.size()) return false;
  const StewartTrinkle::Assembly& a = st->freeze_assembly();
  if (a.psi_b.size() > 0 || !a.corner_contact.empty() || a.support.points() > 0) return false;
  for (const CompliantNormalRow& law : a.compliance)
    if (law.compliant) return false;
  if (z.size() != static_cast<Eigen::Index>(a.contacts.size()) * (2 + a.nd)) return false;
  st->PlainLcpAlongInto(u, s, t, z, w, v1);
  return true;
}

void StateDirectionalDerivativeInto(const StepModel& m, const VectorXd& z, const StepInput& u,
                                    const VectorXd& s, double step, StepResiduals* out) {
  const auto* st = dynamic_cast<const StewartTrinkleModel*>(&m);
  const StepLayout& l = m.layout();
  const State& x0 = m.x_freeze();
  if (!st || z.size() != l.size() || s.size() != x0.q.size() + x0.v.size() || !(step > 0.0)) {
    *out = m.StateDirectionalDerivative(z, u, s, step);
    return;
  }
  // As StepModel::StateDirectionalDerivative (the same operations), in the thread's storage.
  struct Minus {
    StepResiduals r;
  };
  ScratchLease<Minus> minus;
  StepResiduals& p = *out;
  StepResiduals& mr = minus.get().r;
  st->AlongInto(z, u, s, step, &p);
  st->AlongInto(z, u, s, -step, &mr);
  p.equality = (p.equality - mr.equality) / (2 * step);
  p.comp_a = (p.comp_a - mr.comp_a) / (2 * step);
  p.comp_b = (p.comp_b - mr.comp_b) / (2 * step);
}

}  // namespace internal

std::unique_ptr<StepModel> Freeze(const Formulation& formulation,
                                  std::shared_ptr<const Scene> scene, const Params& params,
                                  const State& x, const StepInput& u) {
  CheckFreezeInputs(scene.get(), params, x);
  if (const auto* st = dynamic_cast<const StewartTrinkle*>(&formulation))
    return std::make_unique<StewartTrinkleModel>(*st, scene, params, x, u, nullptr);
  if (std::unique_ptr<StepModel> mcp = internal::FreezeMcp(formulation, scene, params, x, u))
    return mcp;
  throw std::invalid_argument("Freeze: formulation '" + std::string(formulation.name()) +
                              "' has no frozen step model");
}

}  // namespace vinci::sim
