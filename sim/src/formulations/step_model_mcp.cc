// The frozen step models of the MCP formulations (step_model.h): NCP, quasistatic DLC / DQC and
// dynamic DQC, geometrically implicit. The Stewart–Trinkle family's is in step_model.cc.
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>

#include "../solvers/scratch_lease.h"
#include "frozen_contacts.h"
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
    ncp_.assembler().AssembleInto(*model_, x_, u_, &freeze_);  // as StewartTrinkleModel
    contacts_ = freeze_.contacts;
    G_b_ = freeze_.G_b;
    k0_ = ComputeBodyKinematics(*model_, x_);
    sides_ = FrozenSides(*model_, contacts_, k0_, &feature_kinks_);
    // The frozen contact set's layout and the scene's differentiable parameters, as
    // EvaluateAssembly at the freeze gives them (no evaluation).
    const StepLayout l = NcpStepper::LayoutOfAssembly(*model_, freeze_);
    std::vector<int> param_columns;
    internal::DifferentiableParamColumns(model_->param_table(), l.size(), &param_columns);
    InitLayout(l, std::move(param_columns));
  }

 protected:
  StepResiduals Residuals(const Scene& model, const Params& theta, const State& x,
                          const StepInput& u, const VectorXd& z, bool) const override {
    if (&model == model_.get() && SameStateAndInput(x, u, x_, u_))
      return ncp_.EvaluateAssembly(model, theta, freeze_, x, z);
    return ncp_.EvaluateAssembly(model, theta, AssembleAt(model, x, u), x, z);
  }
  StepResiduals ResidualsAlong(const VectorXd& z, const StepInput& u, const VectorXd& s,
                               double t) const override {
    const State x = StateAlong(s, t);
    internal::ScratchLease<StewartTrinkle::Assembly> lease;  // as StewartTrinkleModel's
    StewartTrinkle::Assembly& a = lease.get();
    a.contacts = MoveContactsAlong(*model_, contacts_, x_, x, s, t, dt_, k0_, sides_);
    ncp_.assembler().AssembleAtInto(*model_, x, u, /*select_corner_edges=*/false, &a);
    return ncp_.EvaluateAssembly(*model_, params_, a, x, z);
  }
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
