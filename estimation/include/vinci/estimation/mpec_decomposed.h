// The MPEC estimator over several episodes, decomposed by episode (MpecOptions::episodes =
// kDecomposed; docs/estimation.md, "Episodes: joint or decomposed").
//
// The episodes e = 1…E of a log share only θ: the joint MPEC (mpec_estimator.h) is
//
//   min_θ  F(θ) = Σ_e f_e(θ),   f_e(θ) = min over episode e's unknowns y_e of its objective
//                                         (χ², σ_R and σ_Q units) s.t. its step equations at θ,
//
// a profile over θ. First every episode's MPEC is solved alone with θ free (from its
// measured-pose guess, as EstimateMpec would), giving θ̂_e and its Laplace covariance C_e; the
// profile starts at θ_0 = (Σ_e C_e⁻¹)⁻¹ Σ_e C_e⁻¹ θ̂_e. For a fixed θ every episode's MPEC (an
// MpecEstimationProblem of that episode alone with θ's bounds set to θ) is solved by SolveMpec,
// warm-started from the episode's solution at the previous θ (first the NLP of that solution's
// active set alone, the homotopy only if it fails; early-polish attempts capped at 200 Ipopt
// iterations). At an episode's solution (a polished NLP, its active set fixed) the envelope
// theorem gives the profile's gradient from the multipliers λ_e of the step equations g_e:
//
//   ∂f_e/∂θ = ∂L_e/∂θ = λ_eᵀ ∂g_e/∂θ    (the objective does not depend on θ),
//
// and its curvature from the Laplace approximation with θ free (ParameterCovariance: the
// θ-block of the inverse reduced Hessian of ½ objective is the inverse of the profile's
// Gauss–Newton curvature), ∇²f_e = 2 C_e⁻¹. The outer problem takes Newton steps
// d = −(Σ_e ∇²f_e)⁻¹ Σ_e ∇f_e, projected on θ's bounds, halved while F does not decrease, until
// the Newton decrement ½ ∇Fᵀ d falls below 1e-8 (χ² units: a step of 1e-4 standard errors;
// 1e-6 when some episode's solution is a relaxed iterate, mpec_decomposed.cc) or
// the step below 1e-9 (1 + |θ|). Standard errors: C = (Σ_e C_e⁻¹)⁻¹ at the final θ — the joint
// problem's Laplace approximation exactly (the episodes' reduced Hessians couple only through
// θ, so the joint Schur complement in θ is the sum of the episodes'). Without a stated σ_R it
// is scaled by σ̂² / (1 mm)² as in EstimateMpec.
//
// Ipopt 3.11 with sequential MUMPS is not thread-safe (ARCHITECTURE.md): the episodes are
// solved one after the other in a fixed order, each with MpecOptions::threads evaluating its
// steps; the result is bitwise the same for any thread count.
#pragma once

#include "vinci/estimation/mpec_estimator.h"

namespace vinci::estimation {

/// Runs the decomposed MPEC estimator (file comment) on a log of at least one episode; with
/// MpecOptions::bootstrap the resamples are decomposed too. Throws std::invalid_argument for
/// bad input (as EstimateMpec); numerical trouble (an episode's NLP failed at the final θ, the
/// outer iteration did not converge) is reported in the result (converged = false, reason).
/// `stages` counts every episode NLP, `iterations` their Ipopt iterations, `num_unknowns` and
/// the other sizes are summed over the episodes (θ counted once).
MpecEstimateResult EstimateMpecDecomposed(const sim::Simulator& simulator, const Log& log,
                                          const MpecOptions& options);

}  // namespace vinci::estimation
