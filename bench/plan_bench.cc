// plan_bench: OMPL's Benchmark tool over seeded runs of each control planner (KPIECE1, SST, RRT)
// on plan specs (examples/plan/*.yaml), issue 14 item 6. Writes one OMPL log per spec
// (readable by ompl_benchmark_statistics.py) and prints, per planner, the planner's exact-solution
// rate, the rate at which the re-simulated plan reaches the goal (`vinci plan`'s `solved`), and
// the median time to solution (wall, as OMPL measures it, and the process CPU time of the run,
// recorded as the run property cpu_time), and the propagations per run (run property
// propagations; counted after OMPL's check of the solution path, which re-propagates it).
// --budget N also stops each run after N propagations (the time limit still applies): the
// outcome of a seeded run then does not depend on the machine's speed or load.
//
//   plan_bench [--runs N] [--time-limit S] [--seed N] [--out DIR] [--planners kpiece1,sst,rrt]
//              [--budget N] SPEC.yaml...
#include <ompl/tools/benchmark/Benchmark.h>
#include <ompl/util/Console.h>
#include <ompl/util/RandomNumbers.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <iostream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "vinci/planning/plan.h"
#include "vinci/planning/plan_ompl.h"
#include "vinci/planning/plan_spec.h"

namespace {

using namespace vinci::planning;
namespace ob = ompl::base;
namespace oc = ompl::control;

struct Tally {
  int runs = 0, exact = 0, reached = 0;
  std::vector<double> times, cpu_times;          // of exact solutions (wall, process CPU)
  std::vector<double> propagations;              // of exact solutions
  double all_cpu = 0.0, all_propagations = 0.0;  // over every run
};

double Median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

std::string Stem(const std::string& path) {
  std::string s = path.substr(path.find_last_of('/') + 1);
  return s.substr(0, s.find_last_of('.'));
}

void Print(const std::string& plan, const std::string& planner, const Tally& t) {
  std::printf("| %s | %s | %d | %d%% | %d%% | %.2f | %.2f | %.0f | %.0f |\n", plan.c_str(),
              planner.c_str(), t.runs, 100 * t.exact / std::max(1, t.runs),
              100 * t.reached / std::max(1, t.runs), Median(t.times), Median(t.cpu_times),
              Median(t.propagations), t.all_propagations / std::max(1e-9, t.all_cpu));
  std::fflush(stdout);
}

// A planner stopped after `budget` propagations (counted by the propagator) or by the Benchmark's
// time limit, whichever comes first: with a budget the outcome of a seeded run does not depend
// on the machine's load. It reports under the inner planner's name and data.
class Budgeted : public ob::Planner {
 public:
  Budgeted(ob::PlannerPtr inner, std::shared_ptr<std::atomic<long long>> count, long long budget)
      : ob::Planner(inner->getSpaceInformation(), inner->getName()),
        inner_(std::move(inner)),
        count_(std::move(count)),
        budget_(budget) {}
  ob::PlannerStatus solve(const ob::PlannerTerminationCondition& ptc) override {
    if (budget_ <= 0) return inner_->solve(ptc);
    const auto count = count_;
    const long long budget = budget_;
    return inner_->solve(ob::plannerOrTerminationCondition(
        ptc, ob::PlannerTerminationCondition([count, budget] { return count->load() >= budget; })));
  }
  void setProblemDefinition(const ob::ProblemDefinitionPtr& pdef) override {
    ob::Planner::setProblemDefinition(pdef);
    inner_->setProblemDefinition(pdef);
  }
  void setup() override {
    ob::Planner::setup();
    inner_->setup();
  }
  void clear() override {
    ob::Planner::clear();
    inner_->clear();
  }
  void getPlannerData(ob::PlannerData& data) const override { inner_->getPlannerData(data); }

 private:
  ob::PlannerPtr inner_;
  std::shared_ptr<std::atomic<long long>> count_;
  long long budget_;
};

}  // namespace

int main(int argc, char** argv) {
  int runs = 50;
  double time_limit = 10.0;
  unsigned seed = 1;
  std::string out = ".";
  long long budget = 0;
  std::vector<std::string> specs;
  std::vector<PlannerType> planners = {PlannerType::kKpiece1, PlannerType::kSst, PlannerType::kRrt};
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--runs" && i + 1 < argc)
      runs = std::atoi(argv[++i]);
    else if (a == "--time-limit" && i + 1 < argc)
      time_limit = std::atof(argv[++i]);
    else if (a == "--seed" && i + 1 < argc)
      seed = static_cast<unsigned>(std::strtoul(argv[++i], nullptr, 10));
    else if (a == "--planners" && i + 1 < argc) {
      planners.clear();
      std::string list = argv[++i];
      for (std::size_t from = 0; from <= list.size();) {
        const std::size_t comma = std::min(list.find(',', from), list.size());
        planners.push_back(ParsePlannerName(list.substr(from, comma - from), "--planners"));
        from = comma + 1;
      }
    } else if (a == "--out" && i + 1 < argc)
      out = argv[++i];
    else if (a == "--budget" && i + 1 < argc)
      budget = std::atoll(argv[++i]);
    else
      specs.push_back(a);
  }
  if (specs.empty() || runs < 1 || !(time_limit > 0.0) || budget < 0) {
    std::cerr << "usage: plan_bench [--runs N] [--time-limit S] [--seed N] [--out DIR] "
                 "[--planners kpiece1,sst,rrt] [--budget PROPAGATIONS] SPEC.yaml...\n";
    return 2;
  }
  ompl::msg::setLogLevel(ompl::msg::LOG_ERROR);
  ompl::RNG::setSeed(seed);
  std::printf(
      "| plan | planner | runs | exact | re-simulated in goal | median time (s) | median CPU (s) "
      "| median propagations | propagations per CPU s |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|\n");
  for (const std::string& path : specs) {
    const PlanProblem problem(LoadPlanSpec(path));
    auto count = std::make_shared<std::atomic<long long>>(0);
    auto ss = MakeSimpleSetup(problem, problem.StartPoses(), PlannerType::kKpiece1, count);
    ompl::tools::Benchmark b(*ss, Stem(path));
    b.addExperimentParameter("ompl_version", "STRING", OmplVersion());
    b.addExperimentParameter("parts", "INTEGER", std::to_string(problem.num_parts()));
    b.addExperimentParameter("primitives", "INTEGER", std::to_string(problem.num_primitives()));
    b.addExperimentParameter("max_propagations", "INTEGER", std::to_string(budget));
    for (PlannerType t : planners)
      b.addPlanner(std::make_shared<Budgeted>(MakePlanner(ss->getSpaceInformation(), problem, t),
                                              count, budget));
    std::map<std::string, Tally> tally;
    std::clock_t cpu_start = 0;
    b.setPreRunEvent([&](const ob::PlannerPtr&) {
      *count = 0;
      cpu_start = std::clock();
    });
    // After each run: re-simulate the solution from the scene's start (the closed loop of
    // `vinci plan` without re-planning) and record whether it reaches the goal.
    b.setPostRunEvent([&](const ob::PlannerPtr& planner, ompl::tools::Benchmark::RunProperties& p) {
      const double cpu = static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC;
      // OMPL's Benchmark checks the solution path after the run (PathControl::check
      // re-propagates it); the count is read here, after that.
      const long long propagations = count->load();
      p["cpu_time REAL"] = std::to_string(cpu);
      p["propagations INTEGER"] = std::to_string(propagations);
      Tally& t = tally[planner->getName()];
      ++t.runs;
      t.all_cpu += cpu;
      t.all_propagations += static_cast<double>(propagations);
      const ob::ProblemDefinitionPtr& pdef = ss->getProblemDefinition();
      bool reached = false;
      double error = -1.0;
      if (pdef->hasExactSolution()) {
        ++t.exact;
        t.times.push_back(std::atof(p["time REAL"].c_str()));
        t.cpu_times.push_back(cpu);
        t.propagations.push_back(static_cast<double>(propagations));
        const auto* solution = pdef->getSolutionPath()->as<oc::PathControl>();
        Resimulation r;
        Resimulate(problem, StepsFromPath(*solution), &r);
        const PartPoses end = problem.PosesOf(r.states.back());
        const std::vector<double> e = problem.PositionErrors(end);
        error = *std::max_element(e.begin(), e.end());
        reached = r.ok && !r.left_plate && problem.GoalDistance(end) <= 1.0;
      }
      t.reached += reached ? 1 : 0;
      p["resimulated_reached BOOLEAN"] = reached ? "1" : "0";
      p["resimulated_max_position_error REAL"] = std::to_string(error);
    });
    ompl::tools::Benchmark::Request req(time_limit, 4096.0, static_cast<unsigned>(runs), 0.5, false,
                                        false, false);
    b.benchmark(req);
    const std::string log = out + "/" + Stem(path) + ".log";
    if (!b.saveResultsToFile(log.c_str())) std::cerr << "plan_bench: cannot write " << log << "\n";
    for (const auto& [name, t] : tally) Print(Stem(path), name, t);
  }
  return 0;
}
