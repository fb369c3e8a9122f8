// lsq_jacobian_bench: least-squares Jacobians by step sensitivities vs finite differences of
// rollouts (bench/README.md, issue 15 item 3): process CPU time of one whole-episode Jacobian
// and of a whole single-shooting fit, on the tossed 5 cm cube (13 unknowns: μ and the 12
// initial-state components; 100 samples every 7th 1 ms step, 30 µm noise, as
// `estimation_study cube`) and on the planar sliding block (7 unknowns).
//
//   lsq_jacobian_bench [--quick] [--no-fit]
//
// --quick: the block only, no fit (ctest smoke). Prints one line per (scene, method).
#include <cstdio>
#include <cstring>
#include <ctime>
#include <random>
#include <sstream>
#include <string>

#include "vinci/estimation/least_squares.h"
#include "vinci/sim/model/scene_file.h"

namespace est = vinci::estimation;
namespace sim = vinci::sim;

namespace {

const char* kCube =
    "dimension: 3\n"
    "stepper: {dt: 0.001, duration: 1, friction_directions: 8, envelope: 0.002}\n"
    "friction: {default: 0.6}\n"
    "bodies:\n"
    "  - {name: table, kind: static, shapes: [{type: halfspace}]}\n"
    "  - name: cube\n    mass: 0.1\n"
    "    pose: {position: [0, 0, 0.12], rotation: {axis: [1, 1, 0], angle: 0.4}}\n"
    "    velocity: {linear: [0.8, 0.2, 0.5], angular: [3, -2, 5]}\n"
    "    shapes: [{type: box, half_extents: [0.025, 0.025, 0.025]}]\n";

const char* kBlock =
    "dimension: 2\n"
    "gravity: [0, -9.81]\n"
    "stepper: {dt: 0.002, duration: 0.6, envelope: 0.002}\n"
    "friction: {default: 0.5}\n"
    "bodies:\n"
    "  - {name: floor, kind: static, shapes: [{type: halfplane}]}\n"
    "  - name: block\n    mass: 1.0\n    pose: {position: [0, 0.1]}\n"
    "    velocity: {linear: [1.5, 0]}\n"
    "    shapes: [{type: polygon, vertices: [[-0.2, -0.1], [0.2, -0.1], [0.2, 0.1], "
    "[-0.2, 0.1]]}]\n";

// The body's logged poses (positions with noise σ, orientations with σ / 0.1 m), every
// `every` steps, `samples` samples, simulated with mu.default = mu.
est::Log MakeLog(const sim::Simulator& s, const std::string& body, double mu, int every,
                 int samples, double sigma) {
  sim::Params p = s.DefaultParams();
  p.values[s.scene().param_table().Index("mu.default")] = mu;
  const sim::Trajectory tr = s.Rollout(p, s.InitialState(), every * (samples - 1));
  std::mt19937 rng(1);
  std::normal_distribution<double> n01(0.0, 1.0);
  const bool planar = s.scene().dim == sim::Dim::kPlanar;
  const int b = s.scene().FindBody(body);
  const int qo = s.scene().index(b).q;
  est::Episode ep;
  ep.file = body;
  est::BodyTrack t;
  t.body = body;
  t.body_index = b;
  t.dynamic = true;
  t.has_orientation = true;
  t.pose = sim::MatrixXd::Zero(samples, planar ? 3 : 7);
  for (int i = 0; i < samples; ++i) {
    const sim::State& x = tr.states[static_cast<size_t>(i) * every];
    ep.t.push_back(x.t);
    ep.lines.push_back(i + 2);
    const int np = planar ? 2 : 3;
    for (int j = 0; j < np; ++j) t.pose(i, j) = x.q[qo + j] + sigma * n01(rng);
    if (planar) {
      t.pose(i, 2) = x.q[qo + 2] + sigma / 0.1 * n01(rng);
    } else {
      Eigen::Quaterniond q(x.q[qo + 3], x.q[qo + 4], x.q[qo + 5], x.q[qo + 6]);
      const Eigen::Vector3d d(n01(rng), n01(rng), n01(rng));
      q = Eigen::Quaterniond(Eigen::AngleAxisd(sigma / 0.1 * d.norm(), d.normalized())) * q;
      t.pose.row(i).tail<4>() << q.w(), q.x(), q.y(), q.z();
    }
  }
  ep.bodies.push_back(t);
  est::Log log;
  log.episodes.push_back(ep);
  return log;
}

double Cpu() { return static_cast<double>(std::clock()) / CLOCKS_PER_SEC; }

void Run(const char* name, const char* scene, const std::string& body, double mu, int every,
         int samples, double sigma, bool fit) {
  const sim::Simulator s(sim::ParseScene(scene, std::string(name) + ".yaml"));
  const est::Log log = MakeLog(s, body, mu, every, samples, sigma);
  sim::MatrixXd J[2];
  for (int m = 0; m < 2; ++m) {
    est::LeastSquaresOptions o;
    o.params = {"mu.default"};
    o.jacobian = m == 0 ? est::LeastSquaresJacobian::kSensitivity
                        : est::LeastSquaresJacobian::kFiniteDifference;
    const sim::VectorXd theta =
        s.DefaultParams().values.segment(s.scene().param_table().Index("mu.default"), 1);
    sim::VectorXd st, r;
    std::string note;
    const double t0 = Cpu();
    const bool ok =
        est::SegmentJacobian(s, log, 0, 0, samples - 1, theta, o, &st, &r, &J[m], &note);
    const double t_jac = Cpu() - t0;
    std::printf("%-6s %-11s jacobian %4ld x %2ld: %8.3f s CPU (%s)%s\n", name,
                est::ToString(o.jacobian), static_cast<long>(J[m].rows()),
                static_cast<long>(J[m].cols()), t_jac, note.c_str(), ok ? "" : " FAILED");
    if (!fit) continue;
    const double t1 = Cpu();
    const est::EstimateResult res = est::EstimateLeastSquares(s, log, o);
    std::printf("%-6s %-11s fit: mu %.5f +- %.1e (true %.2f), %d iterations, %.2f s CPU, %s\n",
                name, est::ToString(o.jacobian), res.estimates[0], res.std_errors[0], mu,
                res.iterations, Cpu() - t1, res.converged ? "converged" : res.reason.c_str());
  }
  if (J[0].size() == J[1].size() && J[1].size() > 0)
    std::printf("%-6s max |J_sens - J_fd| / max |J_fd| = %.2e\n", name,
                (J[0] - J[1]).lpNorm<Eigen::Infinity>() / J[1].lpNorm<Eigen::Infinity>());
}

}  // namespace

int main(int argc, char** argv) {
  bool quick = false, fit = true;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--quick")) {
      quick = true;
      fit = false;
    } else if (!std::strcmp(argv[i], "--no-fit")) {
      fit = false;
    } else {
      std::fprintf(stderr, "usage: lsq_jacobian_bench [--quick] [--no-fit]\n");
      return 1;
    }
  }
  Run("block", kBlock, "block", 0.3, 5, 60, 1e-3, fit);
  if (!quick) Run("cube", kCube, "cube", 0.4, 7, 100, 3e-5, fit);
  return 0;
}
