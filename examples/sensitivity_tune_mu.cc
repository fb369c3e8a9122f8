// Tunes the friction coefficient of a sliding block by gradient descent so that it stops at a
// target distance (issue 17 demo). The block of block_sliding.yaml is launched at v0 = 2 m/s;
// its stopping distance is v0²/(2 μ g) (continuous time), so μ* = v0²/(2 g d*). The gradient of
// g(μ) = (x_N(μ) − x0 − d*)² comes from reverse-mode step sensitivities (sensitivity.h), one
// rollout per iteration, and each iterate is printed next to the closed form.
//
// usage: sensitivity_tune_mu [target_distance_m (default 0.4)] [out.csv]
#include <cmath>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <string>

#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/simulator/sensitivity.h"
#include "vinci/sim/simulator/simulator.h"

int main(int argc, char** argv) {
  using namespace vinci::sim;
  try {
    const double target = argc > 1 ? std::stod(argv[1]) : 0.4;
    if (!(target > 0.05 && target < 5.0)) {
      std::cerr << "target distance must be in (0.05, 5) m\n";
      return 1;
    }
    const Simulator sim(
        LoadSceneFile(std::string(VINCI_SOURCE_DIR) + "/examples/scenes/block_sliding.yaml"));
    const ParamSelection sel(sim.scene().param_table(), {"mu.default"});
    const int qx = sim.scene().index(sim.scene().FindBody("block")).q;
    const int nx = sim.scene().num_positions() + sim.scene().num_velocities();
    const State x0 = sim.InitialState();
    const double v0 = 2.0, g = 9.81;
    const double mu_star = v0 * v0 / (2 * g * target);
    // Long enough for the block to stop for any μ ≥ 0.2 (t_stop = v0/(μ g) ≤ 1.02 s).
    const std::vector<StepInput> inputs(1500);
    const TerminalObjective objective = [&](const State& xN, VectorXd* grad) {
      const double e = xN.q[qx] - x0.q[qx] - target;
      grad->setZero(nx);
      (*grad)[qx] = 2 * e;
      return e * e;
    };
    std::ofstream csv(argc > 2 ? argv[2] : "sensitivity_tune_mu.csv");
    csv << "iteration,mu,distance_m,objective,gradient\n";
    std::cout << "target distance " << target << " m; closed-form mu* = " << mu_star << "\n";
    std::cout << " it        mu   distance(m)    objective     d/dmu   steps exact/degenerate/"
                 "mode change\n";
    double mu = 0.25;
    for (int it = 0; it < 30; ++it) {
      const Params p = sel.Set(sim.DefaultParams(), VectorXd::Constant(1, mu));
      const RolloutGradient r = RolloutReverse(sim, p, sel, x0, inputs, objective);
      if (!r.ok) {
        std::cerr << "rollout gradient failed: " << r.failure << "\n";
        return 3;
      }
      const double distance = target + std::copysign(std::sqrt(r.value), 1.0);
      csv << it << ',' << std::setprecision(12) << mu << ',' << distance << ',' << r.value << ','
          << r.d_theta[0] << '\n';
      std::cout << std::setw(3) << it << std::setw(10) << std::setprecision(6) << mu
                << std::setw(14) << distance << std::setw(13) << r.value << std::setw(10)
                << r.d_theta[0] << "   " << r.exact_steps << "/" << r.degenerate_steps << "/"
                << r.mode_change_steps << "\n";
      if (r.value < 1e-14) break;
      // Gauss–Newton on the residual e: μ ← μ − e / (de/dμ), de/dμ = g'/(2e); step bounded.
      const double e = std::sqrt(r.value);
      const double de = r.d_theta[0] / (2 * e);
      double step = -e / de;
      if (!std::isfinite(step)) break;
      step = std::max(-0.5 * mu, std::min(0.5 * mu, step));
      mu += step;
    }
    std::cout << "final mu = " << mu << " (closed form " << mu_star << ", relative difference "
              << std::abs(mu - mu_star) / mu_star << ": the discrete stopping distance differs "
              << "from v0^2/(2 mu g) by O(h))\n";
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
}
