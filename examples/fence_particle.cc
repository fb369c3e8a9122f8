// Fence–particle study (docs/formulations.md §5): a fence moving at angle β from its normal pushes
// a particle resting on the table. Quasistatic DQC is compared with the closed form (stick when
// tan β ≤ μ_f, else slide on the friction-cone edge with |v| = (v_F·n)/cos(atan μ_f)), and the
// direction error of DLC is tabulated against the number n_d of support-friction directions.
//
// Usage: fence_particle [out.csv] [--quick]
// Writes one row per (model, n_d, μ_f): the particle velocity, the closed form and the errors;
// prints the table of the worst DLC direction error per n_d.
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/simulator/simulator.h"

using namespace vinci::sim;

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kSpeed = 0.1;  // |v_F| (m/s)

Scene Make(const Scene& base, double beta, double mu_f, FormulationType type, int nd) {
  Scene s = base;
  Body& fence = s.bodies[s.FindBody("fence")];
  fence.motion.dofs[0].velocity = kSpeed * std::cos(beta);
  fence.motion.dofs[1].velocity = kSpeed * std::sin(beta);
  s.default_mu = mu_f;
  s.options.formulation = type;
  s.bodies[s.FindBody("particle")].support.directions = nd;
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  std::string out = "fence_particle.csv";
  bool quick = false;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--quick") == 0) {
      quick = true;
    } else {
      out = argv[i];
    }
  }
  try {
    const Scene base =
        LoadSceneFile(std::string(VINCI_SOURCE_DIR) + "/examples/scenes/fence_particle.yaml");
    const double beta = 75.0 * kPi / 180;
    std::vector<double> mus;
    // Cone half-angles atan μ_f from 2° to 44° (μ_f < 1 keeps the square from tipping: its two
    // fence contacts balance the friction moment only while μ_f < 1).
    const int n_mu = quick ? 3 : 24;
    for (int i = 0; i < n_mu; ++i)
      mus.push_back(std::tan((2.0 + 42.0 * i / (n_mu - 1)) * kPi / 180));
    std::vector<int> nds = quick ? std::vector<int>{4, 8} : std::vector<int>{4, 8, 16, 32, 64, 128};
    std::ofstream csv(out);
    csv << "model,n_d,beta,mu_f,vx,vy,omega,vx_exact,vy_exact,speed_error,direction_error\n";
    std::printf("%-6s %8s %16s %16s %10s\n", "n_d", "model", "worst dir err", "mean dir err",
                "pi/n_d");
    for (int pass = 0; pass < 2; ++pass) {
      const bool dqc = pass == 0;
      for (int nd : dqc ? std::vector<int>{16} : nds) {
        double worst = 0.0, sum = 0.0;
        for (double mu_f : mus) {
          Simulator sim(
              Make(base, beta, mu_f,
                   dqc ? FormulationType::kQuasistaticDqc : FormulationType::kQuasistaticDlc, nd));
          const Trajectory tr = sim.Rollout(sim.DefaultParams(), sim.InitialState(), 10);
          if (!tr.ok) {
            std::cerr << "rollout failed: " << tr.failure << "\n";
            return 3;
          }
          const VectorXd& v = tr.states.back().v;
          const double vx = kSpeed * std::cos(beta), vy = vx * mu_f;  // sliding closed form
          const double dir_err = std::abs(std::atan2(v[1], v[0]) - std::atan2(vy, vx));
          const double speed_err = std::hypot(v[0], v[1]) - std::hypot(vx, vy);
          worst = std::max(worst, dir_err);
          sum += dir_err;
          char line[256];
          std::snprintf(
              line, sizeof line, "%s,%d,%.6f,%.4f,%.12g,%.12g,%.12g,%.12g,%.12g,%.6g,%.6g\n",
              dqc ? "dqc" : "dlc", nd, beta, mu_f, v[0], v[1], v[2], vx, vy, speed_err, dir_err);
          csv << line;
        }
        std::printf("%-6d %8s %16.3e %16.3e %10.4f\n", nd, dqc ? "DQC" : "DLC", worst,
                    sum / mus.size(), kPi / nd);
      }
    }
    std::printf("wrote %s\n", out.c_str());
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
