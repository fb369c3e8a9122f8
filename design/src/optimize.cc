#include "vinci/design/optimize.h"

#include <IpIpoptApplication.hpp>
#include <IpTNLP.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <nlopt.hpp>
#include <stdexcept>

namespace vinci::design {
namespace {

using Clock = std::chrono::steady_clock;

struct AlgorithmName {
  const char* name;
  nlopt::algorithm algorithm;
  bool global;
};

const std::vector<AlgorithmName>& Algorithms() {
  static const std::vector<AlgorithmName> list = {
      {"direct-l", nlopt::GN_DIRECT_L, true},
      {"crs2", nlopt::GN_CRS2_LM, true},
      {"isres", nlopt::GN_ISRES, true},
      {"esch", nlopt::GN_ESCH, true},
      {"bobyqa", nlopt::LN_BOBYQA, false},
      {"cobyla", nlopt::LN_COBYLA, false},
      {"neldermead", nlopt::LN_NELDERMEAD, false},
      {"sbplx", nlopt::LN_SBPLX, false},
  };
  return list;
}

const AlgorithmName* FindAlgorithm(const std::string& name) {
  for (const AlgorithmName& a : Algorithms())
    if (name == a.name) return &a;
  return nullptr;
}

// "global+local" | "global" | "local".
void ParseOptimizer(const std::string& name, const AlgorithmName** global,
                    const AlgorithmName** local) {
  const auto fail = [&]() {
    std::string list;
    for (const std::string& n : OptimizerNames()) list += (list.empty() ? "" : ", ") + n;
    throw std::invalid_argument("optimizer: expected one of {" + list + "} or global+local, got '" +
                                name + "'");
  };
  *global = *local = nullptr;
  if (name == "ipopt") return;
  const std::size_t plus = name.find('+');
  if (plus == std::string::npos) {
    const AlgorithmName* a = FindAlgorithm(name);
    if (!a) fail();
    (a->global ? *global : *local) = a;
    return;
  }
  *global = FindAlgorithm(name.substr(0, plus));
  *local = FindAlgorithm(name.substr(plus + 1));
  if (!*global || !(*global)->global || !*local || (*local)->global) fail();
}

// The search state shared with the NLopt callbacks.
struct Search {
  const DesignSpec* spec = nullptr;
  const JobOptions* options = nullptr;
  Evaluator* evaluator = nullptr;
  std::map<std::string, Evaluation> memo;             // replayed and computed evaluations
  std::map<std::string, std::string> screened_phase;  // memo keys a screening stage rejected
  std::uint64_t stream = 0;
  int samples = 0;
  Progress progress;
  Clock::time_point start;
  DesignResult* result = nullptr;
  Screener* screener = nullptr;  // null: no screening stages
  bool stop = false;
  bool have_best = false;
  int search_left = 0;  // evaluations the budget still allows
  std::string phase;

  std::vector<Evaluation> Run(const std::vector<EvalRequest>& requests,
                              std::vector<std::string> phases) {
    std::vector<Evaluation> out(requests.size());
    std::vector<EvalRequest> todo;
    std::vector<std::size_t> where;
    std::vector<bool> replayed(requests.size(), false);
    for (std::size_t r = 0; r < requests.size(); ++r) {
      const std::string key = EvaluationKey(requests[r].stream, requests[r].samples, requests[r].x);
      const auto it = memo.find(key);
      if (it != memo.end()) {
        out[r] = it->second;
        replayed[r] = true;
        const auto sp = screened_phase.find(key);
        if (sp != screened_phase.end()) phases[r] = sp->second;
        continue;
      }
      // Search candidates pass the screening stages first; a rejected one is not simulated.
      if (screener && IsSearch(requests[r])) {
        const int k = screener->Screen(requests[r].x, requests[r].stream);
        if (k >= 0) {
          out[r] = memo[key] =
              screener->Rejected(requests[r].x, requests[r].stream, requests[r].samples, k);
          phases[r] = screened_phase[key] = screener->Phase(k);
          continue;
        }
      }
      todo.push_back(requests[r]);
      where.push_back(r);
    }
    if (!todo.empty()) {
      const Clock::time_point t0 = Clock::now();
      const std::vector<Evaluation> fresh = evaluator->Evaluate(todo);
      const double wall = std::chrono::duration<double>(Clock::now() - t0).count();
      int full = 0;
      long long full_sims = 0;
      for (std::size_t k = 0; k < fresh.size(); ++k) {
        out[where[k]] = fresh[k];
        result->simulations += todo[k].samples;
        memo[EvaluationKey(todo[k].stream, todo[k].samples, todo[k].x)] = fresh[k];
        if (IsSearch(todo[k])) {
          ++full;
          full_sims += todo[k].samples;
        }
      }
      if (screener) screener->CountFull(full, full_sims, wall * full / fresh.size());
    }
    for (std::size_t r = 0; r < requests.size(); ++r) {
      // Search evaluations (on the search stream) compete for the best design; the first of
      // equal losses wins.
      if (requests[r].stream == stream && requests[r].samples == samples &&
          (!have_best || out[r].loss < result->best_search.loss)) {
        result->best_search = out[r];
        result->best = requests[r].x;
        have_best = true;
        progress.best_objective = out[r].objective;
      }
      HistoryEntry h;
      h.index = result->evaluations++;
      h.phase = phases[r];
      h.eval = out[r];
      h.replayed = replayed[r];
      result->replayed += replayed[r] ? 1 : 0;
      ++progress.evaluations;
      progress.elapsed_s = std::chrono::duration<double>(Clock::now() - start).count();
      if (options->on_evaluation && !options->on_evaluation(h, progress)) stop = true;
    }
    return out;
  }

  bool IsSearch(const EvalRequest& r) const { return r.stream == stream && r.samples == samples; }

  // One search evaluation.
  double Loss(const VectorXd& x) { return Run({EvalRequest{x, stream, samples}}, {phase})[0].loss; }
};

double NloptObjective(unsigned n, const double* x, double* grad, void* data) {
  auto* opt_and_search = static_cast<std::pair<nlopt::opt*, Search*>*>(data);
  Search* s = opt_and_search->second;
  if (grad) std::fill(grad, grad + n, 0.0);  // derivative-free algorithms only
  if (s->search_left <= 0 || s->stop) {      // some algorithms overrun maxeval by one
    opt_and_search->first->set_force_stop(1);
    return HUGE_VAL;
  }
  --s->search_left;
  try {
    const double loss = s->Loss(Eigen::Map<const VectorXd>(x, n));
    if (s->stop) opt_and_search->first->set_force_stop(1);
    return std::isfinite(loss) ? loss : HUGE_VAL;
  } catch (const std::exception& e) {
    s->result->errors.push_back(s->phase + ": " + e.what());
  } catch (...) {
    s->result->errors.push_back(s->phase + ": unknown exception");
  }
  s->stop = true;
  opt_and_search->first->set_force_stop(1);
  return HUGE_VAL;
}

void RunNlopt(const AlgorithmName& a, int max_evals, const VectorXd& lower, const VectorXd& upper,
              const VectorXd& x0, Search* s) {
  if (max_evals < 1 || s->stop) return;
  s->search_left = max_evals;
  const unsigned n = static_cast<unsigned>(lower.size());
  nlopt::opt opt(a.algorithm, n);
  opt.set_lower_bounds(std::vector<double>(lower.data(), lower.data() + n));
  opt.set_upper_bounds(std::vector<double>(upper.data(), upper.data() + n));
  opt.set_maxeval(max_evals);
  if (!a.global) {
    std::vector<double> step(n);
    for (unsigned k = 0; k < n; ++k) step[k] = 0.1 * (upper[k] - lower[k]);
    opt.set_initial_step(step);
    opt.set_xtol_rel(1e-8);
  }
  std::pair<nlopt::opt*, Search*> data(&opt, s);
  opt.set_min_objective(NloptObjective, &data);
  std::vector<double> x(x0.data(), x0.data() + n);
  for (unsigned k = 0; k < n; ++k) x[k] = std::min(std::max(x[k], lower[k]), upper[k]);
  double f = 0.0;
  try {
    opt.optimize(x, f);
  } catch (const nlopt::roundoff_limited&) {
    // Converged as far as floating point allows: the best point is kept by Search.
  } catch (const nlopt::forced_stop&) {
    // Cancelled or a callback failed: recorded by the callback.
  } catch (const std::exception& e) {
    s->result->errors.push_back(s->phase + ": nlopt: " + e.what());
  }
}

// Ipopt on a smooth loss (margin, distance): gradients by central differences under common
// random numbers (every evaluation uses the search stream, so the differences are not sampling
// noise), steps of 1e-4 of each parameter's range (one-sided at a bound), a limited-memory
// Hessian. Each gradient costs 2n evaluations; the budget stops the solve through the
// intermediate callback. No exception leaves a callback: it is recorded and the callback
// returns false.
class DesignTnlp : public Ipopt::TNLP {
 public:
  DesignTnlp(const VectorXd& lower, const VectorXd& upper, const VectorXd& x0, Search* s)
      : lower_(lower), upper_(upper), x0_(x0), s_(s) {}

  bool get_nlp_info(Ipopt::Index& n, Ipopt::Index& m, Ipopt::Index& nnz_jac, Ipopt::Index& nnz_h,
                    IndexStyleEnum& style) override {
    n = static_cast<Ipopt::Index>(lower_.size());
    m = nnz_jac = nnz_h = 0;
    style = C_STYLE;
    return true;
  }
  bool get_bounds_info(Ipopt::Index n, Ipopt::Number* xl, Ipopt::Number* xu, Ipopt::Index,
                       Ipopt::Number*, Ipopt::Number*) override {
    for (Ipopt::Index k = 0; k < n; ++k) {
      xl[k] = lower_[k];
      xu[k] = upper_[k];
    }
    return true;
  }
  bool get_starting_point(Ipopt::Index n, bool, Ipopt::Number* x, bool, Ipopt::Number*,
                          Ipopt::Number*, Ipopt::Index, bool, Ipopt::Number*) override {
    for (Ipopt::Index k = 0; k < n; ++k) x[k] = x0_[k];
    return true;
  }
  bool eval_f(Ipopt::Index n, const Ipopt::Number* x, bool, Ipopt::Number& f) override {
    return Guard([&] { f = Loss(VectorXd(Eigen::Map<const VectorXd>(x, n))); });
  }
  bool eval_grad_f(Ipopt::Index n, const Ipopt::Number* x, bool, Ipopt::Number* g) override {
    return Guard([&] {
      VectorXd p = Eigen::Map<const VectorXd>(x, n);
      for (Ipopt::Index k = 0; k < n; ++k) {
        const double h = 1e-4 * (upper_[k] - lower_[k]);
        const double a = std::max(lower_[k], p[k] - h), b = std::min(upper_[k], p[k] + h);
        VectorXd xa = p, xb = p;
        xa[k] = a;
        xb[k] = b;
        g[k] = (Loss(xb) - Loss(xa)) / (b - a);
      }
    });
  }
  bool eval_g(Ipopt::Index, const Ipopt::Number*, bool, Ipopt::Index, Ipopt::Number*) override {
    return true;
  }
  bool eval_jac_g(Ipopt::Index, const Ipopt::Number*, bool, Ipopt::Index, Ipopt::Index,
                  Ipopt::Index*, Ipopt::Index*, Ipopt::Number*) override {
    return true;
  }
  bool intermediate_callback(Ipopt::AlgorithmMode, Ipopt::Index, Ipopt::Number, Ipopt::Number,
                             Ipopt::Number, Ipopt::Number, Ipopt::Number, Ipopt::Number,
                             Ipopt::Number, Ipopt::Number, Ipopt::Index, const Ipopt::IpoptData*,
                             Ipopt::IpoptCalculatedQuantities*) override {
    return !s_->stop && s_->search_left > 0;
  }
  void finalize_solution(Ipopt::SolverReturn, Ipopt::Index, const Ipopt::Number*,
                         const Ipopt::Number*, const Ipopt::Number*, Ipopt::Index,
                         const Ipopt::Number*, const Ipopt::Number*, Ipopt::Number,
                         const Ipopt::IpoptData*, Ipopt::IpoptCalculatedQuantities*) override {}

 private:
  struct BudgetExhausted {};
  double Loss(const VectorXd& x) {
    if (s_->search_left <= 0) throw BudgetExhausted{};
    --s_->search_left;
    return s_->Loss(x);
  }
  template <class F>
  bool Guard(F f) {
    try {
      f();
      return true;
    } catch (const BudgetExhausted&) {
      return false;  // the intermediate callback then ends the solve
    } catch (const std::exception& e) {
      s_->result->errors.push_back(std::string("ipopt: ") + e.what());
    } catch (...) {
      s_->result->errors.push_back("ipopt: unknown exception");
    }
    s_->stop = true;
    return false;
  }

  VectorXd lower_, upper_, x0_;
  Search* s_;
};

void RunIpopt(int max_evals, const VectorXd& lower, const VectorXd& upper, const VectorXd& x0,
              Search* s) {
  if (max_evals < 1 || s->stop) return;
  s->search_left = max_evals;
  s->phase = "ipopt";
  Ipopt::SmartPtr<Ipopt::IpoptApplication> app = IpoptApplicationFactory();
  app->Options()->SetIntegerValue("print_level", 0);
  app->Options()->SetStringValue("sb", "yes");
  app->Options()->SetStringValue("hessian_approximation", "limited-memory");
  app->Options()->SetNumericValue("tol", 1e-9);
  app->Options()->SetIntegerValue("max_iter", std::max(1, max_evals));
  if (app->Initialize() != Ipopt::Solve_Succeeded) {
    s->result->errors.push_back("ipopt: initialization failed");
    return;
  }
  Ipopt::SmartPtr<Ipopt::TNLP> nlp = new DesignTnlp(lower, upper, x0, s);
  try {
    app->OptimizeTNLP(nlp);  // the outcome is the best point seen (Search)
  } catch (const std::exception& e) {
    s->result->errors.push_back(std::string("ipopt: ") + e.what());
  }
}

}  // namespace

std::vector<std::string> OptimizerNames() {
  std::vector<std::string> names;
  for (const AlgorithmName& a : Algorithms()) names.push_back(a.name);
  names.push_back("ipopt");
  return names;
}

void CheckOptimizer(const std::string& name) {
  const AlgorithmName* global = nullptr;
  const AlgorithmName* local = nullptr;
  ParseOptimizer(name, &global, &local);
}

std::string DefaultOptimizer(const DesignSpec& spec) {
  // The success rate is piecewise constant in x: a simplex method copes better than BOBYQA's
  // quadratic model there.
  return spec.objective.type == ObjectiveType::kSuccess ? "direct-l+sbplx" : "direct-l+bobyqa";
}

std::string EvaluationKey(std::uint64_t stream, int samples, const VectorXd& x) {
  std::string key = std::to_string(stream) + "|" + std::to_string(samples);
  char buf[40];
  for (Eigen::Index k = 0; k < x.size(); ++k) {
    std::snprintf(buf, sizeof buf, "|%.17g", x[k]);
    key += buf;
  }
  return key;
}

DesignResult RunDesign(const DesignSpec& spec, const JobOptions& options) {
  DesignResult result;
  const Clock::time_point start = Clock::now();
  result.optimizer = !options.optimizer.empty() ? options.optimizer
                     : !spec.optimizer.empty()  ? spec.optimizer
                                                : DefaultOptimizer(spec);
  const AlgorithmName* global = nullptr;
  const AlgorithmName* local = nullptr;
  ParseOptimizer(result.optimizer, &global, &local);
  const bool ipopt = result.optimizer == "ipopt";
  if (ipopt && spec.objective.type == ObjectiveType::kSuccess)
    throw std::invalid_argument(
        "optimizer: ipopt needs a smooth objective (type margin or distance), got type success");
  if (options.budget < 0) throw std::invalid_argument("budget: expected an integer >= 1");
  if (options.samples < 0) throw std::invalid_argument("samples: expected an integer >= 1");
  if (options.threads < 1) throw std::invalid_argument("threads: expected an integer >= 1");

  const DesignProblem problem(spec);
  std::unique_ptr<ThreadEvaluator> own;
  Search s;
  s.spec = &spec;
  s.options = &options;
  s.evaluator = options.evaluator;
  if (!s.evaluator) {
    own = std::make_unique<ThreadEvaluator>(problem, options.threads);
    s.evaluator = own.get();
  }
  for (const Evaluation& e : options.replay) s.memo[EvaluationKey(e.stream, e.samples, e.x)] = e;
  const std::uint64_t seed = options.has_seed ? options.seed : spec.seed;
  s.stream = seed;
  s.samples = options.samples > 0 ? options.samples : spec.samples;
  s.start = start;
  s.result = &result;
  const int budget = options.budget > 0 ? options.budget : spec.budget;
  const int validation = spec.validation_samples > 0 ? spec.validation_samples : s.samples;
  const int max_evals = std::max(1, budget / s.samples);
  const int search_evals = max_evals - 1;
  const int global_evals =
      global ? (local ? static_cast<int>(std::lround(0.6 * search_evals)) : search_evals) : 0;
  const int local_evals = local ? search_evals - global_evals : 0;
  s.progress.max_evaluations = max_evals + 2;
  nlopt::srand(seed);
  Screener screener(spec, problem, options.threads);
  if (screener.active()) s.screener = &screener;

  // The start design.
  const VectorXd lower = problem.lower(), upper = problem.upper(), x0 = problem.start();
  s.phase = "start";
  try {
    s.Loss(x0);
  } catch (const std::exception& e) {
    result.errors.push_back(std::string("start: ") + e.what());
    s.stop = true;
  }
  result.start_search = result.best_search;
  if (global) {
    s.phase = "global";
    RunNlopt(*global, global_evals, lower, upper, x0, &s);
  }
  if (local) {
    s.phase = "local";
    RunNlopt(*local, local_evals, lower, upper, s.have_best ? result.best : x0, &s);
  }
  if (ipopt) RunIpopt(search_evals, lower, upper, x0, &s);

  // Fresh samples for the best and the start design.
  if (s.have_best && !s.stop) {
    const std::uint64_t fresh = FreshStream(seed);
    try {
      const std::vector<Evaluation> v =
          s.Run({EvalRequest{result.best, fresh, validation}, EvalRequest{x0, fresh, validation}},
                {"validate-best", "validate-start"});
      result.best_fresh = v[0];
      result.start_fresh = v[1];
      result.validated = true;
    } catch (const std::exception& e) {
      result.errors.push_back(std::string("validation: ") + e.what());
    }
  }
  result.screening = screener.Report();
  for (std::size_t k = 0; k + 1 < result.screening.size(); ++k)
    result.simulations += result.screening[k].simulations;
  result.cancelled = s.stop && result.errors.empty();
  result.time_s = std::chrono::duration<double>(Clock::now() - start).count();
  return result;
}

}  // namespace vinci::design
