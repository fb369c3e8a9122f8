// The data behind `vinci view`: a scene's shapes, a trajectory CSV of `vinci simulate` (decimated
// for the browser) and a velocity-field CSV of `vinci field`, checked against the scene and
// written as one JSON object that the page (cli/view/viewer.js) draws. The JSON layout is
// documented at the top of viewer.js.
#pragma once

#include <cstdint>
#include <iosfwd>
#include <optional>
#include <string>
#include <vector>

#include "vinci/sim/model/scene.h"

namespace vinci::cli {

/// A trajectory read from CSV, reduced to at most a given number of frames. Frames are rows of
/// the file chosen evenly by row index, always including the first and the last; the step
/// report of the rows a frame stands for is aggregated into it (worst case), so a peak or an
/// unusual status between two frames is not lost.
struct ViewTrajectory {
  std::int64_t rows = 0;            ///< data rows in the file
  std::vector<std::int64_t> steps;  ///< `step` column of each frame
  std::vector<double> t;            ///< s, non-decreasing
  /// Per body (scene order), per frame: planar x, y, θ (m, rad); spatial x, y, z, qw, qx, qy, qz.
  std::vector<std::vector<double>> poses;
  bool has_report = false;  ///< the file has the step-report columns
  // Per frame, over the rows since the previous frame (max, max, max, min, worst):
  std::vector<int> contacts;
  std::vector<int> iterations;
  std::vector<double> residual;  ///< NaN propagates (a NaN residual is the worst)
  std::vector<double> min_gap;   ///< m, over rows with contacts; NaN if none had any
  std::vector<int> status;       ///< index into status_names
  std::vector<std::string> status_names;
  /// Rows whose status is neither "solved" nor "initial" (all rows, not only frames): the first
  /// kMaxFlagged of them, and how many there were.
  struct Flag {
    std::int64_t step;
    double t;
    std::string status;
  };
  static constexpr int kMaxFlagged = 500;
  std::vector<Flag> flagged;
  std::int64_t num_flagged = 0;
};

/// Reads a trajectory CSV written by `vinci simulate --out` for `scene`: header `step,t`, the
/// pose and velocity columns of every body in scene order, then optionally the step report
/// `contacts,solver_iterations,residual,min_gap,status`. Keeps at most `max_frames` (≥ 2) frames.
/// Throws std::invalid_argument as "path:line: ..." for an unreadable file, a header that does
/// not match the scene's bodies (naming the first differing column), a row with the wrong number
/// of fields, a value that is not a number, non-finite poses or times, or time going backwards.
ViewTrajectory ReadViewTrajectory(const std::string& path, const sim::Scene& scene,
                                  std::int64_t max_frames);

/// One point of a velocity field, in the world frame (the plate's initial frame mapped by its
/// scene pose).
struct ViewFieldPoint {
  sim::Vector3d p_W;   ///< start point (m)
  sim::Vector3d v_W;   ///< average velocity (m/s)
  double omega = 0.0;  ///< rad/s about the plate normal
  bool left_plate = false;
  bool failed = false;
};

struct ViewField {
  std::string plate, part;  ///< body names from the scene's `field:` section
  double spacing = 0.0;     ///< grid spacing (m), 0 for a single point
  sim::Vector3d normal_W = sim::Vector3d::UnitZ();  ///< plate normal (planar: in the plane)
  std::vector<ViewFieldPoint> points;
};

/// Reads a velocity-field CSV written by `vinci field` (header
/// `x,y,vx,vy,omega,left_plate,failed[,x_mean,y_mean]`) for the scene file `scene_path`, whose
/// `field:` section names the plate. Throws std::invalid_argument as "path:line: ..." for bad
/// input (and as LoadFieldSpec for a scene without a `field:` section).
ViewField ReadViewField(const std::string& path, const std::string& scene_path,
                        const sim::Scene& scene);

/// Writes the page's data object: {"format", "scene", "trajectory", "field", "sources"}
/// (see cli/view/viewer.js). Strings are escaped so that the text can sit in an HTML <script>.
void WriteViewJson(const sim::Scene& scene, const std::string& scene_path,
                   const ViewTrajectory* trajectory, const std::string& trajectory_path,
                   const ViewField* field, const std::string& field_path, std::ostream& out);

}  // namespace vinci::cli
