#include "vinci/sim/formulations/quasistatic.h"

#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>

#include "../solvers/scratch_lease.h"
#include "step_util.h"
#include "vinci/sim/model/kinematics.h"

namespace vinci::sim {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Offsets of the blocks of y = [ν; p_n; p_f; σ; p_b; p_s; σ_s] (the step unknowns without q).
struct Offsets {
  int nv, nc, nf, nb, nps, ns;
  int v() const { return 0; }
  int pn() const { return nv; }
  int pf() const { return pn() + nc; }
  int sigma() const { return pf() + nf; }
  int pb() const { return sigma() + nc; }
  int ps() const { return pb() + nb; }
  int ss() const { return ps() + nps; }
  int size() const { return ss() + ns; }
};

Offsets OffsetsOf(const StepLayout& l) { return {l.nv, l.nc, l.nc * l.nd, l.nb, l.nps, l.ns}; }

// Everything the step function needs, shared by the MCP callback and Evaluate.
struct StepData {
  StewartTrinkle::Assembly a;
  StepLayout layout;
  MatrixXd eps_M;  // ε_M M (quasistatic) or M (dynamic-dqc)
  VectorXd v0;     // 0 (quasistatic) or ν_ℓ (dynamic-dqc)
  double h = 0.0;
  bool quadratic = false;
  bool joint_stabilization = true;
};

// F(y) of the step (rows in the order of y) and, if J is non-null, ∂F/∂y.
void StepFunction(const StepData& d, const VectorXd& y, VectorXd* F, MatrixXd* J) {
  const StewartTrinkle::Assembly& a = d.a;
  const SupportRows& sup = a.support;
  const Offsets o = OffsetsOf(d.layout);
  const int nd = d.layout.nd;
  const auto nu = y.segment(o.v(), o.nv);
  F->resize(o.size());
  // Every product into a buffer first, then the sums in the expression's order: what Eigen does
  // for the whole expression (it evaluates each product, and the product's vector argument
  // ν − ν₀, into a temporary), in this thread's storage.
  thread_local VectorXd dnu, t_m, t_n, t_f, t_b, t_s, w_n, w_f, w_b,
      w_s;  // t: ν rows, w: the others
  dnu = nu - d.v0;
  t_m.noalias() = d.eps_M * dnu;
  t_n.noalias() = a.G_n * y.segment(o.pn(), o.nc);
  t_f.noalias() = a.G_f * y.segment(o.pf(), o.nf);
  t_b.noalias() = a.G_b * y.segment(o.pb(), o.nb);
  t_s.noalias() = sup.G_s * y.segment(o.ps(), o.nps);
  F->segment(o.v(), o.nv) = t_m - t_n - t_f - t_b - t_s - a.p_ext;
  w_n.noalias() = a.G_n.transpose() * nu;
  F->segment(o.pn(), o.nc) = w_n + a.psi_n / d.h + a.dpsi_n;
  w_f.noalias() = a.G_f.transpose() * nu;
  F->segment(o.pf(), o.nf) = w_f + a.dpsi_f;
  for (int c = 0; c < o.nc; ++c) {
    double sum_pf = 0.0;
    for (int j = 0; j < nd; ++j) {
      (*F)[o.pf() + c * nd + j] += y[o.sigma() + c];
      sum_pf += y[o.pf() + c * nd + j];
    }
    (*F)[o.sigma() + c] = a.mu[c] * y[o.pn() + c] - sum_pf;
  }
  if (o.nb > 0) {
    w_b.noalias() = a.G_b.transpose() * nu;
    F->segment(o.pb(), o.nb) = w_b + a.dpsi_b;
    if (d.joint_stabilization) F->segment(o.pb(), o.nb) += a.psi_b / d.h;
  }
  w_s.noalias() = sup.G_s.transpose() * nu;
  F->segment(o.ps(), o.nps) = w_s;
  for (int k = 0; k < o.ns; ++k) {
    const double L = sup.limit[k];
    const int first = o.ps() + sup.first[k], n = sup.count[k];
    const double s = y[o.ss() + k];
    if (!d.quadratic) {
      double sum = 0.0;
      for (int j = 0; j < n; ++j) {
        (*F)[first + j] += s;
        sum += y[first + j];
      }
      (*F)[o.ss() + k] = L - sum;
    } else if (L > 0.0) {
      const auto p = y.segment(first, 2);
      F->segment(first, 2) += s * p / L;
      (*F)[o.ss() + k] = (L * L - p.squaredNorm()) / L;
    } else {  // no normal force: p_s = 0 and σ_s = 0
      F->segment(first, 2) = y.segment(first, 2);
      (*F)[o.ss() + k] = 1.0;
    }
  }
  if (!J) return;
  J->setZero(o.size(), o.size());
  J->block(o.v(), o.v(), o.nv, o.nv) = d.eps_M;
  J->block(o.v(), o.pn(), o.nv, o.nc) = -a.G_n;
  J->block(o.v(), o.pf(), o.nv, o.nf) = -a.G_f;
  J->block(o.v(), o.pb(), o.nv, o.nb) = -a.G_b;
  J->block(o.v(), o.ps(), o.nv, o.nps) = -sup.G_s;
  J->block(o.pn(), o.v(), o.nc, o.nv) = a.G_n.transpose();
  J->block(o.pf(), o.v(), o.nf, o.nv) = a.G_f.transpose();
  J->block(o.pb(), o.v(), o.nb, o.nv) = a.G_b.transpose();
  J->block(o.ps(), o.v(), o.nps, o.nv) = sup.G_s.transpose();
  for (int c = 0; c < o.nc; ++c) {
    for (int j = 0; j < nd; ++j) {
      (*J)(o.pf() + c * nd + j, o.sigma() + c) = 1.0;
      (*J)(o.sigma() + c, o.pf() + c * nd + j) = -1.0;
    }
    (*J)(o.sigma() + c, o.pn() + c) = a.mu[c];
  }
  for (int k = 0; k < o.ns; ++k) {
    const double L = sup.limit[k];
    const int first = o.ps() + sup.first[k], n = sup.count[k];
    const double s = y[o.ss() + k];
    if (!d.quadratic) {
      for (int j = 0; j < n; ++j) {
        (*J)(first + j, o.ss() + k) = 1.0;
        (*J)(o.ss() + k, first + j) = -1.0;
      }
    } else if (L > 0.0) {
      for (int j = 0; j < 2; ++j) {
        (*J)(first + j, first + j) = s / L;
        (*J)(first + j, o.ss() + k) = y[first + j] / L;
        (*J)(o.ss() + k, first + j) = -2.0 * y[first + j] / L;
      }
    } else {
      J->block(first, o.v(), 2, o.nv).setZero();
      (*J)(first, first) = (*J)(first + 1, first + 1) = 1.0;
    }
  }
}

// The MCP of the step data d, whose assembly is set, into *mcp (its storage reused; evaluate is
// left to the caller): fills its layout *l (= d->layout) and the rest of d from the assembly.
void FillStepMcp(const Scene& model, const State& x, const StepperOptions& options, bool dynamic,
                 bool quadratic, StepData* d, StepLayout* l, McpProblem* mcp_out) {
  l->nq = model.num_positions();
  l->nv = model.num_velocities();
  l->nc = static_cast<int>(d->a.contacts.size());
  l->nd = d->a.nd;
  l->nb = static_cast<int>(d->a.psi_b.size());
  l->ns = d->a.support.points();
  l->nps = d->a.support.columns();
  // M.ToDense() (ε_M times it for the quasistatic models), in d's storage.
  const BlockDiagonal& M = d->a.M;
  d->eps_M.setZero(M.rows(), M.cols());
  for (int o = 0; o < M.rows(); o += M.block_size())
    d->eps_M.block(o, o, M.block_size(), M.block_size()) = M.BlockAt(o);
  if (!dynamic) d->eps_M = kQuasistaticRegularization * d->eps_M;
  if (dynamic)
    d->v0 = x.v;
  else
    d->v0.setZero(l->nv);
  d->h = options.dt;
  d->quadratic = quadratic;
  d->joint_stabilization = options.joint_stabilization;
  const Offsets o = OffsetsOf(*l);
  McpProblem& mcp = *mcp_out;
  mcp.lower.setZero(o.size());
  mcp.upper.setConstant(o.size(), kInf);
  mcp.lower.segment(o.v(), o.nv).setConstant(-kInf);
  mcp.lower.segment(o.pb(), o.nb).setConstant(-kInf);
  if (quadratic) mcp.lower.segment(o.ps(), o.nps).setConstant(-kInf);
}

McpProblem MakeStepMcp(const Scene& model, const State& x, const StepperOptions& options,
                       bool dynamic, bool quadratic, const std::shared_ptr<StepData>& d,
                       StepLayout* l, StepLayout* layout) {
  McpProblem mcp;
  FillStepMcp(model, x, options, dynamic, quadratic, d.get(), l, &mcp);
  mcp.evaluate = [d](const VectorXd& y, VectorXd* F, MatrixXd* J) { StepFunction(*d, y, F, J); };
  if (layout) *layout = *l;
  return mcp;
}

// Quasistatic::Step's storage, one per thread (scratch_lease.h). The linearized support rows
// that StewartTrinkle::AssembleInto writes and the quadratic ones of the DQC models are kept
// in two SupportRows swapped in and out of the assembly, so neither is resized every step.
struct QuasistaticStepScratch {
  StepData d;
  SupportRows other_support;
  bool swapped = false;
  McpProblem mcp;
  VectorXd y, v1;
};

}  // namespace

Quasistatic::Quasistatic(StepperOptions options, McpOptions mcp)
    : options_(std::move(options)),
      solver_(mcp),
      lcp_solver_(MakeLcpSolver(options_.solver, options_.solver_options)),
      assembler_(options_, lcp_solver_),
      quadratic_(options_.formulation != FormulationType::kQuasistaticDlc),
      dynamic_(options_.formulation == FormulationType::kDynamicDqc) {
  if (options_.formulation != FormulationType::kQuasistaticDlc &&
      options_.formulation != FormulationType::kQuasistaticDqc &&
      options_.formulation != FormulationType::kDynamicDqc)
    throw std::invalid_argument(
        "Quasistatic: the formulation must be quasistatic-dlc, quasistatic-dqc or dynamic-dqc");
}

std::string_view Quasistatic::name() const {
  return dynamic_ ? "dynamic-dqc" : quadratic_ ? "quasistatic-dqc" : "quasistatic-dlc";
}

StewartTrinkle::Assembly Quasistatic::Assemble(const Scene& model, const State& x,
                                               const StepInput& u, bool quadratic) const {
  if (model.dim != Dim::kPlanar)
    throw std::invalid_argument(std::string(name()) + ": quasistatic models need a planar scene");
  StewartTrinkle::Assembly a = assembler_.Assemble(model, x, u);
  if (quadratic) a.support = AssembleSupport(model, x, options_.dt, /*quadratic=*/true);
  return a;
}

StewartTrinkle::Assembly Quasistatic::AssembleAt(const Scene& model, const State& x,
                                                 const StepInput& u,
                                                 std::vector<Contact> contacts) const {
  if (model.dim != Dim::kPlanar)
    throw std::invalid_argument(std::string(name()) + ": quasistatic models need a planar scene");
  StewartTrinkle::Assembly a =
      assembler_.AssembleAt(model, x, u, std::move(contacts), /*select_corner_edges=*/false);
  if (quadratic_) a.support = AssembleSupport(model, x, options_.dt, /*quadratic=*/true);
  return a;
}

StepLayout Quasistatic::Layout(const Scene& model, const State& x) const {
  StepLayout l = assembler_.Layout(model, x);
  if (quadratic_) l.nps = 2 * l.ns;
  return l;
}

McpProblem Quasistatic::BuildMcp(const Scene& model, const State& x, const StepInput& u,
                                 StepLayout* layout) const {
  return MakeMcp(model, x, u, quadratic_, layout);
}

McpProblem Quasistatic::MakeMcp(const Scene& model, const State& x, const StepInput& u,
                                bool quadratic, StepLayout* layout,
                                std::vector<Contact>* contacts) const {
  auto d = std::make_shared<StepData>();
  d->a = Assemble(model, x, u, quadratic);
  if (contacts) *contacts = d->a.contacts;
  StepLayout& l = d->layout;
  return MakeStepMcp(model, x, options_, dynamic_, quadratic, d, &l, layout);
}

McpProblem Quasistatic::MakeMcpFrom(const Scene& model, const State& x, StewartTrinkle::Assembly a,
                                    bool quadratic, StepLayout* layout) const {
  auto d = std::make_shared<StepData>();
  d->a = std::move(a);
  return MakeStepMcp(model, x, options_, dynamic_, quadratic, d, &d->layout, layout);
}

SolverReport Quasistatic::SolveDlc(const McpProblem& mcp, const VectorXd* warm, VectorXd* y) const {
  // F(y) = J y + F(0) is affine for DLC. Free unknowns (ν, p_b) are split y = y⁺ − y⁻.
  // (Buffers in this thread's storage: allocation reuse only.)
  thread_local struct DlcScratch {
    VectorXd y0, F0, z, z_warm;
    MatrixXd J;
    std::vector<int> free_rows, nonneg_rows;
    std::vector<std::pair<int, double>> cols;
    LcpProblem lcp;
  } scratch;
  const int n = mcp.size();
  VectorXd& F0 = scratch.F0;
  MatrixXd& J = scratch.J;
  scratch.y0.setZero(n);
  mcp.evaluate(scratch.y0, &F0, &J);
  std::vector<int>&free_rows = scratch.free_rows, &nonneg_rows = scratch.nonneg_rows;
  free_rows.clear();
  nonneg_rows.clear();
  for (int i = 0; i < n; ++i) (std::isinf(mcp.lower[i]) ? free_rows : nonneg_rows).push_back(i);
  const int nf = static_cast<int>(free_rows.size()), nn = static_cast<int>(nonneg_rows.size());
  // LCP unknowns: [y⁺_free (nf); y⁻_free (nf); y_nonneg (nn)].
  std::vector<std::pair<int, double>>& cols = scratch.cols;  // (y index, sign) per LCP unknown
  cols.clear();
  for (int i : free_rows) cols.push_back({i, 1.0});
  for (int i : free_rows) cols.push_back({i, -1.0});
  for (int i : nonneg_rows) cols.push_back({i, 1.0});
  const int m = 2 * nf + nn;
  LcpProblem& lcp = scratch.lcp;
  lcp.M.resize(m, m);
  lcp.q.resize(m);
  for (int r = 0; r < m; ++r) {
    const auto [ri, rs] = cols[r];
    lcp.q[r] = rs * F0[ri];
    for (int c = 0; c < m; ++c) lcp.M(r, c) = rs * cols[c].second * J(ri, cols[c].first);
  }
  // A warm start y_w (the previous step's solution) maps to z = [max(y_w, 0); max(−y_w, 0); y_w].
  VectorXd &z = scratch.z, &z_warm = scratch.z_warm;
  z.setZero(m);
  z_warm.resize(m);
  if (warm && warm->size() == n && warm->allFinite())
    for (int c = 0; c < m; ++c) z_warm[c] = std::max(0.0, cols[c].second * (*warm)[cols[c].first]);
  const SolverReport report =
      lcp_solver_->Solve(lcp, warm && warm->size() == n ? &z_warm : nullptr, &z);
  y->setZero(n);
  for (int c = 0; c < m; ++c) (*y)[cols[c].first] += cols[c].second * z[c];
  return report;
}

void Quasistatic::Step(const Scene& model, const State& x, const StepInput& u, Workspace* ws,
                       State* next, StepInfo* info) const {
  internal::BeginStep(x, next, info);
  const double h = options_.dt;
  // MakeMcp(model, x, u, quadratic_, ...) in this thread's storage.
  if (model.dim != Dim::kPlanar)
    throw std::invalid_argument(std::string(name()) + ": quasistatic models need a planar scene");
  internal::ScratchLease<QuasistaticStepScratch> lease;
  QuasistaticStepScratch& scratch = lease.get();
  StepData* d = &scratch.d;
  if (scratch.swapped) std::swap(d->a.support, scratch.other_support);
  scratch.swapped = false;
  assembler_.AssembleInto(model, x, u, &d->a);
  if (quadratic_) {
    AssembleSupportInto(model, x, options_.dt, /*quadratic=*/true, &scratch.other_support);
    std::swap(d->a.support, scratch.other_support);
    scratch.swapped = true;
  }
  const std::vector<Contact>& contacts = d->a.contacts;  // (for the report)
  StepLayout& l = d->layout;
  McpProblem& mcp = scratch.mcp;
  FillStepMcp(model, x, options_, dynamic_, quadratic_, d, &l, &mcp);
  mcp.evaluate = [d](const VectorXd& y, VectorXd* F, MatrixXd* J) { StepFunction(*d, y, F, J); };
  info->contacts = l.nc;
  info->joint_rows = l.nb;
  info->min_gap = 0.0;
  for (std::size_t c = 0; c < contacts.size(); ++c)
    info->min_gap = c == 0 ? contacts[c].point.gap : std::min(info->min_gap, contacts[c].point.gap);
  if (!internal::CheckStartPenetration(l.nc, options_.max_penetration, info)) return;
  VectorXd& y = scratch.y;
  if (!quadratic_) {
    info->solver = SolveDlc(mcp, &x.warm_start, &y);
  } else {
    if (x.warm_start.size() == mcp.size())
      y = x.warm_start;
    else
      y.setZero(mcp.size());
    if (!y.allFinite()) y.setZero();
    info->solver = solver_.Solve(mcp, &y);
    if (!info->solver.ok()) {
      // Restart from the DLC solution of the same step.
      StepLayout ll;
      const McpProblem lin = MakeMcp(model, x, u, /*quadratic=*/false, &ll);
      VectorXd yl;
      if (SolveDlc(lin, nullptr, &yl).ok()) {
        const Offsets o = OffsetsOf(l), ol = OffsetsOf(ll);
        const SupportRows sl = AssembleSupport(model, x, h, /*quadratic=*/false);
        y = VectorXd::Zero(mcp.size());
        y.head(o.ps()) = yl.head(ol.ps());
        for (int k = 0; k < o.ns; ++k) {
          Vector2d p = Vector2d::Zero();
          for (int j = 0; j < sl.count[k]; ++j) {
            const double phi = 2.0 * 3.14159265358979323846 * j / sl.count[k];
            p += yl[ol.ps() + sl.first[k] + j] * Vector2d(std::cos(phi), std::sin(phi));
          }
          y.segment(o.ps() + 2 * k, 2) = p;
          y[o.ss() + k] = yl[ol.ss() + k];
        }
        const int first_iterations = info->solver.iterations;
        info->solver = solver_.Solve(mcp, &y);
        info->solver.iterations += first_iterations;
      }
    }
  }
  if (!info->solver.ok()) {
    internal::SolverFailed(quadratic_ ? "MCP solver '" + std::string(solver_.name()) + "'"
                                      : "LCP solver '" + std::string(lcp_solver_->name()) + "'",
                           info);
    return;
  }
  scratch.v1 = y.head(l.nv);
  if (!internal::CompleteStep(model, x, scratch.v1, h, &y, next, info)) return;
  if (ws) ws->contacts = contacts;  // a copy into its storage (the assembly is reused)
  info->ok = true;
  info->status = StepStatus::kOk;
}

StepResiduals Quasistatic::Evaluate(const Scene& model, const Params& params, const State& x,
                                    const StepInput& u, const VectorXd& z) const {
  return EvaluateAssembly(model, params, Assemble(model, x, u, quadratic_), x, z);
}

StepResiduals Quasistatic::EvaluateAssembly(const Scene& model, const Params& params,
                                            const StewartTrinkle::Assembly& a, const State& x,
                                            const VectorXd& z) const {
  StepLayout l;
  const McpProblem mcp = MakeMcpFrom(model, x, a, quadratic_, &l);
  const std::string who = std::string(name()) + "::Evaluate";
  if (z.size() != l.size())
    throw std::invalid_argument(who + ": z has " + std::to_string(z.size()) +
                                " entries, the step layout needs " + std::to_string(l.size()));
  if (params.values.size() != model.param_table().size())
    throw std::invalid_argument(who + ": params do not match the scene");
  const Offsets o = OffsetsOf(l);
  const int nq = l.nq, nv = l.nv, nb = l.nb;
  const double h = options_.dt;
  const VectorXd y = z.tail(o.size());
  VectorXd F;
  MatrixXd JF;
  mcp.evaluate(y, &F, &JF);

  StepResiduals r;
  r.layout = l;
  const std::vector<int> column_of =
      internal::DifferentiableParamColumns(model.param_table(), l.size(), &r.param_columns);
  const int ncol = l.size() + static_cast<int>(r.param_columns.size());

  // Rows of F (indices into y) that are equations and pairs, in the documented order.
  std::vector<int> eq_rows, comp_rows;
  for (int i = 0; i < nv; ++i) eq_rows.push_back(o.v() + i);
  for (int i = o.pn(); i < o.pb(); ++i) comp_rows.push_back(i);  // p_n, p_f, σ
  for (int i = 0; i < nb; ++i) eq_rows.push_back(o.pb() + i);
  for (int i = 0; i < o.nps; ++i) (quadratic_ ? eq_rows : comp_rows).push_back(o.ps() + i);
  for (int i = 0; i < o.ns; ++i) comp_rows.push_back(o.ss() + i);

  // Equalities: [impulse balance (nv); kinematics (nq); joints (nb); DQC support (nps)].
  const int neq = static_cast<int>(eq_rows.size()) + nq;
  r.equality.resize(neq);
  r.d_equality = MatrixXd::Zero(neq, ncol);
  const auto put_eq = [&](int row, int f_row) {
    r.equality[row] = F[f_row];
    r.d_equality.block(row, nq, 1, o.size()) = JF.row(f_row);
  };
  for (int i = 0; i < nv; ++i) put_eq(i, eq_rows[i]);
  for (int i = nv; i < static_cast<int>(eq_rows.size()); ++i) put_eq(i + nq, eq_rows[i]);
  VectorXd q_pred(nq);
  for (int bi : model.dynamic_bodies()) {
    const BodyIndex& idx = model.index(bi);
    IntegratePosition(model.dim, x.q.data() + idx.q, y.data() + idx.v, h, q_pred.data() + idx.q);
    for (int k = 0; k < 3; ++k) r.d_equality(nv + idx.q + k, l.v1() + idx.v + k) = -h;
  }
  r.equality.segment(nv, nq) = z.head(nq) - q_pred;
  r.d_equality.block(nv, l.q1(), nq, nq).setIdentity();

  const int ncomp = static_cast<int>(comp_rows.size());
  r.comp_a.resize(ncomp);
  r.comp_b.resize(ncomp);
  r.d_comp_a = MatrixXd::Zero(ncomp, ncol);
  r.d_comp_b = MatrixXd::Zero(ncomp, ncol);
  for (int i = 0; i < ncomp; ++i) {
    r.comp_a[i] = y[comp_rows[i]];
    r.d_comp_a(i, nq + comp_rows[i]) = 1.0;
    r.comp_b[i] = F[comp_rows[i]];
    r.d_comp_b.block(i, nq, 1, o.size()) = JF.row(comp_rows[i]);
  }

  // Parameter columns. Friction: the σ rows U p_n − Eᵀ p_f (pairs nc + nf .. 2nc + nf).
  for (int c = 0; c < o.nc; ++c)
    r.d_comp_b(o.nc + o.nf + c, column_of[a.contacts[c].mu_param]) = y[o.pn() + c];
  // Support rows through the disk radius L_k = h μ_s N_k: column `col` with ∂L_k = dL.
  const SupportRows& sup = a.support;
  const auto add_radius_derivative = [&](int k, int col, double dL) {
    const int sk = ncomp - o.ns + k;  // σ_s pair of point k
    if (!quadratic_) {
      r.d_comp_b(sk, col) = dL;
    } else if (sup.limit[k] > 0.0) {
      const double Lk = sup.limit[k];
      const auto p = y.segment(o.ps() + sup.first[k], 2);
      const double s = y[o.ss() + k];
      r.d_comp_b(sk, col) = (1.0 + p.squaredNorm() / (Lk * Lk)) * dL;
      // DQC support equations follow the joints in the equality block.
      const int e0 = nv + nq + nb + 2 * k;
      for (int j = 0; j < 2; ++j) r.d_equality(e0 + j, col) = -s * p[j] / (Lk * Lk) * dL;
    }
  };
  for (int i = 0; i < model.param_table().size(); ++i) {
    const ParamInfo& info = model.param_table().info(i);
    if (info.kind != ParamKind::kSupportFriction) continue;
    for (int k = 0; k < o.ns; ++k)
      if (sup.body[k] == info.a) add_radius_derivative(k, column_of[i], sup.hN[k]);
  }
  // Mass: ε_M M ν − p_ext scale with m (inertia ∝ m); a static support load scales with m.
  for (int i = 0; i < model.param_table().size(); ++i) {
    const ParamInfo& info = model.param_table().info(i);
    if (info.kind != ParamKind::kMass) continue;
    const Body& b = model.bodies[info.a];
    const int ov = model.index(info.a).v;
    const double scale = dynamic_ ? 1.0 : kQuasistaticRegularization;
    const VectorXd dv =
        y.segment(ov, 3) - (dynamic_ ? VectorXd(x.v.segment(ov, 3)) : VectorXd::Zero(3));
    VectorXd dm = scale * a.M.BlockAt(ov).topLeftCorner(3, 3) * dv / b.mass;
    if (b.gravity) dm.head(2) -= h * model.gravity_W.head(2);
    r.d_equality.block(ov, column_of[i], 3, 1) = dm;
    if (!b.support.static_distribution) continue;
    for (int k = 0; k < o.ns; ++k)
      if (sup.body[k] == info.a) add_radius_derivative(k, column_of[i], sup.limit[k] / b.mass);
  }
  return r;
}

}  // namespace vinci::sim
