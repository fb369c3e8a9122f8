// The MPEC estimator's problem assembly: the grid, the frozen step models, the unknowns, their
// scales and initial guess, the measurement rows, and the Jacobian and Hessian structures
// (mpec_estimator.h).
#include <cmath>
#include <limits>
#include <random>
#include <sstream>
#include <stdexcept>
#include <utility>

#include "estimation_internal.h"
#include "log_smoothing.h"
#include "mpec_problem.h"
#include "vinci/sim/model/state_util.h"

namespace vinci::estimation {

using mpec_internal::kDefaultSigma;
using mpec_internal::kInf;
using mpec_internal::ParallelFor;
using mpec_internal::ResidualRow;
using mpec_internal::StepBlock;
using sim::Params;
using sim::State;
using sim::VectorXd;

using internal::LoggedQuaternion;
using internal::RotationLog;

LeastSquaresOptions mpec_internal::StartFitOptions(const MpecOptions& o) {
  LeastSquaresOptions lo;
  lo.params = o.params;
  lo.noise_sigma = o.noise_sigma;
  lo.threads = o.threads;
  lo.orientation_length = o.orientation_length;
  lo.max_iterations = o.least_squares_iterations;
  lo.horizon_samples = o.least_squares_horizon;
  lo.horizon_growth = o.least_squares_horizon_growth;
  lo.horizon_refinement = false;  // a rough fit; EstimateFromLeastSquares refits carefully
  lo.episode_restarts = false;    // likewise
  return lo;
}

void MpecOptions::Validate() const {
  auto fail = [](const std::string& field, double v, const std::string& expected) {
    std::ostringstream m;
    m << "mpec: " << field << " = " << v << ", expected " << expected;
    throw std::invalid_argument(m.str());
  };
  if (params.empty()) throw std::invalid_argument("mpec: no parameter to estimate");
  if (!(noise_sigma >= 0) || !std::isfinite(noise_sigma)) fail("noise", noise_sigma, "finite ≥ 0");
  if (!std::isfinite(process_noise)) fail("process_noise", process_noise, "finite");
  if (!(orientation_length > 0) || !std::isfinite(orientation_length))
    fail("orientation_length", orientation_length, "finite > 0");
  if (threads < 1) fail("threads", threads, "≥ 1");
  if (bootstrap < 0) fail("bootstrap", bootstrap, "≥ 0");
  if (!std::isfinite(contact_margin)) fail("contact_margin", contact_margin, "finite");
  if (substeps < 0) fail("substeps", substeps, "≥ 0 (0: the scene's dt)");
  if (start_theta.size() > 0 || !start_states.empty()) {
    if (start_theta.size() != static_cast<Eigen::Index>(params.size()) || start_states.empty())
      throw std::invalid_argument(
          "mpec: start_theta needs one value per parameter and start_states one state per "
          "episode (or both empty)");
    if (!start_theta.allFinite()) throw std::invalid_argument("mpec: start_theta not finite");
  }
  if (start_polish_iterations < 0) fail("start_polish_iterations", start_polish_iterations, "≥ 0");
  if (!(start_max_relative_std_error > 0))
    fail("start_max_relative_std_error", start_max_relative_std_error, "> 0 (+∞: no test)");
  if (least_squares_start) {
    if (episodes == MpecEpisodes::kDecomposed)
      throw std::invalid_argument("mpec: least_squares_start is not for decomposed episodes");
    if (!(noise_sigma > 0))
      throw std::invalid_argument(
          "mpec: least_squares_start needs a stated noise (its solution is accepted by its χ²)");
    try {
      mpec_internal::StartFitOptions(*this).Validate();
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(std::string("mpec: least_squares_start: ") + e.what());
    }
  }
  solver.Validate();
}

void MpecEstimationProblem::Impl::Build(const Log& log) {
  internal::CheckDifferentiable(scene, opts.params);
  if (scene.options.formulation == sim::FormulationType::kGeometricallyImplicit) {
    // Its contact points at ℓ+1 are step unknowns whose pairs the frozen contact sets of the
    // guess do not follow: on a planar rolling disc's log the first relaxation stage ran 3 000
    // Ipopt iterations twice without converging, where the Stewart–Trinkle model of the same
    // scene converges in ~200.
    throw std::invalid_argument(
        "mpec: the scene's stepper formulation is gi (geometrically implicit), which the MPEC "
        "estimator does not support; set `stepper: {formulation: stewart-trinkle}` in the scene "
        "for the estimation, or use --method lsq or filter");
  }
  if (log.episodes.empty()) throw std::invalid_argument("no log episode");
  const bool planar = scene.dim == sim::Dim::kPlanar;
  {
    std::vector<int> own;
    for (const Episode& ep : log.episodes) {
      int k = 0;
      for (const BodyTrack& b : ep.bodies) k += b.dynamic;
      own.push_back(k * (planar ? 6 : 12));
    }
    CheckEnoughSamples(log, scene.dim, sel.size(), own);
  }
  base = sim.DefaultParams();
  const bool simulated = !opts.start_states.empty();
  if (simulated) {
    if (opts.start_states.size() != log.episodes.size())
      throw std::invalid_argument(
          "mpec: start_states: " + std::to_string(opts.start_states.size()) + " states for " +
          std::to_string(log.episodes.size()) + " episodes");
    VectorXd th = opts.start_theta;
    for (int i = 0; i < sel.size(); ++i) th[i] = std::clamp(th[i], sel.lower()[i], sel.upper()[i]);
    base = sel.Set(base, th);
  }
  model_dt = std::make_shared<const sim::Scene>(scene.ApplyParams(base));
  ntheta = sel.size();
  nq = scene.num_positions();
  nv = scene.num_velocities();
  nx = nq + nv;
  sigma_q = opts.process_noise;
  if (!(sigma_q > 0)) {
    double m_min = std::numeric_limits<double>::infinity();
    for (int b : scene.dynamic_bodies()) m_min = std::min(m_min, scene.bodies[b].mass);
    if (!std::isfinite(m_min)) m_min = 1.0;
    const double g = scene.gravity_W.norm();
    sigma_q = 0.01 * m_min * (g > 0 ? g : 1.0);
  }
  margin = opts.contact_margin >= 0 ? opts.contact_margin : 3 * sigma;
  num_episodes = static_cast<int>(log.episodes.size());
  const double dt = scene.options.dt;
  const double L = opts.orientation_length;

  n = ntheta;
  std::vector<double> xl(ntheta), xu(ntheta), x0(ntheta), sc(ntheta, 1.0);
  for (int i = 0; i < ntheta; ++i) {
    xl[i] = sel.lower()[i];
    xu[i] = sel.upper()[i];
    x0[i] = sel.Get(base)[i];
  }
  auto add_vars = [&](int count, double lo, double hi, double var_scale = 1.0) {
    const int c = n;
    n += count;
    xl.resize(n, lo);
    xu.resize(n, hi);
    x0.resize(n, 0.0);
    sc.resize(n, var_scale);
    return c;
  };
  // Scales of the unknowns (the solver works on x / scale, so that the Scholtes products
  // x_a x_b ≤ ε and the polish's choice of the zero side compare like with like): impulses of
  // a step of h: m_min max(|g|, 1 m/s²) h, the weight impulse of the lightest body; process
  // noise: σ_Q; states, velocities, sliding speeds: 1; slacks: the magnitude of their row,
  // max_j |∂c/∂z_j| scale_j over the step unknowns at the guess.
  double m_min = std::numeric_limits<double>::infinity();
  for (int b : scene.dynamic_bodies()) m_min = std::min(m_min, scene.bodies[b].mass);
  if (!std::isfinite(m_min)) m_min = 1.0;
  const double g_ref = std::max(scene.gravity_W.norm(), 1.0);
  std::mt19937 rng(12345);
  for (int e = 0; e < num_episodes; ++e) {
    const Episode& ep = log.episodes[e];
    // The guessed poses come from the log smoothed by local quadratic fits (its noise estimated
    // from the data; an exact log is used as is): raw noisy poses make the guessed velocities'
    // noise √2 σ / Δt (0.7 m/s for 1 mm at 2 ms) and the guess far from every step's dynamics.
    const Episode smooth = opts.smooth_initial_guess ? internal::SmoothedEpisode(ep, planar) : ep;
    // The grid.
    std::vector<double> T{ep.t[0]};
    std::vector<int> sample_node{0};
    std::vector<double> step_h;
    for (int i = 0; i + 1 < ep.num_samples(); ++i) {
      const double span = ep.t[i + 1] - ep.t[i];
      const int ni =
          opts.substeps > 0 ? opts.substeps : std::max(1, static_cast<int>(std::lround(span / dt)));
      double h = span / ni;
      if (std::abs(h - dt) <= 1e-9 * dt) h = dt;
      for (int j = 1; j <= ni; ++j) {
        T.push_back(j == ni ? ep.t[i + 1] : ep.t[i] + j * h);
        step_h.push_back(h);
      }
      sample_node.push_back(static_cast<int>(T.size()) - 1);
    }
    const int nodes = static_cast<int>(T.size());
    // Guessed states: measured poses interpolated between samples.
    std::vector<State> guess(nodes, sim.InitialState());
    for (int l = 0; l < nodes; ++l) {
      guess[l].t = T[l];
      guess[l].warm_start.resize(0);
    }
    auto set_pose = [&](int l, int i, int j, double a) {
      for (const BodyTrack& b : smooth.bodies) {
        if (!b.dynamic) continue;
        if (planar) {
          const Eigen::Vector3d p = (1 - a) * b.pose.row(i).head<3>().transpose() +
                                    a * b.pose.row(j).head<3>().transpose();
          const double th = b.has_orientation ? p[2] : guess[l].q[scene.index(b.body_index).q + 2];
          sim::SetPlanarBodyPose(scene, b.body, p[0], p[1], th, &guess[l]);
        } else {
          Eigen::Isometry3d X = sim::GetBodyKinematics(scene, guess[l], b.body).X_WB;
          X.translation() = (1 - a) * b.pose.row(i).head<3>().transpose() +
                            a * b.pose.row(j).head<3>().transpose();
          if (b.has_orientation) {
            X.linear() = LoggedQuaternion(b, i).slerp(a, LoggedQuaternion(b, j)).toRotationMatrix();
          }
          sim::SetBodyPose(scene, b.body, X, &guess[l]);
        }
      }
    };
    set_pose(0, 0, 0, 0.0);
    for (int i = 0; i + 1 < ep.num_samples(); ++i) {
      const int l0 = sample_node[i], l1 = sample_node[i + 1];
      for (int l = l0 + 1; l <= l1; ++l) set_pose(l, i, i + 1, (T[l] - T[l0]) / (T[l1] - T[l0]));
    }
    // Velocities: backward differences (ν_ℓ+1 = (q_ℓ+1 − q_ℓ)/h); ν_0 = ν_1.
    for (int l = 1; l < nodes; ++l) {
      const double h = T[l] - T[l - 1];
      for (const BodyTrack& b : ep.bodies) {
        if (!b.dynamic) continue;
        const sim::BodyIndex& ix = scene.index(b.body_index);
        if (planar) {
          guess[l].v.segment<3>(ix.v) =
              (guess[l].q.segment<3>(ix.q) - guess[l - 1].q.segment<3>(ix.q)) / h;
        } else {
          guess[l].v.segment<3>(ix.v) =
              (guess[l].q.segment<3>(ix.q) - guess[l - 1].q.segment<3>(ix.q)) / h;
          const Eigen::Quaterniond q0(guess[l - 1].q[ix.q + 3], guess[l - 1].q[ix.q + 4],
                                      guess[l - 1].q[ix.q + 5], guess[l - 1].q[ix.q + 6]);
          const Eigen::Quaterniond q1(guess[l].q[ix.q + 3], guess[l].q[ix.q + 4],
                                      guess[l].q[ix.q + 5], guess[l].q[ix.q + 6]);
          guess[l].v.segment<3>(ix.v + 3) = RotationLog(q0.conjugate() * q1) / h;
        }
      }
    }
    if (nodes > 1) {
      for (const BodyTrack& b : ep.bodies) {
        if (!b.dynamic) continue;
        const sim::BodyIndex& ix = scene.index(b.body_index);
        guess[0].v.segment(ix.v, planar ? 3 : 6) = guess[1].v.segment(ix.v, planar ? 3 : 6);
      }
    }
    if (simulated) RolloutGuess(opts.start_states[e], step_h, &guess);
    const std::vector<VectorXd> w_guess =
        opts.tracking_guess && !simulated ? TrackGuess(ep, step_h, &guess)
                                          : std::vector<VectorXd>(nodes - 1, VectorXd::Zero(nv));

    // Variables and step blocks.
    x0_col.push_back(add_vars(nx, -kInf, kInf));
    for (int i = 0; i < nx; ++i)
      x0[x0_col.back() + i] = i < nq ? guess[0].q[i] : guess[0].v[i - nq];
    node_t.push_back(T);
    node_col.push_back({x0_col.back()});
    for (int l = 0; l + 1 < nodes; ++l) {
      StepBlock blk;
      blk.episode = e;
      blk.t = T[l];
      std::shared_ptr<const sim::Scene> model;
      const sim::Formulation& form = FormulationFor(step_h[l], &model);
      blk.model = sim::Freeze(form, model, base, guess[l]);
      blk.nz = blk.model->layout().size();
      const int nxl = blk.model->layout().nq + blk.model->layout().nv;
      // The MPEC chains z_ℓ's head as x_ℓ+1: the step unknowns must start with the next state.
      {
        VectorXd zt(blk.nz);
        for (int i = 0; i < blk.nz; ++i) zt[i] = 0.1 + 0.01 * i;
        const State s = blk.model->StateFromUnknowns(zt);
        if (nxl != nx || s.q.size() != nq || s.v.size() != nv || s.q != zt.head(nq) ||
            s.v != zt.segment(nq, nv)) {
          throw std::invalid_argument(
              "mpec: formulation " + std::string(form.name()) +
              ": its step unknowns do not start with the next state (q, ν); the MPEC estimator "
              "supports Stewart–Trinkle, Anitescu–Potra, first order, NCP and quasistatic");
        }
      }
      blk.x_col = node_col.back().back();
      blk.z_col = add_vars(blk.nz, -kInf, kInf);
      node_col.back().push_back(blk.z_col);
      blk.w_col = add_vars(nv, -kInf, kInf, sigma_q);
      for (int i = 0; i < nv; ++i) x0[blk.w_col + i] = w_guess[l][i];
      {
        const sim::StepLayout& lay = blk.model->layout();
        const double impulse = m_min * g_ref * step_h[l];
        for (int i = lay.pn(); i < lay.sigma(); ++i) sc[blk.z_col + i] = impulse;
        for (int i = lay.pb(); i < lay.sigma_s(); ++i) sc[blk.z_col + i] = impulse;
      }
      w_cols.push_back(blk.w_col);
      // Guess of z: a simulator step from the guessed state, next state from the guess.
      VectorXd z = VectorXd::Zero(blk.nz);
      {
        sim::Workspace ws;
        State next;
        sim::StepInfo info;
        sim::StepInput u;
        u.generalized_force = w_guess[l];
        form.Step(*model, guess[l], u, &ws, &next, &info);
        if (info.ok) {
          try {
            z = blk.model->UnknownsFromStep(next);
          } catch (const std::invalid_argument&) {
            z.setZero();
          }
        }
      }
      z.head(nq) = guess[l + 1].q;
      z.segment(nq, nv) = guess[l + 1].v;
      blk.z_guess = z;
      for (int i = 0; i < blk.nz; ++i) x0[blk.z_col + i] = z[i];
      // θ columns.
      const std::vector<int>& pc = blk.model->param_columns();
      blk.theta_map.assign(pc.size(), -1);
      for (std::size_t c = 0; c < pc.size(); ++c)
        for (int k = 0; k < ntheta; ++k)
          if (sel.indices()[k] == pc[c]) blk.theta_map[c] = k;
      // Which comp rows are single unknowns (row = z_j)? Decided on the union of the entries
      // at the guess and at two perturbed points, which is also the block's structure.
      std::vector<sim::StepModelValues> evals;
      {
        VectorXd xs = VectorXd::Zero(n);
        for (int i = 0; i < n; ++i) xs[i] = x0[i];
        const Params th = Theta(xs);
        sim::StepInput u;
        u.generalized_force = VectorXd::Zero(nv);
        const State xg = guess[l];
        evals.push_back(blk.model->Evaluate(z, th, xg, u));
        std::normal_distribution<double> nd(0.0, 1.0);
        for (int r = 0; r < 4; ++r) {
          VectorXd zp = z;
          for (int i = 0; i < zp.size(); ++i) zp[i] += 0.1 * nd(rng);
          State xp = xg;
          for (int i = 0; i < nq; ++i) xp.q[i] += 1e-4 * nd(rng);
          for (int i = 0; i < nv; ++i) xp.v[i] += 0.1 * nd(rng);
          Params tp = th;
          for (int k = 0; k < ntheta; ++k) {
            const int pi = sel.indices()[k];
            tp.values[pi] = std::clamp(tp.values[pi] * (1 + 0.1 * std::abs(nd(rng))),
                                       sel.lower()[k], sel.upper()[k]);
          }
          sim::StepInput up;
          up.generalized_force = VectorXd::Zero(nv);
          for (int i = 0; i < nv; ++i) up.generalized_force[i] = nd(rng);
          evals.push_back(blk.model->Evaluate(zp, tp, xp, up));
        }
      }
      const sim::StepModelValues& v0 = evals[0];
      blk.neq = static_cast<int>(v0.equality.size());
      const int np = static_cast<int>(v0.comp_a.size());
      auto single_var = [&](const sim::StepModelJacobian& J0, int r, bool side_a) -> int {
        int col = -1;
        for (const sim::StepModelValues& v : evals) {
          const sim::StepModelJacobian& J = side_a ? v.d_comp_a : v.d_comp_b;
          auto count = [&](const sim::SparseMatrixXd& M, bool is_z) {
            for (int c = 0; c < M.outerSize(); ++c) {
              for (sim::SparseMatrixXd::InnerIterator it(M, c); it; ++it) {
                if (it.row() != r || it.value() == 0.0) continue;
                if (!is_z || it.value() != 1.0 || (col >= 0 && col != c)) return false;
                col = c;
              }
            }
            return true;
          };
          if (!count(J.d_z, true) || !count(J.d_theta, false) || !count(J.d_x, false) ||
              !count(J.d_u, false))
            return -1;
        }
        (void)J0;
        if (col < 0) return -1;
        const double val = side_a ? v0.comp_a[r] : v0.comp_b[r];
        return std::abs(val - z[col]) <= 1e-12 * (1 + std::abs(z[col])) ? col : -1;
      };
      blk.a_slack.assign(np, -1);
      blk.b_slack.assign(np, -1);
      blk.a_var.assign(np, -1);
      blk.b_var.assign(np, -1);
      for (int r = 0; r < np; ++r) {
        const int ca = single_var(v0.d_comp_a, r, true);
        if (ca >= 0) {
          blk.a_var[r] = blk.z_col + ca;
        } else {
          blk.a_slack[r] = blk.ns++;
        }
        const int cb = single_var(v0.d_comp_b, r, false);
        if (cb >= 0) {
          blk.b_var[r] = blk.z_col + cb;
        } else {
          blk.b_slack[r] = blk.ns++;
        }
      }
      blk.s_col = add_vars(blk.ns, 0.0, kInf);
      {
        std::vector<double> row_scale(blk.ns, 0.0);
        ForEachEntry(blk, v0, [&](int lr, int lc, double val) {
          if (lr < blk.neq || lc >= blk.nz) return;  // slack rows, z columns
          double& rs = row_scale[lr - blk.neq];
          rs = std::max(rs, std::abs(val) * sc[blk.z_col + lc]);
        });
        for (int k = 0; k < blk.ns; ++k) sc[blk.s_col + k] = row_scale[k] > 0 ? row_scale[k] : 1.0;
      }
      for (int r = 0; r < np; ++r) {
        if (blk.a_slack[r] >= 0) {
          blk.a_var[r] = blk.s_col + blk.a_slack[r];
          x0[blk.a_var[r]] = std::max(0.0, v0.comp_a[r]);
        }
        if (blk.b_slack[r] >= 0) {
          blk.b_var[r] = blk.s_col + blk.b_slack[r];
          x0[blk.b_var[r]] = std::max(0.0, v0.comp_b[r]);
        }
        pairs.emplace_back(blk.a_var[r], blk.b_var[r]);
      }
      // Structure: every row × the θ columns (dense: θ enters through the parameters), plus
      // the entries of the five evaluations at random points (z, θ, x_ℓ, u all perturbed: an
      // entry of the formulation's dense z / u block that vanishes at all of them is a
      // structural zero of its assembly). The x_ℓ block is a central difference of the frozen
      // equations: its structural zeros come out as rounding noise ~1e-16 |row| / 1e-7, so an
      // x_ℓ entry counts when above kStateJacobianNoise at some point (Jacobian test).
      for (const sim::StepModelValues& v : evals) {
        ForEachEntry(blk, v, [&](int lr, int lc, double val) {
          if (IsStateColumn(blk, lc) && std::abs(val) <= mpec_internal::kStateJacobianNoise) return;
          blk.keys.push_back(Key(blk, lr, lc));
        });
      }
      for (int lr = 0; lr < blk.neq + blk.ns; ++lr)
        for (int k = 0; k < ntheta; ++k) blk.keys.push_back(Key(blk, lr, blk.nz + k));
      std::sort(blk.keys.begin(), blk.keys.end());
      blk.keys.erase(std::unique(blk.keys.begin(), blk.keys.end()), blk.keys.end());
      blk.row = m;
      m += blk.neq + blk.ns;
      steps.push_back(std::move(blk));
    }
    // Measurement residuals at the sample nodes.
    for (int i = 0; i < ep.num_samples(); ++i) {
      const int col = node_col.back()[sample_node[i]];
      const State& g = guess[sample_node[i]];
      for (const BodyTrack& b : ep.bodies) {
        if (!b.dynamic) continue;
        const int qo = col + scene.index(b.body_index).q;
        for (int k = 0; k < (planar ? 2 : 3); ++k) {
          ResidualRow r;
          r.episode = e;
          r.n = 1;
          r.col[0] = qo + k;
          r.coef[0] = 1.0;
          r.y = b.pose(i, k);
          residuals.push_back(r);
        }
        if (!b.has_orientation) continue;
        if (planar) {
          ResidualRow r;
          r.episode = e;
          r.n = 1;
          r.col[0] = qo + 2;
          r.coef[0] = L;
          r.y = L * b.pose(i, 2);
          residuals.push_back(r);
        } else {
          // 2 L vec(q̄_y ⊗ q) = 2 L (w_y q_v − q_w v_y − v_y × q_v), sign of q_y chosen near q.
          Eigen::Vector4d qy(b.pose(i, 3), b.pose(i, 4), b.pose(i, 5), b.pose(i, 6));
          qy.normalize();
          if (qy.dot(g.q.segment<4>(scene.index(b.body_index).q + 3)) < 0) qy = -qy;
          const double wy = qy[0];
          const Eigen::Vector3d vy = qy.tail<3>();
          Eigen::Matrix<double, 3, 4> M;
          M.col(0) = -vy;
          Eigen::Matrix3d S;
          S << 0, -vy.z(), vy.y(), vy.z(), 0, -vy.x(), -vy.y(), vy.x(), 0;
          M.rightCols<3>() = wy * Eigen::Matrix3d::Identity() - S;
          for (int k = 0; k < 3; ++k) {
            ResidualRow r;
            r.episode = e;
            r.n = 4;
            for (int j = 0; j < 4; ++j) {
              r.col[j] = qo + 3 + j;
              r.coef[j] = 2 * L * M(k, j);
            }
            r.y = 0.0;
            residuals.push_back(r);
          }
        }
      }
    }
  }
  // Quaternion-norm rows of the initial states (spatial).
  if (!planar) {
    for (int e = 0; e < num_episodes; ++e) {
      for (int b : scene.dynamic_bodies()) {
        quat_rows.emplace_back(m++, x0_col[e] + scene.index(b).q + 3);
      }
    }
  }
  scale = Eigen::Map<VectorXd>(sc.data(), n);
  x_l = Eigen::Map<VectorXd>(xl.data(), n).cwiseQuotient(scale);
  x_u = Eigen::Map<VectorXd>(xu.data(), n).cwiseQuotient(scale);
  start = Eigen::Map<VectorXd>(x0.data(), n).cwiseQuotient(scale);
  BuildStructure();
}

std::vector<VectorXd> MpecEstimationProblem::Impl::TrackGuess(const Episode& ep,
                                                              const std::vector<double>& step_h,
                                                              std::vector<State>* guess) {
  const bool planar = scene.dim == sim::Dim::kPlanar;
  const int num = static_cast<int>(step_h.size());
  std::vector<VectorXd> w(num, VectorXd::Zero(nv));
  State s = (*guess)[0];
  for (int l = 0; l < num; ++l) {
    const double h = step_h[l];
    const State& target = (*guess)[l + 1];
    std::shared_ptr<const sim::Scene> model;
    const sim::Formulation& form = FormulationFor(h, &model);
    // ν*: the velocity that reaches the guessed pose in one step (ν_ℓ+1 = (q_ℓ+1 − q_ℓ)/h).
    std::vector<std::pair<int, VectorXd>> want;  // (first velocity index, ν* of the body)
    for (const BodyTrack& b : ep.bodies) {
      if (!b.dynamic) continue;
      const sim::BodyIndex& ix = scene.index(b.body_index);
      VectorXd v(planar ? 3 : 6);
      v.head<3>() = (target.q.segment<3>(ix.q) - s.q.segment<3>(ix.q)) / h;
      if (!planar) {
        const Eigen::Quaterniond q0(s.q[ix.q + 3], s.q[ix.q + 4], s.q[ix.q + 5], s.q[ix.q + 6]);
        const Eigen::Quaterniond q1(target.q[ix.q + 3], target.q[ix.q + 4], target.q[ix.q + 5],
                                    target.q[ix.q + 6]);
        v.tail<3>() = RotationLog(q0.conjugate() * q1) / h;
      }
      want.emplace_back(ix.v, v);
    }
    sim::StepInput u;
    u.generalized_force = VectorXd::Zero(nv);
    State next;
    bool ok = false;
    for (int k = 0; k < 3; ++k) {
      sim::Workspace ws;
      sim::StepInfo info;
      form.Step(*model, s, u, &ws, &next, &info);
      ok = info.ok && next.q.allFinite() && next.v.allFinite();
      if (!ok || k == 2) break;
      // u += M (ν* − ν_ℓ+1) / h per observed body (planar: m, m, I_zz; spatial: m I, the
      // body-frame inertia).
      int j = 0;
      for (const BodyTrack& b : ep.bodies) {
        if (!b.dynamic) continue;
        const sim::Body& body = scene.bodies[b.body_index];
        const auto& [vi, vstar] = want[j++];
        const VectorXd dv = (vstar - next.v.segment(vi, vstar.size())) / h;
        if (planar) {
          u.generalized_force.segment<2>(vi) += body.mass * dv.head<2>();
          u.generalized_force[vi + 2] += body.inertia(2, 2) * dv[2];
        } else {
          u.generalized_force.segment<3>(vi) += body.mass * dv.head<3>();
          u.generalized_force.segment<3>(vi + 3) += body.inertia * dv.tail<3>();
        }
      }
    }
    if (!ok) break;
    next.t = target.t;
    next.warm_start.resize(0);
    w[l] = u.generalized_force;
    (*guess)[l + 1] = next;
    s = next;
  }
  return w;
}

void MpecEstimationProblem::Impl::RolloutGuess(const State& x0, const std::vector<double>& step_h,
                                               std::vector<State>* guess) {
  if (x0.q.size() != nq || x0.v.size() != nv || !x0.q.allFinite() || !x0.v.allFinite())
    throw std::invalid_argument("mpec: start_states: a state of the wrong size or not finite");
  State s = x0;
  s.t = (*guess)[0].t;
  (*guess)[0] = s;
  // Stepped as the least squares' rollouts (RolloutResiduals: the first step cold, each next one
  // from the last one's solution): where the contact solution is not unique (a cube landing flat)
  // a step started elsewhere picks another one, and the guess left the data the fit had matched
  // (measured: objective 4.1e5 at the start instead of ~1e3, the active set's NLP stalled at
  // 1.1e4).
  s = internal::ColdStart(std::move(s));
  sim::StepInput u;
  u.generalized_force = VectorXd::Zero(nv);
  for (std::size_t l = 0; l < step_h.size(); ++l) {
    std::shared_ptr<const sim::Scene> model;
    const sim::Formulation& form = FormulationFor(step_h[l], &model);
    sim::Workspace ws;
    sim::StepInfo info;
    State next;
    form.Step(*model, s, u, &ws, &next, &info);
    // A failed step leaves the rest of the guess at the log's poses.
    if (!info.ok || !next.q.allFinite() || !next.v.allFinite()) return;
    next.t = (*guess)[l + 1].t;
    (*guess)[l + 1] = next;
    s = next;
  }
}

void MpecEstimationProblem::Impl::BuildStructure() {
  jac.clear();
  for (StepBlock& b : steps) {
    b.jac_offset = static_cast<int>(jac.size());
    const long long ncols = b.nz + ntheta + nx + nv;
    for (long long k : b.keys)
      jac.push_back(
          {b.row + static_cast<int>(k / ncols), GlobalCol(b, static_cast<int>(k % ncols))});
    for (std::size_t r = 0; r < b.a_slack.size(); ++r) {
      if (b.a_slack[r] >= 0) jac.push_back({b.row + b.neq + b.a_slack[r], b.a_var[r]});
      if (b.b_slack[r] >= 0) jac.push_back({b.row + b.neq + b.b_slack[r], b.b_var[r]});
    }
  }
  quat_jac_offset = static_cast<int>(jac.size());
  for (const auto& [row, col] : quat_rows)
    for (int j = 0; j < 4; ++j) jac.push_back({row, col + j});
  // Hessian: 2/σ² Σ aᵀa + 2/σ_Q² on w, plus the quaternion rows' diagonals.
  std::vector<Eigen::Triplet<double>> tr;
  for (const ResidualRow& r : residuals)
    for (int i = 0; i < r.n; ++i)
      for (int j = 0; j < r.n; ++j)
        if (r.col[i] >= r.col[j])
          tr.emplace_back(r.col[i], r.col[j], 2 * r.coef[i] * r.coef[j] / (sigma * sigma));
  for (int c : w_cols)
    for (int i = 0; i < nv; ++i) tr.emplace_back(c + i, c + i, 2 / (sigma_q * sigma_q));
  for (const auto& [row, col] : quat_rows)
    for (int j = 0; j < 4; ++j) tr.emplace_back(col + j, col + j, 0.0);
  sim::SparseMatrixXd H(n, n);
  H.setFromTriplets(tr.begin(), tr.end());
  hess.clear();
  hess_obj.resize(H.nonZeros());
  std::map<std::pair<int, int>, int> where;
  for (int c = 0; c < H.outerSize(); ++c) {
    for (sim::SparseMatrixXd::InnerIterator it(H, c); it; ++it) {
      where[{static_cast<int>(it.row()), c}] = static_cast<int>(hess.size());
      hess_obj[static_cast<int>(hess.size())] = it.value() * scale[it.row()] * scale[c];
      hess.push_back({static_cast<int>(it.row()), c});
    }
  }
  hess_quat.clear();
  for (const auto& [row, col] : quat_rows)
    for (int j = 0; j < 4; ++j) hess_quat.emplace_back(where.at({col + j, col + j}), row);
}

MpecEstimationProblem::MpecEstimationProblem(const sim::Simulator& simulator, const Log& log,
                                             const MpecOptions& options, double sigma) {
  options.Validate();
  if (!(sigma > 0) || !std::isfinite(sigma))
    throw std::invalid_argument("mpec: sigma = " + std::to_string(sigma) + ", expected > 0");
  impl_ = std::make_unique<Impl>(simulator, options);
  impl_->sigma = sigma;
  impl_->Build(log);
}

MpecEstimationProblem::~MpecEstimationProblem() = default;

}  // namespace vinci::estimation
