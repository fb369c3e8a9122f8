// Disc falling on a compliant half-plane (applications.md §B.3, docs/formulations.md §4): simulates
// examples/scenes/disc_on_compliant_plane.yaml (Kelvin–Voigt layer, Stewart–Trinkle stepper) and
// compares with the closed forms of a linear spring under gravity:
//   ω = √(k/m), δ_s = m g / k, v = impact speed;
//   contact duration  T = (π + 2 atan(δ_s ω / v)) / ω   (π √(m/k) without gravity),
//   rebound speed = v (no damping), peak overlap δ_s + √(δ_s² + (v/ω)²), static overlap δ_s.
// Then the same drop with damping c (restitution falls monotonically with c) and a damped
// settle for the static overlap. Writes the undamped drop as a CSV table
// (t, overlap_m, p_n_Ns, force_N, velocity_mps) and prints a summary; exits 1 if a closed-form
// check misses its tolerance.
//
// usage: compliant_impact [out.csv]
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>

#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/simulator/simulator.h"

namespace {

using namespace vinci::sim;

constexpr double kPi = 3.14159265358979323846;

struct Drop {
  double t_in = -1, t_out = -1;  // interpolated crossings of overlap 0 (s)
  double v_in = 0, v_out = 0;    // speeds at the crossings (m/s)
  double max_overlap = 0;        // m
  double final_overlap = 0;      // m
  bool ok = false;
  std::string failure;
};

// Runs `steps` steps; optionally writes the CSV rows.
Drop Simulate(const Scene& scene, int steps, std::ofstream* csv) {
  Simulator sim(scene);
  const double r = 0.1, h = scene.options.dt;
  const Trajectory tr = sim.Rollout(sim.DefaultParams(), sim.InitialState(), steps);
  Drop d;
  if (!tr.ok) {
    d.failure = tr.failure;
    return d;
  }
  for (std::size_t k = 0; k < tr.states.size(); ++k) {
    const State& x = tr.states[k];
    const double overlap = r - x.q[1];
    d.max_overlap = std::max(d.max_overlap, overlap);
    if (csv) {
      // p_n of the step that produced x: the first LCP unknown when a contact was active.
      const double pn = k > 0 && tr.steps[k - 1].contacts > 0 ? x.warm_start[0] : 0.0;
      char line[160];
      std::snprintf(line, sizeof line, "%.6f,%.9e,%.9e,%.9e,%.9e\n", x.t, overlap, pn, pn / h,
                    x.v[1]);
      *csv << line;
    }
    if (k == 0) continue;
    const State& x0 = tr.states[k - 1];
    const double g0 = x0.q[1] - r, g1 = x.q[1] - r;
    const double s = g0 / (g0 - g1);  // crossing fraction within the step
    if (d.t_in < 0 && g0 >= 0 && g1 < 0) {
      d.t_in = x0.t + s * h;
      d.v_in = -(x0.v[1] + s * (x.v[1] - x0.v[1]));
    } else if (d.t_in >= 0 && d.t_out < 0 && g0 < 0 && g1 >= 0) {
      d.t_out = x0.t + s * h;
      d.v_out = x0.v[1] + s * (x.v[1] - x0.v[1]);
    }
  }
  d.final_overlap = r - tr.states.back().q[1];
  d.ok = true;
  return d;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const Scene base = LoadSceneFile(std::string(VINCI_SOURCE_DIR) +
                                     "/examples/scenes/disc_on_compliant_plane.yaml");
    const int floor = base.FindBody("floor"), disc = base.FindBody("disc");
    const double k = base.bodies[floor].compliance.stiffness, m = base.bodies[disc].mass;
    const double g = -base.gravity_W.y(), h = base.options.dt;
    const double omega = std::sqrt(k / m), delta_s = m * g / k;
    const int steps = static_cast<int>(std::lround(base.options.duration / h));

    std::ofstream csv(argc > 1 ? argv[1] : "compliant_impact.csv");
    csv << "t,overlap_m,p_n_Ns,force_N,velocity_mps\n";
    const Drop d = Simulate(base, steps, &csv);
    if (!d.ok || d.t_out < 0) {
      std::cerr << "compliant_impact: the drop did not bounce: " << d.failure << '\n';
      return 3;
    }
    const double v = d.v_in;
    const double T_closed = (kPi + 2.0 * std::atan(delta_s * omega / v)) / omega;
    const double T = d.t_out - d.t_in;
    const double peak_closed = delta_s + std::sqrt(delta_s * delta_s + v * v / (omega * omega));
    int failures = 0;
    const auto row = [&](const char* what, double sim, double closed, double tol) {
      const double err = std::abs(sim - closed) / std::abs(closed);
      failures += err > tol ? 1 : 0;
      std::printf("  %-30s %12.6g %12.6g %9.3f%%%s\n", what, sim, closed, 100 * err,
                  err > tol ? "  FAIL" : "");
    };
    std::printf(
        "disc on a compliant half-plane: k = %g N/m, m = %g kg, h = %g s (h omega = %.4f)\n", k, m,
        h, h * omega);
    std::printf("  %-30s %12s %12s %10s\n", "quantity", "simulated", "closed form", "error");
    row("contact duration (s)", T, T_closed, 0.02);
    std::printf("  %-30s %12s %12.6g  (pi sqrt(m/k), no gravity)\n", "", "", kPi / omega);
    row("rebound speed (m/s)", d.v_out, v, 0.02);
    row("peak overlap (m)", d.max_overlap, peak_closed, 0.02);

    // Damping sweep: restitution e = v_out / v_in falls with c.
    std::printf("  damping sweep (Kelvin-Voigt c, N s/m): restitution\n");
    double previous = 2.0;
    for (double c : {0.0, 2.0, 5.0, 10.0, 20.0}) {
      Scene s = base;
      s.bodies[floor].compliance.damping = c;
      const Drop dc = Simulate(s, static_cast<int>(0.2 / h), nullptr);
      if (!dc.ok || dc.t_out < 0) {
        std::printf("    c = %5.1f: no rebound\n", c);
        continue;
      }
      const double e = dc.v_out / dc.v_in;
      std::printf("    c = %5.1f  zeta = %.3f  e = %.4f\n", c, c / (2 * std::sqrt(k * m)), e);
      if (!(e < previous)) ++failures;
      previous = e;
    }

    // Static overlap after a damped settle (critically damped layer, 1 s at h = 1e-3).
    Scene s = base;
    s.bodies[floor].compliance.damping = 2.0 * std::sqrt(k * m);
    s.options.dt = 1e-3;
    const Drop settle = Simulate(s, 1000, nullptr);
    if (!settle.ok) {
      std::cerr << "compliant_impact: settle failed: " << settle.failure << '\n';
      return 3;
    }
    row("static overlap m g / k (m)", settle.final_overlap, delta_s, 0.01);
    std::printf(failures == 0 ? "all closed-form checks pass\n" : "%d CHECKS FAILED\n", failures);
    return failures == 0 ? 0 : 1;
  } catch (const std::exception& e) {
    std::cerr << "compliant_impact: error: " << e.what() << '\n';
    return 1;
  }
}
