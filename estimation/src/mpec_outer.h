// The decomposed MPEC's outer problem over the shared θ (mpec_decomposed.cc): its Newton
// model's secant correction and the cluster-robust covariance over episodes.
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

// The cluster-robust (sandwich) covariance of the θ̂ that minimizes F = Σ_e f_e over n ≥ 2
// independent episodes, f_e in χ² units (−2 log-likelihood):
//
//   C_robust = n / (n − 1) · H⁻¹ (Σ_e g_e g_eᵀ) H⁻¹,   H = ∇²F(θ̂), g_e = ∇f_e(θ̂).
//
// With a right model E[g_e g_eᵀ] = 2 ∇²f_e, so C_robust estimates C = 2 H⁻¹; when the episodes
// disagree beyond their noise (model error) it grows with their scatter. Returns an empty
// matrix if H is not positive definite or n < 2.
sim::MatrixXd ClusterRobustCovariance(const sim::MatrixXd& h,
                                      const std::vector<sim::VectorXd>& gradients);

}  // namespace vinci::estimation::mpec_internal
