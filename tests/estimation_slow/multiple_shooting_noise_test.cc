// Multiple shooting with seeded noise (slow: ~20 s): it agrees with single shooting.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <string>

#include "../estimation/estimation_test_util.h"
#include "vinci/estimation/least_squares.h"
#include "vinci/sim/model/scene_file.h"

namespace vinci::estimation {
namespace {

using testing::SyntheticLog;

constexpr double kTrueMu = 0.3;

// The first-order standard error of μ̂ for the sliding block from x samples of the discrete
// model (v ← max(0, v − μ g dt), x ← x + dt v on the log's grid; x0, v0, μ unknown, y carries
// no information about them): σ √((JᵀJ)⁻¹)_μμ, J by central differences.
double ClosedFormStandardError(const Episode& ep, double x0, double v0, double mu, double sigma) {
  const double dt = 0.002, g = 9.81;
  auto samples = [&](double a, double b, double m) {
    Eigen::VectorXd out(ep.num_samples());
    double x = a, v = b;
    int k = 0;
    for (int i = 0; i < ep.num_samples(); ++i) {
      for (; k < std::lround(ep.t[i] / dt); ++k) {
        v = std::max(0.0, v - m * g * dt);
        x += dt * v;
      }
      out[i] = x;
    }
    return out;
  };
  Eigen::MatrixXd J(ep.num_samples(), 3);
  const double h = 1e-6;
  J.col(0) = (samples(x0 + h, v0, mu) - samples(x0 - h, v0, mu)) / (2 * h);
  J.col(1) = (samples(x0, v0 + h, mu) - samples(x0, v0 - h, mu)) / (2 * h);
  J.col(2) = (samples(x0, v0, mu + h) - samples(x0, v0, mu - h)) / (2 * h);
  const Eigen::MatrixXd cov = (J.transpose() * J).inverse();
  return sigma * std::sqrt(cov(2, 2));
}

// Single and multiple shooting agree with noise (same model, the continuity is a constraint up
// to O(1/w²)), and their standard errors are close to each other and to the closed form.
// Tolerance 10%: the fits' μ̂ and σ̂ differ slightly, and the estimators also profile out y0
// and vy0 (vy0 acts through the first step's friction impulse only).
TEST(MultipleShooting, AgreesWithSingleShootingWithNoise) {
  const sim::Simulator sim(sim::ParseScene(testing::kPlanarBlock, "block.yaml"));
  const std::string path =
      SyntheticLog(sim, "block", kTrueMu, 0.6, 5, 1e-3, 7, "ms_noise.csv", false);
  const Log log = ReadLog({path}, sim.scene());
  LeastSquaresOptions single;
  single.params = {"mu.default"};
  const EstimateResult a = EstimateLeastSquares(sim, log, single);
  const EstimateResult b = EstimateLeastSquares(sim, log, [] {
    LeastSquaresOptions o;
    o.params = {"mu.default"};
    o.shooting = Shooting::kMultiple;
    o.segment_samples = 20;
    return o;
  }());
  ASSERT_TRUE(a.converged) << a.reason;
  ASSERT_TRUE(b.converged) << b.reason;
  EXPECT_NEAR(b.estimates[0], a.estimates[0], 0.1 * a.std_errors[0]);
  EXPECT_NEAR(b.std_errors[0], a.std_errors[0], 0.1 * a.std_errors[0]);
  EXPECT_NEAR(b.sigma, a.sigma, 0.1 * a.sigma);
  // The scene's block starts at x = 0 with vx = 1.5 m/s.
  const double closed = ClosedFormStandardError(log.episodes[0], 0.0, 1.5, kTrueMu, a.sigma);
  EXPECT_NEAR(a.std_errors[0], closed, 0.1 * closed);
  EXPECT_NEAR(b.std_errors[0], closed, 0.1 * closed);
}

}  // namespace
}  // namespace vinci::estimation
