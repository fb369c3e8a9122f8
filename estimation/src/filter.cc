#include "vinci/estimation/filter.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "estimation_internal.h"

namespace vinci::estimation {

using sim::MatrixXd;
using sim::Params;
using sim::State;
using sim::VectorXd;
using namespace internal;  // NOLINT(google-build-using-namespace): this layer's own helpers

void FilterOptions::Validate() const {
  auto fail = [](const std::string& field, double v, const std::string& expected) {
    FailOption("filter", field, v, expected);
  };
  if (params.empty()) throw std::invalid_argument("filter: no parameter to estimate");
  if (!(noise_sigma >= 0) || !std::isfinite(noise_sigma)) fail("noise", noise_sigma, "finite ≥ 0");
  if (!(orientation_length > 0) || !std::isfinite(orientation_length))
    fail("orientation_length", orientation_length, "finite > 0");
  if (!(param_prior_sigma >= 0) || !std::isfinite(param_prior_sigma))
    fail("param_prior_sigma", param_prior_sigma, "finite ≥ 0");
  if (!(param_drift >= 0) || !std::isfinite(param_drift))
    fail("param_drift", param_drift, "finite ≥ 0");
  if (!(process_noise >= 0) || !std::isfinite(process_noise))
    fail("process_noise", process_noise, "finite ≥ 0");
  if (!(alpha > 0) || !(alpha <= 1)) fail("alpha", alpha, "in (0, 1]");
}

double EstimateNoiseFromLog(const Log& log, sim::Dim dim) {
  constexpr int kWindow = 7;
  const int np = dim == sim::Dim::kPlanar ? 2 : 3;
  double ss = 0.0;
  int dof = 0;
  for (const Episode& ep : log.episodes) {
    for (const BodyTrack& b : ep.bodies) {
      if (!b.dynamic) continue;
      for (int w = 0; w + kWindow <= ep.num_samples(); w += kWindow) {
        Eigen::MatrixXd A(kWindow, 3);
        for (int i = 0; i < kWindow; ++i) {
          const double tau = ep.t[w + i] - ep.t[w];
          A.row(i) << 1.0, tau, tau * tau;
        }
        const auto qr = A.colPivHouseholderQr();
        for (int j = 0; j < np; ++j) {
          const VectorXd y = b.pose.col(j).segment(w, kWindow);
          ss += (A * qr.solve(y) - y).squaredNorm();
          dof += kWindow - 3;
        }
      }
    }
  }
  return dof > 0 ? std::sqrt(ss / dof) : 0.0;
}

namespace {

// Process noise of one interval dt: white acceleration of density a on every body's linear
// and (divided by orientation_length) angular coordinates; random walk of θ.
MatrixXd ProcessNoise(bool planar, int bodies, int np, double dt, const FilterOptions& o) {
  const int blk = StateBlockSize(planar);
  const int n = bodies * blk + np;
  MatrixXd Q = MatrixXd::Zero(n, n);
  const double a2 = o.process_noise * o.process_noise;
  const double l2 = o.orientation_length * o.orientation_length;
  const double qpp = a2 * dt * dt * dt / 3, qpv = a2 * dt * dt / 2, qvv = a2 * dt;
  for (int b = 0; b < bodies; ++b) {
    const int o0 = b * blk;
    const int nl = planar ? 2 : 3, na = planar ? 1 : 3;  // linear, angular coordinates
    const int pos = o0, ang = o0 + nl, vel = o0 + nl + na, angv = o0 + 2 * nl + na;
    for (int j = 0; j < nl; ++j) {
      Q(pos + j, pos + j) = qpp;
      Q(pos + j, vel + j) = Q(vel + j, pos + j) = qpv;
      Q(vel + j, vel + j) = qvv;
    }
    for (int j = 0; j < na; ++j) {
      Q(ang + j, ang + j) = qpp / l2;
      Q(ang + j, angv + j) = Q(angv + j, ang + j) = qpv / l2;
      Q(angv + j, angv + j) = qvv / l2;
    }
  }
  for (int i = 0; i < np; ++i)
    Q(bodies * blk + i, bodies * blk + i) = o.param_drift * o.param_drift * dt;
  return Q;
}

// A lower-triangular L with L Lᵀ = P (P symmetrized, with growing jitter if needed).
bool SquareRoot(const MatrixXd& P, MatrixXd* L) {
  MatrixXd S = 0.5 * (P + P.transpose());
  const double scale = std::max(1e-300, S.diagonal().cwiseAbs().maxCoeff());
  for (double jitter = 0.0; jitter < 1e-3 * scale;
       jitter = jitter == 0 ? 1e-14 * scale : jitter * 100) {
    Eigen::LLT<MatrixXd> llt(S + jitter * MatrixXd::Identity(S.rows(), S.cols()));
    if (llt.info() == Eigen::Success) {
      *L = llt.matrixL();
      return true;
    }
  }
  return false;
}

}  // namespace

EstimateResult EstimateFilter(const sim::Simulator& simulator, const Log& log,
                              const FilterOptions& options) {
  options.Validate();
  const auto start = std::chrono::steady_clock::now();
  const sim::Scene& scene = simulator.scene();
  CheckDifferentiable(scene, options.params);
  if (log.episodes.empty()) throw std::invalid_argument("no log episode");
  const sim::ParamSelection sel(scene.param_table(), options.params);
  const int np = sel.size();
  const VectorXd lo = sel.lower(), hi = sel.upper();
  const bool planar = Planar(simulator);
  const int blk = StateBlockSize(planar);
  const double dt = scene.options.dt;
  const Params base = simulator.DefaultParams();

  EstimateResult result;
  result.method = "filter";
  result.names = options.params;
  result.initial_values = sel.Get(base);
  result.sigma = options.noise_sigma > 0 ? options.noise_sigma
                                         : std::max(1e-6, EstimateNoiseFromLog(log, scene.dim));
  const double sigma = result.sigma;
  VectorXd theta = result.initial_values;
  MatrixXd P_theta = MatrixXd::Zero(np, np);
  for (int i = 0; i < np; ++i) {
    const double s = options.param_prior_sigma > 0 ? options.param_prior_sigma
                                                   : std::max(0.5 * std::abs(theta[i]), 0.1);
    P_theta(i, i) = s * s;
  }
  std::string failure;
  int failed_points = 0;
  double innovation_ss = 0.0, post_ss = 0.0;
  result.num_unknowns = np;

  for (const Episode& ep : log.episodes) {
    if (!failure.empty()) break;
    const int nb = ObservedDynamic(ep);
    const int ns = nb * blk, n = ns + np;
    const int per = ResidualsPerSample(ep, scene.dim);
    result.num_unknowns += ns;
    result.num_residuals += per * ep.num_samples();
    VectorXd se;
    const State x_guess = GuessInitialState(simulator, ep, &se);
    Episode anchor = Slice(ep, 0, 0);
    VectorXd z(n);
    z.head(ns) = VectorFromState(simulator, anchor, x_guess);
    z.tail(np) = theta;
    MatrixXd P = MatrixXd::Zero(n, n);
    const int k8 = std::min(ep.num_samples() - 1, 7);
    const double span = k8 > 0 ? ep.t[k8] - ep.t[0] : 1.0;
    for (int b = 0; b < nb; ++b) {
      for (int j = 0; j < blk; ++j) {
        const int i = b * blk + j;
        const bool angular = planar ? (j == 2 || j == 5) : ((j >= 3 && j < 6) || j >= 9);
        const bool velocity = j >= blk / 2;
        double v = sigma * sigma;
        if (velocity) v = v / (span * span) + se[i] * se[i];
        if (angular) v /= options.orientation_length * options.orientation_length;
        P(i, i) = v;
      }
    }
    P.bottomRightCorner(np, np) = P_theta;
    const MatrixXd R = MatrixXd::Identity(per, per) * sigma * sigma;
    const double t0 = ep.t.front();
    int grid = 0;
    State center = x_guess;
    double ep_ss = 0.0;
    const double lambda = options.alpha * options.alpha * n - n;
    const double c = std::sqrt(n + lambda);
    const int m = 2 * n + 1;
    VectorXd wm = VectorXd::Constant(m, 0.5 / (n + lambda)), wc = wm;
    wm[0] = lambda / (n + lambda);
    wc[0] = wm[0] + 1 - options.alpha * options.alpha + 2.0;  // β = 2
    sim::RolloutOptions ro;
    ro.warm_start = sim::WarmStartPolicy::kCold;

    for (int i = 0; i < ep.num_samples(); ++i) {
      const int target = StepsTo(simulator, t0, ep.t[i]);
      const int G = std::max(0, target - grid);
      MatrixXd L;
      if (!SquareRoot(P, &L)) {
        failure = ep.file + ":" + std::to_string(ep.lines[i]) +
                  ": the filter covariance is not positive definite";
        break;
      }
      MatrixXd Z(n, m);
      Z.col(0) = z;
      for (int j = 0; j < n; ++j) {
        Z.col(1 + j) = z + c * L.col(j);
        Z.col(1 + n + j) = z - c * L.col(j);
      }
      Episode next_anchor = Slice(ep, i, i);
      MatrixXd Zp(n, m), D(per, m);
      State center_next;
      for (int j = 0; j < m; ++j) {
        const State x = StateFromVector(simulator, anchor, center, Z.col(j).data());
        const Params p = sel.Set(base, Z.col(j).tail(np).cwiseMax(lo).cwiseMin(hi));
        const sim::Trajectory tr = simulator.Rollout(p, x, std::vector<sim::StepInput>(G), ro);
        if (!tr.ok || static_cast<int>(tr.states.size()) != G + 1) {
          if (j == 0) {
            failure = ep.file + ":" + std::to_string(ep.lines[i]) +
                      ": the mean's rollout failed: " + tr.failure;
            break;
          }
          ++failed_points;
          Zp.col(j) = Zp.col(0);
          D.col(j) = D.col(0);
          continue;
        }
        int k = 0;
        double al = 0.0;
        if (G > 0) Bracket(tr.states, ep.t[i], &k, &al);
        const State& a = tr.states[k];
        const State& b = tr.states[std::min(k + 1, G)];
        SampleResiduals(simulator, ep, i, a, b, al, options.orientation_length, D.col(j).data());
        Zp.col(j).head(ns) = VectorFromState(simulator, next_anchor, tr.states.back());
        Zp.col(j).tail(np) = Z.col(j).tail(np);
        if (j == 0) center_next = tr.states.back();
      }
      if (!failure.empty()) break;
      const VectorXd z_pred = Zp * wm;
      const VectorXd d_mean = D * wm;
      MatrixXd P_pred = ProcessNoise(planar, nb, np, G * dt, options);
      MatrixXd P_dd = R, P_zd = MatrixXd::Zero(n, per);
      for (int j = 0; j < m; ++j) {
        const VectorXd dz = Zp.col(j) - z_pred, dd = D.col(j) - d_mean;
        P_pred += wc[j] * dz * dz.transpose();
        P_dd += wc[j] * dd * dd.transpose();
        P_zd -= wc[j] * dz * dd.transpose();  // the prediction is measured − D
      }
      const Eigen::LDLT<MatrixXd> S(P_dd);
      const MatrixXd K = S.solve(P_zd.transpose()).transpose();
      z = z_pred + K * d_mean;
      P = P_pred - K * P_dd * K.transpose();
      P = 0.5 * (P + P.transpose());
      innovation_ss += d_mean.squaredNorm();
      ep_ss += d_mean.squaredNorm();
      post_ss += (R * S.solve(d_mean)).squaredNorm();
      center = StateFromVector(simulator, next_anchor, center_next, z.data());
      anchor = std::move(next_anchor);
      grid += G;
      ++result.iterations;
      if (options.progress) {
        try {
          options.progress(result.iterations, z.tail(np));
        } catch (...) {
          // progress reporting must not end the run
        }
      }
    }
    theta = z.tail(np);
    P_theta = P.bottomRightCorner(np, np);
    EpisodeEstimate ee;
    ee.file = ep.file;
    ee.x0 = x_guess;
    ee.rms_residual = std::sqrt(ep_ss / std::max(1, per * ep.num_samples()));
    result.episodes.push_back(ee);
  }

  result.estimates = theta.cwiseMax(lo).cwiseMin(hi);
  result.std_errors = P_theta.diagonal().cwiseMax(0.0).cwiseSqrt();
  result.initial_cost = 0.5 * innovation_ss;
  result.final_cost = 0.5 * post_ss;
  result.converged = failure.empty();
  std::ostringstream reason;
  if (failure.empty())
    reason << "filtered " << result.iterations << " samples";
  else
    reason << failure << " (after " << result.iterations << " samples)";
  if (failed_points > 0)
    reason << "; " << failed_points << " sigma-point rollout(s) failed (replaced by the mean's)";
  result.reason = reason.str();
  result.time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace vinci::estimation
