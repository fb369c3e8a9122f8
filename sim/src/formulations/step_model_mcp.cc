// The frozen step models of the MCP formulations (step_model.h): NCP, quasistatic DLC / DQC and
// dynamic DQC, geometrically implicit. The Stewart–Trinkle family's is in step_model.cc.
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>

#include "../solvers/scratch_lease.h"
#include "frozen_contacts.h"
#include "ncp_internal.h"
#include "step_util.h"
#include "vinci/sim/formulations/geometrically_implicit.h"
#include "vinci/sim/formulations/ncp.h"
#include "vinci/sim/formulations/quasistatic.h"
#include "vinci/sim/formulations/step_model.h"

namespace vinci::sim {
namespace {

using internal::FrozenSides;
using internal::MoveContacts;
using internal::MoveContactsAlong;
using internal::SameStateAndInput;
using internal::SizeMismatch;

// --- NCP ---------------------------------------------------------------------------------------

class NcpModel final : public StepModel {
 public:
  NcpModel(const NcpStepper& ncp, std::shared_ptr<const Scene> model, Params params, State x,
           StepInput u)
      : StepModel(std::move(model), std::move(params), std::move(x), std::move(u),
                  ncp.assembler().options().dt),
        ncp_(ncp) {
    Build();
  }
  const NcpStepper& formulation() const { return ncp_; }
  // As StewartTrinkleModel's: frozen at (scene, params, x, u) bitwise; refrozen in place.
  bool FrozenAt(const Scene* scene, const Params& params, const State& x,
                const StepInput& u) const {
    return model_.get() == scene && params_ == params && SameStateAndInput(x, u, x_, u_);
  }
  void Refreeze(std::shared_ptr<const Scene> model, const Params& params, const State& x,
                const StepInput& u) {
    model_ = std::move(model);
    params_ = params;
    x_ = x;
    u_ = u;
    dt_ = ncp_.assembler().options().dt;
    Build();
  }

 protected:
  StepResiduals Residuals(const Scene& model, const Params& theta, const State& x,
                          const StepInput& u, const VectorXd& z, bool jacobians) const override {
    const bool at_freeze = &model == model_.get() && SameStateAndInput(x, u, x_, u_);
    if (jacobians)
      return ncp_.EvaluateAssembly(model, theta, at_freeze ? freeze_ : AssembleAt(model, x, u), x,
                                   z);
    StepResiduals r;
    internal::NcpEvaluateAssemblyInto(
        ncp_, model, theta, at_freeze ? freeze_ : AssembleAt(model, x, u), x, z, &r, nullptr);
    return r;
  }
  StepResiduals ResidualsAlong(const VectorXd& z, const StepInput& u, const VectorXd& s,
                               double t) const override {
    const State x = StateAlong(s, t);
    internal::ScratchLease<StewartTrinkle::Assembly> lease;  // as StewartTrinkleModel's
    StewartTrinkle::Assembly& a = lease.get();
    a.contacts = MoveContactsAlong(*model_, contacts_, x_, x, s, t, dt_, k0_, sides_);
    ncp_.assembler().AssembleAtInto(*model_, x, u, /*select_corner_edges=*/false, &a);
    StepResiduals r;
    internal::NcpEvaluateAssemblyInto(ncp_, *model_, params_, a, x, z, &r, nullptr);
    return r;
  }

 public:
  // EvaluateResiduals(z, θ, x, u, true) into *out with the Jacobians by rows into *jac (out's d_
  // matrices left empty), if x and u are the freeze's (bitwise): else false (nothing written).
  bool FreezeResidualsInto(const VectorXd& z, const Params& theta, const State& x,
                           const StepInput& u, StepResiduals* out,
                           internal::SparseJacobians* jac) const {
    if (z.size() != layout_.size() || !SameStateAndInput(x, u, x_, u_)) return false;
    internal::NcpEvaluateAssemblyInto(ncp_, *model_, theta, freeze_, x, z, out, jac);
    return true;
  }

 protected:
  // The MCP solution [p_n (nc); (p_t, p_o) per contact (2 nc); σ (nc)] is z's p_n, p_f, σ.
  VectorXd Unknowns(const State& next) const override {
    const StepLayout& l = layout_;
    const VectorXd& w = next.warm_start;
    if (w.size() != 4 * l.nc)
      throw std::invalid_argument("StepModel::UnknownsFromStep: next.warm_start " +
                                  SizeMismatch("", w.size(), 4 * l.nc) +
                                  " (the NCP step's solution)");
    VectorXd z = VectorXd::Zero(l.size());
    z.segment(l.q1(), l.nq) = next.q;
    z.segment(l.v1(), l.nv) = next.v;
    z.segment(l.pn(), 4 * l.nc) = w;
    RecoverJointImpulses(G_b_, &z);
    return z;
  }
  VectorXd WarmStart(const VectorXd& z) const override {
    return z.segment(layout_.pn(), 4 * layout_.nc);
  }

 private:
  StewartTrinkle::Assembly AssembleAt(const Scene& model, const State& x,
                                      const StepInput& u) const {
    return ncp_.assembler().AssembleAt(model, x, u,
                                       MoveContacts(model, contacts_, x_, x, dt_, &k0_, &sides_),
                                       /*select_corner_edges=*/false);
  }
  // The assembly at the freeze (the thread's last step's if it was this one: step_record.h),
  // in this object's storage, and what is derived from it.
  void Build() {
    if (!internal::CopyNcpStepAssembly(ncp_, model_, x_, u_, &freeze_))
      ncp_.assembler().AssembleInto(*model_, x_, u_, &freeze_);  // as StewartTrinkleModel
    contacts_ = freeze_.contacts;
    G_b_ = freeze_.G_b;
    ComputeBodyKinematics(*model_, x_, &k0_);
    internal::FrozenSidesInto(*model_, contacts_, k0_, &sides_, &feature_kinks_);
    // The frozen contact set's layout and the scene's differentiable parameters, as
    // EvaluateAssembly at the freeze gives them (no evaluation).
    layout_ = NcpStepper::LayoutOfAssembly(*model_, freeze_);
    param_columns_.clear();
    internal::DifferentiableParamColumns(model_->param_table(), layout_.size(), &param_columns_);
  }
  const NcpStepper& ncp_;
  std::vector<Contact> contacts_;
  std::vector<BodyKinematics> k0_;      // at x_
  std::vector<PolytopeFeature> sides_;  // per contact: the vertex a box–box contact keeps
  StewartTrinkle::Assembly freeze_;     // at (model_, x_, u_)
  MatrixXd G_b_;
};

// --- Quasistatic DLC / DQC, dynamic DQC --------------------------------------------------------

class QuasistaticModel final : public StepModel {
 public:
  QuasistaticModel(const Quasistatic& qs, std::shared_ptr<const Scene> model, Params params,
                   State x, StepInput u)
      : StepModel(std::move(model), std::move(params), std::move(x), std::move(u),
                  qs.assembler().options().dt),
        qs_(qs) {
    contacts_ = qs_.assembler().Assemble(*model_, x_, u_).contacts;
    Init(qs_.Layout(*model_, x_).size());  // the contact set at x_ℓ is the frozen one
  }

 protected:
  StepResiduals Residuals(const Scene& model, const Params& theta, const State& x,
                          const StepInput& u, const VectorXd& z, bool) const override {
    return qs_.EvaluateAssembly(
        model, theta, qs_.AssembleAt(model, x, u, MoveContacts(model, contacts_, x_, x, dt_)), x,
        z);
  }
  // The MCP unknowns y = z without q_ℓ+1.
  VectorXd Unknowns(const State& next) const override {
    const StepLayout& l = layout_;
    const VectorXd& w = next.warm_start;
    if (w.size() != l.size() - l.nq)
      throw std::invalid_argument("StepModel::UnknownsFromStep: next.warm_start " +
                                  SizeMismatch("", w.size(), l.size() - l.nq) +
                                  " (the quasistatic step's solution)");
    VectorXd z(l.size());
    z << next.q, w;
    return z;
  }
  VectorXd WarmStart(const VectorXd& z) const override { return z.tail(z.size() - layout_.nq); }

 private:
  const Quasistatic& qs_;
  std::vector<Contact> contacts_;
};

// --- Geometrically implicit ----------------------------------------------------------------------

class GiModel final : public StepModel {
 public:
  GiModel(const GeometricallyImplicit& gi, std::shared_ptr<const Scene> model, Params params,
          State x, StepInput u)
      : StepModel(std::move(model), std::move(params), std::move(x), std::move(u), gi.options().dt),
        gi_(gi) {
    frozen_ = gi_.FreezePairs(*model_, x_);
    Init(frozen_.layout.size());
  }

 protected:
  StepResiduals Residuals(const Scene& model, const Params& theta, const State& x,
                          const StepInput& u, const VectorXd& z, bool) const override {
    return gi_.EvaluateFrozen(model, theta, frozen_, x, u, z);
  }
  VectorXd Unknowns(const State& next) const override {
    return gi_.UnknownsFromStep(*model_, frozen_, x_, next);
  }
  VectorXd WarmStart(const VectorXd& z) const override {
    return gi_.StateFromUnknowns(*model_, frozen_, x_, z).warm_start;
  }
  State EndState(const VectorXd& z, const State& x) const override {
    return gi_.StateFromUnknowns(*model_, frozen_, x, z);
  }

 private:
  const GeometricallyImplicit& gi_;
  GeometricallyImplicit::FrozenPairs frozen_;
};

}  // namespace

namespace internal {

void FreezeNcpInto(const NcpStepper& ncp, std::shared_ptr<const Scene> scene, const Params& params,
                   const State& x, const StepInput& u, std::unique_ptr<StepModel>* frozen) {
  auto* reuse = dynamic_cast<NcpModel*>(frozen->get());
  if (reuse && &reuse->formulation() == &ncp) {
    if (!reuse->FrozenAt(scene.get(), params, x, u))
      reuse->Refreeze(std::move(scene), params, x, u);
    return;
  }
  *frozen = std::make_unique<NcpModel>(ncp, std::move(scene), params, x, u);
}

bool McpFreezeResidualsInto(const StepModel& m, const VectorXd& z, const Params& theta,
                            const State& x, const StepInput& u, StepResiduals* out,
                            SparseJacobians* jac) {
  const auto* ncp = dynamic_cast<const NcpModel*>(&m);
  return ncp && ncp->FreezeResidualsInto(z, theta, x, u, out, jac);
}

std::unique_ptr<StepModel> FreezeMcp(const Formulation& formulation,
                                     std::shared_ptr<const Scene> scene, const Params& params,
                                     const State& x, const StepInput& u) {
  if (const auto* ncp = dynamic_cast<const NcpStepper*>(&formulation))
    return std::make_unique<NcpModel>(*ncp, scene, params, x, u);
  if (const auto* qs = dynamic_cast<const Quasistatic*>(&formulation))
    return std::make_unique<QuasistaticModel>(*qs, scene, params, x, u);
  if (const auto* gi = dynamic_cast<const GeometricallyImplicit*>(&formulation))
    return std::make_unique<GiModel>(*gi, scene, params, x, u);
  return nullptr;
}

}  // namespace internal
}  // namespace vinci::sim
