// Sphere on two spheres (issue 4 §5; applications.md §B) with the geometrically implicit (GI)
// stepper: simulates examples/scenes/sphere_on_two_spheres.yaml and checks the closed-form rest
// state (the ball at distance r + R from both fixed centres) and that the spheres never overlap
// at the end of a step (the GI contact points are end-of-step unknowns). Writes a CSV table
// (t, ball position, distances and gaps to both spheres) and prints a summary.
//
// usage: sphere_on_two_spheres [--quick] [out.csv]   (--quick: 0.6 s instead of the scene's)
#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <string>

#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/simulator/simulator.h"

int main(int argc, char** argv) {
  using namespace vinci::sim;
  try {
    bool quick = false;
    std::string out = "sphere_on_two_spheres.csv";
    for (int i = 1; i < argc; ++i) {
      if (std::strcmp(argv[i], "--quick") == 0) {
        quick = true;
      } else if (argv[i][0] == '-') {
        std::cerr << "usage: sphere_on_two_spheres [--quick] [out.csv]\n";
        return 2;
      } else {
        out = argv[i];
      }
    }
    const Simulator sim(LoadSceneFile(std::string(VINCI_SOURCE_DIR) +
                                      "/examples/scenes/sphere_on_two_spheres.yaml"));
    const Scene& s = sim.scene();
    const int ball = s.FindBody("ball"), left = s.FindBody("left"), right = s.FindBody("right");
    const double r = s.bodies[ball].shapes[0].radius;
    const double R = s.bodies[left].shapes[0].radius;
    const Vector3d cl = s.bodies[left].X_WB0.translation(),
                   cr = s.bodies[right].X_WB0.translation();
    const double T = quick ? 0.6 : s.options.duration, h = s.options.dt;
    const int steps = static_cast<int>(std::lround(T / h));
    const Trajectory tr = sim.Rollout(sim.DefaultParams(), sim.InitialState(), steps);

    std::ofstream csv(out);
    if (!csv) throw std::invalid_argument("cannot write '" + out + "'");
    csv << "t,x,y,z,vz,dist_left,dist_right,gap_left,gap_right\n" << std::setprecision(12);
    const int iq = s.index(ball).q, iv = s.index(ball).v;
    double min_gap = 1e300, min_gap_t = 0.0;
    for (const State& x : tr.states) {
      const Vector3d c = x.q.segment<3>(iq);
      const double dl = (c - cl).norm(), dr = (c - cr).norm();
      const double gl = dl - r - R, gr = dr - r - R;
      if (std::min(gl, gr) < min_gap) min_gap = std::min(gl, gr), min_gap_t = x.t;
      csv << x.t << ',' << c.x() << ',' << c.y() << ',' << c.z() << ',' << x.v[iv + 2] << ',' << dl
          << ',' << dr << ',' << gl << ',' << gr << '\n';
    }
    const State& xf = tr.states.back();
    const Vector3d c = xf.q.segment<3>(iq);
    const double half = 0.5 * (cr - cl).norm();
    const double z_rest = 0.5 * (cl + cr).z() + std::sqrt((r + R) * (r + R) - half * half);
    double iters = 0.0;
    for (const StepInfo& i : tr.steps) iters += i.solver.iterations;
    std::cout << std::fixed << std::setprecision(10)
              << "sphere on two spheres (GI, h = " << std::setprecision(4) << h
              << std::setprecision(10) << " s, " << tr.steps.size() << " steps, "
              << (tr.ok ? "ok" : "FAILED: " + tr.failure) << ")\n"
              << "  final distance to left centre   " << (c - cl).norm() << " m (r + R = " << r + R
              << ", error " << std::scientific << std::setprecision(2) << (c - cl).norm() - r - R
              << ")\n"
              << std::fixed << std::setprecision(10) << "  final distance to right centre  "
              << (c - cr).norm() << " m (error " << std::scientific << std::setprecision(2)
              << (c - cr).norm() - r - R << ")\n"
              << std::fixed << std::setprecision(10) << "  final centre height             "
              << c.z() << " m (closed form " << z_rest << ")\n"
              << std::scientific << std::setprecision(2) << "  final speed                     "
              << xf.v.segment<3>(iv).norm() << " m/s\n"
              << "  minimum gap over all steps      " << min_gap << " m (at t = " << std::fixed
              << std::setprecision(3) << min_gap_t << " s; negative = overlap)\n"
              << "  mean solver iterations per step " << std::setprecision(2)
              << iters / std::max<std::size_t>(1, tr.steps.size()) << "\n"
              << "wrote " << out << '\n';
    return tr.ok ? 0 : 3;
  } catch (const std::exception& e) {
    std::cerr << "sphere_on_two_spheres: error: " << e.what() << '\n';
    return 1;
  }
}
