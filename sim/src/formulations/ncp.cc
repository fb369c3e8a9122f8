#include "vinci/sim/formulations/ncp.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <vector>

#include "../solvers/scratch_lease.h"
#include "ncp_internal.h"
#include "step_record.h"
#include "step_util.h"
#include "stewart_trinkle_internal.h"
#include "vinci/sim/model/kinematics.h"

namespace vinci::sim {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
// p_ref floor for ε_σ when no external impulse acts (N·s).
constexpr double kMinImpulseScale = 1e-6;
// A contact with p_n ≤ this · p_ref is unloaded for the polish step.
constexpr double kUnloaded = 1e-6;
// Floor of the velocity scale V (m/s).
constexpr double kMinVelocityScale = 1e-9;

// p_ref = max(‖p_ext‖_∞, kMinImpulseScale).
double ImpulseScale(const StewartTrinkle::Assembly& a) {
  return std::max(a.p_ext.size() ? a.p_ext.cwiseAbs().maxCoeff() : 0.0, kMinImpulseScale);
}

StepperOptions AssemblyOptions(StepperOptions o) {
  o.formulation = FormulationType::kStewartTrinkle;  // position-level normal rows
  o.friction_directions = 4;                         // d_0 = t, d_1 = o, d_2 = −t, d_3 = −o
  return o;
}

}  // namespace

namespace internal {

// The numbers the MCP function needs: u = b + A P for P = z.head(3 n_c) (normal, then (t, o)
// per contact), the velocity of each row's direction (normal rows: the full normal row).
struct NcpData {
  std::vector<int> sel;  // Build's LCP index of each MCP force (storage only)
  int nc = 0;
  bool planar = false;
  MatrixXd A;   // 3 n_c × 3 n_c, ε_n on the normal diagonal included
  VectorXd b;   // 3 n_c
  VectorXd mu;  // n_c
  double et2 = 1.0, eo2 = 1.0;
  double eps_t = 0.0, eps_s = 0.0;                        // ε_t (m/s) and ε_σ (N²·s³/m)
  Eigen::SparseMatrix<double, Eigen::RowMajor> A_sparse;  // A without its zeros (sparse path)
  // SparseJacobianNcp's storage: J's terms in the order setFromTriplets sums them, and for the
  // patterns of A_sparse (a_outer, a_inner) and J (j_outer, j_inner) they were found for, each
  // term's index in J's values and whether it is the first term of its entry.
  struct SparseJacobianCache {
    std::vector<Eigen::Triplet<double>> terms;
    std::vector<int> pos, a_outer, a_inner, j_outer, j_inner;
    std::vector<char> first;
    VectorXd Az, u;
  };
  mutable SparseJacobianCache jac;  // (one thread evaluates an NcpData at a time)
};

}  // namespace internal

namespace {

using internal::NcpData;

// A.sparseView() (A's entries that are not 0, row by row) into *S, reusing its storage.
void SparseViewInto(const MatrixXd& A, Eigen::SparseMatrix<double, Eigen::RowMajor>* S) {
  const Eigen::Index rows = A.rows(), cols = A.cols();
  const auto kept = [](double a) { return !(std::abs(a) <= 0.0); };  // (NaN is kept)
  Eigen::Index nnz = 0;
  for (Eigen::Index j = 0; j < cols; ++j)
    for (Eigen::Index i = 0; i < rows; ++i) nnz += kept(A(i, j)) ? 1 : 0;
  S->resize(rows, cols);
  S->resizeNonZeros(nnz);
  int* outer = S->outerIndexPtr();
  int* inner = S->innerIndexPtr();
  double* values = S->valuePtr();
  int k = 0;
  for (Eigen::Index i = 0; i < rows; ++i) {
    outer[i] = k;
    for (Eigen::Index j = 0; j < cols; ++j) {
      if (!kept(A(i, j))) continue;
      inner[k] = static_cast<int>(j);
      values[k++] = A(i, j);
    }
  }
  outer[rows] = k;
}

// Whether v holds the n ints at p.
bool SameInts(const std::vector<int>& v, const int* p, Eigen::Index n) {
  return static_cast<Eigen::Index>(v.size()) == n && std::equal(p, p + n, v.begin());
}

// The same Jacobian as EvaluateNcp, as a sparse matrix with a z-independent pattern. When A's
// pattern and *J's are those of the last call, the values are written in place (the same sums
// in the same order as setFromTriplets), else J is built from triplets.
void SparseJacobianNcp(const NcpData& d, const VectorXd& z, Eigen::SparseMatrix<double>* J) {
  using RowIt = Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator;
  const int nc = d.nc, m = 3 * nc;
  NcpData::SparseJacobianCache& cache = d.jac;
  // u = b + A P with the product in a buffer first (as Eigen evaluates the sum).
  cache.Az.noalias() = d.A_sparse * z.head(m);
  cache.u = d.b + cache.Az;
  const VectorXd& u = cache.u;
  std::vector<Eigen::Triplet<double>>& t = cache.terms;
  t.clear();
  for (int c = 0; c < nc; ++c) {
    const int in = c, it = nc + 2 * c, io = it + 1, is = m + c;
    const double pn = z[in], pt = z[it], po = z[io], s = z[is], mu = d.mu[c];
    for (RowIt e(d.A_sparse, in); e; ++e) t.emplace_back(in, static_cast<int>(e.col()), e.value());
    for (RowIt e(d.A_sparse, it); e; ++e)
      t.emplace_back(it, static_cast<int>(e.col()), d.et2 * mu * pn * e.value());
    for (RowIt e(d.A_sparse, io); e; ++e)
      t.emplace_back(io, static_cast<int>(e.col()), d.eo2 * mu * pn * e.value());
    t.emplace_back(it, in, d.et2 * mu * u[it]);
    t.emplace_back(io, in, d.eo2 * mu * u[io]);
    t.emplace_back(it, it, (s + d.eps_t));
    t.emplace_back(io, io, (s + d.eps_t));
    t.emplace_back(it, is, pt);
    t.emplace_back(io, is, po);
    t.emplace_back(is, in, 2.0 * mu * mu * pn);
    t.emplace_back(is, it, -2.0 * pt / d.et2);
    t.emplace_back(is, io, -2.0 * po / d.eo2);
    t.emplace_back(is, is, d.eps_s);
  }
  const Eigen::SparseMatrix<double, Eigen::RowMajor>& A = d.A_sparse;
  const bool same = J->rows() == 4 * nc && J->cols() == 4 * nc && J->isCompressed() &&
                    cache.pos.size() == t.size() &&
                    SameInts(cache.a_outer, A.outerIndexPtr(), A.outerSize() + 1) &&
                    SameInts(cache.a_inner, A.innerIndexPtr(), A.nonZeros()) &&
                    SameInts(cache.j_outer, J->outerIndexPtr(), J->outerSize() + 1) &&
                    SameInts(cache.j_inner, J->innerIndexPtr(), J->nonZeros());
  if (same) {
    double* values = J->valuePtr();
    for (std::size_t k = 0; k < t.size(); ++k) {
      if (cache.first[k])
        values[cache.pos[k]] = t[k].value();
      else
        values[cache.pos[k]] += t[k].value();
    }
    return;
  }
  J->resize(4 * nc, 4 * nc);
  J->setFromTriplets(t.begin(), t.end());  // duplicates (diagonal of A and the σ term) add
  // Where each term lands (J is compressed, rows sorted within each column).
  const int* outer = J->outerIndexPtr();
  const int* inner = J->innerIndexPtr();
  cache.pos.resize(t.size());
  cache.first.assign(t.size(), 0);
  std::vector<char> seen(J->nonZeros(), 0);
  for (std::size_t k = 0; k < t.size(); ++k) {
    const int col = t[k].col();
    const int p = static_cast<int>(
        std::lower_bound(inner + outer[col], inner + outer[col + 1], t[k].row()) - inner);
    cache.pos[k] = p;
    cache.first[k] = seen[p] ? 0 : 1;
    seen[p] = 1;
  }
  cache.a_outer.assign(A.outerIndexPtr(), A.outerIndexPtr() + A.outerSize() + 1);
  cache.a_inner.assign(A.innerIndexPtr(), A.innerIndexPtr() + A.nonZeros());
  cache.j_outer.assign(outer, outer + J->outerSize() + 1);
  cache.j_inner.assign(inner, inner + J->nonZeros());
}

void EvaluateNcp(const NcpData& d, const VectorXd& z, VectorXd* F, MatrixXd* J) {
  const int nc = d.nc, m = 3 * nc;
  // u = b + A P with the product in a buffer first (as Eigen evaluates the sum), in this
  // thread's storage.
  thread_local VectorXd Az, u_buffer;
  Az.noalias() = d.A * z.head(m);
  VectorXd& u = u_buffer;
  u = d.b + Az;
  F->resize(4 * nc);
  if (J) J->setZero(4 * nc, 4 * nc);
  for (int c = 0; c < nc; ++c) {
    const int in = c, it = nc + 2 * c, io = it + 1, is = m + c;
    const double pn = z[in], pt = z[it], po = z[io], s = z[is], mu = d.mu[c];
    (*F)[in] = u[in];
    const double et = d.eps_t, es = d.eps_s;
    (*F)[it] = (d.et2 * mu * pn * u[it] + (s + et) * pt);
    (*F)[io] = (d.eo2 * mu * pn * u[io] + (s + et) * po);
    (*F)[is] = (mu * mu * pn * pn - pt * pt / d.et2 - po * po / d.eo2 + es * s);
    if (!J) continue;
    J->block(in, 0, 1, m) = d.A.row(in);
    J->block(it, 0, 1, m) = d.et2 * mu * pn * d.A.row(it);
    J->block(io, 0, 1, m) = d.eo2 * mu * pn * d.A.row(io);
    (*J)(it, in) += d.et2 * mu * u[it];
    (*J)(io, in) += d.eo2 * mu * u[io];
    (*J)(it, it) += (s + et);
    (*J)(io, io) += (s + et);
    (*J)(it, is) = pt;
    (*J)(io, is) = po;
    (*J)(is, in) = 2.0 * mu * mu * pn;
    (*J)(is, it) = -2.0 * pt / d.et2;
    (*J)(is, io) = -2.0 * po / d.eo2;
    (*J)(is, is) = es;
  }
}

std::string Sci(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", x);
  return buf;
}

std::string Describe(const SolverReport& r) {
  return std::string(ToString(r.status)) + ", residual " + Sci(r.residual) + " after " +
         std::to_string(r.iterations) + " iterations" +
         (r.message.empty() ? "" : " (" + r.message + ")");
}

}  // namespace

NcpStepper::NcpStepper(StepperOptions options, NcpOptions ncp)
    : options_(options),
      ncp_(ncp),
      st_(AssemblyOptions(options), MakeLcpSolver(options.solver, options.solver_options)),
      lcp_solver_(MakeLcpSolver(options.solver, options.solver_options)),
      mcp_(ncp.mcp),
      mcp_sparse_([&] {
        McpOptions o = ncp.mcp;
        o.sparse = true;
        return o;
      }()) {
  if (!(ncp_.e_t > 0.0) || !(ncp_.e_o > 0.0) || !std::isfinite(ncp_.e_t) ||
      !std::isfinite(ncp_.e_o))
    throw std::invalid_argument("NcpStepper: ellipticities e_t, e_o must be finite and > 0");
}

NcpStepper::StepProblem NcpStepper::Build(const Scene& model, const State& x,
                                          const StepInput& u) const {
  StepProblem sp;
  auto d = std::make_shared<NcpData>();
  BuildInto(model, x, u, &sp, d.get());
  sp.mcp.evaluate = [d](const VectorXd& z, VectorXd* F, MatrixXd* J) { EvaluateNcp(*d, z, F, J); };
  d->A_sparse = d->A.sparseView();
  sp.mcp.sparse_jacobian = [d](const VectorXd& z, Eigen::SparseMatrix<double>* J) {
    SparseJacobianNcp(*d, z, J);
  };
  return sp;
}

void NcpStepper::BuildInto(const Scene& model, const State& x, const StepInput& u,
                           StepProblem* sp_out, NcpData* d) const {
  StepProblem& sp = *sp_out;
  st_.AssembleInto(model, x, u, &sp.assembly);
  const StewartTrinkle::Assembly& a = sp.assembly;
  st_.BuildLcpInto(model, a, x.v, &sp.v_star, &sp.joints, &sp.lcp);
  const int nc = static_cast<int>(a.contacts.size()), nd = a.nd;
  d->nc = nc;
  d->planar = model.dim == Dim::kPlanar;
  d->mu = a.mu;
  d->et2 = ncp_.e_t * ncp_.e_t;
  d->eo2 = ncp_.e_o * ncp_.e_o;
  // LCP index of each MCP force: normal c, t: column 0, o: column 1 (−1 planar).
  std::vector<int>& sel = d->sel;
  sel.assign(3 * nc, -1);
  for (int c = 0; c < nc; ++c) {
    sel[c] = c;
    sel[nc + 2 * c] = nc + c * nd;
    if (!d->planar) sel[nc + 2 * c + 1] = nc + c * nd + 1;
  }
  d->A.setZero(3 * nc, 3 * nc);
  d->b.setZero(3 * nc);
  for (int i = 0; i < 3 * nc; ++i) {
    if (sel[i] < 0) continue;
    d->b[i] = sp.lcp.q[sel[i]];
    for (int j = 0; j < 3 * nc; ++j)
      if (sel[j] >= 0) d->A(i, j) = sp.lcp.M(sel[i], sel[j]);
  }
  // ε_n on rigid normal rows only (a compliant row already has its diagonal γ > 0).
  double diag = 0.0;
  for (int c = 0; c < nc; ++c) diag = std::max(diag, d->A(c, c) - a.compliance[c].vel_diagonal);
  for (int c = 0; c < nc; ++c)
    if (!a.compliance[c].compliant) d->A(c, c) += ncp_.normal_regularization * diag;
  // Scales (NcpOptions::scale_rows): impulses by P, σ and velocities by V (see ncp.h).
  double P = 1.0, V = 1.0;
  if (ncp_.scale_rows && nc > 0) {
    P = ImpulseScale(a);
    double approach = 0.0;  // impulse that stops the fastest free approach at one contact
    for (int c = 0; c < nc; ++c)
      if (d->A(c, c) > 0.0) approach = std::max(approach, -d->b[c] / d->A(c, c));
    P = std::max(P, approach);
    V = std::max({P * d->A.diagonal().maxCoeff(), d->b.cwiseAbs().maxCoeff(), kMinVelocityScale});
  }
  d->A *= P / V;
  d->b /= V;
  d->eps_t = ncp_.tangent_regularization / V;
  d->eps_s = ncp_.scale_rows ? ncp_.cone_regularization
                             : ncp_.cone_regularization * ImpulseScale(a) * ImpulseScale(a);
  sp.scale.setConstant(4 * nc, P);
  sp.scale.tail(nc).setConstant(V);

  sp.mcp.lower.setZero(4 * nc);
  sp.mcp.upper.setConstant(4 * nc, kInf);
  sp.mcp.lower.segment(nc, 2 * nc).setConstant(-kInf);
  if (d->planar)
    for (int c = 0; c < nc; ++c) sp.mcp.lower[nc + 2 * c + 1] = sp.mcp.upper[nc + 2 * c + 1] = 0;
}

VectorXd NcpStepper::VelocityAfter(const StepProblem& sp, const VectorXd& z) const {
  const StewartTrinkle::Assembly& a = sp.assembly;
  const int nc = static_cast<int>(a.contacts.size()), nd = a.nd;
  VectorXd z_lcp = VectorXd::Zero(sp.lcp.size());
  for (int c = 0; c < nc; ++c) {
    z_lcp[c] = z[c];
    z_lcp[nc + c * nd] = z[nc + 2 * c];  // VelocityAfter is linear: a signed p_t is fine
    if (nd == 4) z_lcp[nc + c * nd + 1] = z[nc + 2 * c + 1];
  }
  return st_.VelocityAfter(a, sp.v_star, z_lcp, sp.joints);
}

VectorXd NcpStepper::FromLcpSolution(const StepProblem& sp, const VectorXd& z_lcp) const {
  const StewartTrinkle::Assembly& a = sp.assembly;
  const int nc = static_cast<int>(a.contacts.size()), nd = a.nd, nf = nc * nd;
  VectorXd z = VectorXd::Zero(4 * nc);
  for (int c = 0; c < nc; ++c) {
    const double* f = z_lcp.data() + nc + c * nd;
    z[c] = z_lcp[c];
    if (nd == 4) {
      z[nc + 2 * c] = f[0] - f[2];
      z[nc + 2 * c + 1] = f[1] - f[3];
    } else {
      z[nc + 2 * c] = f[0] - f[1];
    }
    z[3 * nc + c] = z_lcp[nc + nf + c];
  }
  return z;
}

VectorXd NcpStepper::FreeSlipStart(const StepProblem& sp) const {
  const StewartTrinkle::Assembly& a = sp.assembly;
  const int nc = static_cast<int>(a.contacts.size()), nd = a.nd;
  VectorXd z = VectorXd::Zero(4 * nc);
  for (int c = 0; c < nc; ++c) {
    const double ut = sp.lcp.q[nc + c * nd];
    const double uo = nd == 4 ? sp.lcp.q[nc + c * nd + 1] : 0.0;
    z[3 * nc + c] = std::hypot(ncp_.e_t * ut, ncp_.e_o * uo);
  }
  return z;
}

namespace {

// NcpStepper::Step's storage, one per thread (scratch_lease.h).
struct NcpStepScratch {
  NcpStepper::StepProblem sp;
  NcpData d;
  VectorXd z, z_lcp, v1;
  internal::StepRecord record;  // what sp.assembly was made from (step_record.h)
};

}  // namespace

void internal::ClearNcpStepRecord() {
  ScratchLease<NcpStepScratch> lease;  // a nested lease's scratch is fresh: nothing to clear
  lease.get().record.Clear();
}

void internal::StampNcpStepOwner(const std::shared_ptr<const Scene>& scene) {
  ScratchLease<NcpStepScratch> lease;
  StepRecord& r = lease.get().record;
  if (r.valid && r.model == scene.get()) r.owner = scene;
}

bool internal::CopyNcpStepAssembly(const NcpStepper& ncp, const std::shared_ptr<const Scene>& scene,
                                   const State& x, const StepInput& u,
                                   StewartTrinkle::Assembly* out) {
  ScratchLease<NcpStepScratch> lease;
  const NcpStepScratch& s = lease.get();
  if (!s.record.Holds(ncp.assembler(), scene, x, u)) return false;
  *out = s.sp.assembly;
  return true;
}

void NcpStepper::Step(const Scene& model, const State& x, const StepInput& u, Workspace* ws,
                      State* next, StepInfo* info) const {
  internal::BeginStep(x, next, info);
  const double h = options_.dt;
  internal::ScratchLease<NcpStepScratch> lease;
  NcpStepScratch& scratch = lease.get();
  StepProblem& sp = scratch.sp;
  NcpData* d = &scratch.d;
  // Kept for the step derivative's frozen model, with what it was made from (step_record.h).
  scratch.record.Clear();
  BuildInto(model, x, u, &sp, d);
  scratch.record.Stamp(st_, model, x, u);
  // Bound to this thread's data (a pointer: the std::function holds it without allocating).
  sp.mcp.evaluate = [d](const VectorXd& z, VectorXd* F, MatrixXd* J) { EvaluateNcp(*d, z, F, J); };
  const StewartTrinkle::Assembly& a = sp.assembly;
  const int nc = static_cast<int>(a.contacts.size());
  info->contacts = nc;
  info->joint_rows = static_cast<int>(a.psi_b.size());
  info->min_gap = nc > 0 ? a.psi_n.minCoeff() : 0.0;
  if (!internal::CheckStartPenetration(nc, options_.max_penetration, info)) return;
  if (nc >= ncp_.sparse_min_contacts) {
    SparseViewInto(d->A, &d->A_sparse);
    sp.mcp.sparse_jacobian = [d](const VectorXd& z, Eigen::SparseMatrix<double>* J) {
      SparseJacobianNcp(*d, z, J);
    };
  } else {
    sp.mcp.sparse_jacobian = nullptr;  // (the dense solver does not read it)
  }

  VectorXd& z = scratch.z;
  z.setZero(4 * nc);
  if (nc > 0) {
    // Starts, in order: the previous step's solution, zero, the Stewart–Trinkle LCP solution
    // of this step. The first converged attempt is accepted; each failure is reported.
    const bool warm = x.warm_start.size() == 4 * nc && x.warm_start.allFinite();
    const McpSolver& mcp = nc >= ncp_.sparse_min_contacts ? mcp_sparse_ : mcp_;
    // The MCP's unknowns are ẑ = z ⊘ sp.scale; starts and the result are converted.
    const VectorXd& scale = sp.scale;
    std::string history;
    int iterations = 0;
    double time_s = 0.0;
    bool solved = false;
    for (int attempt = warm ? 0 : 1; attempt < 3 && !solved; ++attempt) {
      const char* start = attempt == 0   ? "warm start"
                          : attempt == 1 ? "free-slip start"
                                         : "LCP start";
      if (attempt == 0) {
        z = x.warm_start.cwiseQuotient(scale);
      } else if (attempt == 1) {
        z = FreeSlipStart(sp).cwiseQuotient(scale);
      } else {
        VectorXd z_lcp;
        const SolverReport lcp = lcp_solver_->Solve(sp.lcp, nullptr, &z_lcp);
        time_s += lcp.time_s;
        if (!lcp.ok()) {
          history += std::string(history.empty() ? "" : "; ") +
                     "Stewart-Trinkle LCP for the start failed: " + Describe(lcp);
          continue;
        }
        z = FromLcpSolution(sp, z_lcp).cwiseQuotient(scale);
      }
      if (!z.allFinite()) {
        history += std::string(history.empty() ? "" : "; ") + start + ": not finite";
        continue;
      }
      info->solver = mcp.Solve(sp.mcp, &z);
      iterations += info->solver.iterations;
      time_s += info->solver.time_s;
      solved = info->solver.ok();
      if (solved) break;
      history += std::string(history.empty() ? "" : "; ") + start + ": " + Describe(info->solver);
      // Polish: fix the friction of unloaded contacts at 0 and re-solve from the best point.
      McpProblem reduced = sp.mcp;
      VectorXd zr = z;
      int fixed = 0;
      for (int c = 0; c < nc; ++c) {
        if (!(z[c] * scale[c] <= kUnloaded * ImpulseScale(a))) continue;
        for (int i : {nc + 2 * c, nc + 2 * c + 1, 3 * nc + c}) {
          reduced.lower[i] = reduced.upper[i] = 0.0;
          zr[i] = 0.0;
        }
        ++fixed;
      }
      if (fixed == 0) continue;
      const SolverReport polish = mcp.Solve(reduced, &zr);
      iterations += polish.iterations;
      time_s += polish.time_s;
      if (polish.ok()) {
        // Give each fixed contact its exact sliding friction for the (tiny) p_n it carries:
        // p_(t,o) = −μ p_n (e_t² u_t, e_o² u_o)/σ, σ = ‖(e_t u_t, e_o u_o)‖ (0 if not slipping).
        zr = zr.cwiseProduct(scale);
        const VectorXd v1 = VelocityAfter(sp, zr);
        const double et = ncp_.e_t, eo = ncp_.e_o;
        for (int c = 0; c < nc; ++c) {
          if (reduced.lower[3 * nc + c] != reduced.upper[3 * nc + c]) continue;
          const int nd = a.nd;
          const double ut = a.G_f.col(c * nd).dot(v1) + a.dpsi_f[c * nd];
          const double uo = model.dim == Dim::kPlanar
                                ? 0.0
                                : a.G_f.col(c * nd + 1).dot(v1) + a.dpsi_f[c * nd + 1];
          const double slip = std::hypot(et * ut, eo * uo);
          if (!(slip > 0.0)) continue;
          zr[nc + 2 * c] = -a.mu[c] * zr[c] * et * et * ut / slip;
          zr[nc + 2 * c + 1] = -a.mu[c] * zr[c] * eo * eo * uo / slip;
          zr[3 * nc + c] = slip;
        }
        zr = zr.cwiseQuotient(scale);
      }
      const double full = polish.ok() ? McpResidual(sp.mcp, zr) : polish.residual;
      double pn_fixed = 0.0;
      for (int c = 0; c < nc; ++c)
        if (reduced.lower[3 * nc + c] == reduced.upper[3 * nc + c])
          pn_fixed = std::max(pn_fixed, zr[c] * scale[c]);
      if (polish.ok() && full <= mcp_.options().tolerance) {
        z = zr;
        info->solver = polish;
        info->solver.residual = full;
        info->solver.message =
            "polished with " + std::to_string(fixed) + " unloaded contact(s) frictionless";
        solved = true;
      } else {
        history += "; polish of " + std::to_string(fixed) + " unloaded contact(s): " +
                   (polish.ok() ? "full residual " + Sci(full) + ", p_n max " + Sci(pn_fixed)
                                : Describe(polish));
      }
    }
    info->solver.iterations = iterations;
    info->solver.time_s = time_s;
    if (!history.empty()) {
      const std::string note = (solved ? "retried after: " : "") + history;
      info->solver.message =
          info->solver.message.empty() || !solved ? note : info->solver.message + "; " + note;
    }
    if (!solved) {
      internal::FailStep(StepStatus::kSolverFailed, "MCP failed from every start: " + history,
                         info);
      return;
    }
    z = z.cwiseProduct(scale);
  } else {
    info->solver.status = SolverStatus::kSolved;
  }

  // VelocityAfter, in this thread's storage.
  VectorXd& z_lcp = scratch.z_lcp;
  z_lcp.setZero(sp.lcp.size());
  for (int c = 0; c < nc; ++c) {
    z_lcp[c] = z[c];
    z_lcp[nc + c * a.nd] = z[nc + 2 * c];
    if (a.nd == 4) z_lcp[nc + c * a.nd + 1] = z[nc + 2 * c + 1];
  }
  st_.VelocityAfterInto(a, sp.v_star, z_lcp, sp.joints, &scratch.v1);
  if (!internal::CompleteStep(model, x, scratch.v1, h, &z, next, info)) return;
  if (ws) ws->contacts = sp.assembly.contacts;  // a copy into its storage (the assembly is reused)
  info->ok = true;
  info->status = StepStatus::kOk;
}

StepLayout NcpStepper::Layout(const Scene& model, const State& x) const {
  StepLayout l = st_.Layout(model, x);
  l.nd = 2;
  return l;
}

StepResiduals NcpStepper::Evaluate(const Scene& model, const Params& params, const State& x,
                                   const StepInput& u, const VectorXd& z) const {
  return EvaluateAssembly(model, params, st_.Assemble(model, x, u), x, z);
}

StepLayout NcpStepper::LayoutOfAssembly(const Scene& model, const StewartTrinkle::Assembly& a) {
  StepLayout l;
  l.nq = model.num_positions();
  l.nv = model.num_velocities();
  l.nc = static_cast<int>(a.contacts.size());
  l.nd = 2;
  l.nb = static_cast<int>(a.psi_b.size());
  return l;
}

StepResiduals NcpStepper::EvaluateAssembly(const Scene& model, const Params& params,
                                           const StewartTrinkle::Assembly& a, const State& x,
                                           const VectorXd& z) const {
  StepResiduals r;
  internal::SparseJacobians jac;
  internal::NcpEvaluateAssemblyInto(*this, model, params, a, x, z, &r, &jac);
  const int ncol = r.layout.size() + static_cast<int>(r.param_columns.size());
  const auto dense = [ncol](const internal::SparseRows& from, MatrixXd* to) {
    to->setZero(from.rows(), ncol);
    for (int i = 0; i < from.rows(); ++i)
      for (int k = from.ptr[i]; k < from.ptr[i + 1]; ++k) (*to)(i, from.col[k]) = from.val[k];
  };
  dense(jac.equality, &r.d_equality);
  dense(jac.comp_a, &r.d_comp_a);
  dense(jac.comp_b, &r.d_comp_b);
  return r;
}

void internal::NcpEvaluateAssemblyInto(const NcpStepper& ncp, const Scene& model,
                                       const Params& params, const StewartTrinkle::Assembly& a,
                                       const State& x, const VectorXd& z, StepResiduals* out,
                                       SparseJacobians* jac) {
  StepResiduals& r = *out;
  StepLayout& l = r.layout;
  l = NcpStepper::LayoutOfAssembly(model, a);
  if (z.size() != l.size())
    throw std::invalid_argument("NcpStepper::Evaluate: z has " + std::to_string(z.size()) +
                                " entries, the step layout needs " + std::to_string(l.size()));
  const int nc = l.nc, nv = l.nv, nq = l.nq, nb = l.nb, nd = a.nd;
  const bool planar = model.dim == Dim::kPlanar;
  r.d_equality.resize(0, 0);
  r.d_comp_a.resize(0, 0);
  r.d_comp_b.resize(0, 0);

  // The Stewart–Trinkle equations with p_f = (p_t, p_o, 0, 0) (planar (p_t, 0)) give the
  // dynamics, kinematics, joint and normal rows.
  struct Scratch {
    VectorXd zs;
    StepResiduals rs;
    SparseJacobians js;
    std::vector<int> col;
  };
  ScratchLease<Scratch> lease;
  Scratch& sc = lease.get();
  StepLayout ls = l;
  ls.nd = nd;
  VectorXd& zs = sc.zs;
  zs.setZero(ls.size());
  zs.head(nq + nv + nc) = z.head(nq + nv + nc);
  for (int c = 0; c < nc; ++c) {
    zs[ls.pf() + c * nd] = z[l.pf() + 2 * c];
    if (!planar) zs[ls.pf() + c * nd + 1] = z[l.pf() + 2 * c + 1];
  }
  zs.segment(ls.sigma(), nc) = z.segment(l.sigma(), nc);
  zs.segment(ls.pb(), nb) = z.segment(l.pb(), nb);
  const StepResiduals& rs = sc.rs;
  EvaluateAssemblyInto(ncp.assembler(), model, params, a, x, zs, jac != nullptr, &sc.rs,
                       jac ? &sc.js : nullptr, /*normal_pairs_only=*/true);
  r.param_columns = rs.param_columns;
  const int np = static_cast<int>(r.param_columns.size());
  const int ncol = l.size() + np;
  const int ne = nv + nq + nb;
  r.equality.resize(ne + 2 * nc);
  r.equality.head(ne) = rs.equality;
  r.comp_a.resize(2 * nc);
  r.comp_b.resize(2 * nc);
  // Column of the ST layout → column of ours (−1: an ST unknown we do not have); increasing
  // where defined, so a remapped row keeps its column order.
  std::vector<int>& col = sc.col;
  if (jac) {
    col.assign(ls.size() + np, -1);
    for (int i = 0; i < nq + nv + nc; ++i) col[i] = i;
    for (int c = 0; c < nc; ++c) {
      col[ls.pf() + c * nd] = l.pf() + 2 * c;
      if (!planar) col[ls.pf() + c * nd + 1] = l.pf() + 2 * c + 1;
      col[ls.sigma() + c] = l.sigma() + c;
    }
    for (int i = 0; i < nb; ++i) col[ls.pb() + i] = l.pb() + i;
    for (int i = 0; i < np; ++i) col[ls.size() + i] = l.size() + i;
    jac->equality.Reset(ncol);
    jac->comp_a.Reset(ncol);
    jac->comp_b.Reset(ncol);
  }
  const auto remap = [&col](const SparseRows& from, int row, SparseRows* to) {
    for (int k = from.ptr[row]; k < from.ptr[row + 1]; ++k)
      if (col[from.col[k]] >= 0) to->Push(col[from.col[k]], from.val[k]);
    to->EndRow();
  };
  for (int i = 0; jac && i < ne; ++i) remap(sc.js.equality, i, &jac->equality);
  const auto v1 = z.segment(l.v1(), nv);
  const NcpOptions& o = ncp.ncp_options();
  const double et2 = o.e_t * o.e_t, eo2 = o.e_o * o.e_o;
  const auto push = [](SparseRows* to, int c, double v) {
    if (v != 0.0) to->Push(c, v);
  };
  // Contact c's friction coefficient's column among [z; θ] (ncol if it is not differentiable).
  const auto mu_column = [&](int c) {
    const auto& pc = r.param_columns;
    return l.size() +
           static_cast<int>(std::find(pc.begin(), pc.end(), a.contacts[c].mu_param) - pc.begin());
  };
  for (int c = 0; c < nc; ++c) {
    const double pn = z[l.pn() + c], pt = z[l.pf() + 2 * c], po = z[l.pf() + 2 * c + 1];
    const double s = z[l.sigma() + c], mu = a.mu[c];
    const int mu_col = mu_column(c);
    // Friction equalities: e² μ p_n u + p σ = 0 per direction (planar: p_o = 0).
    const int et = ne + 2 * c, eo = et + 1;
    const double ut = a.G_f.col(c * nd).dot(v1) + a.dpsi_f[c * nd];
    r.equality[et] = et2 * mu * pn * ut + pt * s;
    const double uo = planar ? 0.0 : a.G_f.col(c * nd + 1).dot(v1) + a.dpsi_f[c * nd + 1];
    r.equality[eo] = planar ? po : eo2 * mu * pn * uo + po * s;
    // Cone pair: σ ⊥ μ² p_n² − p_t²/e_t² − p_o²/e_o².
    r.comp_a[c] = pn;
    r.comp_b[c] = rs.comp_b[c];
    r.comp_a[nc + c] = s;
    r.comp_b[nc + c] = mu * mu * pn * pn - pt * pt / et2 - po * po / eo2;
    if (!jac) continue;
    // Rows in column order: ν_ℓ+1, p_n, p_f, σ, θ.
    for (int f = 0; f < (planar ? 1 : 2); ++f) {
      const int d = c * nd + f;
      const double e2 = f == 0 ? et2 : eo2, u = f == 0 ? ut : uo;
      SparseRows& E = jac->equality;
      for (SparseMatrixd::InnerIterator it(a.G_f, d); it; ++it)
        push(&E, l.v1() + static_cast<int>(it.row()), e2 * mu * pn * it.value());
      push(&E, l.pn() + c, e2 * mu * u);
      push(&E, l.pf() + 2 * c + f, s);
      push(&E, l.sigma() + c, f == 0 ? pt : po);
      if (mu_col < ncol) push(&E, mu_col, e2 * pn * u);
      E.EndRow();
    }
    if (planar) {
      jac->equality.Push(l.pf() + 2 * c + 1, 1.0);
      jac->equality.EndRow();
    }
  }
  if (!jac) return;
  for (int c = 0; c < nc; ++c) {  // normal pairs: p_n ⊥ the ST normal row
    jac->comp_a.Push(l.pn() + c, 1.0);
    jac->comp_a.EndRow();
    remap(sc.js.comp_b, c, &jac->comp_b);
  }
  for (int c = 0; c < nc; ++c) {  // cone pairs
    const double pn = z[l.pn() + c], pt = z[l.pf() + 2 * c], po = z[l.pf() + 2 * c + 1];
    const double mu = a.mu[c];
    const int mu_col = mu_column(c);
    jac->comp_a.Push(l.sigma() + c, 1.0);
    jac->comp_a.EndRow();
    SparseRows& B = jac->comp_b;
    push(&B, l.pn() + c, 2.0 * mu * mu * pn);
    push(&B, l.pf() + 2 * c, -2.0 * pt / et2);
    push(&B, l.pf() + 2 * c + 1, -2.0 * po / eo2);
    if (mu_col < ncol) push(&B, mu_col, 2.0 * mu * pn * pn);
    B.EndRow();
  }
}

}  // namespace vinci::sim
