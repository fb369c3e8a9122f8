#include "simulate_command.h"

#include <unistd.h>

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdint>
#include <fstream>
#include <initializer_list>
#include <iomanip>
#include <iostream>
#include <limits>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "vinci/sim/formulations/contact.h"
#include "vinci/sim/formulations/formulation.h"
#include "vinci/sim/model/scene.h"
#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/model/state.h"
#include "vinci/sim/simulator/sensitivity.h"
#include "vinci/sim/simulator/simulator.h"
#include "vinci/sim/solvers/lcp.h"
#include "vinci/sim/solvers/text_format.h"

namespace vinci::cli {
namespace {

using Clock = std::chrono::steady_clock;
using sim::Dim;

// Guards the double → integer conversion of the step count; far beyond any real run.
constexpr double kMaxSteps = 1e12;
// Unflushed CSV rows are at most this old (a crash loses no more than this much output).
constexpr double kFlushIntervalS = 0.1;
// Progress on a terminal is redrawn at most this often; on a pipe or file it is printed every
// 10% once the run has lasted this long.
constexpr double kTtyRedrawS = 0.1;
constexpr double kQuietRunS = 2.0;
constexpr double kTwoPi = 6.283185307179586476925286766559;

double Seconds(Clock::duration d) { return std::chrono::duration<double>(d).count(); }

// Shortest decimal text that reads back as exactly `v` (full precision, locale-independent).
void AppendNumber(double v, std::string* s) {
  char buf[32];
  const auto res = std::to_chars(buf, buf + sizeof(buf), v);
  s->append(buf, res.ptr);
}

std::string Number(double v) {
  std::string s;
  AppendNumber(v, &s);
  return s;
}

// A CSV field, quoted (RFC 4180) only if it has to be.
std::string CsvField(const std::string& s) {
  if (s.find_first_of(",\"\r\n") == std::string::npos) return s;
  std::string q = "\"";
  for (char c : s) q += (c == '"') ? std::string("\"\"") : std::string(1, c);
  return q + "\"";
}

void CheckPositiveFinite(const char* flag, double value) {
  if (!std::isfinite(value) || value <= 0.0)
    throw std::invalid_argument(std::string(flag) + ": expected a finite number > 0 (s), got " +
                                Number(value));
}

// The per-body columns of a trajectory row: world pose and velocity of every body in scene
// order. Planar (x, y, θ, vx, vy, ω); spatial (p, quaternion wxyz, v_W, ω_W). Dynamic bodies
// report their generalized coordinates (θ unwrapped as integrated); the angle of a prescribed
// planar body is unwrapped and the quaternion of a prescribed spatial body kept on the
// hemisphere of the previous row, so that every column is continuous in time.
class BodyColumns {
 public:
  explicit BodyColumns(const sim::Scene& scene) : scene_(scene) {
    for (const sim::Body& b : scene.bodies) {
      const sim::Matrix3d R = b.X_WB0.linear();
      theta_.push_back(std::atan2(R(1, 0), R(0, 0)));
      sim::Quaterniond q(R);
      if (q.w() < 0) q.coeffs() *= -1.0;
      quat_.push_back(q);
    }
  }

  int per_body() const { return scene_.dim == Dim::kPlanar ? 6 : 13; }

  // "<body>.<column>" of every body, body after body (per_body() each).
  std::vector<std::string> Names() const {
    static const char* const kPlanar[] = {"x", "y", "theta", "vx", "vy", "omega"};
    static const char* const kSpatial[] = {"x",  "y",  "z",  "qw", "qx", "qy", "qz",
                                           "vx", "vy", "vz", "wx", "wy", "wz"};
    std::vector<std::string> names;
    for (const sim::Body& b : scene_.bodies)
      for (int i = 0; i < per_body(); ++i)
        names.push_back(b.name + "." + (scene_.dim == Dim::kPlanar ? kPlanar[i] : kSpatial[i]));
    return names;
  }

  std::string Header() const {
    std::string h;
    for (const std::string& n : Names()) h += ',' + CsvField(n);
    return h;
  }

  // Values of all bodies at x, body after body (per_body() each).
  const std::vector<double>& Evaluate(const sim::State& x) {
    const std::vector<sim::BodyKinematics> kin = sim::ComputeBodyKinematics(scene_, x);
    values_.clear();
    for (std::size_t i = 0; i < kin.size(); ++i) {
      const sim::Body& b = scene_.bodies[i];
      const sim::BodyKinematics& k = kin[i];
      const bool dynamic = b.kind == sim::BodyKind::kDynamic;
      const double* q = dynamic ? x.q.data() + scene_.index(static_cast<int>(i)).q : nullptr;
      const sim::Vector3d p = k.X_WB.translation();
      if (scene_.dim == Dim::kPlanar) {
        double theta;
        if (dynamic) {
          theta = q[2];
        } else {
          const sim::Matrix3d R = k.X_WB.linear();
          theta = theta_[i] + std::remainder(std::atan2(R(1, 0), R(0, 0)) - theta_[i], kTwoPi);
          theta_[i] = theta;
        }
        Push({p.x(), p.y(), theta, k.v_WB.x(), k.v_WB.y(), k.w_WB.z()});
      } else {
        sim::Quaterniond quat;
        if (dynamic) {
          quat = sim::Quaterniond(q[3], q[4], q[5], q[6]);
        } else {
          quat = sim::Quaterniond(k.X_WB.linear());
          if (quat.coeffs().dot(quat_[i].coeffs()) < 0) quat.coeffs() *= -1.0;
          quat_[i] = quat;
        }
        Push({p.x(), p.y(), p.z(), quat.w(), quat.x(), quat.y(), quat.z(), k.v_WB.x(), k.v_WB.y(),
              k.v_WB.z(), k.w_WB.x(), k.w_WB.y(), k.w_WB.z()});
      }
    }
    return values_;
  }

 private:
  void Push(std::initializer_list<double> v) { values_.insert(values_.end(), v); }

  const sim::Scene& scene_;
  std::vector<double> theta_;           // last reported angle (planar, non-dynamic)
  std::vector<sim::Quaterniond> quat_;  // last reported quaternion (spatial, non-dynamic)
  std::vector<double> values_;
};

// Writes the trajectory as it is produced. Rows are flushed at least every kFlushIntervalS
// and on Close(), so an interrupted run leaves every completed row but the last few on disk.
class CsvWriter {
 public:
  explicit CsvWriter(const std::string& path)
      : path_(path), out_(path, std::ios::out | std::ios::trunc) {
    if (!out_) throw std::invalid_argument("--out: cannot open '" + path + "' for writing");
  }

  void Write(const std::string& line) {
    out_.write(line.data(), static_cast<std::streamsize>(line.size()));
    out_.put('\n');
    ++rows_;
    const Clock::time_point now = Clock::now();
    if (Seconds(now - last_flush_) >= kFlushIntervalS) Flush(now);
  }

  void Flush(Clock::time_point now = Clock::now()) {
    out_.flush();
    last_flush_ = now;
    if (!out_) throw std::invalid_argument("--out: writing '" + path_ + "' failed");
  }

  void Close() {
    Flush();
    out_.close();
    if (!out_) throw std::invalid_argument("--out: writing '" + path_ + "' failed");
  }

  std::int64_t rows() const { return rows_; }  // data rows and header

 private:
  std::string path_;
  std::ofstream out_;
  std::int64_t rows_ = 0;
  Clock::time_point last_flush_ = Clock::now();
};

// Progress on stderr: a line redrawn in place on a terminal; otherwise one line per 10% once
// the run has taken longer than kQuietRunS (short runs in scripts stay silent).
class Progress {
 public:
  Progress(bool enabled, std::int64_t total)
      : enabled_(enabled && total > 0), tty_(isatty(STDERR_FILENO) == 1), total_(total) {}

  void Update(std::int64_t done, double t) {
    if (!enabled_ || done >= total_) return;
    const Clock::time_point now = Clock::now();
    const double elapsed = Seconds(now - start_);
    const int percent = static_cast<int>(100 * done / total_);
    if (tty_) {
      if (Seconds(now - last_draw_) < kTtyRedrawS) return;
      last_draw_ = now;
      std::cerr << "\r\033[Kvinci simulate: " << std::setw(3) << percent << "% (" << done << "/"
                << total_ << " steps, t = " << t << " s, " << std::fixed << std::setprecision(1)
                << elapsed << " s)" << std::defaultfloat << std::setprecision(6) << std::flush;
      drawn_ = true;
    } else if (elapsed >= kQuietRunS && percent / 10 > last_decile_) {
      last_decile_ = percent / 10;
      std::cerr << "vinci simulate: " << 10 * last_decile_ << "% (" << done << "/" << total_
                << " steps, t = " << t << " s, " << std::fixed << std::setprecision(1) << elapsed
                << " s)" << std::defaultfloat << std::setprecision(6) << std::endl;
    }
  }

  // Clears the in-place line so the summary starts on a clean terminal line.
  void Finish() {
    if (drawn_) std::cerr << "\r\033[K" << std::flush;
    drawn_ = false;
  }

 private:
  bool enabled_, tty_;
  std::int64_t total_;
  Clock::time_point start_ = Clock::now();
  Clock::time_point last_draw_ = start_;  // first drawn after kTtyRedrawS: short runs stay quiet
  bool drawn_ = false;
  int last_decile_ = 0;
};

// The sensitivity columns (--sensitivity): forward-mode S = ∂x/∂θ (sensitivity.h) and, for each
// parameter, the derivative of every dynamic body's columns along its S column, by a central
// difference of the column map (smooth in the state; O(h²) with h = 1e-6 of the state's scale).
class SensitivityColumns {
 public:
  SensitivityColumns(const sim::Simulator& sim, const std::vector<std::string>& names)
      : sim_(sim), names_(names), selection_(MakeSelection(sim, names)) {
    const int nx = sim.scene().num_positions() + sim.scene().num_velocities();
    S_ = sim::MatrixXd::Zero(nx, selection_.size());
  }

  std::string Header(const BodyColumns& columns) const {
    const std::vector<std::string> all = columns.Names();
    std::string out;
    for (const std::string& name : names_)
      for (int bi : sim_.scene().dynamic_bodies())
        for (int c = 0; c < columns.per_body(); ++c)
          out += "," + CsvField("d(" + all[static_cast<std::size_t>(bi) * columns.per_body() + c] +
                                ")/d(" + name + ")");
    return out + ",sensitivity_status";
  }

  // Advances S over the step x → next and returns its status.
  sim::SensitivityStatus Step(const sim::Params& params, const sim::State& x,
                              const sim::StepInput& u, const sim::State& next) {
    sim::MatrixXd S1;
    const sim::StepSensitivity st =
        sim::PropagateStep(sim_, params, selection_, x, u, next, S_, &S1, {}, &ws_);
    S_ = std::move(S1);
    return st.status;
  }

  // The derivative columns at x (after Step, or the zeros of the initial state).
  void Append(const sim::State& x, const char* status, std::string* row) const {
    const sim::Scene& scene = sim_.scene();
    const int nq = scene.num_positions();
    for (int j = 0; j < S_.cols(); ++j) {
      const sim::VectorXd s = S_.col(j);
      std::vector<double> d;
      const double sn = s.cwiseAbs().maxCoeff();
      if (!std::isfinite(sn)) {
        d.assign(Width(), std::numeric_limits<double>::quiet_NaN());
      } else if (sn == 0.0) {
        d.assign(Width(), 0.0);
      } else {
        const double xn = std::max(
            {1.0, x.q.cwiseAbs().maxCoeff(), x.v.size() ? x.v.cwiseAbs().maxCoeff() : 0.0});
        const double h = 1e-6 * xn / sn;
        sim::State xp = x, xm = x;
        xp.q += h * s.head(nq);
        xm.q -= h * s.head(nq);
        xp.v += h * s.tail(s.size() - nq);
        xm.v -= h * s.tail(s.size() - nq);
        BodyColumns cp(scene), cm(scene);
        const std::vector<double> vp = cp.Evaluate(xp), vm = cm.Evaluate(xm);
        for (int bi : scene.dynamic_bodies())
          for (int c = 0; c < cp.per_body(); ++c) {
            const std::size_t k = static_cast<std::size_t>(bi) * cp.per_body() + c;
            d.push_back((vp[k] - vm[k]) / (2 * h));
          }
      }
      for (double v : d) {
        *row += ',';
        AppendNumber(v, row);
      }
    }
    *row += ',';
    *row += status;
  }

 private:
  static sim::ParamSelection MakeSelection(const sim::Simulator& sim,
                                           const std::vector<std::string>& names) {
    const std::vector<std::string> allowed =
        sim::SensitivityParameterNames(sim.scene().param_table());
    for (const std::string& n : names)
      if (std::find(allowed.begin(), allowed.end(), n) == allowed.end()) {
        std::string list;
        for (const std::string& a : allowed) list += (list.empty() ? "" : ", ") + a;
        throw std::invalid_argument("--sensitivity: '" + sim::EscapeText(n) +
                                    "' is not a parameter the step can be differentiated by; "
                                    "expected one of: " +
                                    (list.empty() ? std::string("(none in this scene)") : list));
      }
    return sim::ParamSelection(sim.scene().param_table(), names);
  }
  std::size_t Width() const {
    return sim_.scene().dynamic_bodies().size() *
           static_cast<std::size_t>(sim_.scene().dim == Dim::kPlanar ? 6 : 13);
  }

  const sim::Simulator& sim_;
  std::vector<std::string> names_;
  sim::Workspace ws_;  // the scene resolved once for every step's derivative
  sim::ParamSelection selection_;
  sim::MatrixXd S_;
};

// Aggregates of the successful steps.
struct RunStats {
  std::int64_t steps_done = 0;
  int max_contacts = 0;
  std::int64_t total_iterations = 0;
  int max_iterations = 0;
  double worst_residual = 0.0;

  void Add(const sim::StepInfo& info) {
    ++steps_done;
    max_contacts = std::max(max_contacts, info.contacts);
    total_iterations += info.solver.iterations;
    max_iterations = std::max(max_iterations, info.solver.iterations);
    if (!(info.solver.residual <= worst_residual)) worst_residual = info.solver.residual;  // NaN
  }
};

// Columns after the bodies: the report of the step that produced the row.
void AppendStepColumns(const sim::StepInfo* info, std::string* row) {
  if (info == nullptr) {  // row 0, the initial state
    row->append(",0,0,0,0,initial");
    return;
  }
  *row += ',';
  *row += std::to_string(info->contacts);
  *row += ',';
  *row += std::to_string(info->solver.iterations);
  *row += ',';
  AppendNumber(info->solver.residual, row);
  *row += ',';
  AppendNumber(info->min_gap, row);
  *row += ',';
  *row += sim::ToString(info->solver.status);
}

std::string FormatRow(std::int64_t step, const sim::State& x, const std::vector<double>& bodies,
                      const sim::StepInfo* info) {
  std::string row = std::to_string(step);
  row += ',';
  AppendNumber(x.t, &row);
  for (double v : bodies) {
    row += ',';
    AppendNumber(v, &row);
  }
  AppendStepColumns(info, &row);
  return row;
}

void PrintSummary(const sim::Simulator& simulator, const RunStats& stats, std::int64_t num_steps,
                  double t_final, double wall_s, const std::vector<double>& final_values,
                  int per_body, const std::string& out, std::int64_t csv_rows, bool partial) {
  const sim::Scene& scene = simulator.scene();
  int count[3] = {0, 0, 0};
  for (const sim::Body& b : scene.bodies) ++count[static_cast<int>(b.kind)];
  std::ostringstream s;
  s << std::setprecision(6);
  s << "scene       " << (scene.name.empty() ? "(unnamed)" : scene.name) << " ("
    << (scene.dim == Dim::kPlanar ? "planar" : "spatial") << ", " << scene.bodies.size()
    << " bodies: " << count[0] << " dynamic, " << count[1] << " static, " << count[2]
    << " prescribed)\n";
  s << "steps       " << stats.steps_done << " / " << num_steps << " (dt = " << scene.options.dt
    << " s, formulation " << sim::ToString(scene.options.formulation) << ", solver "
    << scene.options.solver << ")" << (partial ? "  PARTIAL" : "") << "\n";
  s << "simulated   " << t_final << " s\n";
  s << "wall time   " << wall_s << " s";
  if (wall_s > 0 && stats.steps_done > 0)
    s << " (" << std::fixed << std::setprecision(0)
      << static_cast<double>(stats.steps_done) / wall_s << std::defaultfloat << std::setprecision(6)
      << " steps/s)";
  s << "\n";
  s << "contacts    max " << stats.max_contacts << " per step\n";
  s << "solver      " << stats.total_iterations << " iterations in total, max "
    << stats.max_iterations << " per step, worst residual " << stats.worst_residual << "\n";
  bool first = true;
  for (int bi : scene.dynamic_bodies()) {
    const double* v = final_values.data() + static_cast<std::size_t>(bi) * per_body;
    s << (first ? "final pose  " : "            ") << scene.bodies[bi].name << ": ";
    if (scene.dim == Dim::kPlanar)
      s << "x = " << v[0] << " m, y = " << v[1] << " m, theta = " << v[2] << " rad\n";
    else
      s << "p = (" << v[0] << ", " << v[1] << ", " << v[2] << ") m, q(wxyz) = (" << v[3] << ", "
        << v[4] << ", " << v[5] << ", " << v[6] << ")\n";
    first = false;
  }
  if (out.empty())
    s << "trajectory  not written (use --out FILE)\n";
  else
    s << "trajectory  " << out << " (" << csv_rows - 1 << (csv_rows == 2 ? " state" : " states")
      << (partial ? ", partial" : "") << ")\n";
  std::cout << s.str() << std::flush;
}

// "a, b, c".
std::string JoinNames(const std::vector<std::string>& names) {
  std::string s;
  for (const std::string& n : names) s += (s.empty() ? "" : ", ") + n;
  return s;
}

// The solver names each formulation accepts (sim::SolverNames), formulations with the same
// list grouped: "stewart-trinkle, ...: lemke, pgs, fb-newton; gi: lemke, semismooth-newton".
std::string SolverHelp() {
  std::vector<std::pair<std::vector<std::string>, std::vector<std::string>>> groups;
  for (const auto& [name, type] : sim::FormulationTable()) {
    const std::vector<std::string> solvers = sim::SolverNames(type);
    auto it = std::find_if(groups.begin(), groups.end(),
                           [&](const auto& g) { return g.first == solvers; });
    if (it == groups.end()) it = groups.insert(groups.end(), {solvers, {}});
    it->second.push_back(name);
  }
  std::string s;
  for (const auto& [solvers, formulations] : groups)
    s += (s.empty() ? "" : "; ") + JoinNames(formulations) + ": " + JoinNames(solvers);
  return "By formulation: " + s;
}

}  // namespace

ExitCode RunSimulate(const SimulateOptions& o) {
  // Flags first (no I/O), then the scene, then the output file.
  if (o.dt) CheckPositiveFinite("--dt", *o.dt);
  if (o.duration) CheckPositiveFinite("--duration", *o.duration);

  sim::Scene scene = sim::LoadSceneFile(o.scene_path);
  for (const std::string& w : sim::SceneWarnings(scene))
    std::cerr << "vinci: warning: " << o.scene_path << ": " << sim::EscapeText(w) << "\n";
  if (o.dt) scene.options.dt = *o.dt;  // before the Simulator copies the scene
  if (o.duration) scene.options.duration = *o.duration;
  if (o.formulation) {
    try {
      scene.options.formulation = sim::ParseFormulation(*o.formulation);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(std::string("--formulation: ") + e.what());
    }
  }
  if (o.solver) scene.options.solver = *o.solver;
  if (o.solver || o.formulation) {
    // The solver (given or the scene's) must be one the formulation (given or the scene's)
    // accepts.
    const std::vector<std::string> names = sim::SolverNames(scene.options.formulation);
    if (std::find(names.begin(), names.end(), scene.options.solver) == names.end())
      throw std::invalid_argument(
          std::string(o.solver ? "--solver: '" : "--formulation: the scene's solver '") +
          scene.options.solver + "' is not a solver of formulation " +
          std::string(sim::ToString(scene.options.formulation)) +
          "; expected one of: " + JoinNames(names) + (o.solver ? "" : " (use --solver)"));
    try {
      sim::MakeFormulation(scene.options);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(std::string(o.solver ? "--solver: " : "--formulation: ") +
                                  e.what());
    }
  }
  const double dt = scene.options.dt, duration = scene.options.duration;
  const double steps_real = std::round(duration / dt);
  if (!(steps_real >= 1.0))
    throw std::invalid_argument("duration " + Number(duration) + " s with dt " + Number(dt) +
                                " s gives no step; expected duration >= dt / 2");
  if (steps_real > kMaxSteps)
    throw std::invalid_argument("duration " + Number(duration) + " s with dt " + Number(dt) +
                                " s gives " + Number(steps_real) + " steps; expected at most " +
                                Number(kMaxSteps));
  const auto num_steps = static_cast<std::int64_t>(steps_real);

  const sim::Simulator simulator(std::move(scene));
  const sim::Params params = simulator.DefaultParams();
  BodyColumns columns(simulator.scene());

  std::unique_ptr<SensitivityColumns> sens;
  if (!o.sensitivity.empty()) {
    if (o.out.empty()) throw std::invalid_argument("--sensitivity: needs --out FILE");
    sens = std::make_unique<SensitivityColumns>(simulator, o.sensitivity);
  }
  std::unique_ptr<CsvWriter> csv;
  if (!o.out.empty()) csv = std::make_unique<CsvWriter>(o.out);

  const Clock::time_point start = Clock::now();
  sim::Workspace ws;
  const sim::StepInput no_input;
  sim::State x = simulator.InitialState(), next;
  if (csv) {
    std::string header =
        "step,t" + columns.Header() + ",contacts,solver_iterations,residual,min_gap,status";
    std::string row0 = FormatRow(0, x, columns.Evaluate(x), nullptr);
    if (sens) {
      header += sens->Header(columns);
      sens->Append(x, "initial", &row0);
    }
    csv->Write(header);
    csv->Write(row0);
    csv->Flush();  // the header and the initial state exist whatever happens next
  }

  RunStats stats;
  Progress progress(!o.quiet, num_steps);
  sim::StepInfo failed;
  std::int64_t failed_step = -1;
  // SIGINT/SIGTERM during the run: the loop stops after the current step and the results so far
  // are written as for a failed step.
  InterruptGuard interrupt_guard;
  for (std::int64_t k = 0; k < num_steps; ++k) {
    if (Interrupted()) break;
    sim::StepInfo info = simulator.Step(params, x, no_input, &ws, &next);
    if (!info.ok) {
      failed = std::move(info);
      failed_step = k;
      break;
    }
    const char* sens_status = nullptr;
    if (sens) sens_status = sim::SensitivityStatusName(sens->Step(params, x, no_input, next));
    std::swap(x, next);
    stats.Add(info);
    if (csv) {
      std::string row = FormatRow(k + 1, x, columns.Evaluate(x), &info);
      if (sens) sens->Append(x, sens_status, &row);
      csv->Write(row);
    }
    progress.Update(k + 1, x.t);
  }
  progress.Finish();
  if (csv) csv->Close();
  const double wall_s = Seconds(Clock::now() - start);

  const bool interrupted = failed_step < 0 && stats.steps_done < num_steps;
  const bool ok = failed_step < 0 && !interrupted;
  if (!o.quiet)
    PrintSummary(simulator, stats, num_steps, x.t, wall_s, columns.Evaluate(x), columns.per_body(),
                 o.out, csv ? csv->rows() : 0, !ok);
  if (ok) return ExitCode::kOk;
  if (interrupted) {
    std::ostringstream msg;
    msg << "interrupted after " << stats.steps_done << " of " << num_steps << " steps";
    if (csv) msg << "; the trajectory in '" << o.out << "' is partial";
    PrintError(msg.str());
    return ExitCode::kInterrupted;
  }
  std::ostringstream msg;
  msg << std::setprecision(17) << "step " << failed_step << " (from t = " << x.t
      << " s) failed: " << failed.failure;
  if (csv)
    msg << "\nthe trajectory in '" << o.out << "' is partial: states 0.." << stats.steps_done
        << " of " << num_steps;
  PrintError(msg.str());
  return ExitCode::kSolveFailed;
}

Command RegisterSimulateCommand(CLI::App& app) {
  auto options = std::make_shared<SimulateOptions>();
  CLI::App* sub =
      app.add_subcommand("simulate", "Simulate a scene and write its trajectory as CSV.");
  sub->add_option("SCENE", options->scene_path, "Scene file (YAML, see docs/scene-format.md)")
      ->required()
      ->check(CLI::ExistingFile);
  sub->add_option_function<double>(
         "--duration", [options](double v) { options->duration = v; },
         "Simulated time in s (default: the scene's stepper.duration); runs "
         "round(duration / dt) steps")
      ->type_name("T");
  sub->add_option_function<double>(
         "--dt", [options](double v) { options->dt = v; },
         "Time step in s (default: the scene's stepper.dt)")
      ->type_name("H");
  sub->add_option("--out,-o", options->out,
                  "Write the trajectory to this CSV file: a header, then one row per state (row "
                  "0 = initial state): step, t, each body's pose and velocity, and the report of "
                  "the step that produced it")
      ->type_name("FILE");
  sub->add_option_function<std::string>(
         "--formulation", [options](const std::string& v) { options->formulation = v; },
         "Time-stepping formulation (default: the scene's stepper.formulation), one of: " +
             JoinNames(sim::FormulationNames()) + " (docs/formulations.md)")
      ->type_name("NAME");
  sub->add_option_function<std::string>(
         "--solver", [options](const std::string& v) { options->solver = v; },
         "Complementarity solver by name (default: the scene's stepper.solver). " + SolverHelp())
      ->type_name("NAME");
  sub->add_option("--sensitivity", options->sensitivity,
                  "Differentiate the trajectory by these parameters (comma-separated; friction "
                  "mu.*, support_mu.*, mass.*, and motion.* of prescribed bodies): adds the "
                  "columns d(<column>)/d(<NAME>) of every dynamic body and sensitivity_status "
                  "(exact, degenerate, mode_change, failed) per step (docs/sensitivity.md). Needs "
                  "--out")
      ->delimiter(',')
      ->type_name("NAME[,NAME...]");
  sub->add_flag("--quiet,-q", options->quiet, "Print nothing but errors (no progress, no summary)");
  sub->footer(
      "CSV columns: step,t, then per body (all bodies, scene order) planar "
      "<name>.x,.y,.theta,.vx,.vy,.omega or spatial <name>.x,.y,.z,.qw,.qx,.qy,.qz,.vx,.vy,.vz,"
      ".wx,.wy,.wz (world frame), then contacts,solver_iterations,residual,min_gap,status.\n"
      "If a step fails, the CSV keeps every state up to the last good one and vinci exits 3.");
  return Command{sub, [options] { return RunSimulate(*options); }};
}

}  // namespace vinci::cli
