#include "vinci/estimation/mpec_estimator.h"

#include <Eigen/SparseCholesky>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "vinci/sim/formulations/step_model.h"
#include "vinci/sim/model/state_util.h"

namespace vinci::estimation {
namespace {

using sim::Params;
using sim::State;
using sim::VectorXd;

constexpr double kDefaultSigma = 1e-3;  // m, weighting when no noise is stated
constexpr double kInf = 1e20;

// A measurement residual r = Σ coef_k x[col_k] − y (m).
struct ResidualRow {
  int episode = 0;
  int n = 0;
  int col[4] = {0, 0, 0, 0};
  double coef[4] = {0, 0, 0, 0};
  double y = 0.0;
};

struct StepBlock {
  int episode = 0;
  double t = 0.0;
  std::unique_ptr<sim::StepModel> model;
  int nz = 0, neq = 0, ns = 0;
  int x_col = 0, z_col = 0, w_col = 0, s_col = 0;
  int row = 0;  // first constraint row: equality rows, then slack rows
  // Per comp row: its complementarity variable, and the slack index (−1: the row is z itself).
  std::vector<int> a_var, b_var, a_slack, b_slack;
  std::vector<int> theta_map;   // per param_columns() entry: chosen index or −1
  std::vector<long long> keys;  // sorted local (row, col) keys of the model's entries
  int jac_offset = 0;           // first global Jacobian entry (model entries, then slacks)
  VectorXd z_guess;
};

// Runs f(i) for i in [0, n) on `threads` threads.
template <class F>
void ParallelFor(int n, int threads, const F& f) {
  threads = std::max(1, std::min(threads, n));
  if (threads == 1) {
    for (int i = 0; i < n; ++i) f(i);
    return;
  }
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t) {
    pool.emplace_back([&, t] {
      for (int i = t; i < n; i += threads) f(i);
    });
  }
  for (std::thread& th : pool) th.join();
}

Eigen::Quaterniond LoggedQuaternion(const BodyTrack& b, int i) {
  return Eigen::Quaterniond(b.pose(i, 3), b.pose(i, 4), b.pose(i, 5), b.pose(i, 6)).normalized();
}

Eigen::Vector3d RotationLog(const Eigen::Quaterniond& q_in) {
  Eigen::Quaterniond q = q_in.normalized();
  if (q.w() < 0) q.coeffs() = -q.coeffs();
  const double s = q.vec().norm();
  if (s < 1e-300) return Eigen::Vector3d::Zero();
  return 2.0 * std::atan2(s, q.w()) * q.vec() / s;
}

}  // namespace

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
  if (!std::isfinite(contact_margin)) fail("contact_margin", contact_margin, "finite");
  solver.Validate();
}

struct MpecEstimationProblem::Impl {
  const sim::Simulator& sim;
  const sim::Scene& scene;
  MpecOptions opts;
  double sigma = kDefaultSigma, sigma_q = 1.0;
  double margin = 0.0;  // added to the envelope for the frozen contact sets
  sim::ParamSelection sel;
  Params base;
  int ntheta = 0, nq = 0, nv = 0, nx = 0;
  int n = 0, m = 0;
  int num_episodes = 0;
  std::vector<int> x0_col;                  // per episode
  std::vector<std::vector<double>> node_t;  // per episode, node times
  std::vector<std::vector<int>> node_col;   // per episode, node state columns
  std::vector<StepBlock> steps;
  std::vector<ResidualRow> residuals;
  std::vector<int> w_cols;  // first column of every w block
  // Quaternion-norm rows: (row, first column of the 4 quaternion entries).
  std::vector<std::pair<int, int>> quat_rows;
  int quat_jac_offset = 0;
  std::vector<std::pair<int, int>> pairs;
  VectorXd x_l, x_u, start;  // in the solver's (scaled) variables
  // Per unknown its typical magnitude: the solver's variables are y = x / scale (x physical).
  VectorXd scale;
  // Constant objective Hessian (lower triangle) and quaternion-row diagonal positions.
  std::vector<Entry> hess;
  VectorXd hess_obj;
  std::vector<std::pair<int, int>> hess_quat;  // (entry, constraint row)
  std::vector<Entry> jac;
  // Per-formulation cache for steps whose h differs from the scene's dt.
  struct Stepper {
    std::unique_ptr<sim::Formulation> formulation;
    std::shared_ptr<sim::Scene> model;
  };
  std::map<double, Stepper> steppers;
  sim::Scene model_dt;  // the scene with base params (dt steps)
  // Evaluation caches.
  mutable VectorXd cache_g_x, cache_g, cache_j_x, cache_j;
  mutable bool cache_g_ok = false, cache_j_ok = false;
  mutable double max_dropped = 0.0;  // largest Jacobian entry outside the structure

  Impl(const sim::Simulator& s, const MpecOptions& o)
      : sim(s), scene(s.scene()), opts(o), sel(s.scene().param_table(), o.params) {}

  VectorXd Physical(const VectorXd& y) const { return y.cwiseProduct(scale); }

  Params Theta(const VectorXd& x) const {
    VectorXd th = x.head(ntheta);
    for (int i = 0; i < ntheta; ++i) th[i] = std::clamp(th[i], sel.lower()[i], sel.upper()[i]);
    return sel.Set(base, th);
  }

  State NodeState(const VectorXd& x, int col, double t) const {
    State st;
    st.t = t;
    st.q = x.segment(col, nq);
    st.v = x.segment(col + nq, nv);
    return st;
  }

  sim::StepModelValues EvaluateStep(const StepBlock& b, const VectorXd& x, const Params& theta,
                                    bool jacobians) const {
    sim::StepInput u;
    u.generalized_force = x.segment(b.w_col, nv);
    sim::StepModelOptions so;
    so.jacobians = jacobians;
    so.state_jacobian = jacobians;
    return b.model->Evaluate(x.segment(b.z_col, b.nz), theta, NodeState(x, b.x_col, b.t), u, so);
  }

  // Visits the model's Jacobian entries of one step as (local row, local col, value); comp rows
  // that are pure variables are skipped. Local columns: z | θ (chosen) | x | w.
  template <class F>
  void ForEachEntry(const StepBlock& b, const sim::StepModelValues& v, const F& f) const {
    const int oz = 0, ot = b.nz, ox = b.nz + ntheta, ow = b.nz + ntheta + nx;
    auto group = [&](const sim::StepModelJacobian& J, auto row_of, double sign) {
      auto block = [&](const sim::SparseMatrixXd& M, int off, bool theta) {
        for (int c = 0; c < M.outerSize(); ++c) {
          int lc = off + c;
          if (theta) {
            const int k = b.theta_map[c];
            if (k < 0) continue;
            lc = ot + k;
          }
          for (sim::SparseMatrixXd::InnerIterator it(M, c); it; ++it) {
            const int lr = row_of(static_cast<int>(it.row()));
            if (lr >= 0) f(lr, lc, sign * it.value());
          }
        }
      };
      block(J.d_z, oz, false);
      block(J.d_theta, 0, true);
      block(J.d_x, ox, false);
      block(J.d_u, ow, false);
    };
    group(
        v.d_equality, [](int r) { return r; }, 1.0);
    group(
        v.d_comp_a, [&](int r) { return b.a_slack[r] < 0 ? -1 : b.neq + b.a_slack[r]; }, -1.0);
    group(
        v.d_comp_b, [&](int r) { return b.b_slack[r] < 0 ? -1 : b.neq + b.b_slack[r]; }, -1.0);
  }

  int GlobalCol(const StepBlock& b, int lc) const {
    if (lc < b.nz) return b.z_col + lc;
    lc -= b.nz;
    if (lc < ntheta) return lc;
    lc -= ntheta;
    if (lc < nx) return b.x_col + lc;
    return b.w_col + (lc - nx);
  }
  long long Key(const StepBlock& b, int lr, int lc) const {
    return static_cast<long long>(lr) * (b.nz + ntheta + nx + nv) + lc;
  }

  const sim::Formulation& FormulationFor(double h, const sim::Scene** model) {
    if (h == scene.options.dt && margin == 0.0) {
      *model = &model_dt;
      return sim.formulation();
    }
    auto it = steppers.find(h);
    if (it == steppers.end()) {
      sim::Scene s = scene;
      s.options.dt = h;
      s.options.envelope += margin;
      Stepper st;
      st.formulation = sim::MakeFormulation(s.options);
      st.model = std::make_shared<sim::Scene>(s.ApplyParams(base));
      it = steppers.emplace(h, std::move(st)).first;
    }
    *model = it->second.model.get();
    return *it->second.formulation;
  }

  void Build(const Log& log);
  void BuildStructure();
};

void MpecEstimationProblem::Impl::Build(const Log& log) {
  const sim::ParamTable& table = scene.param_table();
  for (const std::string& name : opts.params) {
    const sim::ParamInfo& info = table.info(table.Index(name));
    if (!info.differentiable) {
      std::string names;
      for (const std::string& d : table.DifferentiableNames())
        names += (names.empty() ? "" : ", ") + d;
      throw std::invalid_argument("--param " + name +
                                  ": not a differentiable parameter; estimable here: " + names);
    }
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
  model_dt = scene.ApplyParams(base);
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
    // The grid.
    std::vector<double> T{ep.t[0]};
    std::vector<int> sample_node{0};
    std::vector<double> step_h;
    for (int i = 0; i + 1 < ep.num_samples(); ++i) {
      const double span = ep.t[i + 1] - ep.t[i];
      const int ni = std::max(1, static_cast<int>(std::lround(span / dt)));
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
      for (const BodyTrack& b : ep.bodies) {
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
      const sim::Scene* model = nullptr;
      const sim::Formulation& form = FormulationFor(step_h[l], &model);
      blk.model = sim::Freeze(form, *model, base, guess[l]);
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
        form.Step(*model, guess[l], sim::StepInput{}, &ws, &next, &info);
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
      // Structure: the union of the entries of the three evaluations.
      for (const sim::StepModelValues& v : evals)
        ForEachEntry(blk, v, [&](int lr, int lc, double) { blk.keys.push_back(Key(blk, lr, lc)); });
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

int MpecEstimationProblem::num_variables() const { return impl_->n; }
int MpecEstimationProblem::num_constraints() const { return impl_->m; }
double MpecEstimationProblem::process_noise() const { return impl_->sigma_q; }
double MpecEstimationProblem::dropped_jacobian() const { return impl_->max_dropped; }
int MpecEstimationProblem::num_steps() const { return static_cast<int>(impl_->steps.size()); }
int MpecEstimationProblem::num_residuals() const {
  return static_cast<int>(impl_->residuals.size());
}

void MpecEstimationProblem::Bounds(VectorXd* x_l, VectorXd* x_u, VectorXd* g_l,
                                   VectorXd* g_u) const {
  *x_l = impl_->x_l;
  *x_u = impl_->x_u;
  *g_l = VectorXd::Zero(impl_->m);
  *g_u = VectorXd::Zero(impl_->m);
}

VectorXd MpecEstimationProblem::StartingPoint() const { return impl_->start; }

std::vector<std::pair<int, int>> MpecEstimationProblem::ComplementarityPairs() const {
  return impl_->pairs;
}

bool MpecEstimationProblem::Objective(const VectorXd& y, double* f) const {
  const Impl& I = *impl_;
  const VectorXd x = I.Physical(y);
  double s = 0.0;
  for (const ResidualRow& r : I.residuals) {
    double v = -r.y;
    for (int i = 0; i < r.n; ++i) v += r.coef[i] * x[r.col[i]];
    s += v * v;
  }
  double w = 0.0;
  for (int c : I.w_cols) w += x.segment(c, I.nv).squaredNorm();
  *f = s / (I.sigma * I.sigma) + w / (I.sigma_q * I.sigma_q);
  return std::isfinite(*f);
}

bool MpecEstimationProblem::Gradient(const VectorXd& y, VectorXd* grad) const {
  const Impl& I = *impl_;
  const VectorXd x = I.Physical(y);
  grad->setZero(I.n);
  for (const ResidualRow& r : I.residuals) {
    double v = -r.y;
    for (int i = 0; i < r.n; ++i) v += r.coef[i] * x[r.col[i]];
    for (int i = 0; i < r.n; ++i) (*grad)[r.col[i]] += 2 * v * r.coef[i] / (I.sigma * I.sigma);
  }
  for (int c : I.w_cols) grad->segment(c, I.nv) += 2 * x.segment(c, I.nv) / (I.sigma_q * I.sigma_q);
  *grad = grad->cwiseProduct(I.scale);
  return grad->allFinite();
}

bool MpecEstimationProblem::Constraints(const VectorXd& y, VectorXd* g) const {
  const Impl& I = *impl_;
  if (I.cache_g_ok && I.cache_g_x.size() == y.size() && I.cache_g_x == y) {
    *g = I.cache_g;
    return true;
  }
  const VectorXd x = I.Physical(y);
  g->setZero(I.m);
  const Params theta = I.Theta(x);
  std::vector<char> ok(I.steps.size(), 1);
  ParallelFor(static_cast<int>(I.steps.size()), I.opts.threads, [&](int k) {
    const StepBlock& b = I.steps[k];
    try {
      const sim::StepModelValues v = I.EvaluateStep(b, x, theta, false);
      g->segment(b.row, b.neq) = v.equality;
      for (std::size_t r = 0; r < b.a_slack.size(); ++r) {
        if (b.a_slack[r] >= 0) (*g)[b.row + b.neq + b.a_slack[r]] = x[b.a_var[r]] - v.comp_a[r];
        if (b.b_slack[r] >= 0) (*g)[b.row + b.neq + b.b_slack[r]] = x[b.b_var[r]] - v.comp_b[r];
      }
    } catch (const std::exception&) {
      ok[k] = 0;
    }
  });
  for (const auto& [row, col] : I.quat_rows) (*g)[row] = x.segment(col, 4).squaredNorm() - 1.0;
  const bool all = std::all_of(ok.begin(), ok.end(), [](char c) { return c != 0; });
  if (!all || !g->allFinite()) return false;
  I.cache_g_x = y;
  I.cache_g = *g;
  I.cache_g_ok = true;
  return true;
}

std::vector<Entry> MpecEstimationProblem::JacobianStructure() const { return impl_->jac; }

bool MpecEstimationProblem::JacobianValues(const VectorXd& y, VectorXd* values) const {
  const Impl& I = *impl_;
  if (I.cache_j_ok && I.cache_j_x.size() == y.size() && I.cache_j_x == y) {
    *values = I.cache_j;
    return true;
  }
  const VectorXd x = I.Physical(y);
  values->setZero(static_cast<int>(I.jac.size()));
  const Params theta = I.Theta(x);
  std::vector<char> ok(I.steps.size(), 1);
  std::vector<double> dropped(I.steps.size(), 0.0);
  VectorXd g(I.m);
  ParallelFor(static_cast<int>(I.steps.size()), I.opts.threads, [&](int k) {
    const StepBlock& b = I.steps[k];
    try {
      const sim::StepModelValues v = I.EvaluateStep(b, x, theta, true);
      I.ForEachEntry(b, v, [&](int lr, int lc, double val) {
        const long long key = I.Key(b, lr, lc);
        const auto it = std::lower_bound(b.keys.begin(), b.keys.end(), key);
        if (it == b.keys.end() || *it != key) {
          // An entry outside the structure (found from five points at setup): dropped, and
          // its size reported (MpecEstimateResult::dropped_jacobian) — usually central-
          // difference noise of the x_ℓ block (~1e-16 |row| / 1e-7).
          dropped[k] = std::max(dropped[k], std::abs(val));
          return;
        }
        (*values)[b.jac_offset + static_cast<int>(it - b.keys.begin())] = val;
      });
      int e = b.jac_offset + static_cast<int>(b.keys.size());
      for (std::size_t r = 0; r < b.a_slack.size(); ++r) {
        if (b.a_slack[r] >= 0) (*values)[e++] = 1.0;
        if (b.b_slack[r] >= 0) (*values)[e++] = 1.0;
      }
      g.segment(b.row, b.neq) = v.equality;
      for (std::size_t r = 0; r < b.a_slack.size(); ++r) {
        if (b.a_slack[r] >= 0) g[b.row + b.neq + b.a_slack[r]] = x[b.a_var[r]] - v.comp_a[r];
        if (b.b_slack[r] >= 0) g[b.row + b.neq + b.b_slack[r]] = x[b.b_var[r]] - v.comp_b[r];
      }
    } catch (const std::exception&) {
      ok[k] = 0;
    }
  });
  int e = I.quat_jac_offset;
  for (const auto& [row, col] : I.quat_rows) {
    g[row] = x.segment(col, 4).squaredNorm() - 1.0;
    for (int j = 0; j < 4; ++j) (*values)[e++] = 2 * x[col + j];
  }
  const bool all = std::all_of(ok.begin(), ok.end(), [](char c) { return c != 0; });
  if (!all || !values->allFinite()) return false;
  for (std::size_t k = 0; k < I.jac.size(); ++k)
    (*values)[static_cast<int>(k)] *= I.scale[I.jac[k].col];
  for (double d : dropped) I.max_dropped = std::max(I.max_dropped, d);
  I.cache_j_x = y;
  I.cache_j = *values;
  I.cache_j_ok = true;
  I.cache_g_x = y;
  I.cache_g = g;
  I.cache_g_ok = true;
  return true;
}

std::vector<Entry> MpecEstimationProblem::HessianStructure() const { return impl_->hess; }

bool MpecEstimationProblem::HessianValues(const VectorXd& /*x*/, double obj_factor,
                                          const VectorXd& lambda, VectorXd* values) const {
  const Impl& I = *impl_;
  *values = obj_factor * I.hess_obj;
  // (quaternion unknowns have scale 1)
  for (const auto& [entry, row] : I.hess_quat) (*values)[entry] += 2 * lambda[row];
  return true;
}

VectorXd MpecEstimationProblem::Parameters(const VectorXd& y) const {
  return impl_->Physical(y).head(impl_->ntheta);
}

State MpecEstimationProblem::InitialState(const VectorXd& y, int episode) const {
  const Impl& I = *impl_;
  return I.NodeState(I.Physical(y), I.x0_col.at(episode), I.node_t.at(episode).front());
}

double MpecEstimationProblem::SquaredResiduals(const VectorXd& y, std::vector<double>* per_episode,
                                               double* max_w) const {
  const Impl& I = *impl_;
  const VectorXd x = I.Physical(y);
  if (per_episode) per_episode->assign(I.num_episodes, 0.0);
  double s = 0.0;
  for (const ResidualRow& r : I.residuals) {
    double v = -r.y;
    for (int i = 0; i < r.n; ++i) v += r.coef[i] * x[r.col[i]];
    s += v * v;
    if (per_episode) (*per_episode)[r.episode] += v * v;
  }
  if (max_w) {
    *max_w = 0.0;
    for (int c : I.w_cols) *max_w = std::max(*max_w, x.segment(c, I.nv).cwiseAbs().maxCoeff());
  }
  return s;
}

void MpecEstimationProblem::StepViolation(const VectorXd& y, double* equality,
                                          double* complementarity) const {
  const Impl& I = *impl_;
  const VectorXd x = I.Physical(y);
  const Params theta = I.Theta(x);
  *equality = 0.0;
  *complementarity = 0.0;
  for (const StepBlock& b : I.steps) {
    const sim::StepModelValues v = I.EvaluateStep(b, x, theta, false);
    if (v.equality.size() > 0) *equality = std::max(*equality, v.equality.cwiseAbs().maxCoeff());
    if (v.comp_a.size() > 0) {
      *complementarity =
          std::max(*complementarity, v.comp_a.cwiseMin(v.comp_b).cwiseAbs().maxCoeff());
    }
  }
  for (const auto& [row, col] : I.quat_rows)
    *equality = std::max(*equality, std::abs(x.segment(col, 4).squaredNorm() - 1.0));
}

VectorXd MpecEstimationProblem::VariablesFromRollouts(const std::vector<sim::Trajectory>& rollouts,
                                                      const Params& params) const {
  const Impl& I = *impl_;
  if (static_cast<int>(rollouts.size()) != I.num_episodes)
    throw std::invalid_argument("mpec: one rollout per episode expected");
  VectorXd x = I.Physical(I.start);
  x.head(I.ntheta) = I.sel.Get(params);
  auto find = [&](int e, double t) -> const State& {
    for (const State& s : rollouts[e].states)
      if (std::abs(s.t - t) <= 1e-9) return s;
    throw std::invalid_argument("mpec: no rollout state at t = " + std::to_string(t));
  };
  for (int e = 0; e < I.num_episodes; ++e) {
    const State& s0 = find(e, I.node_t[e].front());
    x.segment(I.x0_col[e], I.nq) = s0.q;
    x.segment(I.x0_col[e] + I.nq, I.nv) = s0.v;
  }
  int k = 0;
  for (int e = 0; e < I.num_episodes; ++e) {
    for (std::size_t l = 0; l + 1 < I.node_t[e].size(); ++l, ++k) {
      const StepBlock& b = I.steps[k];
      const VectorXd z = b.model->UnknownsFromStep(find(e, I.node_t[e][l + 1]));
      x.segment(b.z_col, b.nz) = z;
      x.segment(b.w_col, I.nv).setZero();
    }
  }
  // Slacks = their rows.
  const Params theta = I.Theta(x);
  for (const StepBlock& b : I.steps) {
    const sim::StepModelValues v = I.EvaluateStep(b, x, theta, false);
    for (std::size_t r = 0; r < b.a_slack.size(); ++r) {
      if (b.a_slack[r] >= 0) x[b.a_var[r]] = v.comp_a[r];
      if (b.b_slack[r] >= 0) x[b.b_var[r]] = v.comp_b[r];
    }
  }
  return x.cwiseQuotient(I.scale);
}

bool MpecEstimationProblem::ParameterVariances(const VectorXd& x,
                                               const std::vector<bool>& first_at_zero,
                                               VectorXd* variances) const {
  const Impl& I = *impl_;
  variances->setConstant(I.ntheta, std::numeric_limits<double>::quiet_NaN());
  std::vector<char> fixed(I.n, 0);
  for (std::size_t k = 0; k < I.pairs.size() && k < first_at_zero.size(); ++k)
    fixed[first_at_zero[k] ? I.pairs[k].first : I.pairs[k].second] = 1;
  for (int i = 0; i < I.ntheta; ++i)
    if (x[i] <= I.x_l[i] + 1e-12 || x[i] >= I.x_u[i] - 1e-12) fixed[i] = 1;
  VectorXd J;
  if (!JacobianValues(x, &J)) return false;
  // Unknowns that nothing depends on at x (no objective term, all Jacobian entries zero) are
  // undetermined and irrelevant: left out.
  std::vector<char> used(I.n, 0);
  for (const Entry& h : I.hess) used[h.row] = used[h.col] = 1;
  for (std::size_t e = 0; e < I.jac.size(); ++e)
    if (J[static_cast<int>(e)] != 0.0) used[I.jac[e].col] = 1;
  std::vector<int> map(I.n, -1);
  int nf = 0;
  for (int i = 0; i < I.n; ++i)
    if (!fixed[i] && used[i]) map[i] = nf++;
  std::vector<Eigen::Triplet<double>> tr;
  for (std::size_t e = 0; e < I.hess.size(); ++e) {
    const int r = map[I.hess[e].row], c = map[I.hess[e].col];
    if (r < 0 || c < 0) continue;
    const double h = 0.5 * I.hess_obj[static_cast<int>(e)];
    tr.emplace_back(r, c, h);
    if (r != c) tr.emplace_back(c, r, h);
  }
  for (std::size_t e = 0; e < I.jac.size(); ++e) {
    const int c = map[I.jac[e].col];
    if (c < 0 || J[static_cast<int>(e)] == 0.0) continue;
    tr.emplace_back(nf + I.jac[e].row, c, J[static_cast<int>(e)]);
    tr.emplace_back(c, nf + I.jac[e].row, J[static_cast<int>(e)]);
  }
  // Quasi-definite regularization [H + δ₁ I, J_Fᵀ; J_F, −δ₂ I] (H is only semi-definite: the
  // impulses have no objective term) so that a sparse LDLᵀ exists for any ordering; δ₁ = 1e-9 of
  // H's largest diagonal, δ₂ = 1e-12: the variances change by ~δ relative.
  double hmax = 0.0;
  for (const Eigen::Triplet<double>& t : tr)
    if (t.row() == t.col() && t.row() < nf) hmax = std::max(hmax, std::abs(t.value()));
  for (int i = 0; i < nf; ++i) tr.emplace_back(i, i, 1e-9 * std::max(hmax, 1.0));
  for (int j = 0; j < I.m; ++j) tr.emplace_back(nf + j, nf + j, -1e-12);
  sim::SparseMatrixXd K(nf + I.m, nf + I.m);
  K.setFromTriplets(tr.begin(), tr.end());
  Eigen::SimplicialLDLT<sim::SparseMatrixXd, Eigen::Lower> lu;
  lu.compute(K);
  if (lu.info() != Eigen::Success) return false;
  for (int i = 0; i < I.ntheta; ++i) {
    if (map[i] < 0) continue;
    VectorXd rhs = VectorXd::Zero(nf + I.m);
    rhs[map[i]] = 1.0;
    const VectorXd sol = lu.solve(rhs);
    if (lu.info() != Eigen::Success || !sol.allFinite()) return false;
    (*variances)[i] = sol[map[i]];
  }
  return true;
}

MpecEstimateResult EstimateMpec(const sim::Simulator& simulator, const Log& log,
                                const MpecOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  options.Validate();
  const bool stated = options.noise_sigma > 0;
  const double sigma_w = stated ? options.noise_sigma : kDefaultSigma;
  MpecEstimationProblem problem(simulator, log, options, sigma_w);
  MpecEstimateResult r;
  r.method = "mpec";
  r.names = options.params;
  const VectorXd x0 = problem.StartingPoint();
  r.initial_values = problem.Parameters(x0);
  r.complementarity = ToString(options.solver.method);
  r.num_constraints = problem.num_constraints();
  r.num_pairs = static_cast<int>(problem.ComplementarityPairs().size());
  r.num_steps = problem.num_steps();
  r.num_unknowns = problem.num_variables();
  r.num_residuals = problem.num_residuals();
  r.initial_cost = 0.5 * problem.SquaredResiduals(x0);
  r.process_noise = problem.process_noise();
  if (options.progress) {
    std::ostringstream s;
    s << "mpec: " << r.num_steps << " steps, " << r.num_unknowns << " unknowns, "
      << r.num_constraints << " constraints, " << r.num_pairs << " complementarity pairs ("
      << r.complementarity << ")";
    options.progress(s.str());
  }
  MpecSolverOptions so = options.solver;
  if (!so.progress) so.progress = options.progress;
  const MpecSolution sol = SolveMpec(problem, so);
  r.estimates = problem.Parameters(sol.x);
  r.iterations = sol.iterations;
  r.stages = sol.stages;
  r.polished = sol.polished;
  r.converged = sol.converged;
  r.reason = sol.reason;
  std::vector<double> per_episode;
  const double ss = problem.SquaredResiduals(sol.x, &per_episode, &r.max_process_noise);
  r.final_cost = 0.5 * ss;
  problem.StepViolation(sol.x, &r.equality_violation, &r.complementarity_violation);
  r.dropped_jacobian = problem.dropped_jacobian();
  // σ: stated, or estimated from the residuals (p = parameters + observed initial states).
  const bool planar = simulator.scene().dim == sim::Dim::kPlanar;
  int p = static_cast<int>(options.params.size());
  for (const Episode& ep : log.episodes)
    for (const BodyTrack& b : ep.bodies) p += b.dynamic ? (planar ? 6 : 12) : 0;
  r.sigma = stated ? options.noise_sigma : std::sqrt(ss / std::max(1, r.num_residuals - p));
  VectorXd var;
  if (problem.ParameterVariances(sol.x, sol.first_at_zero, &var)) {
    const double scale = stated ? 1.0 : (r.sigma * r.sigma) / (sigma_w * sigma_w);
    r.std_errors = (var * scale).cwiseMax(0.0).cwiseSqrt();
    for (int i = 0; i < var.size(); ++i)
      if (!(var[i] > 0)) r.std_errors[i] = std::numeric_limits<double>::quiet_NaN();
  } else {
    r.std_errors = VectorXd::Constant(r.estimates.size(), std::numeric_limits<double>::quiet_NaN());
  }
  for (int e = 0; e < static_cast<int>(log.episodes.size()); ++e) {
    EpisodeEstimate ee;
    ee.file = log.episodes[e].file;
    ee.x0 = problem.InitialState(sol.x, e);
    int rows = 0;
    for (const BodyTrack& b : log.episodes[e].bodies) rows += b.dynamic ? 1 : 0;
    const int per_sample = ResidualsPerSample(log.episodes[e], simulator.scene().dim);
    (void)rows;
    ee.rms_residual =
        std::sqrt(per_episode[e] / std::max(1, per_sample * log.episodes[e].num_samples()));
    r.episodes.push_back(ee);
  }
  r.time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return r;
}

}  // namespace vinci::estimation
