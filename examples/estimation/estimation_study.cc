// Friction-estimation studies (issue 15, thesis chapter 7; docs/estimation.md): the RMS error
// of μ̂ over seeded trials of synthetic logs, per method, noise level and window length.
//
//   estimation_study STUDY [--trials N] [--noise S1,S2,..] [--windows W1,W2,..]
//                    [--particles N1,N2,..] [--episodes N] [--methods
//                    lsq,lsq_sens,lsq_ms,filter,mpec,mpec_pen,mpec_dec,mpec_lsq]
//                    [--guess MU] [--first-trial K] [--threads N] [--mpec-substeps N]
//                    [--only-episode K[,L...]] [--write-logs DIR] [--out FILE.csv]
//
// STUDY:
//   plate      a particle on a vibrating plate (planar, true μ = 0.2), windows in samples
//   particles  several particles sharing μ on the same plate (RMS error vs number of particles)
//   block      a block sliding to rest on a table (planar, true μ = 0.3)
//   cube       a cube tossed onto a table (spatial, 8 corners, 150 Hz, 30 µm noise)
//
// Every trial simulates the truth, samples the observed positions with seeded Gaussian noise
// and runs each method from the scene's μ (the initial guess). With --episodes N (default 1) a
// trial is N episodes estimated together (shared μ, per-episode initial states); the cube's
// episodes are different tosses (seeded launch velocities around the scene's), the planar
// studies' differ only in their noise; --only-episode K[,L...] estimates only those of them (the
// same seeded log); --write-logs DIR writes each estimated episode's log to DIR/<episode>.csv
// (`vinci estimate`'s format; DIR is created if missing). One CSV row per trial and method: study,
// method, noise_m, window, particles, episodes, trial, true_mu, mu_hat, std_error, converged,
// iterations, time_s (wall), samples, cpu_s (the process's CPU time: meaningful on a loaded
// machine, summed over threads and over the worker processes of mpec_dec), robust_se (mpec_dec: the
// s.e. from the episodes' jackknife; nan otherwise). Methods: lsq (single shooting), lsq_sens
// (single shooting with step-sensitivity Jacobians, LeastSquaresJacobian::kSensitivity), lsq_ms
// (multiple shooting, 25-sample segments), filter (the UKF with μ in the state), mpec (Ipopt,
// Scholtes relaxation homotopy), mpec_pen (Ipopt, ℓ1 penalty homotopy), mpec_dec (mpec with the
// episodes decomposed: MpecEpisodes::kDecomposed, mpec_decomposed.h), mpec_lsq (mpec started
// from a rough least-squares fit: MpecOptions::least_squares_start). The defaults are the full
// study (20 trials); --trials and --methods cut it down (scripts/estimation_studies.sh runs all
// four studies). --threads N (default 1) is passed to lsq/lsq_ms (episodes in parallel),
// mpec/mpec_pen (steps in parallel) and mpec_dec (episodes in worker processes); --mpec-substeps N
// (default 0: the scene's dt) the MPEC's steps per log interval (MpecOptions::substeps);
// --mpec-raw-guess 1 the MPEC's initial guess from the raw log (MpecOptions::smooth_initial_guess
// off); --mpec-ordering auto|scotch|qamd MUMPS' ordering (MpecSolverOptions::ordering). Plots:
// scripts/plot_estimation_study.py FILE.csv.
//
// To add a method, add one line to Methods() below.
#include <sys/resource.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "vinci/estimation/filter.h"
#include "vinci/estimation/least_squares.h"
#include "vinci/estimation/log.h"
#include "vinci/estimation/mpec_estimator.h"
#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/model/state_util.h"
#include "vinci/sim/simulator/simulator.h"

namespace {

// CPU seconds of this process and of its waited-for children (mpec_dec's worker processes).
double CpuSeconds() {
  double s = 0.0;
  for (const int who : {RUSAGE_SELF, RUSAGE_CHILDREN}) {
    rusage u{};
    getrusage(who, &u);
    s += static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         1e-6 * static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
  }
  return s;
}

using vinci::estimation::EstimateResult;
using vinci::estimation::Log;
namespace est = vinci::estimation;
namespace sim = vinci::sim;

// A method's result, and its standard error from the episodes' jackknife where it has one
// (mpec_dec: MpecEstimateResult::robust_std_errors; NaN otherwise).
struct StudyResult {
  EstimateResult r;
  double robust_se = std::nan("");
};

// An estimator: (simulator whose scene holds the initial guess, log, stated noise σ) → result.
using Estimator = std::function<StudyResult(const sim::Simulator&, const Log&, double)>;

// Threads for the methods that evaluate in parallel (lsq: episodes; mpec: steps); --threads.
int g_threads = 1;
// MPEC steps per log interval (MpecOptions::substeps; 0: the scene's dt); --mpec-substeps.
int g_mpec_substeps = 0;
// Single-shooting least squares' first horizon (LeastSquaresOptions::horizon_samples; 0: the
// whole log at once); --lsq-horizon.
int g_lsq_horizon = 0;
// Single-shooting least squares' standard errors (LeastSquaresOptions::std_errors);
// --lsq-std-errors linearized|profile.
est::LeastSquaresStdErrors g_lsq_std_errors = est::LeastSquaresStdErrors::kLinearized;
// --mpec-raw-guess: the MPEC's initial guess from the raw log (MpecOptions::smooth_initial_guess
// off; the estimator before 2026-11-25's smoothing, for comparisons).
bool g_mpec_raw_guess = false;
// --mpec-ordering: MUMPS' ordering (MpecSolverOptions::ordering).
est::MpecSolverOptions::Ordering g_mpec_ordering = est::MpecSolverOptions::Ordering::kAuto;
// --verbose 1: the MPEC's progress lines (setup, each NLP) on stderr; ≥ 2: also Ipopt's output
// at that print_level.
int g_verbose = 0;

std::vector<std::pair<std::string, Estimator>> Methods() {
  auto lsq = [](est::Shooting shooting,
                est::LeastSquaresJacobian jacobian = est::LeastSquaresJacobian::kFiniteDifference) {
    return [shooting, jacobian](const sim::Simulator& s, const Log& log, double sigma) {
      est::LeastSquaresOptions o;
      o.params = {"mu.default"};
      o.noise_sigma = sigma;
      o.shooting = shooting;
      o.jacobian = jacobian;
      o.segment_samples = 25;
      o.max_iterations = 50;
      o.threads = g_threads;
      if (shooting == est::Shooting::kSingle) {
        o.horizon_samples = g_lsq_horizon;
        o.std_errors = g_lsq_std_errors;
      }
      if (g_verbose > 0)
        o.horizon_progress = [](int horizon, const EstimateResult& fit,
                                const std::vector<int>& discarded) {
          std::cerr << "  horizon " << horizon << ": mu " << fit.estimates[0] << ", sigma_hat "
                    << fit.sigma_residual << ", " << fit.iterations << " iterations";
          if (!discarded.empty()) std::cerr << " (discarded, smaller steps:";
          for (int e : discarded) std::cerr << " episode " << e;
          std::cerr << (discarded.empty() ? "" : ")") << "\n";
        };
      return StudyResult{est::EstimateLeastSquares(s, log, o)};
    };
  };
  auto mpec = [](est::ComplementarityMethod method,
                 est::MpecEpisodes episodes = est::MpecEpisodes::kJoint, bool lsq_start = false) {
    return [method, episodes, lsq_start](const sim::Simulator& s, const Log& log,
                                         double sigma) -> StudyResult {
      est::MpecOptions o;
      o.episodes = episodes;
      o.least_squares_start = lsq_start;
      o.params = {"mu.default"};
      o.noise_sigma = sigma;
      o.solver.method = method;
      o.threads = g_threads;
      o.substeps = g_mpec_substeps;
      o.smooth_initial_guess = !g_mpec_raw_guess;
      o.solver.ordering = g_mpec_ordering;
      if (g_verbose > 0)
        o.progress = [](const std::string& line) { std::cerr << "  " << line << "\n"; };
      if (g_verbose > 1) o.solver.print_level = g_verbose;
      const est::MpecEstimateResult r = est::EstimateMpec(s, log, o);
      return StudyResult{r, r.robust_std_errors[0]};
    };
  };
  return {
      {"lsq", lsq(est::Shooting::kSingle)},
      {"lsq_sens", lsq(est::Shooting::kSingle, est::LeastSquaresJacobian::kSensitivity)},
      {"lsq_ms", lsq(est::Shooting::kMultiple)},
      {"filter",
       [](const sim::Simulator& s, const Log& log, double sigma) {
         est::FilterOptions o;
         o.params = {"mu.default"};
         o.noise_sigma = sigma;
         return StudyResult{est::EstimateFilter(s, log, o)};
       }},
      {"mpec", mpec(est::ComplementarityMethod::kScholtes)},
      {"mpec_pen", mpec(est::ComplementarityMethod::kPenalty)},
      {"mpec_dec", mpec(est::ComplementarityMethod::kScholtes, est::MpecEpisodes::kDecomposed)},
      {"mpec_lsq",
       mpec(est::ComplementarityMethod::kScholtes, est::MpecEpisodes::kJoint, /*lsq_start=*/true)},
  };
}

// The scene file's lines before the bodies' entries.
std::string Header(int dim, const std::string& stepper, double mu) {
  std::ostringstream y;
  y << "dimension: " << dim << "\n"
    << (dim == 2 ? "gravity: [0, -9.81]\n" : "") << "stepper: {" << stepper << "}\n"
    << "friction: {default: " << mu << "}\nbodies:\n";
  return y.str();
}

// A planar plate vibrating at 20 Hz (x acceleration 20 m/s², y 5 m/s², y a quarter cycle
// ahead), with `particles` discs of 2 mm radius spaced 5 cm apart (huge inertia: they slide
// like particles), friction `mu`.
std::string PlateScene(int particles, double mu) {
  std::ostringstream y;
  y << Header(2, "dt: 0.001, duration: 1, envelope: 0.001, prescribed_velocity: exact", mu)
    << "  - name: plate\n    kind: prescribed\n    shapes: [{type: halfplane}]\n"
    << "    motion:\n      frequency: 20\n"
    << "      x: {harmonics: [{order: 1, amplitude: 1.2665e-3, phase: 0}]}\n"
    << "      y: {harmonics: [{order: 1, amplitude: 3.166e-4, phase: 1.5707963267948966}]}\n";
  for (int i = 0; i < particles; ++i) {
    y << "  - name: p" << i << "\n    mass: 0.01\n    inertia: 1.0\n"
      << "    pose: {position: [" << 0.05 * i << ", 0.0023]}\n"
      << "    shapes: [{type: disc, radius: 0.002}]\n";
  }
  return y.str();
}

// The planar block of the estimation tests: 0.4 × 0.2 m, 1 kg, launched at 1.5 m/s.
std::string BlockScene(double mu) {
  std::ostringstream y;
  y << Header(2, "dt: 0.002, duration: 1, envelope: 0.002", mu)
    << "  - {name: floor, kind: static, shapes: [{type: halfplane}]}\n"
    << "  - name: block\n    mass: 1.0\n    pose: {position: [0, 0.1]}\n"
    << "    velocity: {linear: [1.5, 0]}\n"
    << "    shapes: [{type: polygon, vertices: [[-0.2, -0.1], [0.2, -0.1], [0.2, 0.1], "
       "[-0.2, 0.1]]}]\n";
  return y.str();
}

// A 5 cm cube (0.1 kg) tossed onto a table: 12 cm up, 0.8 m/s sideways, spinning.
std::string CubeScene(double mu) {
  std::ostringstream y;
  y << Header(3, "dt: 0.001, duration: 1, friction_directions: 8, envelope: 0.002", mu)
    << "  - {name: table, kind: static, shapes: [{type: halfspace}]}\n"
    << "  - name: cube\n    mass: 0.1\n"
    << "    pose: {position: [0, 0, 0.12], rotation: {axis: [1, 1, 0], angle: 0.4}}\n"
    << "    velocity: {linear: [0.8, 0.2, 0.5], angular: [3, -2, 5]}\n"
    << "    shapes: [{type: box, half_extents: [0.025, 0.025, 0.025]}]\n";
  return y.str();
}

struct Study {
  std::string name;
  double true_mu = 0.2, guess_mu = 0.5;
  double warmup = 0.0;  // s simulated before the log starts
  int every = 2;        // steps per logged sample
  bool orientation = false;
  bool vary_launch = false;  // each episode a different seeded launch (the cube's tosses)
  std::function<std::string(int particles, double mu)> scene;
};

// Simulates the truth and samples the dynamic bodies' poses every `every` steps from `warmup`
// for `window` samples with Gaussian noise σ (angles σ / 0.1 m), `episodes` times. With
// st.vary_launch each episode starts with a seeded launch velocity: the scene's plus N(0, 0.2
// m/s) per horizontal component and N(0, 2 rad/s) per angular one.
Log MakeLog(const sim::Simulator& truth, const Study& st, int window, int episodes, double sigma,
            unsigned seed) {
  const sim::Scene& scene = truth.scene();
  const bool planar = scene.dim == sim::Dim::kPlanar;
  const int warm = static_cast<int>(std::lround(st.warmup / scene.options.dt));
  std::mt19937 rng(seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  Log log;
  for (int e = 0; e < episodes; ++e) {
    sim::State x0 = truth.InitialState();
    if (st.vary_launch) {
      for (const sim::Body& body : scene.bodies) {
        if (body.kind != sim::BodyKind::kDynamic) continue;
        const sim::BodyKinematics k = sim::GetBodyKinematics(scene, x0, body.name);
        Eigen::Vector3d v = k.v_WB, w = k.w_WB;
        v.x() += 0.2 * n01(rng);
        v.y() += 0.2 * n01(rng);
        if (planar) {
          w.z() += 2.0 * n01(rng);
        } else {
          for (int j = 0; j < 3; ++j) w[j] += 2.0 * n01(rng);
        }
        sim::SetBodyVelocity(scene, body.name, v, w, &x0);
      }
    }
    const sim::Trajectory tr = truth.Rollout(truth.DefaultParams(), x0, warm + window * st.every);
    if (!tr.ok) throw std::runtime_error("the true rollout failed: " + tr.failure);
    est::Episode ep;
    ep.file = st.name + "_" + std::to_string(seed) + "_" + std::to_string(e);
    for (int i = 0; i < window; ++i) {
      ep.t.push_back(tr.states[warm + i * st.every].t);
      ep.lines.push_back(i + 2);
    }
    for (int b = 0; b < static_cast<int>(scene.bodies.size()); ++b) {
      if (scene.bodies[b].kind != sim::BodyKind::kDynamic) continue;
      est::BodyTrack track;
      track.body = scene.bodies[b].name;
      track.body_index = b;
      track.dynamic = true;
      track.has_orientation = st.orientation;
      const int qo = scene.index(b).q;
      track.pose = sim::MatrixXd::Zero(window, planar ? 3 : 7);
      for (int i = 0; i < window; ++i) {
        const sim::State& x = tr.states[warm + i * st.every];
        for (int j = 0; j < (planar ? 2 : 3); ++j)
          track.pose(i, j) = x.q[qo + j] + sigma * n01(rng);
        if (!st.orientation) continue;
        if (planar) {
          track.pose(i, 2) = x.q[qo + 2] + sigma / 0.1 * n01(rng);
        } else {
          Eigen::Quaterniond q(x.q[qo + 3], x.q[qo + 4], x.q[qo + 5], x.q[qo + 6]);
          const Eigen::Vector3d d(n01(rng), n01(rng), n01(rng));
          if (sigma > 0)
            q = Eigen::Quaterniond(Eigen::AngleAxisd(sigma / 0.1 * d.norm(), d.normalized())) * q;
          track.pose.row(i).tail(4) << q.w(), q.x(), q.y(), q.z();
        }
      }
      ep.bodies.push_back(std::move(track));
    }
    log.episodes.push_back(std::move(ep));
  }
  return log;
}

std::vector<double> ParseList(const std::string& s) {
  std::vector<double> v;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ',')) v.push_back(std::stod(item));
  return v;
}

// Writes `ep` as a log `vinci estimate` reads: DIR/<ep.file>.csv, a `#` line saying what it is,
// then t and the observed bodies' columns at full precision.
void WriteEpisode(const std::string& dir, const std::string& what, bool planar,
                  const est::Episode& ep) {
  std::filesystem::create_directories(dir);
  const std::string path = dir + "/" + ep.file + ".csv";
  std::ofstream f(path);
  if (!f) throw std::runtime_error("cannot write " + path);
  f << "# " << what << "\n"
    << "t";
  for (const est::BodyTrack& b : ep.bodies) {
    for (const char* c : {"x", "y", "z"}) {
      if (planar && c[0] == 'z') continue;
      f << "," << b.body << "." << c;
    }
    if (!b.has_orientation) continue;
    if (planar) {
      f << "," << b.body << ".theta";
    } else {
      for (const char* c : {"qw", "qx", "qy", "qz"}) f << "," << b.body << "." << c;
    }
  }
  f << "\n";
  f.precision(17);
  for (int i = 0; i < ep.num_samples(); ++i) {
    f << ep.t[i];
    for (const est::BodyTrack& b : ep.bodies) {
      const int cols = (planar ? 2 : 3) + (b.has_orientation ? (planar ? 1 : 4) : 0);
      for (int j = 0; j < cols; ++j) f << "," << b.pose(i, j);
    }
    f << "\n";
  }
  if (!f) throw std::runtime_error("cannot write " + path);
}

std::vector<std::string> ParseNames(const std::string& s) {
  std::vector<std::string> v;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ',')) v.push_back(item);
  return v;
}

constexpr const char* kUsage =
    "usage: estimation_study plate|particles|block|cube [--trials N] [--first-trial K]\n"
    "         [--noise S1,S2] [--windows W1,W2] [--particles N1,N2] [--episodes N]\n"
    "         [--methods lsq,lsq_sens,lsq_ms,filter,mpec,mpec_pen,mpec_dec,mpec_lsq]\n"
    "         [--guess MU]\n"
    "         [--threads N] [--lsq-horizon H] [--lsq-std-errors linearized|profile]\n"
    "         [--mpec-substeps N] [--mpec-raw-guess 1] [--mpec-ordering auto|scotch|qamd]\n"
    "         [--verbose 0|1|IPOPT_PRINT_LEVEL]\n"
    "         [--only-episode K[,L...]] [--write-logs DIR]\n"
    "         [--out F.csv]\n";

int Run(int argc, char** argv) {
  if (argc < 2 || std::string(argv[1]) == "--help") {
    std::cerr << kUsage;
    return argc < 2 ? 1 : 0;
  }
  const std::string which = argv[1];
  Study st;
  st.name = which;
  std::vector<double> noise, windows, particles = {1};
  if (which == "plate" || which == "particles") {
    st.true_mu = 0.2;
    st.guess_mu = 0.3;
    st.warmup = 0.2;
    st.every = 2;  // 500 Hz
    st.scene = PlateScene;
    noise = {1e-5, 1e-4};
    windows = {50, 100};
    if (which == "particles") {
      particles = {1, 2, 4, 8};
      windows = {50};
      noise = {1e-4};
    }
  } else if (which == "block") {
    st.true_mu = 0.3;
    st.guess_mu = 0.5;
    st.every = 5;  // 100 Hz
    st.scene = [](int, double mu) { return BlockScene(mu); };
    noise = {1e-4, 1e-3};
    windows = {30, 60};
  } else if (which == "cube") {
    st.true_mu = 0.4;
    st.guess_mu = 0.6;
    st.every = 7;  // ≈ 143 Hz
    st.orientation = true;
    st.vary_launch = true;
    st.scene = [](int, double mu) { return CubeScene(mu); };
    noise = {3e-5};
    windows = {100};
  } else {
    std::cerr << "unknown study '" << which << "'\n" << kUsage;
    return 1;
  }
  int trials = 20, first_trial = 0, episodes = 1;
  std::vector<int> only_episodes;  // of the trial's episodes keep only these (--only-episode)
  std::string out = "estimation_study_" + which + ".csv";
  std::string logs_dir;  // --write-logs: each estimated episode's log is written there
  std::vector<std::string> method_names;
  for (const auto& m : Methods()) method_names.push_back(m.first);
  for (int i = 2; i < argc; i += 2) {
    const std::string flag = argv[i];
    if (i + 1 >= argc) {
      std::cerr << flag << ": missing value\n" << kUsage;
      return 1;
    }
    const std::string value = argv[i + 1];
    if (flag == "--trials") {
      trials = std::stoi(value);
    } else if (flag == "--first-trial") {
      first_trial = std::stoi(value);
    } else if (flag == "--episodes") {
      episodes = std::stoi(value);
    } else if (flag == "--only-episode") {
      std::stringstream list(value);
      for (std::string k; std::getline(list, k, ',');) only_episodes.push_back(std::stoi(k));
    } else if (flag == "--noise") {
      noise = ParseList(value);
    } else if (flag == "--windows") {
      windows = ParseList(value);
    } else if (flag == "--particles") {
      particles = ParseList(value);
    } else if (flag == "--methods") {
      method_names = ParseNames(value);
    } else if (flag == "--threads") {
      g_threads = std::stoi(value);
    } else if (flag == "--mpec-raw-guess") {
      g_mpec_raw_guess = value != "0";
    } else if (flag == "--mpec-ordering") {
      g_mpec_ordering = est::ParseMpecOrdering(value);
    } else if (flag == "--mpec-substeps") {
      g_mpec_substeps = std::stoi(value);
    } else if (flag == "--lsq-horizon") {
      g_lsq_horizon = std::stoi(value);
    } else if (flag == "--lsq-std-errors") {
      g_lsq_std_errors = est::ParseLeastSquaresStdErrors(value);
    } else if (flag == "--verbose") {
      g_verbose = std::stoi(value);
    } else if (flag == "--guess") {
      st.guess_mu = std::stod(value);
    } else if (flag == "--out") {
      out = value;
    } else if (flag == "--write-logs") {
      logs_dir = value;
    } else {
      std::cerr << "unknown option " << flag << "\n" << kUsage;
      return 1;
    }
  }
  for (const std::string& m : method_names) {
    bool known = false;
    for (const auto& k : Methods()) known |= k.first == m;
    if (!known) {
      std::cerr << "--methods: unknown method '" << m
                << "' (lsq, lsq_sens, lsq_ms, filter, mpec, mpec_pen, mpec_dec, mpec_lsq)\n";
      return 1;
    }
  }
  for (const int k : only_episodes) {
    if (k < 0 || k >= episodes) {
      std::cerr << "--only-episode " << k << ": expected 0 ≤ K < --episodes " << episodes << "\n";
      return 1;
    }
  }
  if (trials < 1 || episodes < 1 || first_trial < 0 || g_threads < 1 || g_mpec_substeps < 0 ||
      g_lsq_horizon < 0 || g_lsq_horizon == 1) {
    std::cerr << "--trials, --episodes and --threads must be ≥ 1, --first-trial and "
                 "--mpec-substeps ≥ 0, --lsq-horizon 0 or ≥ 2\n";
    return 1;
  }
  std::ofstream csv(out);
  if (!csv) {
    std::cerr << "cannot write " << out << "\n";
    return 1;
  }
  csv << "study,method,noise_m,window,particles,episodes,trial,true_mu,mu_hat,std_error,"
         "converged,iterations,time_s,samples,cpu_s,robust_se\n";
  csv.precision(10);
  for (double np : particles) {
    const int n_particles = static_cast<int>(np);
    const sim::Simulator truth(sim::ParseScene(st.scene(n_particles, st.true_mu), "truth.yaml"));
    const sim::Simulator model(sim::ParseScene(st.scene(n_particles, st.guess_mu), "model.yaml"));
    for (double sigma : noise) {
      for (double w : windows) {
        for (int trial = first_trial; trial < first_trial + trials; ++trial) {
          const unsigned seed = 1000u * static_cast<unsigned>(w) + static_cast<unsigned>(trial);
          Log log = MakeLog(truth, st, static_cast<int>(w), episodes, sigma, seed);
          if (!only_episodes.empty()) {
            // The same seeded episodes as in the N-episode trial, estimated without the others.
            std::vector<est::Episode> kept;
            for (const int k : only_episodes) kept.push_back(log.episodes.at(k));
            log.episodes = std::move(kept);
          }
          if (!logs_dir.empty()) {
            std::ostringstream what;
            what << which << " study, trial " << trial << " (seed " << seed << "), true mu "
                 << st.true_mu << ", position noise " << sigma << " m";
            for (const est::Episode& ep : log.episodes)
              WriteEpisode(logs_dir, what.str(), truth.scene().dim == sim::Dim::kPlanar, ep);
          }
          for (const auto& [name, estimator] : Methods()) {
            bool wanted = false;
            for (const std::string& m : method_names) wanted |= m == name;
            if (!wanted) continue;
            StudyResult result;
            const double cpu0 = CpuSeconds();
            try {
              result = estimator(model, log, sigma);
            } catch (const std::exception& e) {
              std::cerr << name << " trial " << trial << ": " << e.what() << "\n";
              continue;
            }
            const EstimateResult& r = result.r;
            csv << which << "," << name << "," << sigma << "," << w << "," << n_particles << ","
                << log.episodes.size() << "," << trial << "," << st.true_mu << "," << r.estimates[0]
                << "," << r.std_errors[0] << "," << (r.converged ? 1 : 0) << "," << r.iterations
                << "," << r.time_s << "," << static_cast<int>(w * log.episodes.size()) << ","
                << CpuSeconds() - cpu0 << "," << result.robust_se << std::endl;
            std::fprintf(
                stderr, "%s %-7s σ=%g w=%g n=%d e=%d trial %2d: μ̂ = %.5f ± %.5f %s %d it %.2f s",
                which.c_str(), name.c_str(), sigma, w, n_particles,
                static_cast<int>(log.episodes.size()), trial, r.estimates[0], r.std_errors[0],
                r.converged ? "" : "(not converged)", r.iterations, r.time_s);
            if (std::isfinite(result.robust_se))
              std::fprintf(stderr, " (robust s.e. %.5f)", result.robust_se);
            std::fprintf(stderr, "\n");
            if (!r.converged) std::cerr << "  reason: " << r.reason << "\n";
            if (r.episodes.size() >= 3) {
              // The worst-fitting episodes (by rms residual, against the median): a wrong local
              // solution shows up here.
              double median = 0.0;
              const std::vector<int> poor = est::PoorlyFittingEpisodes(r.episodes, 3.0, &median);
              std::vector<int> order(r.episodes.size());
              for (std::size_t e = 0; e < order.size(); ++e) order[e] = static_cast<int>(e);
              std::sort(order.begin(), order.end(), [&](int a, int b) {
                return r.episodes[a].rms_residual > r.episodes[b].rms_residual;
              });
              std::fprintf(stderr, "  rms residual: median %.3g m, largest", median);
              for (std::size_t i = 0; i < std::min<std::size_t>(5, order.size()); ++i)
                std::fprintf(stderr, " episode %d %.3g", order[i],
                             r.episodes[order[i]].rms_residual);
              std::fprintf(stderr, "; %zu poorly fitting (> 3x the median)\n", poor.size());
            }
          }
        }
      }
    }
  }
  std::cerr << "wrote " << out << "\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return Run(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "estimation_study: " << e.what() << "\n";
    return 1;
  }
}
