#include "command.h"

#include <csignal>
#include <exception>
#include <iostream>
#include <stdexcept>

#include "vinci/sim/solvers/text_format.h"

namespace vinci::cli {

void PrintError(const std::string& message) {
  std::cout.flush();  // keep stdout and stderr in order on a shared terminal
  // Escaped: a message may quote a user's file (raw bytes, terminal escape sequences).
  std::cerr << "vinci: error: " << sim::EscapeText(message, true) << "\n";
}

ExitCode RunCommand(const Command& command) {
  try {
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
