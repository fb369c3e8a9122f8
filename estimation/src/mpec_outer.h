// The decomposed MPEC's outer problem over the shared θ (mpec_decomposed.cc): its Newton
// model's secant correction, the episodes' jackknife covariance, and the choice between an
// episode's two solutions at one θ.
#pragma once

#include <vector>

#include "vinci/sim/types.h"

namespace vinci::estimation::mpec_internal {

// The model Hessian h (symmetric positive definite) of F(θ) corrected by the secant pair
// s = θ₁ − θ₀, y = ∇F(θ₁) − ∇F(θ₀) by the BFGS update
//
//   B = h − (h s)(h s)ᵀ / (sᵀ h s) + y yᵀ / (sᵀ y),
//
// so that B s = y while B = h on the directions h-conjugate to s (one θ: B = y / s). Returns h
// unchanged unless sᵀy > 0 and the ratio sᵀy / sᵀhs of the measured to the modeled curvature
// along s is within [1/10, 10]. *ratio (if given) receives that ratio (NaN if sᵀhs ≤ 0).
sim::MatrixXd SecantCorrected(const sim::MatrixXd& h, const sim::VectorXd& s,
                              const sim::VectorXd& y, double* ratio = nullptr);

// The covariance of the θ̂ that minimizes F = Σ_e f_e over n ≥ 2 independent episodes (f_e in
// χ² units, −2 log-likelihood) from the episodes' scatter: the delta-method jackknife,
//
//   d_e = (H − H_e)⁻¹ g_e,   C_robust = (n − 1)/n · Σ_e (d_e − d̄)(d_e − d̄)ᵀ,
//
// H_e = ∇²f_e, H = Σ_e H_e, g_e = ∇f_e(θ̂): d_e is θ̂ without episode e minus θ̂ (exact for
// quadratic f_e), so no episode is re-solved. With equal H_e it is the cluster sandwich
// n/(n − 1) H⁻¹ (Σ_e g_e g_eᵀ) H⁻¹, an unbiased estimate of C = 2 H⁻¹ when the model is right;
// when the episodes disagree beyond their noise (model error) it carries their scatter, also
// when their weights are unequal (where the sandwich falls short: one episode with 10× the
// others' information, between-episode variance 10× theirs: the sandwich 0.37 of the true
// variance, this 0.99; model right: 0.78 and 1.42 — conservative). Returns an empty matrix if
// n < 2, the sizes disagree or some H − H_e is not positive definite.
sim::MatrixXd EpisodeJackknifeCovariance(const std::vector<sim::MatrixXd>& hessians,
                                         const std::vector<sim::VectorXd>& gradients);

// One episode's solution at θ as seen by PreferRestart: usable (a solved relaxation's iterate
// or better), converged (within every tolerance), its objective f (χ²).
struct EpisodeOutcome {
  bool usable = false, converged = false;
  double f = 0.0;
};

// Whether an episode's solution from its guess (`restart`) replaces its warm-started one
// (`warm`) at the same θ: a usable one before none; then an objective lower by more than
// kRestartObjectiveGap · max(1, |f_other|) wins whether or not either converged (a relaxed
// iterate near the complementarity tolerance is that far from no complementary solution: the
// gap says the two are different local solutions, and the lower one is the fit); within that
// gap converged before not, then the lower objective (the warm start on a tie).
inline constexpr double kRestartObjectiveGap = 1e-2;
bool PreferRestart(const EpisodeOutcome& restart, const EpisodeOutcome& warm);

}  // namespace vinci::estimation::mpec_internal
