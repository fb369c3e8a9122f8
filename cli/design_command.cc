#include "design_command.h"

#include <unistd.h>

#include <cerrno>
#include <charconv>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "distributed.h"
#include "json.h"
#include "vinci/design/best_scene.h"
#include "vinci/design/distributed_evaluator.h"
#include "vinci/design/optimize.h"
#include "vinci/design/ranking.h"
#include "vinci/design/spec.h"
#include "vinci/parallel/mpi.h"

namespace vinci::cli {
namespace {

namespace fs = std::filesystem;
using design::Evaluation;

constexpr double kTtyRedrawS = 0.2;
constexpr int kRankingSize = 10;  // designs in result.json's and the summary's ranking

// A history.csv number: the shortest text that reads back as exactly v ("nan", "inf" as such).
std::string CsvNumber(double v) {
  char buf[32];
  const auto res = std::to_chars(buf, buf + sizeof(buf), v);
  return std::string(buf, res.ptr);
}

std::string Duration(double s) {
  std::ostringstream o;
  if (s < 60)
    o << std::fixed << std::setprecision(0) << s << " s";
  else
    o << static_cast<int>(s / 60) << " min " << static_cast<int>(std::fmod(s, 60.0)) << " s";
  return o.str();
}

// history.csv: one row per evaluation; x with full precision so that --resume matches exactly.
std::string HistoryHeader(const design::DesignSpec& spec) {
  std::string h = "index,phase,stream,samples";
  for (const design::DesignParameter& p : spec.parameters) h += "," + p.name;
  return h + ",objective,loss,successes,lower,upper,failures,time_s";
}

std::string HistoryRow(const design::HistoryEntry& e) {
  std::string r = std::to_string(e.index) + "," + e.phase + "," + std::to_string(e.eval.stream) +
                  "," + std::to_string(e.eval.samples);
  for (Eigen::Index k = 0; k < e.eval.x.size(); ++k) r += "," + CsvNumber(e.eval.x[k]);
  r += "," + CsvNumber(e.eval.objective) + "," + CsvNumber(e.eval.loss) + "," +
       std::to_string(e.eval.successes) + "," + CsvNumber(e.eval.lower) + "," +
       CsvNumber(e.eval.upper) + "," + std::to_string(e.eval.failures) + "," +
       CsvNumber(e.eval.time_s);
  return r;
}

std::vector<std::string> SplitCsv(const std::string& line) {
  std::vector<std::string> f;
  std::string cur;
  for (char c : line) {
    if (c == ',') {
      f.push_back(cur);
      cur.clear();
    } else if (c != '\r') {
      cur += c;
    }
  }
  f.push_back(cur);
  return f;
}

double ParseDouble(const std::string& s, const std::string& where) {
  double v = 0.0;
  const auto res = std::from_chars(s.data(), s.data() + s.size(), v);
  if (res.ec != std::errc() || res.ptr != s.data() + s.size())
    throw std::invalid_argument(where + ": expected a number, got '" + s + "'");
  return v;
}

long long ParseInt(const std::string& s, const std::string& where) {
  long long v = 0;
  const auto res = std::from_chars(s.data(), s.data() + s.size(), v);
  if (res.ec != std::errc() || res.ptr != s.data() + s.size())
    throw std::invalid_argument(where + ": expected an integer, got '" + s + "'");
  return v;
}

unsigned long long ParseUnsigned(const std::string& s, const std::string& where) {
  unsigned long long v = 0;
  const auto res = std::from_chars(s.data(), s.data() + s.size(), v);
  if (res.ec != std::errc() || res.ptr != s.data() + s.size())
    throw std::invalid_argument(where + ": expected an integer, got '" + s + "'");
  return v;
}

// Reads a previous history; a truncated last line (a crash mid-write) is dropped.
std::vector<Evaluation> ReadHistory(const std::string& path, const design::DesignSpec& spec) {
  std::ifstream in(path);
  if (!in) throw std::invalid_argument("--resume: cannot open '" + path + "'");
  std::string line;
  const std::string header = HistoryHeader(spec);
  if (!std::getline(in, line) || line != header)
    throw std::invalid_argument(path + ":1: expected the header '" + header +
                                "' (a history of this spec), got '" + line + "'");
  const std::size_t n = spec.parameters.size();
  std::vector<Evaluation> rows;
  std::vector<std::string> lines;
  while (std::getline(in, line)) lines.push_back(line);
  const bool complete_last = [&] {
    in.clear();
    in.seekg(-1, std::ios::end);
    char c = 0;
    return in.get(c) && c == '\n';
  }();
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const std::string where = path + ":" + std::to_string(i + 2);
    const std::vector<std::string> f = SplitCsv(lines[i]);
    if (f.size() != 4 + n + 7) {
      if (i + 1 == lines.size() && !complete_last) break;  // cut off by an interruption
      throw std::invalid_argument(where + ": expected " + std::to_string(4 + n + 7) +
                                  " fields, got " + std::to_string(f.size()));
    }
    Evaluation e;
    e.stream = ParseUnsigned(f[2], where);
    e.samples = static_cast<int>(ParseInt(f[3], where));
    e.x.resize(static_cast<Eigen::Index>(n));
    for (std::size_t k = 0; k < n; ++k) e.x[k] = ParseDouble(f[4 + k], where);
    e.objective = ParseDouble(f[4 + n], where);
    e.loss = ParseDouble(f[5 + n], where);
    e.successes = static_cast<int>(ParseInt(f[6 + n], where));
    e.lower = ParseDouble(f[7 + n], where);
    e.upper = ParseDouble(f[8 + n], where);
    e.failures = static_cast<int>(ParseInt(f[9 + n], where));
    e.time_s = ParseDouble(f[10 + n], where);
    rows.push_back(e);
  }
  return rows;
}

std::string EvaluationJson(const design::DesignSpec& spec, const Evaluation& e,
                           const std::string& indent) {
  std::ostringstream o;
  o << "{\"samples\": " << e.samples << ", \"objective\": " << JsonNumber(e.objective);
  if (spec.objective.type != design::ObjectiveType::kDistance)
    o << ", \"success_rate\": "
      << JsonNumber(static_cast<double>(e.successes) / std::max(1, e.samples))
      << ", \"interval\": [" << JsonNumber(e.lower) << ", " << JsonNumber(e.upper) << "]";
  o << ", \"failed_samples\": " << e.failures << "}";
  (void)indent;
  return o.str();
}

std::string DesignJson(const design::DesignSpec& spec, const design::VectorXd& x) {
  std::string s = "{";
  for (std::size_t k = 0; k < spec.parameters.size(); ++k)
    s += (k ? ", " : "") + JsonString(spec.parameters[k].name) + ": " + JsonNumber(x[k]);
  return s + "}";
}

std::string RankingJson(const design::DesignSpec& spec,
                        const std::vector<design::RankedDesign>& ranking) {
  std::string s = "[";
  for (const design::RankedDesign& d : ranking) {
    s += std::string(d.rank > 1 ? "," : "") + "\n    {\"rank\": " + std::to_string(d.rank) +
         ", \"index\": " + std::to_string(d.index) + ", \"phase\": " + JsonString(d.phase) +
         ", \"design\": " + DesignJson(spec, d.search.x) +
         ", \"search\": " + EvaluationJson(spec, d.search, "") +
         (d.fresh ? ", \"fresh\": " + EvaluationJson(spec, *d.fresh, "") : "") + "}";
  }
  return s + (ranking.empty() ? "]" : "\n  ]");
}

// {"ranks": N, "samples_per_rank": [...]}: where the samples ran (`mpirun`).
std::string MpiJson(const parallel::Distributor& ranks) {
  std::string s = "{\"ranks\": " + std::to_string(ranks.size()) + ", \"samples_per_rank\": [";
  const std::vector<long long> items = ranks.ItemsPerRank();
  for (std::size_t k = 0; k < items.size(); ++k) s += (k ? ", " : "") + std::to_string(items[k]);
  return s + "]}";
}

void WriteAtomically(const std::string& path, const std::string& text) {
  const std::string tmp = path + ".partial";
  {
    std::ofstream out(tmp);
    out << text;
    out.close();
    if (!out) throw std::invalid_argument("--out: cannot write '" + tmp + "'");
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0)
    throw std::invalid_argument("--out: cannot rename '" + tmp + "' to '" + path + "'");
}

}  // namespace

ExitCode RunDesignCommand(const DesignOptions& o) {
  // Under mpirun: rank 0 runs the search below, the other ranks run its samples (distributed.h).
  const std::unique_ptr<parallel::Distributor> ranks = parallel::MakeDistributor();
  if (!ranks->root()) return ServeDesign(o, *ranks);
  if (o.threads < 1) throw std::invalid_argument("--threads: expected an integer >= 1");
  if (o.budget < 0) throw std::invalid_argument("--budget: expected an integer >= 1");
  if (o.samples < 0) throw std::invalid_argument("--samples: expected an integer >= 1");
  if (o.validation_samples < 0)
    throw std::invalid_argument("--validation-samples: expected an integer >= 1");
  if (o.has_seed && o.seed < 0) throw std::invalid_argument("--seed: expected an integer >= 0");
  if (o.out.empty()) throw std::invalid_argument("--out: expected an output folder");
  design::DesignSpec spec = design::LoadDesignSpec(o.spec_path);
  if (o.validation_samples > 0) spec.validation_samples = o.validation_samples;

  std::error_code ec;
  fs::create_directories(o.out, ec);
  if (ec || !fs::is_directory(o.out))
    throw std::invalid_argument("--out: cannot create the folder '" + o.out + "'");
  const std::string history_path = o.out + "/history.csv";

  design::JobOptions job;
  job.optimizer = o.optimizer;
  job.budget = o.budget;
  job.samples = o.samples;
  job.threads = o.threads;
  job.has_seed = o.has_seed;
  job.seed = static_cast<std::uint64_t>(o.seed);
  if (o.resume && fs::exists(history_path)) job.replay = ReadHistory(history_path, spec);
  std::unique_ptr<design::DesignProblem> mpi_problem;
  std::unique_ptr<design::DistributedEvaluator> mpi_evaluator;
  if (ranks->size() > 1) {
    mpi_problem = std::make_unique<design::DesignProblem>(spec);
    mpi_evaluator = std::make_unique<design::DistributedEvaluator>(*mpi_problem, *ranks, o.threads);
    job.evaluator = mpi_evaluator.get();
  }

  // Validate the optimizer name before touching the history.
  design::CheckOptimizer(!o.optimizer.empty()      ? o.optimizer
                         : !spec.optimizer.empty() ? spec.optimizer
                                                   : design::DefaultOptimizer(spec));

  // The history: a resumed run appends after the replayed rows (rewritten without a truncated
  // last line); otherwise a new file.
  std::ofstream history;
  {
    std::string kept = HistoryHeader(spec) + "\n";
    if (o.resume && !job.replay.empty()) {
      std::ifstream in(history_path);
      std::string line;
      std::getline(in, line);
      for (std::size_t i = 0; i < job.replay.size() && std::getline(in, line); ++i)
        kept += line + "\n";
    }
    WriteAtomically(history_path, kept);
    history.open(history_path, std::ios::app);
    if (!history) throw std::invalid_argument("--out: cannot open '" + history_path + "'");
  }

  const bool tty = isatty(STDERR_FILENO);
  double last_print = -1e9;
  int last_decile = -1;
  const bool success_type = spec.objective.type == design::ObjectiveType::kSuccess;
  std::vector<design::HistoryEntry> evaluated;  // for the ranking
  job.on_evaluation = [&](const design::HistoryEntry& h, const design::Progress& p) {
    evaluated.push_back(h);
    // A resumed run repeats the interrupted one: its first rows are already in the file.
    if (h.index >= static_cast<int>(job.replay.size()))
      history << HistoryRow(h) << "\n" << std::flush;
    if (!o.quiet) {
      const bool last = p.evaluations >= p.max_evaluations;
      const int decile = 10 * p.evaluations / std::max(1, p.max_evaluations);
      if (last || (tty ? p.elapsed_s - last_print >= kTtyRedrawS : decile != last_decile)) {
        last_decile = decile;
        last_print = p.elapsed_s;
        const double eta = p.evaluations > 0
                               ? p.elapsed_s * (p.max_evaluations - p.evaluations) / p.evaluations
                               : 0.0;
        std::ostringstream s;
        s << "design: " << p.evaluations << " / " << p.max_evaluations << " evaluations ("
          << h.phase << "), best " << (success_type ? "success rate " : "objective ")
          << std::setprecision(6) << p.best_objective << ", " << Duration(p.elapsed_s)
          << " elapsed";
        if (p.evaluations < p.max_evaluations) s << ", ETA " << Duration(eta);
        std::cerr << (tty ? "\r" : "") << s.str() << (tty ? "\x1b[K" : "\n") << std::flush;
      }
    }
    return Interrupted() == 0;
  };

  design::DesignResult r;
  {
    InterruptGuard guard;
    r = design::RunDesign(spec, job);
  }
  if (!o.quiet && tty) std::cerr << "\n";
  history.close();

  std::vector<design::RankedDesign> ranking =
      design::RankDesigns(evaluated, spec.objective.type, kRankingSize);
  if (o.rank_fresh && !ranking.empty() && Interrupted() == 0) {
    const design::DesignProblem problem(spec);
    design::ThreadEvaluator evaluator(problem, o.threads);
    const int samples = spec.validation_samples > 0 ? spec.validation_samples
                        : o.samples > 0             ? o.samples
                                                    : spec.samples;
    design::ValidateRanking(
        evaluator, design::FreshStream(o.has_seed ? static_cast<std::uint64_t>(o.seed) : spec.seed),
        samples, spec.objective.type, &ranking);
  }
  if (r.best.size() > 0) {
    WriteAtomically(o.out + "/best.yaml", design::BestSceneYaml(spec, r.best));
    std::ostringstream j;
    j << "{\n";
    j << "  \"spec\": " << JsonString(o.spec_path) << ",\n";
    j << "  \"optimizer\": " << JsonString(r.optimizer) << ",\n";
    j << "  \"objective_type\": \""
      << (success_type                                              ? "success"
          : spec.objective.type == design::ObjectiveType::kDistance ? "distance"
                                                                    : "margin")
      << "\",\n";
    j << "  \"best\": " << DesignJson(spec, r.best) << ",\n";
    const Evaluation& reported = r.validated ? r.best_fresh : r.best_search;
    j << "  \"objective\": " << JsonNumber(reported.objective) << ",\n";
    if (spec.objective.type != design::ObjectiveType::kDistance) {
      j << "  \"success_rate\": "
        << JsonNumber(static_cast<double>(reported.successes) / std::max(1, reported.samples))
        << ",\n";
      j << "  \"interval\": [" << JsonNumber(reported.lower) << ", " << JsonNumber(reported.upper)
        << "],\n";
    }
    j << "  \"fresh_samples\": " << (r.validated ? "true" : "false") << ",\n";
    j << "  \"best_search\": " << EvaluationJson(spec, r.best_search, "  ") << ",\n";
    if (r.validated) j << "  \"best_fresh\": " << EvaluationJson(spec, r.best_fresh, "  ") << ",\n";
    j << "  \"start\": " << DesignJson(spec, r.start_search.x) << ",\n";
    j << "  \"start_search\": " << EvaluationJson(spec, r.start_search, "  ") << ",\n";
    if (r.validated)
      j << "  \"start_fresh\": " << EvaluationJson(spec, r.start_fresh, "  ") << ",\n";
    j << "  \"evaluations\": " << r.evaluations << ",\n";
    j << "  \"replayed\": " << r.replayed << ",\n";
    j << "  \"simulations\": " << r.simulations << ",\n";
    j << "  \"time_s\": " << JsonNumber(r.time_s) << ",\n";
    j << "  \"cancelled\": " << (r.cancelled ? "true" : "false") << ",\n";
    j << "  \"errors\": [";
    for (std::size_t k = 0; k < r.errors.size(); ++k)
      j << (k ? ", " : "") << JsonString(r.errors[k]);
    j << "],\n";
    j << "  \"ranking_by\": \"" << (o.rank_fresh ? "fresh" : "search") << "\",\n";
    j << "  \"ranking\": " << RankingJson(spec, ranking) << ",\n";
    if (ranks->size() > 1) j << "  \"mpi\": " << MpiJson(*ranks) << ",\n";
    j << "  \"screening\": [";
    for (std::size_t k = 0; k < r.screening.size(); ++k) {
      const design::StageReport& st = r.screening[k];
      j << (k ? ",\n    " : "\n    ") << "{\"stage\": " << JsonString(st.stage)
        << ", \"candidates_in\": " << st.candidates_in
        << ", \"candidates_out\": " << st.candidates_out << ", \"simulations\": " << st.simulations
        << ", \"time_s\": " << JsonNumber(st.time_s) << "}";
    }
    j << (r.screening.empty() ? "]\n}\n" : "\n  ]\n}\n");
    WriteAtomically(o.out + "/result.json", j.str());
  }

  if (!o.quiet && r.best.size() > 0) {
    std::ostringstream s;
    s << std::setprecision(6);
    s << "optimizer    " << r.optimizer << "\n";
    s << "best         ";
    for (std::size_t k = 0; k < spec.parameters.size(); ++k)
      s << (k ? ", " : "") << spec.parameters[k].name << " = " << r.best[k];
    s << "\n";
    const auto line = [&](const char* label, const Evaluation& e) {
      s << label;
      if (success_type || spec.objective.type == design::ObjectiveType::kMargin)
        s << "success " << static_cast<double>(e.successes) / std::max(1, e.samples) << " ["
          << e.lower << ", " << e.upper << "] of " << e.samples << " samples";
      if (spec.objective.type == design::ObjectiveType::kMargin) s << ", ";
      if (!success_type) s << "objective " << e.objective;
      if (e.failures) s << ", " << e.failures << " failed samples";
      if (!e.first_failure.empty()) s << " (first: " << e.first_failure << ")";
      s << "\n";
    };
    line("search       ", r.best_search);
    if (r.validated) {
      line("fresh best   ", r.best_fresh);
      line("fresh start  ", r.start_fresh);
    }
    s << "evaluations  " << r.evaluations << " (" << r.replayed << " not recomputed), "
      << r.simulations << " simulations, " << Duration(r.time_s) << "\n";
    if (!r.screening.empty()) {
      s << "screening    stage        candidates in  candidates out  simulations   time\n";
      for (const design::StageReport& st : r.screening)
        s << "             " << std::left << std::setw(12) << st.stage << std::right
          << std::setw(14) << st.candidates_in << std::setw(16) << st.candidates_out
          << std::setw(13) << st.simulations << "   " << std::fixed << std::setprecision(1)
          << st.time_s << " s\n"
          << std::defaultfloat << std::setprecision(6);
    }
    s << (o.rank_fresh ? "ranking (by the fresh samples)\n"
                       : "ranking (search samples; fresh: re-evaluated on new samples)\n")
      << design::RankingTable(spec, ranking);
    if (ranks->size() > 1) s << "mpi          " << MpiJson(*ranks) << "\n";
    s << "results      " << o.out << "/{best.yaml,result.json,history.csv}\n";
    std::cout << s.str() << std::flush;
  }
  for (const std::string& e : r.errors) PrintError(e);
  if (Interrupted()) return ExitCode::kInterrupted;
  if (!r.errors.empty() || r.best.size() == 0) return ExitCode::kSolveFailed;
  return ExitCode::kOk;
}

Command RegisterDesignCommand(CLI::App& app) {
  auto options = std::make_shared<DesignOptions>();
  CLI::App* sub = app.add_subcommand(
      "design",
      "Design search under uncertainty: the design with the best success probability "
      "(docs/design.md).");
  sub->add_option("SPEC", options->spec_path, "Design spec file (YAML, docs/design.md)")
      ->required()
      ->check(CLI::ExistingFile);
  std::string names;
  for (const std::string& n : design::OptimizerNames()) names += (names.empty() ? "" : ", ") + n;
  sub->add_option("--optimizer", options->optimizer,
                  "NLopt algorithm(s): GLOBAL+LOCAL, GLOBAL or LOCAL with GLOBAL one of "
                  "direct-l, crs2, isres, esch and LOCAL one of bobyqa, cobyla, neldermead, "
                  "sbplx (default: the spec's, else direct-l+sbplx for success, "
                  "direct-l+bobyqa otherwise)")
      ->type_name("NAME");
  sub->add_option("--budget", options->budget, "Simulations (rollouts) for the search")
      ->type_name("N");
  sub->add_option("--samples", options->samples, "Monte Carlo samples per design")->type_name("N");
  sub->add_option("--validation-samples", options->validation_samples,
                  "Fresh samples for the final estimate of the best and the start design "
                  "(default: the spec's validation_samples)")
      ->type_name("N");
  sub->add_option("--threads,-j", options->threads,
                  "Worker threads (the result is identical for any number)")
      ->type_name("N");
  sub->add_option_function<long long>(
         "--seed",
         [options](long long v) {
           options->has_seed = true;
           options->seed = v;
         },
         "Random seed (default: the spec's seed)")
      ->type_name("S");
  sub->add_option("--out,-o", options->out, "Output folder: best.yaml, result.json, history.csv")
      ->required()
      ->type_name("DIR");
  sub->add_flag("--resume", options->resume,
                "Replay DIR/history.csv (an interrupted run) instead of recomputing it");
  sub->add_flag("--rank-fresh", options->rank_fresh,
                "Re-evaluate the ranked designs (top 10) on the fresh validation samples and "
                "rank them by those rates");
  sub->add_flag("--quiet,-q", options->quiet, "Print nothing but errors");
  sub->footer("Optimizer names: " + names +
              ".\nExit 3 if an evaluation failed (results so far are written), 130 if "
              "interrupted (history.csv is kept: rerun with --resume).\n`mpirun -np N vinci "
              "design ...` spreads the samples over N processes (the same results).");
  return Command{sub, [options] { return RunDesignCommand(*options); }};
}

}  // namespace vinci::cli
