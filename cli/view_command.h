// `vinci view SCENE [TRAJ.csv] --out view.html`: a self-contained web page (three.js and the
// viewer inlined, no network needed) that draws the scene and plays its trajectory, with the
// step report as overlays and an optional velocity field (README.md, "vinci view").
#pragma once

#include <CLI/CLI.hpp>
#include <cstdint>
#include <string>

#include "command.h"

namespace vinci::cli {

/// Everything `vinci view` takes from the command line.
struct ViewOptions {
  std::string scene_path;
  std::string trajectory_path;     ///< CSV of `vinci simulate --out`; empty: none
  std::string field_path;          ///< CSV of `vinci field --out`; empty: none
  std::string out;                 ///< HTML path (required)
  std::int64_t max_frames = 2000;  ///< trajectories with more rows are decimated to this
  bool quiet = false;              ///< no summary
};

/// Adds the `view` subcommand to `app`.
Command RegisterViewCommand(CLI::App& app);

/// Runs `vinci view`. Throws std::invalid_argument for bad input (scene, trajectory that does
/// not match the scene, field CSV, flag values, an output path that cannot be written).
ExitCode RunView(const ViewOptions& options);

}  // namespace vinci::cli
