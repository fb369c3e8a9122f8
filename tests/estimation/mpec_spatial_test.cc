// The MPEC estimator (mpec_estimator.h) on spatial scenes: quaternion states, the
// quaternion-norm rows of the initial states and the linear orientation residuals
// 2 L vec(q̄_y ⊗ q). A simulated trajectory of a box sliding on a plane (4 corner contacts) and
// of a cube tossed onto a table (impacts, 8 corners) satisfies the MPEC's constraints to 1e-9.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "estimation_test_util.h"
#include "vinci/estimation/mpec_estimator.h"
#include "vinci/sim/model/scene_file.h"

namespace vinci::estimation {
namespace {

using sim::VectorXd;

// The rollout of `sim` with mu.default = mu for `steps` steps and its log: the dynamic body's
// position and orientation (quaternion) every `every`-th state, noise-free.
struct Logged {
  sim::Params params;
  sim::Trajectory rollout;
  Log log;
};

Logged SimulateAndLog(const sim::Simulator& sim, const std::string& body, double mu, int steps,
                      int every) {
  Logged out;
  out.params = sim.DefaultParams();
  out.params.values[sim.scene().param_table().Index("mu.default")] = mu;
  out.rollout = sim.Rollout(out.params, sim.InitialState(), steps);
  const int b = sim.scene().FindBody(body);
  const int qo = sim.scene().index(b).q;
  Episode ep;
  ep.file = body + ".csv";
  BodyTrack track;
  track.body = body;
  track.body_index = b;
  track.dynamic = true;
  track.has_orientation = true;
  std::vector<int> rows;
  for (int k = 0; k < static_cast<int>(out.rollout.states.size()); k += every) rows.push_back(k);
  track.pose = sim::MatrixXd::Zero(static_cast<int>(rows.size()), 7);
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const sim::State& x = out.rollout.states[rows[i]];
    ep.t.push_back(x.t);
    ep.lines.push_back(static_cast<int>(i) + 2);
    track.pose.row(static_cast<int>(i)) = x.q.segment<7>(qo).transpose();
  }
  ep.bodies.push_back(std::move(track));
  out.log.episodes.push_back(std::move(ep));
  return out;
}

// Every constraint, complementarity pair and measurement residual of `problem` vanishes at the
// unknowns mapped from the rollout.
void ExpectRolloutSatisfiesMpec(const MpecEstimationProblem& problem, const Logged& d,
                                const std::string& what) {
  const VectorXd x = problem.VariablesFromRollouts({d.rollout}, d.params);
  VectorXd g;
  ASSERT_TRUE(problem.Constraints(x, &g)) << what;
  EXPECT_LE(g.cwiseAbs().maxCoeff(), 1e-9) << what;
  double worst_pair = 0.0;
  for (const auto& [a, b] : problem.ComplementarityPairs()) {
    EXPECT_GE(x[a], -1e-9) << what;
    EXPECT_GE(x[b], -1e-9) << what;
    worst_pair = std::max(worst_pair, std::abs(std::min(x[a], x[b])));
  }
  EXPECT_LE(worst_pair, 1e-9) << what;
  double eq = 0, comp = 0;
  problem.StepViolation(x, &eq, &comp);
  EXPECT_LE(eq, 1e-9) << what;
  EXPECT_LE(comp, 1e-9) << what;
  // The orientation residuals are linear in q and vanish at q = ±q_y; positions exact.
  EXPECT_LE(problem.SquaredResiduals(x), 1e-20) << what;
  double f = 0;
  ASSERT_TRUE(problem.Objective(x, &f));
  EXPECT_LE(f, 1e-12) << what;
  VectorXd jv;
  EXPECT_TRUE(problem.JacobianValues(x, &jv)) << what;
  EXPECT_EQ(problem.dropped_jacobian(), 0.0) << what;
}

TEST(MpecSpatial, SlidingBoxTrajectorySatisfiesConstraints) {
  const sim::Simulator sim(sim::ParseScene(testing::kSpatialBox, "box.yaml"));
  // 0.5 s: sliding on its 4 bottom corners, then at rest (stops at 1.2 / (0.3 g) ≈ 0.41 s).
  const Logged d = SimulateAndLog(sim, "box", 0.3, 250, 1);
  ASSERT_TRUE(d.rollout.ok) << d.rollout.failure;
  MpecOptions o;
  o.params = {"mu.default"};
  o.contact_margin = 0.0;  // the simulator's own contact sets
  const MpecEstimationProblem problem(sim, d.log, o, 1e-3);
  EXPECT_EQ(problem.num_steps(), 250);
  ExpectRolloutSatisfiesMpec(problem, d, "box");
  // Changing μ by 0.1 breaks the sliding steps' friction rows μ p_n − Σ β by 0.1 p_n per corner,
  // p_n ≈ m g h / 4 (1 kg, h = 2 ms).
  const VectorXd x = problem.VariablesFromRollouts({d.rollout}, d.params);
  VectorXd x2 = x, g;
  x2[0] = 0.4;
  ASSERT_TRUE(problem.Constraints(x2, &g));
  EXPECT_GT(g.cwiseAbs().maxCoeff(), 0.5 * 0.1 * 9.81 * 0.002 / 4);
}

TEST(MpecSpatial, TossedCubeTrajectorySatisfiesConstraints) {
  const sim::Simulator sim(sim::ParseScene(testing::kTossedCube, "cube.yaml"));
  // 0.45 s: flight, impacts on edges and corners, sliding and tumbling.
  const Logged d = SimulateAndLog(sim, "cube", 0.4, 450, 1);
  ASSERT_TRUE(d.rollout.ok) << d.rollout.failure;
  // The toss lands: some state has the cube on the table.
  double z_min = 1.0;
  for (const sim::State& s : d.rollout.states) z_min = std::min(z_min, s.q[2]);
  EXPECT_LT(z_min, 0.04);
  MpecOptions o;
  o.params = {"mu.default"};
  o.contact_margin = 0.0;
  const MpecEstimationProblem problem(sim, d.log, o, 3e-5);
  EXPECT_EQ(problem.num_steps(), 450);
  ExpectRolloutSatisfiesMpec(problem, d, "cube");
}

}  // namespace
}  // namespace vinci::estimation
