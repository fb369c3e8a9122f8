// The `vinci` executable: one subcommand per job, each a thin layer over the libraries.
#include <CLI/CLI.hpp>
#include <iostream>
#include <string>
#include <vector>

#include "command.h"
#include "design_command.h"
#include "estimate_command.h"
#include "field_command.h"
#include "field_design_command.h"
#include "plan_command.h"
#include "simulate_command.h"
#include "solve_command.h"
#include "view_command.h"

#ifndef VINCI_VERSION
#error "VINCI_VERSION must be defined by the build (cli/CMakeLists.txt)"
#endif

namespace {

using vinci::cli::Command;
using vinci::cli::ExitCode;

// Help and version requests exit 0 through CLI11; a value that does not convert or validate
// is bad input (1); anything else wrong with the command line is a usage error (2).
int HandleParseError(const CLI::App& app, const std::vector<Command>& commands,
                     const CLI::ParseError& e) {
  if (e.get_exit_code() == static_cast<int>(CLI::ExitCodes::Success)) return app.exit(e);
  std::string usage = "vinci --help";
  for (const Command& c : commands) {
    if (c.app->parsed()) usage = "vinci " + c.app->get_name() + " --help";
  }
  const bool bad_value = dynamic_cast<const CLI::ConversionError*>(&e) ||
                         dynamic_cast<const CLI::ValidationError*>(&e);
  if (bad_value) {
    vinci::cli::PrintError(e.what());
    return static_cast<int>(ExitCode::kBadInput);
  }
  vinci::cli::PrintError(std::string(e.what()) + "\nRun '" + usage + "' for usage.");
  return static_cast<int>(ExitCode::kUsage);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"vinci: rigid-body contact simulation.", "vinci"};
  app.set_version_flag("--version", "vinci " VINCI_VERSION);
  app.footer(vinci::cli::ExitCodeHelp());
  app.require_subcommand(0, 1);

  // One line per subcommand.
  // clang-format off
  const std::vector<Command> commands = {
      vinci::cli::RegisterSimulateCommand(app),
      vinci::cli::RegisterSolveCommand(app),
      vinci::cli::RegisterFieldCommand(app),
      vinci::cli::RegisterViewCommand(app),
      vinci::cli::RegisterDesignCommand(app),
      vinci::cli::RegisterEstimateCommand(app),
      vinci::cli::RegisterFieldDesignCommand(app),
      vinci::cli::RegisterPlanCommand(app),
  };
  // clang-format on

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return HandleParseError(app, commands, e);
  }
  for (const Command& c : commands) {
    if (c.app->parsed()) return static_cast<int>(vinci::cli::RunCommand(c));
  }
  // No subcommand: show what there is and fail as a usage error.
  std::cerr << app.help();
  return static_cast<int>(ExitCode::kUsage);
}
