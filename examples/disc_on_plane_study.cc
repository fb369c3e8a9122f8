// Disc on a plane (issue 4 §5; applications.md §B; the seed slides' "GI vs N-gon" plot as
// data). A disc of radius r launched along a plane with v0 > r·ω0 (ω0 clockwise, the rolling
// direction) slides until t* = (v0 − r ω0)/(3 μ g), then rolls at (2 v0 + r ω0)/3 with constant
// kinetic energy (3/4) m v² (uniform disc). The geometrically implicit (GI) stepper keeps the
// disc round; an N-gon disc (polygon with its vertices on the circle) under Stewart–Trinkle
// loses energy at every corner impact, and the loss grows as N falls.
//
// Runs examples/scenes/disc_on_plane.yaml with the GI stepper for h ∈ {1e-2, 1e-3, 1e-4}, and
// the same scene with the disc replaced by an N-gon (N ∈ {10, 20, 50, 100}) under
// Stewart–Trinkle for each h; reports the distance travelled and the kinetic energy after T = 2 s
// against the closed form. Writes a CSV table (default disc_on_plane_study.csv; plot it with
// scripts/plot_disc_study.py) and prints a summary.
//
// usage: disc_on_plane_study [--quick] [out.csv]
//   --quick: T = 0.3 s, h ∈ {1e-2, 1e-3}, N ∈ {10, 50} (the smoke test)
#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <string>
#include <vector>

#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/simulator/simulator.h"

namespace {

using namespace vinci::sim;

constexpr double kPi = 3.14159265358979323846;

struct Closed {
  double distance, speed, energy, t_star;
};

// Closed form for a uniform disc (I = m r²/2), ω0 clockwise.
Closed ClosedForm(double v0, double w0, double r, double mu, double g, double m, double T) {
  const double t_star = (v0 - r * w0) / (3.0 * mu * g);
  const double v_roll = (2.0 * v0 + r * w0) / 3.0;
  Closed c;
  c.t_star = t_star;
  if (T <= t_star) {
    const double v = v0 - mu * g * T, w = w0 + 2.0 * mu * g * T / r;
    c.distance = v0 * T - 0.5 * mu * g * T * T;
    c.speed = v;
    c.energy = 0.5 * m * v * v + 0.25 * m * r * r * w * w;
  } else {
    c.distance = v0 * t_star - 0.5 * mu * g * t_star * t_star + v_roll * (T - t_star);
    c.speed = v_roll;
    c.energy = 0.75 * m * v_roll * v_roll;
  }
  return c;
}

struct Run {
  std::string method;
  int n = 0;  // polygon sides; 0 for the GI disc
  double h = 0.0;
  bool ok = false;
  std::string failure;
  double distance = 0.0, speed = 0.0, energy = 0.0, t_roll = -1.0, min_gap = 0.0;
  double mean_iterations = 0.0, cpu_s = 0.0;
  int steps = 0;
};

Run Simulate(Scene scene, const std::string& method, int n, double h, double T, double r) {
  scene.options.dt = h;
  if (n > 0) {
    // The N-gon: vertices on the circle of radius r, an edge flat on the floor, resting on it.
    Shape& s = scene.bodies[scene.FindBody("disc")].shapes[0];
    s.type = ShapeType::kPolygon;
    s.vertices.clear();
    for (int k = 0; k < n; ++k) {
      const double a = -kPi / 2 + kPi / n + 2.0 * kPi * k / n;
      s.vertices.emplace_back(r * std::cos(a), r * std::sin(a), 0.0);
    }
    scene.bodies[scene.FindBody("disc")].X_WB0.translation().y() = r * std::cos(kPi / n);
    scene.options.formulation = FormulationType::kStewartTrinkle;
  }
  const Simulator sim(scene);
  const int steps = static_cast<int>(std::lround(T / h));
  const std::clock_t c0 = std::clock();
  const Trajectory tr = sim.Rollout(sim.DefaultParams(), sim.InitialState(), steps);
  Run run;
  run.cpu_s = static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC;
  run.method = method;
  run.n = n;
  run.h = h;
  run.ok = tr.ok;
  run.failure = tr.failure;
  run.steps = static_cast<int>(tr.steps.size());
  const int bi = sim.scene().FindBody("disc");
  const Body& b = sim.scene().bodies[bi];
  const int iq = sim.scene().index(bi).q, iv = sim.scene().index(bi).v;
  const State& x = tr.states.back();
  run.distance = x.q[iq] - tr.states.front().q[iq];
  run.speed = x.v[iv];
  run.energy = 0.5 * b.mass * x.v.segment<2>(iv).squaredNorm() +
               0.5 * b.inertia(2, 2) * x.v[iv + 2] * x.v[iv + 2];
  // Rolling onset: the first step after which the contact-point slip |v + r ω| stays < 1e-3
  // (GI only: an N-gon rocks from corner to corner and never rolls smoothly).
  double iters = 0.0;
  for (std::size_t k = 0; k < tr.steps.size(); ++k) {
    iters += tr.steps[k].solver.iterations;
    run.min_gap = std::min(run.min_gap, tr.steps[k].min_gap);
  }
  run.mean_iterations = tr.steps.empty() ? 0.0 : iters / tr.steps.size();
  if (n == 0) {
    for (std::size_t k = tr.states.size(); k-- > 1;) {
      const VectorXd& v = tr.states[k].v;
      if (std::abs(v[iv] + r * v[iv + 2]) >= 1e-3) {
        run.t_roll = k + 1 < tr.states.size() ? tr.states[k + 1].t : -1.0;
        break;
      }
    }
  }
  return run;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    bool quick = false;
    std::string out = "disc_on_plane_study.csv";
    for (int i = 1; i < argc; ++i) {
      if (std::strcmp(argv[i], "--quick") == 0) {
        quick = true;
      } else if (argv[i][0] == '-') {
        std::cerr << "usage: disc_on_plane_study [--quick] [out.csv]\n";
        return 2;
      } else {
        out = argv[i];
      }
    }
    const Scene base =
        LoadSceneFile(std::string(VINCI_SOURCE_DIR) + "/examples/scenes/disc_on_plane.yaml");
    const int bi = base.FindBody("disc");
    const Body& disc = base.bodies[bi];
    const double r = disc.shapes[0].radius, m = disc.mass, g = -base.gravity_W.y();
    const double mu = base.default_mu;
    const double v0 = disc.v0_W.x(), w0 = -disc.w0_W.z();  // clockwise spin
    const double T = quick ? 0.3 : 2.0;
    const std::vector<double> hs =
        quick ? std::vector<double>{1e-2, 1e-3} : std::vector<double>{1e-2, 1e-3, 1e-4};
    const std::vector<int> ns =
        quick ? std::vector<int>{10, 50} : std::vector<int>{10, 20, 50, 100};
    const Closed c = ClosedForm(v0, w0, r, mu, g, m, T);

    std::vector<Run> runs;
    for (double h : hs) {
      runs.push_back(Simulate(base, "gi", 0, h, T, r));
      for (int n : ns) runs.push_back(Simulate(base, "stewart-trinkle", n, h, T, r));
    }

    std::ofstream csv(out);
    if (!csv) throw std::invalid_argument("cannot write '" + out + "'");
    csv << "method,sides,h,T,ok,distance,speed,kinetic_energy,closed_distance,closed_speed,"
           "closed_energy,energy_ratio,t_roll,closed_t_roll,min_gap,mean_solver_iterations,"
           "cpu_s\n";
    csv << std::setprecision(12);
    for (const Run& u : runs)
      csv << u.method << ',' << u.n << ',' << u.h << ',' << T << ',' << (u.ok ? 1 : 0) << ','
          << u.distance << ',' << u.speed << ',' << u.energy << ',' << c.distance << ',' << c.speed
          << ',' << c.energy << ',' << u.energy / c.energy << ',' << u.t_roll << ',' << c.t_star
          << ',' << u.min_gap << ',' << u.mean_iterations << ',' << u.cpu_s << '\n';

    std::cout << "disc on a plane: r = " << r << " m, mu = " << mu << ", v0 = " << v0
              << " m/s, omega0 = " << w0 << " rad/s (clockwise), T = " << T << " s\n"
              << "closed form: t* = " << std::setprecision(5) << c.t_star
              << " s, distance = " << std::setprecision(7) << c.distance
              << " m, speed = " << c.speed << " m/s, kinetic energy = " << c.energy << " J\n\n"
              << " method           N        h    distance(m)  err_dist    KE(J)     KE/KE_exact"
                 "  t_roll(s)  iters/step  cpu(s)\n";
    bool all_ok = true;
    for (const Run& u : runs) {
      all_ok = all_ok && u.ok;
      std::cout << ' ' << std::left << std::setw(16) << u.method << std::right << std::setw(3)
                << (u.n == 0 ? std::string("-") : std::to_string(u.n)) << std::setw(9)
                << std::setprecision(0) << std::scientific << u.h << std::fixed
                << std::setprecision(6) << std::setw(12) << u.distance << std::scientific
                << std::setprecision(2) << std::setw(11) << u.distance - c.distance << std::fixed
                << std::setprecision(5) << std::setw(10) << u.energy << std::setw(12)
                << u.energy / c.energy << std::setw(11) << std::setprecision(4)
                << (u.t_roll >= 0 ? u.t_roll : std::nan("")) << std::setw(11)
                << std::setprecision(2) << u.mean_iterations << std::setw(9) << std::setprecision(3)
                << u.cpu_s << (u.ok ? "" : "  FAILED: " + u.failure) << '\n';
    }
    std::cout << "\nwrote " << out << '\n';
    return all_ok ? 0 : 3;
  } catch (const std::exception& e) {
    std::cerr << "disc_on_plane_study: error: " << e.what() << '\n';
    return 1;
  }
}
