// What every `vinci` subcommand shares: exit codes, the registration contract and error
// reporting. A new subcommand is one file `<name>_command.cc` (+ header) that defines
// `Command Register<Name>Command(CLI::App& app)` and one line in main.cc.
#pragma once

#include <CLI/CLI.hpp>
#include <csignal>
#include <functional>
#include <string>

namespace vinci::cli {

/// Exit status of the `vinci` executable (documented in `vinci --help`).
enum class ExitCode : int {
  kOk = 0,             ///< the job completed
  kBadInput = 1,       ///< unreadable or invalid scene/input file, invalid flag value
  kUsage = 2,          ///< malformed command line (unknown flag, missing argument, no subcommand)
  kSolveFailed = 3,    ///< a simulation step or a solve failed; partial results were written
  kInternal = 4,       ///< a bug: an unexpected exception (please report it)
  kInterrupted = 130,  ///< stopped by SIGINT/SIGTERM; partial results were written
};

/// A registered subcommand: its CLI11 parser (owned by the parent app) and the job to run once
/// the command line has been parsed successfully. `run` returns the process exit code.
struct Command {
  CLI::App* app = nullptr;
  std::function<ExitCode()> run;
};

/// Runs `command.run`, turning exceptions into a message on stderr and an exit code:
/// std::invalid_argument → "vinci: error: <what>" and kBadInput; any other std::exception →
/// "vinci: internal error: <what>" and kInternal.
ExitCode RunCommand(const Command& command);

/// Prints "vinci: error: <message>" on stderr.
void PrintError(const std::string& message);

/// Catches SIGINT and SIGTERM for its lifetime so a long job can stop after its current unit of
/// work and write what it has (Interrupted() says a signal came); a second signal takes the
/// default action (terminates). A signal the parent ignored (nohup, `cmd &` in a script) stays
/// ignored. One guard at a time.
class InterruptGuard {
 public:
  InterruptGuard();
  ~InterruptGuard();
  InterruptGuard(const InterruptGuard&) = delete;
  InterruptGuard& operator=(const InterruptGuard&) = delete;

 private:
  void (*old_int_)(int) = SIG_DFL;
  void (*old_term_)(int) = SIG_DFL;
};

/// The signal caught by the current (or last) InterruptGuard, 0 if none.
int Interrupted();

/// The footer appended to `vinci --help` (exit codes).
std::string ExitCodeHelp();

}  // namespace vinci::cli
