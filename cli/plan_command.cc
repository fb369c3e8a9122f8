#include "plan_command.h"

#include <ompl/util/Console.h>
#include <ompl/util/RandomNumbers.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>

#include "json.h"
#include "vinci/planning/plan.h"
#include "vinci/planning/plan_ompl.h"
#include "vinci/planning/plan_spec.h"

namespace vinci::cli {
namespace {

std::string Num(double v) {
  if (!std::isfinite(v)) return "null";
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

std::string Poses(const planning::PlanProblem& problem, const planning::PartPoses& poses) {
  std::ostringstream j;
  j << "{";
  for (std::size_t i = 0; i < poses.size(); ++i)
    j << (i ? ", " : "") << JsonString(problem.spec().goals[i].part) << ": [" << Num(poses[i].x)
      << ", " << Num(poses[i].y) << ", " << Num(poses[i].theta) << "]";
  j << "}";
  return j.str();
}

std::string DefaultTrajectory(const std::string& out) {
  const std::size_t slash = out.find_last_of('/');
  const std::size_t dot = out.find_last_of('.');
  if (dot != std::string::npos && (slash == std::string::npos || dot > slash))
    return out.substr(0, dot) + ".csv";
  return out + ".csv";
}

}  // namespace

ExitCode RunPlanCommand(const PlanOptions& o) {
  if (o.out.empty()) throw std::invalid_argument("--out: expected a file name for plan.json");
  if (o.has_seed && (o.seed < 0 || o.seed > 4294967295LL))
    throw std::invalid_argument("--seed: expected an integer in [0, 4294967295], got " +
                                std::to_string(o.seed));
  if (o.time_limit < 0.0 || !std::isfinite(o.time_limit))
    throw std::invalid_argument("--time-limit: expected a number of seconds > 0");
  if (o.replan < -1) throw std::invalid_argument("--replan: expected an integer >= 0");
  planning::PlanSpec spec = planning::LoadPlanSpec(o.spec_path);
  if (!o.planner.empty()) spec.planner = planning::ParsePlannerName(o.planner, "--planner");
  if (o.time_limit > 0.0) spec.time_limit = o.time_limit;
  if (o.has_seed) spec.seed = static_cast<unsigned>(o.seed);
  if (o.replan >= 0) spec.replan = o.replan;
  if (o.max_propagations < -1)
    throw std::invalid_argument("--max-propagations: expected an integer >= 0");
  if (o.max_propagations >= 0) spec.max_propagations = o.max_propagations;
  const planning::PlanProblem problem(spec);
  const std::string trajectory = o.trajectory.empty() ? DefaultTrajectory(o.out) : o.trajectory;
  {  // fail on an unwritable output before planning
    std::ofstream test(o.out, std::ios::app);
    if (!test) throw std::invalid_argument("--out: cannot write '" + o.out + "'");
  }

  ompl::msg::setLogLevel(ompl::msg::LOG_WARN);
  ompl::RNG::setSeed(spec.seed);
  planning::PlanRunOptions options;
  options.planner = spec.planner;
  options.time_limit = spec.time_limit;
  options.replan = spec.replan;
  options.max_propagations = spec.max_propagations;
  int round = 0;
  options.on_attempt = [&](const planning::PlanAttempt& a, const planning::PartPoses& poses) {
    if (!o.quiet)
      std::cerr << "plan: round " << round << ": " << planning::PlannerName(spec.planner) << " "
                << a.planner_status << " in " << a.solve_time_s << " s (" << a.propagations
                << " propagations), " << a.steps.size() << " steps, model goal distance "
                << a.goal_distance << "; re-simulated goal distance " << problem.GoalDistance(poses)
                << "\n";
    ++round;
  };
  const planning::PlanResult r = planning::RunPlan(problem, options);

  {
    std::ofstream csv(trajectory);
    planning::WriteResimulationCsv(problem, r.resimulation, csv);
    csv.close();
    if (!csv) throw std::runtime_error("cannot write " + trajectory);
  }
  std::ostringstream j;
  j << "{\n";
  j << "  \"spec\": " << JsonString(o.spec_path) << ",\n";
  j << "  \"scene\": " << JsonString(spec.scene_path) << ",\n";
  j << "  \"solved\": " << (r.solved ? "true" : "false") << ",\n";
  j << "  \"reached\": " << (r.reached ? "true" : "false") << ",\n";
  j << "  \"exact\": " << (!r.attempts.empty() && r.attempts.back().exact ? "true" : "false")
    << ",\n";
  j << "  \"planner\": " << JsonString(planning::PlannerName(spec.planner)) << ",\n";
  j << "  \"ompl_version\": " << JsonString(planning::OmplVersion()) << ",\n";
  j << "  \"seed\": " << spec.seed << ",\n";
  j << "  \"time_limit\": " << Num(spec.time_limit) << ",\n";
  j << "  \"max_propagations\": " << spec.max_propagations << ",\n";
  j << "  \"solve_time\": " << Num(r.solve_time_s) << ",\n";
  j << "  \"steps\": [";
  for (std::size_t k = 0; k < r.steps.size(); ++k) {
    const planning::PlanStep& s = r.steps[k];
    j << (k ? ",\n    " : "\n    ") << "{\"primitive\": "
      << JsonString(spec.primitives[static_cast<std::size_t>(s.primitive)].name)
      << ", \"cycles\": " << s.cycles << ", \"round\": " << s.round << "}";
  }
  j << (r.steps.empty() ? "" : "\n  ") << "],\n";
  j << "  \"attempts\": [";
  for (std::size_t k = 0; k < r.attempts.size(); ++k) {
    const planning::PlanAttempt& a = r.attempts[k];
    j << (k ? ",\n    " : "\n    ") << "{\"status\": " << JsonString(a.planner_status)
      << ", \"exact\": " << (a.exact ? "true" : "false")
      << ", \"approximate\": " << (a.approximate ? "true" : "false")
      << ", \"solve_time\": " << Num(a.solve_time_s) << ", \"propagations\": " << a.propagations
      << ", \"steps\": " << a.steps.size() << ", \"model_goal_distance\": " << Num(a.goal_distance)
      << ", \"start\": " << Poses(problem, a.start) << "}";
  }
  j << "\n  ],\n";
  j << "  \"start_poses\": " << Poses(problem, problem.StartPoses()) << ",\n";
  j << "  \"goals\": {";
  for (std::size_t i = 0; i < spec.goals.size(); ++i) {
    const planning::PartGoal& g = spec.goals[i];
    j << (i ? ", " : "") << JsonString(g.part) << ": {\"position\": [" << Num(g.position.x())
      << ", " << Num(g.position.y()) << "], \"tolerance\": " << Num(g.tolerance);
    if (g.has_angle)
      j << ", \"angle\": " << Num(g.angle) << ", \"angle_tolerance\": " << Num(g.angle_tolerance);
    j << "}";
  }
  j << "},\n";
  j << "  \"plate_extent\": {\"x\": [" << Num(spec.x_min) << ", " << Num(spec.x_max)
    << "], \"y\": [" << Num(spec.y_min) << ", " << Num(spec.y_max) << "]},\n";
  j << "  \"plate\": " << JsonString(problem.simulator().scene().bodies[problem.plate()].name)
    << ",\n";
  j << "  \"final_poses\": " << Poses(problem, r.final_poses) << ",\n";
  j << "  \"final_errors\": {";
  for (std::size_t i = 0; i < spec.goals.size(); ++i)
    j << (i ? ", " : "") << JsonString(spec.goals[i].part)
      << ": {\"position\": " << Num(r.final_position_errors[i])
      << ", \"angle\": " << Num(r.final_angle_errors[i]) << "}";
  j << "},\n";
  j << "  \"final_goal_distance\": " << Num(r.final_goal_distance) << ",\n";
  j << "  \"resimulation\": {\"ok\": " << (r.resimulation.ok ? "true" : "false")
    << ", \"left_plate\": " << (r.resimulation.left_plate ? "true" : "false")
    << ", \"steps\": " << r.resimulation.states.size() - 1
    << ", \"failure\": " << JsonString(r.resimulation.failure) << "},\n";
  j << "  \"trajectory\": " << JsonString(trajectory) << "\n";
  j << "}\n";
  std::ofstream out(o.out, std::ios::trunc);
  out << j.str();
  out.close();
  if (!out) throw std::runtime_error("cannot write " + o.out);
  if (!o.quiet) {
    std::cerr << "plan: " << (r.solved ? "solved" : "NOT solved") << " (" << r.steps.size()
              << " steps, " << r.attempts.size() << " planner calls, " << r.solve_time_s
              << " s); final position errors";
    for (double e : r.final_position_errors) std::cerr << " " << e;
    std::cerr << " m";
    bool angles = false;
    for (const planning::PartGoal& g : spec.goals) angles = angles || g.has_angle;
    if (angles) {
      std::cerr << ", angle errors";
      for (double e : r.final_angle_errors) std::cerr << " " << e;
      std::cerr << " rad";
    }
    std::cerr << "; wrote " << o.out << " and " << trajectory << "\n";
  }
  return r.solved ? ExitCode::kOk : ExitCode::kSolveFailed;
}

Command RegisterPlanCommand(CLI::App& app) {
  auto options = std::make_shared<PlanOptions>();
  CLI::App* sub = app.add_subcommand(
      "plan",
      "Plate-motion primitives that carry parts to goal poses, planned with OMPL "
      "(docs/planning.md).");
  sub->add_option("PLAN", options->spec_path, "Plan spec (YAML, docs/planning.md)")
      ->required()
      ->check(CLI::ExistingFile);
  sub->add_option("--out,-o", options->out, "plan.json: steps, final poses and errors")
      ->required()
      ->type_name("FILE");
  sub->add_option("--trajectory", options->trajectory,
                  "Re-simulation CSV (default: --out with extension .csv)")
      ->type_name("FILE");
  sub->add_option("--planner", options->planner, "kpiece1, sst or rrt (default: the spec's)")
      ->type_name("NAME");
  sub->add_option("--time-limit", options->time_limit,
                  "Seconds per planner call (default: the spec's)")
      ->type_name("S");
  sub->add_option_function<long long>(
         "--seed",
         [options](long long v) {
           options->has_seed = true;
           options->seed = v;
         },
         "OMPL's random seed (default: the spec's)")
      ->type_name("N");
  sub->add_option("--replan", options->replan,
                  "Re-plans from the re-simulated state while the goal is missed (default: the "
                  "spec's, else 0)")
      ->type_name("N");
  sub->add_option("--max-propagations", options->max_propagations,
                  "Propagations per planner call, 0: no limit (default: the spec's); with it a "
                  "seeded run does not depend on the machine's speed")
      ->type_name("N");
  sub->add_flag("--quiet,-q", options->quiet, "Print nothing but errors");
  sub->footer("Exit 3 if not solved (plan.json and the trajectory are still written).");
  return Command{sub, [options] { return RunPlanCommand(*options); }};
}

}  // namespace vinci::cli
