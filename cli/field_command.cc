#include "field_command.h"

#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>

#include "distributed.h"
#include "vinci/parallel/mpi.h"
#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/plate/plate_theory.h"
#include "vinci/sim/plate/velocity_field.h"
#include "vinci/sim/simulator/simulator.h"

namespace vinci::cli {
namespace {

using Clock = std::chrono::steady_clock;

// Progress on a terminal is redrawn at most this often; otherwise a line every 10%.
constexpr double kTtyRedrawS = 0.2;

double Seconds(Clock::duration d) { return std::chrono::duration<double>(d).count(); }

// "21x21" → (21, 21); planar also "21" → (21, 1).
void ParseGrid(const std::string& text, bool planar, int* nx, int* ny) {
  const std::string expected =
      planar ? "NX or NXx1 with NX an integer >= 1 (planar scene)" : "NXxNY, integers >= 1";
  const auto fail = [&]() {
    throw std::invalid_argument("--grid: expected " + expected + ", got '" + text + "'");
  };
  const auto parse_int = [&](const std::string& s) {
    if (s.empty() || s.size() > 7 || s.find_first_not_of("0123456789") != std::string::npos) fail();
    const int v = std::stoi(s);
    if (v < 1) fail();
    return v;
  };
  const std::size_t x = text.find_first_of("xX");
  if (x == std::string::npos) {
    if (!planar) fail();
    *nx = parse_int(text);
    *ny = 1;
    return;
  }
  *nx = parse_int(text.substr(0, x));
  *ny = parse_int(text.substr(x + 1));
  if (planar && *ny != 1) fail();
  const long long points = static_cast<long long>(*nx) * *ny;
  if (points > sim::kMaxFieldPoints)
    throw std::invalid_argument("--grid: expected at most " + std::to_string(sim::kMaxFieldPoints) +
                                " points, got '" + text + "' = " + std::to_string(points));
}

std::string Duration(double s) {
  std::ostringstream o;
  if (s < 60)
    o << std::fixed << std::setprecision(0) << s << " s";
  else
    o << static_cast<int>(s / 60) << " min " << static_cast<int>(std::fmod(s, 60.0)) << " s";
  return o.str();
}

// Points done / total, rows done, ETA; serialized by ComputeVelocityField.
class Progress {
 public:
  Progress(bool enabled, int nx) : enabled_(enabled), nx_(nx), tty_(isatty(STDERR_FILENO)) {}
  void Update(int done, int total) {
    if (!enabled_) return;
    const double elapsed = Seconds(Clock::now() - start_);
    const bool last = done == total;
    if (tty_) {
      if (!last && elapsed - last_print_ < kTtyRedrawS) return;
    } else {
      const int decile = 10 * done / total;
      if (!last && decile == last_decile_) return;
      last_decile_ = decile;
    }
    last_print_ = elapsed;
    const double eta = done > 0 ? elapsed * (total - done) / done : 0.0;
    std::ostringstream s;
    s << "field: " << done << " / " << total << " points (" << done / nx_ << " / "
      << (total + nx_ - 1) / nx_ << " rows), " << Duration(elapsed) << " elapsed";
    if (!last) s << ", ETA " << Duration(eta);
    std::cerr << (tty_ ? "\r" : "") << s.str() << (tty_ ? "\x1b[K" : "\n");
    if (tty_ && last) std::cerr << "\n";
    std::cerr << std::flush;
  }

 private:
  bool enabled_;
  int nx_;
  bool tty_;
  Clock::time_point start_ = Clock::now();
  double last_print_ = -1e9;
  int last_decile_ = -1;
};

// Removes a temporary output file when the scope ends before Release(): on every error path,
// exceptions included, no FILE.partial is left behind.
class TempFile {
 public:
  explicit TempFile(std::string path) : path_(std::move(path)) {}
  TempFile(const TempFile&) = delete;
  TempFile& operator=(const TempFile&) = delete;
  ~TempFile() {
    if (!path_.empty()) std::remove(path_.c_str());
  }
  const std::string& path() const { return path_; }
  /// Renames the file to `to`; afterwards nothing is removed. False if the rename failed.
  bool RenameTo(const std::string& to) {
    if (std::rename(path_.c_str(), to.c_str()) != 0) return false;
    path_.clear();
    return true;
  }

 private:
  std::string path_;
};

// The simulator and field spec of a command line (every rank builds the same).
FieldSetup PrepareField(const FieldOptions& o) {
  if (o.dt && !(std::isfinite(*o.dt) && *o.dt > 0.0))
    throw std::invalid_argument("--dt: expected a finite number > 0 (s)");
  if (o.threads < 1) throw std::invalid_argument("--threads: expected an integer >= 1");
  if (o.cycles && *o.cycles < 1) throw std::invalid_argument("--cycles: expected an integer >= 1");
  if (o.average_cycles && *o.average_cycles < 1)
    throw std::invalid_argument("--average-cycles: expected an integer >= 1");
  if (o.out.empty()) throw std::invalid_argument("--out: expected an output CSV path");

  sim::Scene scene = sim::LoadSceneFile(o.scene_path);
  if (o.dt) scene.options.dt = *o.dt;
  FieldSetup setup;
  setup.simulator = std::make_unique<sim::Simulator>(std::move(scene));
  const sim::Simulator& simulator = *setup.simulator;
  sim::FieldSpec& spec = setup.spec;
  spec = sim::LoadFieldSpec(o.scene_path, simulator.scene());
  const bool planar = simulator.scene().dim == sim::Dim::kPlanar;
  if (o.grid) ParseGrid(*o.grid, planar, &spec.nx, &spec.ny);
  if (o.cycles) spec.cycles = *o.cycles;
  if (o.average_cycles) spec.average_cycles = *o.average_cycles;
  if (spec.average_cycles > spec.cycles)
    throw std::invalid_argument("--average-cycles: expected at most the cycles (" +
                                std::to_string(spec.cycles) + "), got " +
                                std::to_string(spec.average_cycles));
  spec.Validate(simulator.scene());
  return setup;
}

}  // namespace

ExitCode RunField(const FieldOptions& o) {
  // Under mpirun: rank 0 runs the field below, the other ranks compute its grid points.
  const std::unique_ptr<parallel::Distributor> ranks = parallel::MakeDistributor();
  if (!ranks->root()) return ServeField([&o] { return PrepareField(o); }, o.threads, *ranks);
  const FieldSetup setup = PrepareField(o);
  const sim::Simulator& simulator = *setup.simulator;
  const sim::FieldSpec& spec = setup.spec;

  // The result is written atomically: to a temporary file next to --out, renamed at the end.
  const std::string tmp = o.out + ".partial";
  {
    std::ofstream probe(tmp);
    if (!probe) throw std::invalid_argument("--out: cannot open '" + tmp + "' for writing");
  }
  TempFile tmp_file(tmp);  // removed if anything below throws

  const double h = simulator.scene().options.dt;
  const int per_cycle = spec.StepsPerCycle(h);
  if (!o.quiet)
    std::cerr << "field: " << spec.nx << "x" << spec.ny << " points, " << spec.cycles
              << " cycles of " << 1.0 / spec.frequency << " s (" << per_cycle
              << " steps each, dt = " << h << " s), averaging the last " << spec.average_cycles
              << ", " << o.threads << (o.threads == 1 ? " thread" : " threads")
              << (ranks->size() > 1 ? " on each of " + std::to_string(ranks->size()) + " MPI ranks"
                                    : std::string())
              << "\n";
  Progress progress(!o.quiet, spec.nx);
  sim::FieldOptions fo;
  fo.threads = o.threads;
  fo.progress = [&progress](int done, int total) { progress.Update(done, total); };
  const Clock::time_point start = Clock::now();
  const sim::VelocityField field =
      ranks->size() > 1
          ? DistributedVelocityField(*ranks, simulator, simulator.DefaultParams(), spec, fo)
          : sim::ComputeVelocityField(simulator, simulator.DefaultParams(), spec, fo);
  const double wall = Seconds(Clock::now() - start);
  {
    std::ofstream out(tmp);
    sim::WriteFieldCsv(field, out);
    out.close();
    if (!out) throw std::invalid_argument("--out: cannot write '" + tmp + "'");
  }
  if (!tmp_file.RenameTo(o.out))
    throw std::invalid_argument("--out: cannot rename '" + tmp + "' to '" + o.out + "'");

  if (!o.theory.empty()) {
    // The cycle-averaged theory of a point part at each grid point (plate_theory.h).
    const sim::PlateTheoryInput in =
        sim::PlateTheoryFromScene(simulator.scene(), spec.plate, spec.part, spec.frequency);
    const std::string ttmp = o.theory + ".partial";
    std::ofstream t(ttmp);
    if (!t) throw std::invalid_argument("--theory: cannot open '" + ttmp + "' for writing");
    TempFile ttmp_file(ttmp);
    t << "x,y,vx,vy,contact_fraction,ok\n";
    char buf[200];
    for (const sim::FieldPoint& p : field.points) {
      const sim::PointTheoryResult r = sim::SolvePointVelocity(in, sim::Vector2d(p.x, p.y));
      std::snprintf(buf, sizeof buf, "%.17g,%.17g,%.17g,%.17g,%.17g,%d\n", p.x, p.y, r.v.x(),
                    r.v.y(), r.contact_fraction, r.ok ? 1 : 0);
      t << buf;
    }
    t.close();
    if (!t || !ttmp_file.RenameTo(o.theory))
      throw std::invalid_argument("--theory: cannot write '" + o.theory + "'");
  }
  if (!o.quiet) {
    double vmax = 0.0;
    for (const sim::FieldPoint& p : field.points)
      if (!p.failed) vmax = std::max(vmax, std::hypot(p.vx, p.vy));
    std::ostringstream s;
    s << std::setprecision(6);
    s << "points      " << field.points.size() << " (" << field.left_plate << " left the plate, "
      << field.failed << " failed)\n";
    s << "max speed   " << vmax << " m/s\n";
    s << "wall time   " << wall << " s ("
      << static_cast<double>(field.points.size()) * per_cycle * spec.cycles / wall << " steps/s)\n";
    if (ranks->size() > 1) {
      s << "mpi ranks   " << ranks->size() << " (points per rank:";
      for (long long n : ranks->ItemsPerRank()) s << " " << n;
      s << ")\n";
    }
    s << "field       " << o.out << "\n";
    if (!o.theory.empty()) s << "theory      " << o.theory << "\n";
    std::cout << s.str() << std::flush;
  }
  if (field.failed > 0) {
    for (const sim::FieldPoint& p : field.points)
      if (p.failed) {
        PrintError("the part at (" + std::to_string(p.x) + ", " + std::to_string(p.y) +
                   ") failed: " + p.failure + " (" + std::to_string(field.failed) +
                   " failed points; rows with failed = 1 in '" + o.out + "')");
        break;
      }
    return ExitCode::kSolveFailed;
  }
  return ExitCode::kOk;
}

Command RegisterFieldCommand(CLI::App& app) {
  auto options = std::make_shared<FieldOptions>();
  CLI::App* sub = app.add_subcommand(
      "field", "Velocity field of a part on a vibrating plate (docs/field.md), as CSV.");
  sub->add_option("PLATE", options->scene_path,
                  "Scene file with a 'field:' section (YAML, docs/field.md)")
      ->required()
      ->check(CLI::ExistingFile);
  sub->add_option_function<std::string>(
         "--grid", [options](const std::string& v) { options->grid = v; },
         "Grid points NXxNY (planar: NX), e.g. 21x21 (default: the file's field.grid.points)")
      ->type_name("NXxNY");
  sub->add_option_function<int>(
         "--cycles", [options](int v) { options->cycles = v; },
         "Simulated plate cycles per point (default: field.cycles)")
      ->type_name("K");
  sub->add_option_function<int>(
         "--average-cycles", [options](int v) { options->average_cycles = v; },
         "Average the velocity over the last N cycles (default: field.average_cycles)")
      ->type_name("N");
  sub->add_option_function<double>(
         "--dt", [options](double v) { options->dt = v; },
         "Time step in s (default: the scene's stepper.dt)")
      ->type_name("H");
  sub->add_option("--threads,-j", options->threads,
                  "Worker threads (the result is identical for any number)")
      ->type_name("N");
  sub->add_option("--out,-o", options->out,
                  "Write the field to this CSV file (atomically: FILE.partial, then renamed)")
      ->required()
      ->type_name("FILE");
  sub->add_option("--theory", options->theory,
                  "Also write the cycle-averaged point-part theory at the grid points to this CSV "
                  "(x,y,vx,vy,contact_fraction,ok)")
      ->type_name("FILE");
  sub->add_flag("--quiet,-q", options->quiet, "Print nothing but errors (no progress, no summary)");
  sub->footer(
      "CSV columns: x,y (start point, plate frame, m), vx,vy (average velocity over the last "
      "cycles, plate frame, m/s), omega (about the plate normal, rad/s), left_plate, failed "
      "(0/1), x_mean,y_mean (mean position over the averaging window).\n"
      "Exit 3 if a step failed at some point (the CSV is written; those rows have failed = 1).\n"
      "`mpirun -np N vinci field ...` spreads the grid points over N processes (each on "
      "--threads threads; the same CSV).");
  return Command{sub, [options] { return RunField(*options); }};
}

}  // namespace vinci::cli
