#include "view_command.h"

#include <cctype>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>

#include "view/view_assets.h"
#include "view_data.h"
#include "vinci/sim/model/scene_file.h"

namespace vinci::cli {
namespace {

// Replaces the one occurrence of `marker` in `page` by `text`; a template without it is a bug.
void Fill(std::string* page, const std::string& marker, const std::string& text) {
  const std::size_t at = page->find(marker);
  if (at == std::string::npos || page->find(marker, at + 1) != std::string::npos)
    throw std::logic_error("viewer template: expected one " + marker);
  page->replace(at, marker.size(), text);
}

// A script to inline in <script>: "</script" inside it would end the element early. In
// JavaScript source it can only occur inside strings, regular expressions or comments, where
// "<\/" means the same.
std::string InlineScript(std::string js) {
  for (std::size_t at = 0; (at = js.find("</", at)) != std::string::npos; at += 3) {
    std::string next = js.substr(at + 2, 6);
    for (char& c : next) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (next == "script") js.replace(at, 2, "<\\/");
  }
  return js;
}

}  // namespace

ExitCode RunView(const ViewOptions& o) {
  if (o.out.empty()) throw std::invalid_argument("--out: expected an output HTML path");
  if (o.max_frames < 2)
    throw std::invalid_argument("--max-frames: expected an integer >= 2, got " +
                                std::to_string(o.max_frames));
  if (!view_assets::kHaveThree)
    throw std::invalid_argument(
        "vinci was built without three.js (Debian package libjs-three, installed by "
        "scripts/setup.sh); install it and rebuild to use 'vinci view'");

  const sim::Scene scene = sim::LoadSceneFile(o.scene_path);
  std::unique_ptr<ViewTrajectory> traj;
  if (!o.trajectory_path.empty())
    traj = std::make_unique<ViewTrajectory>(
        ReadViewTrajectory(o.trajectory_path, scene, o.max_frames));
  std::unique_ptr<ViewField> field;
  if (!o.field_path.empty())
    field = std::make_unique<ViewField>(ReadViewField(o.field_path, o.scene_path, scene));

  std::ostringstream data;
  WriteViewJson(scene, o.scene_path, traj.get(), o.trajectory_path, field.get(), o.field_path,
                data);
  std::string page = view_assets::kViewerHtml;
  Fill(&page, "@VINCI_THREE_JS@", InlineScript(view_assets::kThreeJs));
  Fill(&page, "@VINCI_ORBIT_CONTROLS_JS@", InlineScript(view_assets::kOrbitControlsJs));
  Fill(&page, "@VINCI_VIEWER_JS@", InlineScript(view_assets::kViewerJs));
  Fill(&page, "@VINCI_DATA@", data.str());  // already escaped for <script> (WriteViewJson)

  // Written atomically: to FILE.partial, then renamed.
  const std::string tmp = o.out + ".partial";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) throw std::invalid_argument("--out: cannot open '" + tmp + "' for writing");
    out.write(page.data(), static_cast<std::streamsize>(page.size()));
    out.close();
    if (!out) throw std::invalid_argument("--out: cannot write '" + tmp + "'");
  }
  if (std::rename(tmp.c_str(), o.out.c_str()) != 0) {
    std::remove(tmp.c_str());
    throw std::invalid_argument("--out: cannot rename '" + tmp + "' to '" + o.out + "'");
  }

  if (!o.quiet) {
    std::ostringstream s;
    s << "scene       " << (scene.name.empty() ? "(unnamed)" : scene.name) << " ("
      << (scene.dim == sim::Dim::kPlanar ? "planar" : "spatial") << ", " << scene.bodies.size()
      << " bodies)\n";
    if (traj) {
      s << "trajectory  " << traj->rows << (traj->rows == 1 ? " row" : " rows")
        << ", t = " << traj->t.front() << " .. " << traj->t.back() << " s, " << traj->t.size()
        << " frames";
      if (static_cast<std::int64_t>(traj->t.size()) < traj->rows)
        s << " (decimated from " << traj->rows << ")";
      if (traj->num_flagged > 0) s << ", " << traj->num_flagged << " steps not 'solved'";
      s << "\n";
    }
    if (field) s << "field       " << field->points.size() << " points\n";
    s << "view        " << o.out << " (" << (page.size() + 512) / 1024 << " KiB)\n";
    std::cout << s.str() << std::flush;
  }
  return ExitCode::kOk;
}

Command RegisterViewCommand(CLI::App& app) {
  auto options = std::make_shared<ViewOptions>();
  CLI::App* sub = app.add_subcommand(
      "view",
      "Write a self-contained web page (works offline) that shows a scene and plays its "
      "trajectory.");
  sub->add_option("SCENE", options->scene_path, "Scene file (YAML, see docs/scene-format.md)")
      ->required()
      ->check(CLI::ExistingFile);
  sub->add_option("TRAJ", options->trajectory_path,
                  "Trajectory CSV of 'vinci simulate --out' for this scene (optional: without "
                  "it the scene is shown at its initial pose)")
      ->check(CLI::ExistingFile);
  sub->add_option("--field", options->field_path,
                  "Velocity-field CSV of 'vinci field --out' for this scene (drawn as arrows on "
                  "the plate; the scene needs its 'field:' section)")
      ->check(CLI::ExistingFile)
      ->type_name("FILE");
  sub->add_option("--out,-o", options->out,
                  "Write the page to this HTML file (atomically: FILE.partial, then renamed)")
      ->required()
      ->type_name("FILE");
  sub->add_option("--max-frames", options->max_frames,
                  "Trajectories with more rows are decimated to this many frames (evenly, first "
                  "and last kept; the step report is aggregated, not dropped)")
      ->capture_default_str()
      ->type_name("N");
  sub->add_flag("--quiet,-q", options->quiet, "Print nothing but errors");
  sub->footer(
      "Open FILE in a browser. FILE#t=1.8 opens paused at t = 1.8 s (default 0). Keys: space "
      "play/pause, left/right step, Home/End. Mouse: drag to orbit, wheel to zoom, right-drag "
      "to pan.");
  return Command{sub, [options] { return RunView(*options); }};
}

}  // namespace vinci::cli
