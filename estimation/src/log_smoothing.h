// Smoothing of a noisy log for the MPEC estimator's initial guess (docs/estimation.md, method
// mpec, "Initial guess"). Private to the estimation layer.
#pragma once

#include "vinci/estimation/log.h"

namespace vinci::estimation::internal {

/// The measurement noise σ̂ (m) of an episode's logged positions, estimated from the data alone:
/// the median absolute second difference of every position column of every dynamic body,
/// normalized to unit noise variance (1.4826 median |d| / sqrt(1 + (1 + r)² + r²), r the ratio
/// of adjacent sample intervals). Robust to the few samples at contact transitions (impacts,
/// stops) where the second difference is large; 0 for fewer than 3 samples or an exact log.
double EstimatePositionNoise(const Episode& ep);

/// The episode with its dynamic bodies' logged positions (and planar angles) replaced by a
/// local quadratic fit (least squares over the 2k + 1 samples around each, the window shifted
/// inward at the ends, evaluated at the sample's time). The half-width k is chosen among
/// {0, 1, 2, 3, 4, 6, 8, 11, 16, 22, 32} by Stein's unbiased risk estimate of the positions'
/// error, RSS(k)/n − σ̂² + 2 σ̂² tr(S_k)/n with σ̂ = EstimatePositionNoise: k = 0 (the log as is)
/// for an exact log, wider windows the noisier the log and the smoother its motion. Spatial
/// orientations are left as logged. *half_width (optional) receives k.
Episode SmoothedEpisode(const Episode& ep, bool planar, int* half_width = nullptr);

}  // namespace vinci::estimation::internal
