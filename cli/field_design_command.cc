#include "field_design_command.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>

#include "json.h"
#include "vinci/planning/field_design.h"
#include "vinci/planning/field_design_spec.h"

namespace vinci::cli {
namespace {

namespace fs = std::filesystem;

std::string Num(double v) {
  if (!std::isfinite(v)) return "null";
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

void WriteFile(const fs::path& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
  out.close();
  if (!out) throw std::runtime_error("cannot write " + path.string());
}

// The target as JSON: its type and parameters (for the plot), or the CSV it was read from.
std::string TargetJson(const planning::FieldTarget& t) {
  using planning::TargetType;
  const char* type = "csv";
  switch (t.type) {
    case TargetType::kSink:
      type = "sink";
      break;
    case TargetType::kSource:
      type = "source";
      break;
    case TargetType::kWhirlpool:
      type = "whirlpool";
      break;
    case TargetType::kCircle:
      type = "circle";
      break;
    case TargetType::kSaddle:
      type = "saddle";
      break;
    case TargetType::kLineSink:
      type = "line_sink";
      break;
    case TargetType::kShear:
      type = "shear";
      break;
    case TargetType::kConveyor:
      type = "conveyor";
      break;
    case TargetType::kCsv:
      break;
  }
  std::ostringstream j;
  j << "{\"type\": \"" << type << "\"";
  if (t.type != TargetType::kCsv)
    j << ", \"center\": [" << Num(t.center.x()) << ", " << Num(t.center.y())
      << "], \"radius\": " << Num(t.radius) << ", \"direction\": [" << Num(t.direction.x()) << ", "
      << Num(t.direction.y()) << "], \"speed\": " << Num(t.speed)
      << ", \"clockwise\": " << (t.clockwise ? "true" : "false");
  j << "}";
  return j.str();
}

}  // namespace

ExitCode RunFieldDesignCommand(const FieldDesignOptions& o) {
  if (o.threads < 1) throw std::invalid_argument("--threads: expected an integer >= 1");
  if (o.budget < 0) throw std::invalid_argument("--budget: expected an integer >= 1");
  if (o.has_seed && (o.seed < 0 || o.seed > 4294967295LL))
    throw std::invalid_argument("--seed: expected an integer in [0, 4294967295], got " +
                                std::to_string(o.seed));
  if (o.out.empty()) throw std::invalid_argument("--out: expected an output folder");
  planning::FieldDesignSpec spec = planning::LoadFieldDesignSpec(o.spec_path);
  if (o.budget > 0) spec.budget = o.budget;
  if (o.has_seed) spec.seed = static_cast<unsigned>(o.seed);
  if (o.tolerance >= 0.0) spec.tolerance = o.tolerance;
  const planning::FieldDesignProblem problem(spec);

  const fs::path dir(o.out);
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (!fs::is_directory(dir))
    throw std::invalid_argument("--out: cannot create the folder '" + o.out + "'");

  std::ofstream history(dir / "history.csv");
  if (!history)
    throw std::invalid_argument("--out: cannot write " + (dir / "history.csv").string());
  history << "evaluation,phase,field_error,feasible,peak_vertical_acceleration,bad_points,time_s";
  for (const std::string& n : problem.names()) history << "," << n;
  history << "\n" << std::flush;

  if (!o.quiet)
    std::cerr << "field-design: " << problem.names().size() << " free parameters, "
              << spec.nx * spec.ny << " grid points x " << spec.cycles << " cycles, budget "
              << spec.budget << " evaluations\n";
  planning::FieldDesignOptions options;
  options.budget = spec.budget;
  options.seed = spec.seed;
  options.threads = o.threads;
  options.global_fraction = o.global_fraction;
  if (!o.start.empty()) options.start = problem.ParametersFromScene(o.start);
  double best = HUGE_VAL;
  options.on_evaluation = [&](const planning::FieldEvaluation& e) {
    history << e.index << "," << e.phase << "," << Num(e.error) << "," << (e.feasible ? 1 : 0)
            << "," << Num(e.peak_vertical_acceleration) << "," << e.bad_points << ","
            << Num(e.time_s);
    for (Eigen::Index k = 0; k < e.x.size(); ++k) history << "," << Num(e.x[k]);
    history << "\n" << std::flush;
    best = std::min(best, e.error);
    if (!o.quiet)
      std::cerr << "field-design: " << e.index << " / " << spec.budget << " (" << e.phase
                << ") error " << e.error << (e.feasible ? "" : " (over the actuator limit)")
                << (e.bad_points ? " (" + std::to_string(e.bad_points) + " bad points)" : "")
                << ", best " << best << "\n";
  };
  const planning::FieldDesignResult r = planning::DesignField(problem, options);
  for (const std::string& e : r.errors) std::cerr << "vinci: field-design: " << e << "\n";
  if (r.evaluations == 0) return ExitCode::kSolveFailed;  // the start point threw

  // best.yaml: the plate scene with the best motion (and the spec's grid as its field section).
  WriteFile(dir / "best.yaml", problem.SceneYaml(r.best.x));
  // field.csv: the best field (the `vinci field` columns).
  if (!r.best.field.points.empty()) {
    std::ostringstream csv;
    sim::WriteFieldCsv(r.best.field, csv);
    WriteFile(dir / "field.csv", csv.str());
  }
  // target.csv: the target on the same grid (x, y, vx, vy), for the plot.
  {
    std::ostringstream t;
    t << "x,y,vx,vy\n";
    for (int k = 0; k < spec.nx * spec.ny; ++k) {
      const planning::Vector2d p = planning::GridPoint(spec, k);
      t << Num(p.x()) << "," << Num(p.y()) << "," << Num(problem.target()[k].x()) << ","
        << Num(problem.target()[k].y()) << "\n";
    }
    WriteFile(dir / "target.csv", t.str());
  }
  std::ostringstream j;
  j << "{\n";
  j << "  \"spec\": " << JsonString(o.spec_path) << ",\n";
  j << "  \"scene\": " << JsonString(spec.scene_path) << ",\n";
  j << "  \"target\": " << TargetJson(spec.target) << ",\n";
  j << "  \"objective\": " << JsonString(spec.absolute ? "absolute" : "shape") << ",\n";
  j << "  \"field_error\": " << Num(r.best.error) << ",\n";
  j << "  \"tolerance\": " << Num(spec.tolerance) << ",\n";
  j << "  \"reached_tolerance\": " << (r.reached_tolerance ? "true" : "false") << ",\n";
  j << "  \"feasible\": " << (r.best.feasible ? "true" : "false") << ",\n";
  j << "  \"bad_points\": " << r.best.bad_points << ",\n";
  j << "  \"peak_vertical_acceleration\": " << Num(r.best.peak_vertical_acceleration) << ",\n";
  j << "  \"vertical_peak\": \"" << (spec.exact_vertical_peak ? "exact" : "bound") << "\",\n";
  j << "  \"peak_linear_acceleration\": " << Num(r.best.peak_linear_acceleration) << ",\n";
  j << "  \"peak_angular_acceleration\": " << Num(r.best.peak_angular_acceleration) << ",\n";
  j << "  \"parameters\": {";
  for (std::size_t k = 0; k < problem.names().size(); ++k)
    j << (k ? ", " : "") << JsonString(problem.names()[k]) << ": " << Num(r.best.x[k]);
  j << "},\n";
  j << "  \"motion\": {\"frequency\": " << Num(spec.frequency);
  // A DOF of one order-1 harmonic: {"amplitude", "phase"}; else a list of {"order", ...}.
  const auto values = problem.DofValues(r.best.x);
  for (std::size_t k = 0; k < values.size(); ++k) {
    const auto& d = values[k];
    const bool single = (k == 0 || values[k - 1].dof != d.dof) &&
                        (k + 1 == values.size() || values[k + 1].dof != d.dof);
    const std::string h =
        "{\"amplitude\": " + Num(d.amplitude) + ", \"phase\": " + Num(d.phase) + "}";
    if (single && d.order == 1) {
      j << ", " << JsonString(d.dof) << ": " << h;
      continue;
    }
    if (d.index == 0) j << ", " << JsonString(d.dof) << ": [";
    j << (d.index ? ", " : "") << "{\"order\": " << d.order << ", " << h.substr(1);
    if (k + 1 == values.size() || values[k + 1].dof != d.dof) j << "]";
  }
  j << "},\n";
  j << "  \"grid\": [" << spec.nx << ", " << spec.ny << "],\n";
  j << "  \"cycles\": " << spec.cycles << ",\n";
  j << "  \"evaluations\": " << r.evaluations << ",\n";
  j << "  \"budget\": " << spec.budget << ",\n";
  j << "  \"seed\": " << spec.seed << ",\n";
  j << "  \"global_fraction\": " << Num(o.global_fraction) << ",\n";
  j << "  \"start\": " << (o.start.empty() ? std::string("null") : JsonString(o.start)) << ",\n";
  j << "  \"threads\": " << o.threads << ",\n";
  j << "  \"time_s\": " << Num(r.time_s) << ",\n";
  j << "  \"errors\": [";
  for (std::size_t k = 0; k < r.errors.size(); ++k) j << (k ? ", " : "") << JsonString(r.errors[k]);
  j << "]\n}\n";
  WriteFile(dir / "result.json", j.str());
  if (!o.quiet)
    std::cerr << "field-design: best field error " << r.best.error << " after " << r.evaluations
              << " evaluations, " << r.time_s << " s; wrote " << dir.string()
              << "/{best.yaml,result.json,field.csv,target.csv,history.csv}\n";
  return r.errors.empty() ? ExitCode::kOk : ExitCode::kSolveFailed;
}

Command RegisterFieldDesignCommand(CLI::App& app) {
  auto options = std::make_shared<FieldDesignOptions>();
  CLI::App* sub = app.add_subcommand(
      "field-design",
      "Plate motion whose simulated velocity field matches a target field (docs/planning.md).");
  sub->add_option("SPEC", options->spec_path, "Field-design spec (YAML, docs/planning.md)")
      ->required()
      ->check(CLI::ExistingFile);
  sub->add_option("--out,-o", options->out,
                  "Output folder: best.yaml, result.json, field.csv, target.csv, history.csv")
      ->required()
      ->type_name("DIR");
  sub->add_option("--budget", options->budget, "Field evaluations (default: the spec's budget)")
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
  sub->add_option("--tolerance", options->tolerance,
                  "Field error that stops the search (default: the spec's tolerance)")
      ->check(CLI::NonNegativeNumber)
      ->type_name("E");
  sub->add_option("--global-fraction", options->global_fraction,
                  "Share of the budget for the global phase (default 0.6; 0: local search from "
                  "the start only)")
      ->check(CLI::Range(0.0, 1.0))
      ->type_name("F");
  sub->add_option("--start", options->start,
                  "Start from the plate motion of this scene (e.g. a previous DIR/best.yaml); "
                  "with --budget 1 only that motion is evaluated")
      ->check(CLI::ExistingFile)
      ->type_name("SCENE");
  sub->add_flag("--quiet,-q", options->quiet, "Print nothing but errors");
  sub->footer("Exit 3 if an evaluation failed (the best so far is written).");
  return Command{sub, [options] { return RunFieldDesignCommand(*options); }};
}

}  // namespace vinci::cli
