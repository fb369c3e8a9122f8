// Private helpers shared by the complementarity solvers' sources.
#pragma once

#include <cstdio>
#include <string>

#include "vinci/sim/types.h"

namespace vinci::sim::internal {

/// A number in short form (3 significant digits) for solver messages.
inline std::string FormatDouble(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.3g", v);
  return buf;
}

/// The scaled natural residual behind LcpScaledResidual (lcp_acceptance.h) and
/// McpScaledResidual (mcp.h), for F(z) = J z + c near z:
///   r = max_i |ẑ_i − mid(l_i / s_z, u_i / s_z, ẑ_i − F_i / s_i)|,   ẑ = z / s_z,
///   s_z = max(‖z‖∞, ‖c‖∞ / ‖J‖∞),   s_i = max(row_terms_i, s_z row_norms_i, ε_f s_w),
///   s_w = max(max_k row_terms_k, s_z ‖J‖∞),   ε_f = kLcpRoundoffFloor (each row at its own
///   scale, floored by the problem's),
/// with row_terms_i = |c_i| + Σ_j |J_ij z_j|, row_norms_i = Σ_j |J_ij| (‖J‖∞ = max row_norms),
/// x / 0 read as 0 (s_z = 0 reads as 1: then z = 0 and F = 0). For l = 0, u = ∞ the row term is
/// |min(z_i / s_z, F_i / s_i)|. Null bounds: l = 0, u = ∞ (an LCP). Infinity if z, F or a scale
/// is not finite.
double ScaledNaturalResidual(const VectorXd& z, const VectorXd& F, const VectorXd* lower,
                             const VectorXd* upper, const VectorXd& row_terms,
                             const VectorXd& row_norms, double c_norm);
/// The same with ‖J‖∞ given (j_norm = max_i row_norms_i) and one scale for every row, s_i = s_w
/// (no stricter than the per-row measure: a pre-filter for callers that know ‖J‖∞ from a scan
/// of J and need no O(n²) pass for the row norms; the per-row measure decides acceptance).
double ScaledNaturalResidual(const VectorXd& z, const VectorXd& F, const VectorXd* lower,
                             const VectorXd* upper, const VectorXd& row_terms, double j_norm,
                             double c_norm);

}  // namespace vinci::sim::internal
