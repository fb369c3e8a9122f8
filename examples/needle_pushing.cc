// Needle pushing a planar slider (applications.md §G): a needle (prescribed small disc) pushes
// a slider resting on three support points whose normal forces are unknown. The program samples
// support distributions N = m g f, f uniform on the simplex (fixed seed), predicts the final
// pose of each with the quasistatic DQC model, and reports position and angle errors against
// the reference prediction with the statically determinate distribution.
//
// A sampled distribution f moves the centre of pressure Σ f_k s_k anywhere inside the support
// triangle (the reference puts it at the centre of mass), so the spread of the predictions is
// the effect of not knowing where the slider's weight is carried — the uncertainty that makes
// needle pushing hard to predict.
//
// Usage: needle_pushing [out.csv] [--quick] [--samples N]
// Writes one row per sample (fractions, final pose, errors); prints the error statistics.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>
#include <random>
#include <string>
#include <vector>

#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/model/support.h"
#include "vinci/sim/simulator/simulator.h"

using namespace vinci::sim;

namespace {

// Final (x, y, θ) of the slider after `steps` steps, or NaN on a failed rollout.
Eigen::Vector3d FinalPose(const Scene& scene, int steps, std::string* failure) {
  Simulator sim(scene);
  const Trajectory tr = sim.Rollout(sim.DefaultParams(), sim.InitialState(), steps);
  if (!tr.ok) {
    *failure = tr.failure;
    return Eigen::Vector3d::Constant(NAN);
  }
  const int i = sim.scene().index(sim.scene().FindBody("slider")).q;
  return tr.states.back().q.segment<3>(i);
}

struct Stats {
  double mean = 0, rms = 0, median = 0, p90 = 0, max = 0;
};

Stats Summarize(std::vector<double> e) {
  Stats s;
  for (double x : e) {
    s.mean += x / e.size();
    s.rms += x * x / e.size();
    s.max = std::max(s.max, x);
  }
  s.rms = std::sqrt(s.rms);
  std::sort(e.begin(), e.end());
  s.median = e[e.size() / 2];
  s.p90 = e[static_cast<std::size_t>(0.9 * (e.size() - 1))];
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  std::string out = "needle_pushing.csv";
  bool quick = false;
  int samples = 200;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--quick") == 0) {
      quick = true;
    } else if (std::strcmp(argv[i], "--samples") == 0 && i + 1 < argc) {
      samples = std::atoi(argv[++i]);
    } else {
      out = argv[i];
    }
  }
  if (quick) samples = 5;
  if (samples < 1) {
    std::cerr << "error: --samples expects a positive integer\n";
    return 2;
  }
  try {
    const Scene base =
        LoadSceneFile(std::string(VINCI_SOURCE_DIR) + "/examples/scenes/needle_pushing.yaml");
    const int steps =
        quick ? 10 : static_cast<int>(std::lround(base.options.duration / base.options.dt));
    const int slider = base.FindBody("slider");
    const Body& b = base.bodies[slider];
    const double weight = b.mass * base.plane.g * std::cos(base.plane.tilt);
    std::string failure;
    const Eigen::Vector3d ref = FinalPose(base, steps, &failure);
    if (!ref.allFinite()) {
      std::cerr << "reference rollout failed: " << failure << "\n";
      return 3;
    }
    const std::vector<double> f_ref = b.support.load_fractions;
    std::mt19937 rng(7);
    std::exponential_distribution<double> expo(1.0);  // normalized: uniform on the simplex
    std::ofstream csv(out);
    csv << "sample,f1,f2,f3,x,y,theta,position_error,angle_error\n";
    char line[256];
    std::snprintf(line, sizeof line, "reference,%.6f,%.6f,%.6f,%.9g,%.9g,%.9g,0,0\n", f_ref[0],
                  f_ref[1], f_ref[2], ref[0], ref[1], ref[2]);
    csv << line;
    std::vector<double> pos_err, ang_err;
    int failed = 0;
    for (int k = 0; k < samples; ++k) {
      double f[3], sum = 0;
      for (double& x : f) sum += (x = expo(rng));
      Scene s = base;
      Support& sup = s.bodies[slider].support;
      sup.static_distribution = false;
      sup.load_fractions.clear();
      sup.normal_forces.clear();
      for (double x : f) sup.normal_forces.push_back(weight * x / sum);
      const Eigen::Vector3d pose = FinalPose(s, steps, &failure);
      if (!pose.allFinite()) {
        ++failed;
        std::cerr << "sample " << k << " failed: " << failure << "\n";
        continue;
      }
      const double pe = (pose.head<2>() - ref.head<2>()).norm();
      const double ae = std::abs(pose[2] - ref[2]);
      pos_err.push_back(pe);
      ang_err.push_back(ae);
      std::snprintf(line, sizeof line, "%d,%.6f,%.6f,%.6f,%.9g,%.9g,%.9g,%.6g,%.6g\n", k,
                    f[0] / sum, f[1] / sum, f[2] / sum, pose[0], pose[1], pose[2], pe, ae);
      csv << line;
    }
    if (pos_err.empty()) {
      std::cerr << "every sample failed\n";
      return 3;
    }
    const Stats p = Summarize(pos_err), a = Summarize(ang_err);
    std::printf(
        "needle pushing: %d samples (%d failed), %d steps of %.3g s, model %s\n", samples, failed,
        steps, base.options.dt,
        base.options.formulation == FormulationType::kQuasistaticDqc ? "quasistatic-dqc" : "other");
    std::printf("reference final pose (static loads): x %.5f m, y %.5f m, theta %.5f rad\n", ref[0],
                ref[1], ref[2]);
    std::printf("%-16s %10s %10s %10s %10s %10s\n", "error", "mean", "rms", "median", "p90", "max");
    std::printf("%-16s %10.5f %10.5f %10.5f %10.5f %10.5f\n", "position (m)", p.mean, p.rms,
                p.median, p.p90, p.max);
    std::printf("%-16s %10.5f %10.5f %10.5f %10.5f %10.5f\n", "angle (rad)", a.mean, a.rms,
                a.median, a.p90, a.max);
    std::printf("wrote %s\n", out.c_str());
    return failed > 0 ? 3 : 0;
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
}
