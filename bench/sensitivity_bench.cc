// sensitivity_bench: the cost of exact step sensitivities (simulator/sensitivity.h, issue 17
// item 6), in process CPU time, on the example scenes:
//  1. per step: one forward-mode step derivative for ONE parameter (PropagateStep with one
//     column: the parameter's own column plus ∂x_ℓ+1/∂x_ℓ along the carried sensitivity; by
//     default, and by the general path only, SensitivityOptions::lcp_basis off), the step's own
//     derivative for ONE parameter (StepDerivatives without the state Jacobian: ∂x_ℓ+1/∂θ, no
//     carried column), and StepDerivatives with the full state Jacobian, each relative to
//     Simulator::Step;
//  2. per rollout of N steps (default 1000): the reverse-mode gradient of a terminal objective
//     with respect to p parameters (RolloutReverse) against the 2p + 1 rollouts of central
//     differences, for the case's parameters and for the friction coefficient alone.
// Prints a table. --steps N sets N; --quick runs 50 steps of one scene (the ctest smoke run);
// --scene S runs only the scenes whose file name contains S; --fwd-only measures only step and
// fwd1 (for a profiler: `perf record build/bench/sensitivity_bench --scene box --fwd-only`);
// --once makes each per-step measurement one pass over the N states (for instruction counts:
// `valgrind --tool=callgrind ... --once`, then the inclusive counts of Step and PropagateStep;
// the "roll" pass calls both: --roll-only measures step and roll only, --fwd-only without
// --roll-only step, fwd1 and roll); --general takes fwd1 and roll by the general path only
// (SensitivityOptions::lcp_basis off: callgrind's counts of the two paths, run by run).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <string>
#include <utility>
#include <vector>

#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/simulator/sensitivity.h"

namespace {

using namespace vinci::sim;

double CpuSeconds() { return static_cast<double>(std::clock()) / CLOCKS_PER_SEC; }

struct Case {
  const char* scene;
  std::vector<std::string> params;
  int warmup;  // steps simulated before the measured ones
};

void Run(const Case& c, int steps, bool fwd_only, bool once, bool roll_only,
         const SensitivityOptions& options) {
  const Simulator sim(LoadSceneFile(std::string(VINCI_SOURCE_DIR) + "/examples/scenes/" + c.scene));
  const Params p = sim.DefaultParams();
  const ParamSelection sel(sim.scene().param_table(), c.params);
  const ParamSelection one(sim.scene().param_table(), {c.params.front()});
  const State x0 = sim.Rollout(p, sim.InitialState(), c.warmup).states.back();
  const std::vector<StepInput> inputs(steps);
  const Trajectory tr = sim.Rollout(p, x0, inputs);
  if (!tr.ok) {
    std::printf("%-26s rollout failed: %s\n", c.scene, tr.failure.c_str());
    return;
  }
  const int nx = static_cast<int>(x0.q.size() + x0.v.size());

  // 1. Per step, over the same states: passes over the N states repeated until ≥ 0.2 s of CPU
  // and ≥ 5 passes per measurement, the fastest pass kept (on a shared VM the mean moves by
  // ±30 % from run to run; the differences "step + derivative − step" below need both terms
  // steady).
  const auto per_step = [&](auto&& fn) {
    int reps = 0;
    const double t0 = CpuSeconds();
    double t = t0, best = 1e300;
    do {
      Workspace ws;
      const double start = CpuSeconds();
      for (int k = 0; k < steps; ++k) fn(k, &ws);
      ++reps;
      t = CpuSeconds();
      best = std::min(best, t - start);
    } while (!once && (t - t0 < 0.2 || reps < 5));
    return best / steps;
  };
  const double t_step = per_step([&](int k, Workspace* ws) {
    State next;
    sim.Step(p, tr.states[k], inputs[k], ws, &next);
  });
  MatrixXd S = MatrixXd::Zero(nx, 1), S_next;
  S(0, 0) = 1.0;  // a generic carried sensitivity
  // With a workspace, as RolloutForward / RolloutReverse pass the step's own.
  const double t_fwd = roll_only ? 0.0 : per_step([&](int k, Workspace* ws) {
    PropagateStep(sim, p, one, tr.states[k], inputs[k], tr.states[k + 1], S, &S_next, options, ws);
  });
  // The same with the general path only (SensitivityOptions::lcp_basis off), and the share of
  // the window's steps whose fwd1 was taken on the step LCP's basis.
  SensitivityOptions general;
  general.lcp_basis = false;
  const double t_gen = roll_only ? 0.0 : per_step([&](int k, Workspace* ws) {
    PropagateStep(sim, p, one, tr.states[k], inputs[k], tr.states[k + 1], S, &S_next, general, ws);
  });
  int on_basis = 0;
  for (int k = 0; !roll_only && k < steps; ++k) {
    Workspace ws;
    on_basis +=
        PropagateStep(sim, p, one, tr.states[k], inputs[k], tr.states[k + 1], S, &S_next, {}, &ws)
            .on_lcp_basis;
  }
  const double basis_share = 100.0 * on_basis / steps;
  // As RolloutForward: each step, then its derivative in the same workspace (which reuses what
  // the step assembled, Workspace::step_record); the derivative's cost there is this minus the
  // step's.
  const double t_pair = per_step([&](int k, Workspace* ws) {
    State next;
    sim.Step(p, tr.states[k], inputs[k], ws, &next);
    PropagateStep(sim, p, one, tr.states[k], inputs[k], next, S, &S_next, options, ws);
  });
  const double t_roll = t_pair - t_step;
  // The step's own derivative for one parameter (StepDerivatives without the state Jacobian),
  // right after the step in the same workspace.
  const double t_dtheta =
      per_step([&](int k, Workspace* ws) {
        State next;
        sim.Step(p, tr.states[k], inputs[k], ws, &next);
        StepDerivatives(sim, p, one, tr.states[k], inputs[k], next, false, options, ws);
      }) -
      t_step;
  if (fwd_only) {
    std::printf(
        "%-26s %2d %5d | %9.1f %9.1f %5.2f %9.1f %5.2f %5.0f | %9.1f %5.2f | %9.1f %5.2f |\n",
        c.scene, sel.size(), steps, 1e6 * t_step, 1e6 * t_fwd, t_fwd / t_step, 1e6 * t_gen,
        t_gen / t_step, basis_share, 1e6 * t_roll, t_roll / t_step, 1e6 * t_dtheta,
        t_dtheta / t_step);
    return;
  }
  const double t_full = per_step([&](int k, Workspace* ws) {
    StepDerivatives(sim, p, sel, tr.states[k], inputs[k], tr.states[k + 1], true, {}, ws);
  });

  // 2. Rollout gradient: reverse mode vs 2p + 1 rollouts.
  const TerminalObjective g = [&](const State& xN, VectorXd* grad) {
    grad->setZero(nx);
    (*grad)[0] = 1.0;
    return xN.q[0];
  };
  // The reverse-mode gradient with respect to `selection` and its 2p + 1 rollouts, CPU s.
  bool rev_ok = true;
  double sink = 0.0;
  const auto gradient_times = [&](const ParamSelection& selection) {
    double t0 = CpuSeconds();
    rev_ok = RolloutReverse(sim, p, selection, x0, inputs, g).ok && rev_ok;
    const double t_rev = CpuSeconds() - t0;
    t0 = CpuSeconds();
    sink += sim.Rollout(p, x0, inputs).states.back().q[0];
    for (int j = 0; j < selection.size(); ++j)
      for (double s : {1.0, -1.0}) {
        VectorXd v = selection.Get(p);
        v[j] += s * 1e-6 * std::max(1.0, std::abs(v[j]));
        sink += sim.Rollout(selection.Set(p, v), x0, inputs).states.back().q[0];
      }
    return std::pair<double, double>(t_rev, CpuSeconds() - t0);
  };
  const auto [t_rev, t_fd] = gradient_times(sel);
  const auto [t_rev1, t_fd1] = gradient_times(one);  // the friction coefficient alone
  std::printf(
      "%-26s %2d %5d | %9.1f %9.1f %5.2f %9.1f %5.2f %5.0f | %9.1f %5.2f | %9.1f %5.2f | %9.1f "
      "%6.2f | %8.3f %8.3f %6.2f | %8.3f %8.3f %6.2f | %s%s\n",
      c.scene, sel.size(), steps, 1e6 * t_step, 1e6 * t_fwd, t_fwd / t_step, 1e6 * t_gen,
      t_gen / t_step, basis_share, 1e6 * t_roll, t_roll / t_step, 1e6 * t_dtheta, t_dtheta / t_step,
      1e6 * t_full, t_full / t_step, t_rev, t_fd, t_rev / t_fd, t_rev1, t_fd1, t_rev1 / t_fd1,
      rev_ok ? "ok" : "FAILED", std::isfinite(sink) ? "" : " (nan)");
}

}  // namespace

int main(int argc, char** argv) {
  int steps = 1000;
  bool quick = false, fwd_only = false, once = false, roll_only = false;
  SensitivityOptions options;
  std::string only;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--quick") == 0) {
      quick = true;
      steps = 50;
    } else if (std::strcmp(argv[i], "--fwd-only") == 0) {
      fwd_only = true;
    } else if (std::strcmp(argv[i], "--once") == 0) {
      once = true;
    } else if (std::strcmp(argv[i], "--general") == 0) {
      options.lcp_basis = false;
    } else if (std::strcmp(argv[i], "--roll-only") == 0) {
      fwd_only = roll_only = true;
    } else if (std::strcmp(argv[i], "--scene") == 0 && i + 1 < argc) {
      only = argv[++i];
    } else if (std::strcmp(argv[i], "--steps") == 0 && i + 1 < argc) {
      steps = std::atoi(argv[++i]);
    } else {
      std::fprintf(
          stderr,
          "usage: sensitivity_bench [--steps N] [--quick] [--scene S] [--fwd-only] [--roll-only] "
          "[--once] [--general]\n");
      return 2;
    }
  }
  if (steps < 1) {
    std::fprintf(stderr, "sensitivity_bench: --steps must be ≥ 1\n");
    return 2;
  }
  const std::vector<Case> cases = {
      {"block_sliding.yaml", {"mu.default", "mass.block"}, 10},
      {"plate_disc_planar.yaml",
       {"mu.default", "motion.plate.x.amplitude0", "motion.plate.y.amplitude0",
        "motion.plate.x.phase0", "motion.plate.y.phase0", "mass.disc"},
       0},
      {"sphere_on_incline.yaml", {"mu.default", "mass.ball"}, 50},
      {"box_on_plane.yaml", {"mu.default", "mass.box"}, 100},
      {"disc_on_plane.yaml", {"mu.default", "mass.disc"}, 20},     // geometrically implicit
      {"box_diagonal_push.yaml", {"mu.default", "mass.box"}, 20},  // NCP (quadratic cone)
  };
  std::printf(
      "CPU time. step: Simulator::Step; fwd1: one-parameter forward step derivative "
      "(PropagateStep, 1 column); roll: fwd1 right after its step in the same workspace, as in "
      "RolloutForward (step + fwd1 - step); dθ: StepDerivatives for one parameter without the "
      "state Jacobian, right after its step in the same workspace (step + dθ - step); full: "
      "StepDerivatives with the state Jacobian; rev: "
      "RolloutReverse gradient; fd: 2p+1 rollouts; rev1, fd1: the same for the friction "
      "coefficient alone (p = 1); gen: fwd1 by the general path only "
      "(SensitivityOptions::lcp_basis off); basis%%: the window's steps whose fwd1 was taken on "
      "the step LCP's basis\n");
  std::printf(
      "%-26s %2s %5s | %9s %9s %5s %9s %5s %5s | %9s %5s | %9s %5s | %9s %6s | %8s %8s %6s | %8s "
      "%8s %6s |\n",
      "scene", "p", "N", "step(us)", "fwd1(us)", "ratio", "gen(us)", "ratio", "basis%", "roll(us)",
      "ratio", "dθ(us)", "ratio", "full(us)", "ratio", "rev(s)", "fd(s)", "ratio", "rev1(s)",
      "fd1(s)", "ratio");
  for (const Case& c : cases) {
    if (!only.empty() && std::string(c.scene).find(only) == std::string::npos) continue;
    Run(c, steps, fwd_only, once, roll_only, options);
    if (quick) break;
  }
  return 0;
}
