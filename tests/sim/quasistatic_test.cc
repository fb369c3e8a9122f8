// Quasistatic Model-DLC / Model-DQC (docs/formulations.md §5): fence–particle against its closed
// form, DLC's direction error against n_d, Mason's voting theorem, and the Evaluate() face.
#include "vinci/sim/formulations/quasistatic.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "test_util.h"

namespace vinci::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;

// The fence–particle scene with fence speed |v_F| at angle beta from the fence normal (+x),
// fence friction mu_f, and the given formulation and support n_d.
Scene FenceParticle(double beta, double mu_f, FormulationType type, int nd) {
  Scene s = testing::LoadExample("fence_particle.yaml");
  const double speed = 0.1;
  Body& fence = s.bodies[s.FindBody("fence")];
  fence.motion.dofs[0].velocity = speed * std::cos(beta);
  fence.motion.dofs[1].velocity = speed * std::sin(beta);
  s.default_mu = mu_f;
  s.options.formulation = type;
  s.bodies[s.FindBody("particle")].support.directions = nd;
  return s;
}

// The particle's velocity over the last of `steps` steps (steady sliding or sticking).
Vector3d FenceParticleVelocity(const Scene& scene, int steps = 10) {
  Simulator sim(scene);
  const Trajectory tr = sim.Rollout(sim.DefaultParams(), sim.InitialState(), steps);
  EXPECT_TRUE(tr.ok) << tr.failure << " at step " << tr.steps.size();
  return tr.ok ? Vector3d(tr.states.back().v) : Vector3d::Constant(NAN);
}

// The closed form: stick (v = v_F) when tan β ≤ μ_f, otherwise v = (v_F·n)(1, μ_f).
Vector2d FenceParticleExact(double beta, double mu_f) {
  const double speed = 0.1;
  if (std::tan(beta) <= mu_f) return speed * Vector2d(std::cos(beta), std::sin(beta));
  return speed * std::cos(beta) * Vector2d(1.0, mu_f);
}

// DQC solves the exact disk: only the MCP tolerance (1e-10) and the vanishing-inertia
// regularization (1e-10 relative) separate it from the closed form.
constexpr double kDqcVelocityTol = 1e-8;

TEST(QuasistaticFenceParticle, DqcMatchesTheClosedForm) {
  for (double mu_f : {0.3, 0.8}) {
    for (double beta_deg : {0.0, 10.0, 30.0, 45.0, 60.0, 75.0}) {
      const double beta = beta_deg * kPi / 180;
      const Vector3d v =
          FenceParticleVelocity(FenceParticle(beta, mu_f, FormulationType::kQuasistaticDqc, 16));
      const Vector2d exact = FenceParticleExact(beta, mu_f);
      EXPECT_LT((v.head<2>() - exact).norm(), kDqcVelocityTol * 0.1)
          << "mu_f " << mu_f << " beta " << beta_deg << " v " << v.transpose();
      EXPECT_LT(std::abs(v.z()), kDqcVelocityTol) << "spin";
      // Sliding speed |v| = (v_F·n)/cos(atan μ_f).
      if (std::tan(beta) > mu_f) {
        EXPECT_NEAR(v.head<2>().norm(), 0.1 * std::cos(beta) / std::cos(std::atan(mu_f)),
                    kDqcVelocityTol * 0.1);
      }
    }
  }
}

// Worst and mean direction error of DLC over a sweep of fence friction coefficients, cone
// half-angles atan μ_f from 2° to 44° (sliding regime; μ_f < 1 keeps the square from tipping).
std::pair<double, double> DlcDirectionError(int nd) {
  const double beta = 75.0 * kPi / 180;  // tan β = 3.73 > every μ_f below: always sliding
  double worst = 0.0, sum = 0.0;
  const int n = 24;
  for (int i = 0; i < n; ++i) {
    const double mu_f = std::tan((2.0 + 42.0 * i / (n - 1)) * kPi / 180);
    const Vector3d v =
        FenceParticleVelocity(FenceParticle(beta, mu_f, FormulationType::kQuasistaticDlc, nd));
    const double err = std::abs(std::atan2(v.y(), v.x()) - std::atan(mu_f));
    worst = std::max(worst, err);
    sum += err;
  }
  return {worst, sum / n};
}

TEST(QuasistaticFenceParticle, DlcDirectionErrorShrinksWithDirections) {
  double previous_worst = INFINITY, previous_mean = INFINITY;
  for (int nd : {4, 8, 16, 32, 64}) {
    const auto [worst, mean] = DlcDirectionError(nd);
    // The particle slides along a face normal of the linearized disk, at most π/n_d from any
    // direction inside the face: the bound of §5 (plus solver rounding).
    EXPECT_LE(worst, kPi / nd + 1e-9) << "n_d " << nd;
    EXPECT_LT(worst, previous_worst) << "n_d " << nd;
    EXPECT_LT(mean, previous_mean) << "n_d " << nd;
    previous_worst = worst;
    previous_mean = mean;
  }
}

TEST(Quasistatic, RejectsSpatialScenes) {
  // Rejected when the scene is finalized (loading or building a Simulator), never stepped.
  Scene s = testing::LoadExample("ball_drop.yaml");
  s.options.formulation = FormulationType::kQuasistaticDqc;
  try {
    Simulator sim(s);
    ADD_FAILURE() << "a spatial quasistatic scene was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("need a planar scene"), std::string::npos) << e.what();
  }
}

// Mason's voting theorem (Mason, IJRR 5(3), 1986): for a point pusher, the two edges of the
// contact friction cone and the pushing direction each vote for a sense of rotation by their
// moment about the centre of friction (here the centre of mass: static loads); the slider
// rotates in the sense of the majority.
// Counts of the 100 pushes: rotation in the predicted sense, in the opposite sense, none.
struct Votes {
  int agree = 0, wrong = 0, still = 0;
};

Votes VotingTheorem(FormulationType type) {
  SCOPED_TRACE(type == FormulationType::kQuasistaticDqc ? "quasistatic-dqc" : "quasistatic-dlc");
  std::mt19937 rng(20261122);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  const Scene base = testing::LoadExample("planar_pushing.yaml");
  const int pusher = base.FindBody("pusher");
  const Vector2d c0(0.0, 0.0);  // slider COM = centre of friction
  Votes votes;
  int trials = 0;
  while (trials < 100) {
    const double x_c = -0.07 + 0.14 * U(rng);  // contact point on the edge y = −0.06
    const double phi = (-60.0 + 120.0 * U(rng)) * kPi / 180;  // push direction from +y
    const double mu_c = 0.1 + 0.9 * U(rng);
    const Vector2d p(x_c, -0.06), n(0.0, 1.0);
    const Vector2d d(-std::sin(phi), std::cos(phi));
    const double a = std::atan(mu_c);
    const Vector2d left(-std::sin(a), std::cos(a)), right(std::sin(a), std::cos(a));
    const auto moment = [&](const Vector2d& dir) { return Cross2(p - c0, dir); };
    // Skip near-ties (a voter whose line passes within 2 mm of the centre).
    const double m_l = moment(left), m_r = moment(right), m_d = moment(d);
    if (std::min({std::abs(m_l), std::abs(m_r), std::abs(m_d)}) < 2e-3) continue;
    const int ccw = (m_l > 0) + (m_r > 0) + (m_d > 0);
    const double expected_sign = ccw >= 2 ? 1.0 : -1.0;
    Scene s = base;
    s.options.formulation = type;
    s.default_mu = mu_c;
    Body& b = s.bodies[pusher];
    b.X_WB0 = PlanarPose(x_c, -0.065, 0.0);
    b.motion.dofs[0].velocity = 0.05 * d.x();
    b.motion.dofs[1].velocity = 0.05 * d.y();
    Simulator sim(s);
    const Trajectory tr = sim.Rollout(sim.DefaultParams(), sim.InitialState(), 4);
    EXPECT_TRUE(tr.ok) << tr.failure;
    if (!tr.ok) return votes;
    const double theta = tr.states.back().q[2];
    ++trials;
    if (theta * expected_sign > 0) {
      ++votes.agree;
    } else {
      ++(theta == 0.0 ? votes.still : votes.wrong);
      std::printf("[ note ] x_c %.4f phi %.4f mu %.4f: theta %g\n", x_c, phi, mu_c, theta);
    }
  }
  return votes;
}

TEST(QuasistaticPushing, VotingTheoremHoldsFor100RandomPushes) {
  // DQC (exact support disks): every push rotates the slider in the predicted sense.
  const Votes dqc = VotingTheorem(FormulationType::kQuasistaticDqc);
  EXPECT_EQ(dqc.agree, 100);
  // DLC never rotates it the wrong way, but its linearized disks can absorb a small moment in
  // pure translation (all support forces on one face of the polygon, whose points give a range
  // of moments), so a push whose moment is small may translate the slider without turning it.
  const Votes dlc = VotingTheorem(FormulationType::kQuasistaticDlc);
  EXPECT_EQ(dlc.wrong, 0);
  EXPECT_LE(dlc.still, 2);
  EXPECT_EQ(dlc.agree + dlc.still, 100);
}

// The step equations hold at the simulated step (both models).
constexpr double kResidualTol = 1e-9;

TEST(Quasistatic, SimulatedStepSatisfiesTheStepEquations) {
  for (FormulationType type :
       {FormulationType::kQuasistaticDlc, FormulationType::kQuasistaticDqc}) {
    Scene s = testing::LoadExample("planar_pushing.yaml");
    s.options.formulation = type;
    Simulator sim(s);
    const Trajectory tr = sim.Rollout(sim.DefaultParams(), sim.InitialState(), 3);
    ASSERT_TRUE(tr.ok) << tr.failure;
    const State& x = tr.states[1];
    const State& next = tr.states[2];
    const Formulation& f = sim.formulation();
    const StepLayout l = f.Layout(sim.scene(), x);
    EXPECT_EQ(l.ns, 4);
    EXPECT_EQ(l.nps, type == FormulationType::kQuasistaticDqc ? 8 : 64);
    ASSERT_GT(l.nc, 0);
    VectorXd z(l.size());
    z << next.q, next.warm_start;
    const StepResiduals r = f.Evaluate(sim.scene(), sim.DefaultParams(), x, {}, z);
    EXPECT_LT(r.Violation(), kResidualTol) << f.name();
    for (int j = 0; j < l.size(); ++j) {
      VectorXd zp = z, zm = z;
      zp[j] += 1e-6;
      zm[j] -= 1e-6;
      const StepResiduals rp = f.Evaluate(sim.scene(), sim.DefaultParams(), x, {}, zp);
      const StepResiduals rm = f.Evaluate(sim.scene(), sim.DefaultParams(), x, {}, zm);
      EXPECT_LT(((rp.comp_b - rm.comp_b) / 2e-6 - r.d_comp_b.col(j)).norm(), 1e-5) << j;
      EXPECT_LT(((rp.equality - rm.equality) / 2e-6 - r.d_equality.col(j)).norm(), 1e-5) << j;
    }
    // Parameter columns (friction coefficients, masses) against central differences.
    for (std::size_t c = 0; c < r.param_columns.size(); ++c) {
      const int i = r.param_columns[c];
      Params pp = sim.DefaultParams(), pm = pp;
      const double d = 1e-6 * std::max(1.0, std::abs(pp.values[i]));
      pp.values[i] += d;
      pm.values[i] -= d;
      const StepResiduals rp = f.Evaluate(sim.scene().ApplyParams(pp), pp, x, {}, z);
      const StepResiduals rm = f.Evaluate(sim.scene().ApplyParams(pm), pm, x, {}, z);
      const int col = l.size() + static_cast<int>(c);
      EXPECT_LT(((rp.comp_b - rm.comp_b) / (2 * d) - r.d_comp_b.col(col)).norm(), 1e-5)
          << sim.scene().param_table().info(i).name;
      EXPECT_LT(((rp.equality - rm.equality) / (2 * d) - r.d_equality.col(col)).norm(), 1e-5)
          << sim.scene().param_table().info(i).name;
    }
  }
}

}  // namespace
}  // namespace vinci::sim
