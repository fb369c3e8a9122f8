#include "sensitivity_lcp_basis.h"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <vector>

#include "../formulations/step_record.h"
#include "../solvers/scratch_lease.h"
#include "sensitivity_linearization.h"
#include "vinci/sim/formulations/stewart_trinkle.h"
#include "vinci/sim/model/kinematics.h"

namespace vinci::sim::internal {
namespace {

// A held pair's nonzero side must exceed the activity tolerance by this factor: the general
// path's tolerance also counts the step equations' residual, which this path does not evaluate,
// so only pairs that both would classify alike are taken.
constexpr double kClearMargin = 1e3;
// The basic block's smallest LU pivot relative to its largest at least this (the general path
// factors a singular active block by the complete orthogonal decomposition: not this path's
// answer).
constexpr double kMinPivotRatio = 1e-10;
// A quaternion's central difference step in (q, h ω) along its unit direction.
constexpr double kRotationStep = 1e-6;

struct BasisScratch {
  LcpProblem lcp;
  VectorXd w, v1, v1_p, v1_m, g_p, g_m, dg, dz, dv, zero_v, unit, dz_b, rhs;
  std::vector<int> basic, nonbasic;
  MatrixXd m_bb;
  Eigen::PartialPivLU<MatrixXd> lu;
};

bool FrictionOnly(const Scene& scene, const ParamSelection& selection) {
  for (int index : selection.indices()) {
    const ParamKind k = scene.param_table().info(index).kind;
    if (k != ParamKind::kFriction && k != ParamKind::kDefaultFriction) return false;
  }
  return true;
}

}  // namespace

bool PropagateOnLcpBasis(const Simulator& sim, const Params& params,
                         const ParamSelection& selection, const State& x, const StepInput& u,
                         const State& next, const MatrixXd& S, MatrixXd* S_next,
                         const SensitivityOptions& options, Workspace* ws, StepSensitivity* st) {
  const auto* stewart = dynamic_cast<const StewartTrinkle*>(&sim.formulation());
  if (!stewart || options.smoothing > 0.0 || !FrictionOnly(sim.scene(), selection)) return false;
  Workspace own_ws;
  Workspace* w = ws ? ws : &own_ws;
  const Scene& model = sim.ResolveWithInputs(params, u, w);
  ScratchLease<std::unique_ptr<StepModel>> frozen_lease;
  std::unique_ptr<StepModel>& frozen = frozen_lease.get();
  FreezeInto(sim.formulation(), u.motions.empty() ? w->model : w->motion_model, params, x, u,
             &frozen);
  const StewartTrinkle::Assembly* a0 = FrozenAssembly(*frozen);
  if (!a0 || frozen->feature_kinks() > 0) return false;
  const int nc = static_cast<int>(a0->contacts.size()), nd = a0->nd, nf = nc * nd;
  if (a0->psi_b.size() > 0 || !a0->corner_contact.empty() || a0->support.points() > 0) return false;
  for (const CompliantNormalRow& law : a0->compliance)
    if (law.compliant) return false;
  const int m = nc + nf + nc;
  const VectorXd& z = next.warm_start;
  if (z.size() != m || !z.allFinite()) return false;

  ScratchLease<BasisScratch> lease;
  BasisScratch& b = lease.get();
  const int nq = static_cast<int>(x.q.size()), nx = nq + static_cast<int>(x.v.size());
  b.unit.setZero(nx);
  // w* = M z* + q and ν_after(z*) at the freeze (no M formed: most rejections come below).
  if (!PlainLcpAlongInto(*frozen, u, b.unit, 0.0, z, &b.w, &b.v1)) return false;
  // The freeze's LCP must give the step's own end velocity (the step may have changed z after
  // its solve, e.g. spread indeterminate normals).
  if (b.w.size() != m || b.v1.size() != next.v.size() ||
      !((b.v1 - next.v).cwiseAbs().maxCoeff() <=
        1e-9 * std::max(1.0, next.v.cwiseAbs().maxCoeff())))
    return false;
  // The general path's activity tolerance (Linearization::Compute) without its equality part.
  double scale = 0.0, violation = 0.0;
  for (int i = 0; i < m; ++i) {
    scale = std::max({scale, std::abs(z[i]), std::abs(b.w[i])});
    violation = std::max(violation, std::abs(std::min(z[i], b.w[i])));
  }
  const double tol = options.active_tol * scale + 10.0 * violation;
  b.basic.clear();
  b.nonbasic.clear();
  for (int i = 0; i < m; ++i) {
    const double lo = std::min(z[i], b.w[i]), hi = std::max(z[i], b.w[i]);
    if (!(lo <= tol && hi > kClearMargin * tol)) return false;
    (z[i] > b.w[i] ? b.basic : b.nonbasic).push_back(i);
  }
  if (!FrozenLcpInto(*frozen, &b.lcp) || b.lcp.size() != m) return false;  // M at the freeze
  const int nb = static_cast<int>(b.basic.size());
  b.m_bb.resize(nb, nb);
  for (int i = 0; i < nb; ++i)
    for (int j = 0; j < nb; ++j) b.m_bb(i, j) = b.lcp.M(b.basic[i], b.basic[j]);
  if (nb > 0) {
    // Singular (redundant contacts): a pivot of the partial-pivoting LU at round-off relative
    // to the largest.
    b.lu.compute(b.m_bb);
    const auto pivots = b.lu.matrixLU().diagonal().cwiseAbs();
    if (!(pivots.minCoeff() > kMinPivotRatio * pivots.maxCoeff())) return false;
  }

  const int p = selection.size(), ncols = static_cast<int>(S.cols());
  const VectorXd theta = selection.Get(params);
  double xn =
      std::max(nq ? x.q.cwiseAbs().maxCoeff() : 0.0, x.v.size() ? x.v.cwiseAbs().maxCoeff() : 0.0);
  const double step = options.state_step * std::max(1.0, xn);
  const double h = stewart->options().dt;
  MatrixXd out = MatrixXd::Constant(nx, ncols, std::numeric_limits<double>::quiet_NaN());
  for (int c = 0; c < ncols; ++c) {
    const auto s = S.col(c);
    b.dg.setZero(m);
    b.dv.setZero(nx - nq);
    const double sn = s.cwiseAbs().maxCoeff();
    if (!std::isfinite(sn)) return false;
    if (sn > 0.0) {
      // Along the unit direction, scaled back (a carried column may have decayed to denormals).
      b.unit = s / sn;
      if (!PlainLcpAlongInto(*frozen, u, b.unit, step, z, &b.g_p, &b.v1_p) ||
          !PlainLcpAlongInto(*frozen, u, b.unit, -step, z, &b.g_m, &b.v1_m))
        return false;
      b.dg = (b.g_p - b.g_m) * (sn / (2 * step));
      b.dv = (b.v1_p - b.v1_m) * (sn / (2 * step));
    }
    if (c < p) {
      // ∂(M z*)/∂μ: the cone row of each contact whose μ is this parameter gains its p_n.
      const int index = selection.indices()[c];
      for (int k = 0; k < nc; ++k)
        if (a0->contacts[k].mu_param == index) b.dg[nc + nf + k] += z[k];
    }
    b.dz.setZero(m);
    if (nb > 0) {
      b.rhs.resize(nb);
      for (int i = 0; i < nb; ++i) b.rhs[i] = -b.dg[b.basic[i]];
      b.dz_b = b.lu.solve(b.rhs);
      for (int i = 0; i < nb; ++i) b.dz[b.basic[i]] = b.dz_b[i];
    }
    // The stable radius of Linearization::StableRadius on this basis.
    double rho = std::numeric_limits<double>::infinity();
    for (int i : b.basic)
      if (b.dz[i] < 0.0 && z[i] > tol) rho = std::min(rho, z[i] / -b.dz[i]);
    for (int i : b.nonbasic) {
      double rate = b.dg[i];
      for (int j = 0; j < nb; ++j) rate += b.lcp.M(i, b.basic[j]) * b.dz_b[j];
      if (rate < 0.0 && b.w[i] > tol) rho = std::min(rho, b.w[i] / -rate);
    }
    const double column_scale = c < p ? std::abs(theta[c]) : 1.0;
    if (!(rho >= kMinStableRadius * std::max(1.0, column_scale))) return false;
    // dν_ℓ+1 = (ν_after's x part) + W G dz (ν_after with ν* = 0 is W G z).
    b.zero_v.setZero(nx - nq);
    stewart->VelocityAfterInto(*a0, b.zero_v, b.dz, StewartTrinkle::JointElimination(), &b.v1_p);
    b.dv += b.v1_p;
    out.col(c).tail(nx - nq) = b.dv;
    // dq_ℓ+1 per dynamic body: positions q + h ν exactly, a quaternion by central differences.
    for (int bi : model.dynamic_bodies()) {
      const BodyIndex& idx = model.index(bi);
      for (int k = 0; k < 3; ++k) out(idx.q + k, c) = s[idx.q + k] + h * b.dv[idx.v + k];
      if (model.dim != Dim::kSpatial) continue;
      // Int(Q, φ) = Q ⊗ Exp(φ), φ = h ω: along (dQ, h dω) / n, n its ∞-norm.
      double d[7] = {0, 0, 0}, n = 0.0;
      for (int k = 3; k < 7; ++k) n = std::max(n, std::abs(d[k] = s[idx.q + k]));
      double phi[6] = {0, 0, 0}, dphi[3];
      for (int k = 0; k < 3; ++k) {
        phi[3 + k] = h * next.v[idx.v + 3 + k];
        dphi[k] = h * b.dv[idx.v + 3 + k];
        n = std::max(n, std::abs(dphi[k]));
      }
      if (!(n > 0.0)) {
        for (int k = 3; k < 7; ++k) out(idx.q + k, c) = 0.0;
        continue;
      }
      double qp[7], qm[7], vp[6], vm[6], rp[7], rm[7];
      for (int k = 0; k < 7; ++k) {
        qp[k] = x.q[idx.q + k] + kRotationStep * d[k] / n;
        qm[k] = x.q[idx.q + k] - kRotationStep * d[k] / n;
      }
      for (int k = 0; k < 6; ++k) vp[k] = vm[k] = phi[k];
      for (int k = 0; k < 3; ++k) {
        vp[3 + k] += kRotationStep * dphi[k] / n;
        vm[3 + k] -= kRotationStep * dphi[k] / n;
      }
      IntegratePosition(Dim::kSpatial, qp, vp, 1.0, rp);
      IntegratePosition(Dim::kSpatial, qm, vm, 1.0, rm);
      for (int k = 3; k < 7; ++k) out(idx.q + k, c) = (rp[k] - rm[k]) * (n / (2 * kRotationStep));
    }
    if (!out.col(c).allFinite()) return false;
  }
  // A mode change within the step: the contact set found at the end differs (as the general
  // path).
  const StepLayout end = sim.formulation().Layout(model, next);
  const StepLayout& l = frozen->layout();
  const bool changed = end.nc != l.nc || end.nk != l.nk || end.ns != l.ns;
  *S_next = std::move(out);
  *st = StepSensitivity();
  st->contact_set_changed = changed;
  st->on_lcp_basis = true;
  st->status = changed ? SensitivityStatus::kModeChange : SensitivityStatus::kExact;
  st->message = changed ? "contact set changed" : "";
  return true;
}

}  // namespace vinci::sim::internal
