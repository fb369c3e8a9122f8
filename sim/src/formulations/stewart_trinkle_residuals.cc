#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <stdexcept>
#include <utility>
#include <vector>

#include "end_detection.h"
#include "sparse_lcp.h"
#include "sparse_rows.h"
#include "step_util.h"
#include "stewart_trinkle_internal.h"
#include "vinci/sim/formulations/joint.h"
#include "vinci/sim/formulations/stewart_trinkle.h"
#include "vinci/sim/model/kinematics.h"

namespace vinci::sim {
namespace {

using internal::CheckShapesSupported;
using internal::PrescribedKinematics;

// Appends the support-friction pairs (p_s, G_sᵀν + E_s σ_s) and (σ_s, h μ_s N − E_sᵀ p_s) to
// the complementarity block of r (after every other pair); with `jacobians` the rows are added
// to Ja and Jb, with `entries` too their entries.
void AppendSupportPairs(const SupportRows& sup, const StepLayout& l, const VectorXd& z,
                        bool jacobians, bool entries, StepResiduals* r,
                        internal::JacobianWriter* Ja, internal::JacobianWriter* Jb) {
  const int old = static_cast<int>(r->comp_a.size());
  const int add = l.nps + l.ns;
  r->comp_a.conservativeResize(old + add);
  r->comp_b.conservativeResize(old + add);
  r->comp_a.tail(add) = z.segment(l.ps(), add);  // p_s, σ_s are contiguous
  r->comp_b.segment(old, l.nps) = sup.G_s.transpose() * z.segment(l.v1(), l.nv);
  if (jacobians) {
    Ja->AddRows(add);
    Jb->AddRows(add);
  }
  if (jacobians && entries) {
    Ja->Identity(old, l.ps(), add);
    Jb->DenseBlock(old, l.v1(), sup.G_s.transpose());
  }
  for (int k = 0; k < l.ns; ++k) {
    const int row = old + l.nps + k;
    r->comp_b[row] = sup.limit[k];
    for (int j = 0; j < sup.count[k]; ++j) {
      const int col = sup.first[k] + j;
      r->comp_b[old + col] += z[l.sigma_s() + k];
      r->comp_b[row] -= z[l.ps() + col];
      if (!jacobians || !entries) continue;
      Jb->Set(old + col, l.sigma_s() + k, 1.0);
      Jb->Set(row, l.ps() + col, -1.0);
    }
  }
}

}  // namespace

StepLayout StewartTrinkle::Layout(const Scene& model, const State& x) const {
  // Kept per thread between calls (allocation reuse only: both are overwritten by every call).
  thread_local std::vector<BodyKinematics> kin;
  thread_local std::vector<Contact> found;
  CheckShapesSupported(model);
  // The step that ended at x detected there already (end_detection.h): the same list.
  const std::vector<Contact>* kept =
      internal::KeptEndContacts(model, x, options_.dt, options_.envelope);
  if (kept == nullptr) {
    ComputeBodyKinematics(model, x, &kin);
    for (std::size_t i = 0; i < kin.size(); ++i)  // as in Assemble
      if (model.bodies[i].kind == BodyKind::kPrescribed &&
          model.bodies[i].motion.pose == PoseRule::kIntegrated)
        kin[i] = PrescribedKinematics(model, static_cast<int>(i), x.t, options_.dt);
    FindContacts(model, kin, options_.envelope, &found);
  }
  const std::vector<Contact>& contacts = kept ? *kept : found;
  StepLayout l;
  l.nq = model.num_positions();
  l.nv = model.num_velocities();
  l.nc = static_cast<int>(contacts.size());
  l.nd = model.dim == Dim::kPlanar ? 2 : options_.friction_directions;
  for (const Joint& j : model.joints) l.nb += JointRowCount(j.type, model.dim);
  for (const Contact& c : contacts) l.nk += c.point.corner ? 1 : 0;
  for (int bi : model.dynamic_bodies()) {
    const Support& s = model.bodies[bi].support;
    l.ns += static_cast<int>(s.points_B.size());
    l.nps += static_cast<int>(s.points_B.size()) * s.directions;
  }
  return l;
}

StepLayout StewartTrinkle::LayoutOf(const Scene& model, const Assembly& a) {
  StepLayout l;
  l.nq = model.num_positions();
  l.nv = model.num_velocities();
  l.nc = static_cast<int>(a.contacts.size());
  l.nd = a.nd;
  l.nb = static_cast<int>(a.psi_b.size());
  l.nk = static_cast<int>(a.corner_contact.size());
  l.ns = a.support.points();
  l.nps = a.support.columns();
  return l;
}

StepResiduals StewartTrinkle::Evaluate(const Scene& model, const Params& params, const State& x,
                                       const StepInput& u, const VectorXd& z) const {
  return EvaluateAssembly(model, params, Assemble(model, x, u), x, z);
}

StepResiduals StewartTrinkle::EvaluateAssembly(const Scene& model, const Params& params,
                                               const Assembly& a, const State& x, const VectorXd& z,
                                               bool jacobians) const {
  StepResiduals r;
  internal::EvaluateAssemblyInto(*this, model, params, a, x, z, jacobians, &r);
  return r;
}

void internal::EvaluateAssemblyInto(const StewartTrinkle& st, const Scene& model,
                                    const Params& params, const StewartTrinkle::Assembly& a,
                                    const State& x, const VectorXd& z, bool jacobians,
                                    StepResiduals* out, SparseJacobians* sparse,
                                    bool normal_pairs_only) {
  const StepperOptions& options = st.options();
  const bool velocity_level = options.formulation == FormulationType::kAnitescuPotra;
  const bool first_order = options.formulation == FormulationType::kFirstOrder;
  const double h = options.dt;
  StepResiduals& r = *out;
  r.layout = StewartTrinkle::LayoutOf(model, a);
  const StepLayout& l = r.layout;
  if (z.size() != l.size())
    throw std::invalid_argument("StewartTrinkle::Evaluate: z has " + std::to_string(z.size()) +
                                " entries, the step layout needs " + std::to_string(l.size()));
  if (params.values.size() != model.param_table().size())
    throw std::invalid_argument("StewartTrinkle::Evaluate: params do not match the scene");
  // Differentiable parameters: friction coefficients, support friction and masses.
  r.param_columns.clear();
  // Transient vectors kept per thread (allocation reuse only: all overwritten below).
  struct Scratch {
    std::vector<int> column_of;
    VectorXd zero_v, q_pred;
  };
  thread_local Scratch scratch;
  internal::DifferentiableParamColumnsInto(model.param_table(), l.size(), &r.param_columns,
                                           &scratch.column_of);
  const std::vector<int>& column_of = scratch.column_of;
  const int np = static_cast<int>(r.param_columns.size());
  const int nz = l.size(), ncol = nz + np;
  const int nc = l.nc, nd = l.nd, nf = nc * nd, nv = l.nv, nq = l.nq, nb = l.nb;
  const auto q1 = z.segment(l.q1(), nq);
  const auto v1 = z.segment(l.v1(), nv);
  const auto pn = z.segment(l.pn(), nc);
  const auto pf = z.segment(l.pf(), nf);
  const auto sigma = z.segment(l.sigma(), nc);
  const auto pb = z.segment(l.pb(), nb);

  // Equalities: [dynamics (nv); kinematics (nq); joints (nb)].
  r.equality.resize(nv + nq + nb);
  // Without Jacobians (values only: the sensitivities' directional differences) the d_ blocks
  // stay empty and every write to them below is skipped.
  // With `sparse`, the Jacobians go there (by rows) and the d_ matrices stay empty.
  const bool jac = jacobians;
  const bool pair_jac = jac && !normal_pairs_only;  // the Jacobians of the other pairs' rows
  const int ncomp_all = nc + nc * l.nd + nc + l.nk;
  // Sparse: the writers kept with *sparse (their row patterns reused from the last evaluation).
  JacobianWriter dense_e, dense_a, dense_b;
  JacobianWriter& Je = sparse ? sparse->equality_writer : dense_e;
  JacobianWriter& Ja = sparse ? sparse->comp_a_writer : dense_a;
  JacobianWriter& Jb = sparse ? sparse->comp_b_writer : dense_b;
  if (jac && sparse) {
    Je.Sparse(nv + nq + nb, ncol);
    Ja.Sparse(ncomp_all, ncol);
    Jb.Sparse(ncomp_all, ncol);
  }
  if (!jac || sparse) {
    r.d_equality.resize(0, 0);
    r.d_comp_a.resize(0, 0);
    r.d_comp_b.resize(0, 0);
  }
  if (jac && !sparse) Je.Dense(&r.d_equality, nv + nq + nb, ncol);
  const VectorXd& v_l = first_order ? scratch.zero_v.setZero(nv) : x.v;  // first order: no ν_ℓ
  r.equality.head(nv) = a.M * (v1 - v_l) - a.G_n * pn - a.G_f * pf - a.G_b * pb - a.p_ext;
  if (jac) {
    for (int o = 0; o < nv; o += a.M.block_size()) Je.DenseBlock(o, l.v1() + o, a.M.BlockAt(o));
    Je.Block(0, l.pn(), a.G_n, -1.0);
    Je.Block(0, l.pf(), a.G_f, -1.0);
    Je.Block(0, l.pb(), a.G_b, -1.0);
  }
  if (l.nps > 0) {
    r.equality.head(nv) -= a.support.G_s * z.segment(l.ps(), l.nps);
    if (jac) Je.DenseBlock(0, l.ps(), -a.support.G_s);
  }
  // ∂/∂m of body b's rows: M_b and p_ext scale with the mass (inertia ∝ mass, same shape).
  for (int i = 0; jac && i < model.param_table().size(); ++i) {
    const ParamInfo& info = model.param_table().info(i);
    if (info.kind != ParamKind::kMass) continue;
    const Body& b = model.bodies[info.a];
    const int o = model.index(info.a).v, nvb = VelocitySize(model.dim);
    const VectorXd dv = v1.segment(o, nvb) - x.v.segment(o, nvb);
    // First order: h C does not scale with the mass, only the weight does.
    VectorXd d =
        first_order ? VectorXd(VectorXd::Zero(nvb)) : VectorXd(a.M.BlockAt(o) * dv / b.mass);
    if (b.gravity) {
      d.head(model.dim == Dim::kPlanar ? 2 : 3) -=
          h * model.gravity_W.head(model.dim == Dim::kPlanar ? 2 : 3);
    }
    if (model.dim == Dim::kSpatial && !first_order) {
      const Vector3d w_B = x.v.segment<3>(o + 3);
      d.tail<3>() += h * w_B.cross(b.inertia * w_B) / b.mass;
    }
    Je.DenseBlock(o, column_of[i], d);
  }

  VectorXd& q_pred = scratch.q_pred;
  q_pred.resize(nq);  // every dynamic body's block written below
  for (int bi : model.dynamic_bodies()) {
    const BodyIndex& idx = model.index(bi);
    IntegratePosition(model.dim, x.q.data() + idx.q, v1.data() + idx.v, h, q_pred.data() + idx.q);
  }
  r.equality.segment(nv, nq) = q1 - q_pred;
  if (jac) Je.Identity(nv, l.q1(), nq);
  // ∂q_pred/∂ν: planar and the position part of spatial bodies are exactly h·I; the quaternion
  // block (exponential map) is differentiated by central differences.
  for (int bi : model.dynamic_bodies()) {
    if (!jac) break;
    const BodyIndex& idx = model.index(bi);
    for (int k = 0; k < 3; ++k) Je.Set(nv + idx.q + k, l.v1() + idx.v + k, -h);
    if (model.dim == Dim::kSpatial) {
      const double eps = 1e-7;
      for (int k = 3; k < 6; ++k) {
        VectorXd vp = v1.segment(idx.v, 6), vm = vp;
        vp[k] += eps;
        vm[k] -= eps;
        double qp[7], qm[7];
        IntegratePosition(model.dim, x.q.data() + idx.q, vp.data(), h, qp);
        IntegratePosition(model.dim, x.q.data() + idx.q, vm.data(), h, qm);
        for (int i = 3; i < 7; ++i)
          Je.Set(nv + idx.q + i, l.v1() + idx.v + k, -(qp[i] - qm[i]) / (2 * eps));
      }
    }
  }
  if (nb > 0) {
    VectorXd jr = a.G_b.transpose() * v1 + a.dpsi_b;
    if (options.joint_stabilization) jr += a.psi_b / h;
    r.equality.tail(nb) = jr;
    if (jac) Je.BlockTransposed(nv + nq, l.v1(), a.G_b);
  }

  // Complementarity pairs: (p_n, normal), (p_f, friction), (σ, cone), then (c, corner).
  const int nk = l.nk;
  const int ncomp = nc + nf + nc + nk;
  const auto cc = z.segment(l.corner(), nk);
  r.comp_a.resize(ncomp);
  r.comp_b.resize(ncomp);
  r.comp_a << pn, pf, sigma, cc;
  if (jac && !sparse) {
    Ja.Dense(&r.d_comp_a, ncomp, ncol);
    Jb.Dense(&r.d_comp_b, ncomp, ncol);
  }
  if (pair_jac) {
    Ja.Identity(0, l.pn(), nc + nf + nc);  // contiguous
    Ja.Identity(ncomp - nk, l.corner(), nk);
  }

  r.comp_b.head(nc) = a.G_n.transpose() * v1 + a.dpsi_n;
  if (!velocity_level) r.comp_b.head(nc) += a.psi_n / h;
  if (jac) Jb.BlockTransposed(0, l.v1(), a.G_n);
  for (int c = 0; c < nc; ++c) {
    const CompliantNormalRow& law = a.compliance[c];
    if (!law.compliant) continue;
    r.comp_b[c] = a.G_n.col(c).dot(v1) + a.dpsi_n[c] + law.vel_psi * a.psi_n[c] +
                  law.vel_diagonal * pn[c] + law.vel_constant;
    if (jac) Jb.Set(c, l.pn() + c, law.vel_diagonal);
  }

  r.comp_b.segment(nc, nf) = a.G_f.transpose() * v1 + a.dpsi_f;
  if (pair_jac) Jb.BlockTransposed(nc, l.v1(), a.G_f);
  for (int c = 0; c < nc; ++c) {
    double sum_pf = 0.0;
    for (int j = 0; j < nd; ++j) {
      r.comp_b[nc + c * nd + j] += sigma[c];
      sum_pf += pf[c * nd + j];
      if (!pair_jac) continue;
      Jb.Set(nc + c * nd + j, l.sigma() + c, 1.0);
      Jb.Set(nc + nf + c, l.pf() + c * nd + j, -1.0);
    }
    r.comp_b[nc + nf + c] = a.mu[c] * pn[c] - sum_pf;
    if (!pair_jac) continue;
    Jb.Set(nc + nf + c, l.pn() + c, a.mu[c]);
    Jb.Set(nc + nf + c, column_of[a.contacts[c].mu_param], pn[c]);
  }
  // Corner rows: c_k − ((ψ_1 − ψ_2)/h + (G_1 − G_2)ᵀ ν + ∂ψ_1/∂t − ∂ψ_2/∂t), and + c_k in the
  // normal row of its contact.
  for (int k = 0; k < nk; ++k) {
    const int c = a.corner_contact[k], row = ncomp - nk + k;  // corner pairs last
    const VectorXd D = a.G_1.col(k).toDense() - a.G_n.col(c).toDense();
    r.comp_b[row] = cc[k] - ((a.psi_1[k] - a.psi_n[c]) / h + D.dot(v1) + a.dpsi_1[k] - a.dpsi_n[c]);
    r.comp_b[c] += cc[k];
    if (velocity_level) r.comp_b[c] += a.psi_n[c] / h;  // corners stay position-level
    if (jac) Jb.Set(c, l.corner() + k, 1.0);
    if (!pair_jac) continue;
    Jb.Set(row, l.corner() + k, 1.0);
    Jb.DenseBlock(row, l.v1(), -D.transpose());
  }
  if (l.ns > 0) {
    AppendSupportPairs(a.support, l, z, jac, pair_jac, &r, &Ja, &Jb);
    // A static distribution scales with the mass: ∂(h μ_s N_k)/∂m = h μ_s N_k / m.
    for (int i = 0; pair_jac && i < model.param_table().size(); ++i) {
      const ParamInfo& info = model.param_table().info(i);
      if (info.kind == ParamKind::kSupportFriction) {  // ∂(h μ_s N_k)/∂μ_s = h N_k
        for (int k = 0; k < l.ns; ++k)
          if (a.support.body[k] == info.a) Jb.Set(ncomp + l.nps + k, column_of[i], a.support.hN[k]);
      }
      if (info.kind != ParamKind::kMass || !model.bodies[info.a].support.static_distribution)
        continue;
      for (int k = 0; k < l.ns; ++k)
        if (a.support.body[k] == info.a)
          Jb.Set(ncomp + l.nps + k, column_of[i], a.support.limit[k] / model.bodies[info.a].mass);
    }
  }
  if (jac && sparse) {
    Je.Finish(&sparse->equality);
    Ja.Finish(&sparse->comp_a);
    Jb.Finish(&sparse->comp_b);
  }
}

double StepResiduals::Violation() const {
  double v = equality.size() ? equality.cwiseAbs().maxCoeff() : 0.0;
  for (int i = 0; i < comp_a.size(); ++i) v = std::max(v, std::abs(std::min(comp_a[i], comp_b[i])));
  return v;
}

}  // namespace vinci::sim
