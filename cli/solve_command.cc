#include "solve_command.h"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "json.h"
#include "vinci/sim/solvers/lcp.h"
#include "vinci/sim/solvers/lcp_acceptance.h"
#include "vinci/sim/solvers/lcp_file.h"

namespace vinci::cli {
namespace {

// Shortest decimal text that reads back as exactly `v` (locale-independent); "nan"/"inf" as
// std::to_chars spells them.
void AppendNumber(double v, std::string* s) {
  char buf[32];
  const auto res = std::to_chars(buf, buf + sizeof(buf), v);
  s->append(buf, res.ptr);
}

// A JSON number; JSON has no NaN or infinity, so those are null.
void AppendJsonNumber(double v, std::string* s) {
  if (std::isfinite(v))
    AppendNumber(v, s);
  else
    s->append("null");
}

void AppendJsonArray(const sim::VectorXd& v, std::string* s) {
  *s += '[';
  for (Eigen::Index i = 0; i < v.size(); ++i) {
    if (i > 0) *s += ", ";
    AppendJsonNumber(v(i), s);
  }
  *s += ']';
}

struct Result {
  std::string problem_path;
  int n = 0;
  std::string solver;
  sim::SolverReport report;
  double residual = 0.0;  // LcpResidual of z, independent of the solver
  sim::VectorXd z, w;
};

std::string FormatJson(const Result& r) {
  std::string s = "{\n  \"problem\": ";
  s += JsonString(r.problem_path);
  s += ",\n  \"n\": " + std::to_string(r.n);
  s += ",\n  \"solver\": ";
  s += JsonString(r.solver);
  s += ",\n  \"status\": ";
  s += JsonString(std::string(sim::ToString(r.report.status)));
  s += ",\n  \"iterations\": " + std::to_string(r.report.iterations);
  s += ",\n  \"residual\": ";
  AppendJsonNumber(r.residual, &s);
  s += ",\n  \"time_s\": ";
  AppendJsonNumber(r.report.time_s, &s);
  s += ",\n  \"regularized\": ";
  s += r.report.regularized ? "true" : "false";
  s += ",\n  \"regularization\": ";
  AppendJsonNumber(r.report.regularized ? r.report.regularization : 0.0, &s);
  s += ",\n  \"message\": ";
  s += JsonString(r.report.message);
  s += ",\n  \"z\": ";
  AppendJsonArray(r.z, &s);
  s += ",\n  \"w\": ";
  AppendJsonArray(r.w, &s);
  s += "\n}\n";
  return s;
}

std::string FormatText(const Result& r) {
  std::string s = "problem      " + r.problem_path + " (n = " + std::to_string(r.n) + ")\n";
  s += "solver       " + r.solver + "\n";
  s += "status       " + std::string(sim::ToString(r.report.status)) + "\n";
  s += "iterations   " + std::to_string(r.report.iterations) + "\n";
  s += "residual     ";
  AppendNumber(r.residual, &s);
  s += "  (max_i |min(z_i, w_i)|)\n";
  char time[32];
  std::snprintf(time, sizeof(time), "%.3g", r.report.time_s);
  s += "time         " + std::string(time) + " s\n";
  s += "regularized  ";
  if (r.report.regularized) {
    s += "yes, M + ";
    AppendNumber(r.report.regularization, &s);
    s += " I\n";
  } else {
    s += "no\n";
  }
  if (!r.report.message.empty()) s += "message      " + r.report.message + "\n";
  s += "\ni z w\n";
  for (int i = 0; i < r.n; ++i) {
    s += std::to_string(i + 1);
    s += ' ';
    AppendNumber(r.z(i), &s);
    s += ' ';
    AppendNumber(r.w(i), &s);
    s += '\n';
  }
  return s;
}

std::string JoinNames(const std::vector<std::string>& names) {
  std::string s;
  for (const std::string& n : names) s += (s.empty() ? "" : ", ") + n;
  return s;
}

}  // namespace

ExitCode RunSolve(const SolveOptions& o) {
  // Flags first (no I/O), then the problem, then the warm start (its size comes from the problem).
  std::shared_ptr<const sim::LcpSolver> solver;
  try {
    solver = sim::MakeLcpSolver(o.solver);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string("--solver: ") + e.what());
  }
  const sim::LcpProblem problem = sim::ReadLcpFile(o.problem_path);
  const int n = problem.size();
  sim::VectorXd warm_start;
  if (!o.warm_start_path.empty()) {
    try {
      warm_start = sim::ReadLcpVectorFile(o.warm_start_path, n);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(std::string("--warm-start: ") + e.what());
    }
  }

  Result r;
  r.problem_path = o.problem_path;
  r.n = n;
  r.solver = o.solver;
  r.report = solver->Solve(problem, warm_start.size() > 0 ? &warm_start : nullptr, &r.z);
  if (r.z.size() != n) {
    throw std::logic_error("solver '" + o.solver + "' returned z of size " +
                           std::to_string(r.z.size()) + " for a problem of size " +
                           std::to_string(n));
  }
  // The shared scale-aware acceptance test, independent of the solver's own.
  sim::ConfirmSolved(problem, r.z, &r.report);
  r.w = problem.M * r.z + problem.q;
  r.residual = sim::LcpResidual(problem, r.z);

  std::cout << (o.json ? FormatJson(r) : FormatText(r)) << std::flush;
  if (r.report.ok()) return ExitCode::kOk;
  std::string msg = "solver '" + o.solver + "' did not solve " + o.problem_path + ": " +
                    std::string(sim::ToString(r.report.status));
  if (!r.report.message.empty()) msg += " (" + r.report.message + ")";
  PrintError(msg);
  return ExitCode::kSolveFailed;
}

Command RegisterSolveCommand(CLI::App& app) {
  auto options = std::make_shared<SolveOptions>();
  CLI::App* sub = app.add_subcommand(
      "solve", "Solve an LCP read from a text file; print z, w = Mz + q and the report.");
  sub->add_option("PROBLEM", options->problem_path,
                  "LCP file: n, then M row by row, then q; '#' comments (see docs/lcp-format.md)")
      ->required();
  sub->add_option("--solver", options->solver,
                  "LCP solver, one of: " + JoinNames(sim::LcpSolverNames()))
      ->type_name("NAME")
      ->capture_default_str();
  sub->add_flag("--json", options->json,
                "Print one JSON object (solver, status, iterations, residual, time_s, "
                "regularized, regularization, message, z, w) instead of text");
  sub->add_option("--warm-start", options->warm_start_path,
                  "Start from this guess of z: a file of n numbers >= 0 in the same format")
      ->type_name("FILE");
  sub->footer(
      "Text output: a report (residual = max_i |min(z_i, w_i)|, computed independently of the "
      "solver), then one line 'i z_i w_i' per variable (i from 1). Numbers are printed in the "
      "shortest form that reads back exactly.\n"
      "Exit status: 0 solved; 1 bad input (unknown solver, unreadable or malformed file); 3 the "
      "solver did not solve the problem (the report is still printed; the reason goes to "
      "stderr).");
  return Command{sub, [options] { return RunSolve(*options); }};
}

}  // namespace vinci::cli
