#include "command.h"

#include <csignal>
#include <exception>
#include <iostream>
#include <stdexcept>
#include <string>

#include "vinci/parallel/mpi.h"
#include "vinci/sim/solvers/text_format.h"

namespace vinci::cli {

void PrintError(const std::string& message) {
  std::cout.flush();  // keep stdout and stderr in order on a shared terminal
  // Escaped: a message may quote a user's file (raw bytes, terminal escape sequences).
  std::cerr << "vinci: error: " << sim::EscapeText(message, true) << "\n";
}

ExitCode RunCommand(const Command& command) {
  try {
    // Only design and field share their work among mpirun's processes (cli/distributed.h);
    // N copies of another command would each write the same outputs.
    const std::string name = command.app ? command.app->get_name() : std::string();
    if (name != "design" && name != "field" && parallel::MpirunWorldSize() > 1)
      throw std::invalid_argument("mpirun: 'vinci " + name +
                                  "' runs in one process; only 'vinci design' and 'vinci field' "
                                  "spread their work over mpirun's processes");
    return command.run();
  } catch (const std::invalid_argument& e) {
    PrintError(e.what());
    return ExitCode::kBadInput;
  } catch (const std::exception& e) {
    std::cout.flush();
    std::cerr << "vinci: internal error: " << sim::EscapeText(e.what(), true) << "\n";
    return ExitCode::kInternal;
  }
}

std::string ExitCodeHelp() {
  return "Exit status:\n"
         "    0  success\n"
         "    1  bad input (unreadable or invalid file, invalid flag value)\n"
         "    2  usage error (unknown flag, missing argument, no subcommand)\n"
         "    3  a simulation step or a solve failed (partial results are still written)\n"
         "    4  internal error\n"
         "  130  interrupted (Ctrl-C, SIGTERM); partial results are still written";
}

namespace {

volatile std::sig_atomic_t g_interrupted = 0;

extern "C" void OnInterrupt(int signal) {
  g_interrupted = signal;
  std::signal(signal, SIG_DFL);  // a second signal terminates
}

void (*Install(int signal))(int) {
  void (*old)(int) = std::signal(signal, OnInterrupt);
  if (old == SIG_IGN) std::signal(signal, SIG_IGN);
  return old;
}

}  // namespace

InterruptGuard::InterruptGuard() {
  g_interrupted = 0;
  old_int_ = Install(SIGINT);
  old_term_ = Install(SIGTERM);
}

InterruptGuard::~InterruptGuard() {
  std::signal(SIGINT, old_int_);
  std::signal(SIGTERM, old_term_);
}

int Interrupted() { return g_interrupted; }

}  // namespace vinci::cli
