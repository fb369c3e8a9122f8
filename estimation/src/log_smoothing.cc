// Smoothing of a noisy log for the MPEC estimator's initial guess (log_smoothing.h).
#include "log_smoothing.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace vinci::estimation::internal {
namespace {

// The columns that are smoothed: positions, and the planar angle when logged.
std::vector<int> SmoothedColumns(const BodyTrack& b, bool planar) {
  std::vector<int> cols = planar ? std::vector<int>{0, 1} : std::vector<int>{0, 1, 2};
  if (planar && b.has_orientation) cols.push_back(2);
  return cols;
}

// Local quadratic fit of column c of body b with half-width k: the fitted values (*fit) and the
// hat matrix's diagonal (*lev, the weight of each sample in its own fit).
void LocalQuadratic(const Episode& ep, const BodyTrack& b, int c, int k, std::vector<double>* fit,
                    std::vector<double>* lev) {
  const int n = ep.num_samples();
  fit->assign(n, 0.0);
  lev->assign(n, 1.0);
  for (int i = 0; i < n; ++i) {
    if (k == 0) {
      (*fit)[i] = b.pose(i, c);
      continue;
    }
    const int w = std::min(2 * k + 1, n);
    const int lo = std::clamp(i - k, 0, n - w), hi = lo + w - 1;
    const int deg = std::min(2, w - 1);
    // Times relative to the sample, scaled by the window's span (conditioning).
    const double span = std::max(ep.t[hi] - ep.t[lo], 1e-300);
    Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
    Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
    for (int j = lo; j <= hi; ++j) {
      const double tau = (ep.t[j] - ep.t[i]) / span;
      const Eigen::Vector3d x(1.0, tau, deg >= 2 ? tau * tau : 0.0);
      A += x * x.transpose();
      rhs += x * b.pose(j, c);
    }
    if (deg < 2) A(2, 2) = 1.0;
    const Eigen::LDLT<Eigen::Matrix3d> ldlt(A);
    const Eigen::Vector3d coef = ldlt.solve(rhs);
    const Eigen::Vector3d e0 = ldlt.solve(Eigen::Vector3d::UnitX());
    (*fit)[i] = coef[0];
    (*lev)[i] = e0[0];  // x_iᵀ A⁻¹ x_i with x_i = (1, 0, 0)
  }
}

}  // namespace

double EstimatePositionNoise(const Episode& ep) {
  std::vector<double> d;
  const int n = ep.num_samples();
  for (const BodyTrack& b : ep.bodies) {
    if (!b.dynamic) continue;
    const int ncols = b.pose.cols() == 3 ? 2 : 3;  // planar (x, y, θ) or spatial
    for (int c = 0; c < ncols; ++c) {
      for (int i = 1; i + 1 < n; ++i) {
        const double r = (ep.t[i + 1] - ep.t[i]) / (ep.t[i] - ep.t[i - 1]);
        const double di = b.pose(i + 1, c) - b.pose(i, c) - r * (b.pose(i, c) - b.pose(i - 1, c));
        d.push_back(std::abs(di) / std::sqrt(1 + (1 + r) * (1 + r) + r * r));
      }
    }
  }
  if (d.empty()) return 0.0;
  auto mid = d.begin() + static_cast<long>(d.size() / 2);
  std::nth_element(d.begin(), mid, d.end());
  return 1.4826 * *mid;
}

Episode SmoothedEpisode(const Episode& ep, bool planar, int* half_width) {
  const double sigma = EstimatePositionNoise(ep);
  const int n = ep.num_samples();
  int best_k = 0;
  if (sigma > 0 && n >= 3) {
    double best = std::numeric_limits<double>::infinity();
    std::vector<double> fit, lev;
    for (const int k : {0, 1, 2, 3, 4, 6, 8, 11, 16, 22, 32}) {
      if (k > 0 && 2 * k + 1 > n) break;
      double rss = 0.0, trace = 0.0;
      int count = 0;
      for (const BodyTrack& b : ep.bodies) {
        if (!b.dynamic) continue;
        for (const int c : SmoothedColumns(b, planar)) {
          if (c == 2 && planar) continue;  // angles: other units; positions decide
          LocalQuadratic(ep, b, c, k, &fit, &lev);
          for (int i = 0; i < n; ++i) {
            rss += (fit[i] - b.pose(i, c)) * (fit[i] - b.pose(i, c));
            trace += lev[i];
          }
          count += n;
        }
      }
      if (count == 0) break;
      const double risk = rss / count - sigma * sigma + 2 * sigma * sigma * trace / count;
      if (risk < best) {
        best = risk;
        best_k = k;
      }
    }
  }
  if (half_width) *half_width = best_k;
  Episode out = ep;
  if (best_k == 0) return out;
  std::vector<double> fit, lev;
  for (std::size_t bi = 0; bi < ep.bodies.size(); ++bi) {
    const BodyTrack& b = ep.bodies[bi];
    if (!b.dynamic) continue;
    for (const int c : SmoothedColumns(b, planar)) {
      LocalQuadratic(ep, b, c, best_k, &fit, &lev);
      for (int i = 0; i < n; ++i) out.bodies[bi].pose(i, c) = fit[i];
    }
  }
  return out;
}

}  // namespace vinci::estimation::internal
