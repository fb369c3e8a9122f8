// The gradient through a contact mode change, raw vs smoothed (issue 17 demo). A block rests on
// the 0.3 rad incline of block_on_incline.yaml; for μ < tan θ it slides, x(T) − x(0) =
// ½ g (sin θ − μ cos θ) T² down the slope, and for μ ≥ tan θ it sticks. The exact derivative
// ∂x(T)/∂μ is −g cos θ T²/2 on the sliding side and 0 on the sticking side (no slope tells an
// optimizer that lowering μ would make the block move); the smoothed step's derivative
// (SensitivityOptions::smoothing = ε) varies continuously across the threshold. Sweeps μ/tan θ
// from 0.9 to 1.1 and writes mu, displacement, the central difference, the exact and the
// smoothed derivatives.
//
// usage: sensitivity_mode_change [out.csv]
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
    const Simulator sim(
        LoadSceneFile(std::string(VINCI_SOURCE_DIR) + "/examples/scenes/block_on_incline.yaml"));
    const ParamSelection sel(sim.scene().param_table(), {"mu.default"});
    const int body = sim.scene().FindBody("block");
    const int qx = sim.scene().index(body).q;
    const double theta = 0.3;
    const int steps = 200;  // T = 0.2 s
    const std::vector<StepInput> inputs(steps);
    // The displacement down the slope, whose downhill direction is (cos θ, 0, −sin θ).
    const auto along = [&](const VectorXd& dq) {
      return dq[qx] * std::cos(theta) - dq[qx + 2] * std::sin(theta);
    };
    std::ofstream csv(argc > 1 ? argv[1] : "sensitivity_mode_change.csv");
    csv << "mu_over_tan,mu,displacement_m,fd,exact,smoothed_1e-8,smoothed_1e-6,exact_status\n";
    std::cout << "mu/tan   displacement(m)   central diff        exact   smoothed(1e-8)  "
                 "smoothed(1e-6)  status\n";
    for (double ratio = 0.9; ratio <= 1.1001; ratio += 0.02) {
      const double mu = ratio * std::tan(theta);
      const Params p = sel.Set(sim.DefaultParams(), VectorXd::Constant(1, mu));
      const State x0 = sim.InitialState();
      const auto final_disp = [&](double m) {
        const Params pm = sel.Set(sim.DefaultParams(), VectorXd::Constant(1, m));
        const Trajectory tr = sim.Rollout(pm, x0, inputs);
        return along(tr.states.back().q - x0.q);
      };
      const double hd = 1e-6;
      const double fd = (final_disp(mu + hd) - final_disp(mu - hd)) / (2 * hd);
      double d[3];
      std::string status;
      const double eps[3] = {0.0, 1e-8, 1e-6};
      for (int k = 0; k < 3; ++k) {
        SensitivityOptions o;
        o.smoothing = eps[k];
        const RolloutSensitivity r = RolloutForward(sim, p, sel, x0, inputs, false, o);
        if (!r.trajectory.ok) throw std::runtime_error(r.trajectory.failure);
        d[k] = along(r.d_state.back().topRows(x0.q.size()).col(0));
        if (k == 0)
          status = std::to_string(r.exact_steps) + " exact/" + std::to_string(r.degenerate_steps) +
                   " degenerate/" + std::to_string(r.mode_change_steps) + " mode change";
      }
      const double disp = final_disp(mu);
      csv << ratio << ',' << std::setprecision(12) << mu << ',' << disp << ',' << fd << ',' << d[0]
          << ',' << d[1] << ',' << d[2] << ',' << status << '\n';
      std::cout << std::fixed << std::setprecision(2) << ratio << std::scientific
                << std::setprecision(4) << std::setw(17) << disp << std::setw(15) << fd
                << std::setw(13) << d[0] << std::setw(17) << d[1] << std::setw(16) << d[2] << "  "
                << status << std::defaultfloat << "\n";
    }
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
}
