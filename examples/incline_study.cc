// Block on an incline (issue "Foundation" §10): sweeps μ across the stick/slip threshold
// tan θ, simulates the bundled block_on_incline.yaml for each value through the Params
// interface (no scene rebuild), and compares with the closed form:
//   μ ≥ tan θ: the block sticks (a = 0);  μ < tan θ: a = g (sin θ − μ cos θ).
// Writes a CSV table (mu, a_closed_form, a_simulated, displacement_m, regime) and prints it.
//
// usage: incline_study [out.csv]
#include <cmath>
#include <fstream>
#include <iomanip>
#include <iostream>

#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/simulator/simulator.h"

int main(int argc, char** argv) {
  using namespace vinci::sim;
  try {
    const double theta = 0.3, g = 9.81;  // the scene's incline angle (rad) and gravity
    Simulator sim(
        LoadSceneFile(std::string(VINCI_SOURCE_DIR) + "/examples/scenes/block_on_incline.yaml"));
    const int mu_index = sim.scene().param_table().Index("mu.default");
    const int body = sim.scene().FindBody("block");
    const int o = sim.scene().index(body).q;
    const double h = sim.scene().options.dt;
    const int steps = 1000;
    std::ofstream csv(argc > 1 ? argv[1] : "incline_study.csv");
    csv << "mu,a_closed_form,a_simulated,displacement_m,regime\n";
    std::cout << "   mu     a_exact     a_sim   displacement(1 s)  regime\n";
    int mismatches = 0;
    for (double ratio : {0.0, 0.25, 0.5, 0.75, 0.9, 0.99, 1.01, 1.05, 1.5, 2.0}) {
      const double mu = ratio * std::tan(theta);
      Params p = sim.DefaultParams();
      p.values[mu_index] = mu;
      const Trajectory tr = sim.Rollout(p, sim.InitialState(), steps);
      if (!tr.ok) {
        std::cerr << "rollout failed: " << tr.failure << "\n";
        return 3;
      }
      const double a_exact =
          mu >= std::tan(theta) ? 0.0 : g * (std::sin(theta) - mu * std::cos(theta));
      const auto& x1 = tr.states[1];
      const auto& xn = tr.states.back();
      const double a_sim = (xn.v.head<3>().norm() - x1.v.head<3>().norm()) / ((steps - 1) * h);
      const double disp = (xn.q.segment<3>(o) - tr.states[0].q.segment<3>(o)).norm();
      const char* regime = disp < 1e-9 ? "stick" : "slide";
      if ((a_exact == 0.0) != (disp < 1e-9)) ++mismatches;
      csv << std::setprecision(10) << mu << ',' << a_exact << ',' << a_sim << ',' << disp << ','
          << regime << '\n';
      std::cout << std::fixed << std::setprecision(4) << std::setw(6) << mu << std::setw(11)
                << a_exact << std::setw(11) << a_sim << std::scientific << std::setprecision(3)
                << std::setw(14) << disp << "      " << regime << '\n';
    }
    std::cout << (mismatches == 0 ? "all regimes match tan(theta) = "
                                  : "REGIME MISMATCHES vs tan(theta) = ")
              << std::tan(theta) << '\n';
    return mismatches == 0 ? 0 : 1;
  } catch (const std::exception& e) {
    std::cerr << "incline_study: error: " << e.what() << '\n';
    return 1;
  }
}
