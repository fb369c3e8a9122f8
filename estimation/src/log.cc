#include "vinci/estimation/log.h"

#include <cmath>
#include <cstdlib>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>

#include "vinci/sim/solvers/input_file.h"

namespace vinci::estimation {
namespace {

using sim::Dim;

// Report columns of `vinci simulate --out`, ignored.
const std::set<std::string> kIgnoredColumns = {"step",     "contacts", "solver_iterations",
                                               "residual", "min_gap",  "status"};

// Components per dimension and where they go: kind 0 = pose, 1 = velocity; index in the block.
struct Component {
  int kind;
  int index;
};
const std::map<std::string, Component>& Components(Dim dim) {
  static const std::map<std::string, Component> planar = {{"x", {0, 0}},     {"y", {0, 1}},
                                                          {"theta", {0, 2}}, {"vx", {1, 0}},
                                                          {"vy", {1, 1}},    {"omega", {1, 2}}};
  static const std::map<std::string, Component> spatial = {
      {"x", {0, 0}},  {"y", {0, 1}},  {"z", {0, 2}},  {"qw", {0, 3}}, {"qx", {0, 4}},
      {"qy", {0, 5}}, {"qz", {0, 6}}, {"vx", {1, 0}}, {"vy", {1, 1}}, {"vz", {1, 2}},
      {"wx", {1, 3}}, {"wy", {1, 4}}, {"wz", {1, 5}}};
  return dim == Dim::kPlanar ? planar : spatial;
}

std::string Where(const std::string& file, int line) {
  return file + ":" + std::to_string(line) + ": ";
}

std::vector<std::string> SplitCsv(const std::string& line) {
  std::vector<std::string> out;
  std::string field;
  std::istringstream s(line);
  while (std::getline(s, field, ',')) {
    const auto b = field.find_first_not_of(" \t\r");
    const auto e = field.find_last_not_of(" \t\r");
    out.push_back(b == std::string::npos ? "" : field.substr(b, e - b + 1));
  }
  if (!line.empty() && line.back() == ',') out.push_back("");
  return out;
}

bool IsComment(const std::string& line) {
  const auto b = line.find_first_not_of(" \t\r");
  return b == std::string::npos || line[b] == '#';
}

// What each column of the header feeds: a body track (index into tracks), its kind and index.
struct ColumnTarget {
  int track = -1;  // -1: t or ignored
  int kind = 0;
  int index = 0;
  bool is_time = false;
};

}  // namespace

int ResidualsPerSample(const Episode& episode, Dim dim) {
  int n = 0;
  for (const BodyTrack& b : episode.bodies) {
    if (!b.dynamic) continue;
    n += dim == Dim::kPlanar ? 2 : 3;
    if (b.has_orientation) n += dim == Dim::kPlanar ? 1 : 3;
  }
  return n;
}

Episode ReadEpisode(const std::string& path, const sim::Scene& scene) {
  return ParseEpisode(sim::ReadInputFile(path, "the log file"), path, scene);
}

Episode ParseEpisode(const std::string& text, const std::string& path, const sim::Scene& scene) {
  std::istringstream in(text);
  const Dim dim = scene.dim;
  const bool planar = dim == Dim::kPlanar;
  const auto& components = Components(dim);
  Episode ep;
  ep.file = path;

  std::string line;
  int line_no = 0;
  // Header.
  std::vector<std::string> header;
  int header_line = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (IsComment(line)) continue;
    header = SplitCsv(line);
    header_line = line_no;
    break;
  }
  if (header.empty()) throw std::invalid_argument(path + ": empty log (no header line)");
  const std::string where_header = Where(path, header_line);

  std::vector<ColumnTarget> targets(header.size());
  std::set<std::string> seen;
  // Per track: which pose / velocity components are present.
  std::vector<std::vector<bool>> has_pose, has_vel;
  bool has_time = false;
  for (size_t c = 0; c < header.size(); ++c) {
    const std::string& name = header[c];
    if (!seen.insert(name).second)
      throw std::invalid_argument(where_header + "duplicated column '" + name + "'");
    if (name == "t") {
      targets[c].is_time = true;
      has_time = true;
      continue;
    }
    if (kIgnoredColumns.count(name)) continue;
    const auto dot = name.rfind('.');
    if (dot == std::string::npos || dot == 0) {
      throw std::invalid_argument(where_header + "unknown column '" + name +
                                  "': expected t, <body>.<component> or a report column of "
                                  "vinci simulate (step, contacts, solver_iterations, residual, "
                                  "min_gap, status)");
    }
    const std::string body = name.substr(0, dot), comp = name.substr(dot + 1);
    const auto it = components.find(comp);
    if (it == components.end()) {
      throw std::invalid_argument(
          where_header + "unknown column '" + name + "': component '" + comp + "' is not one of " +
          (planar ? "x, y, theta, vx, vy, omega (planar scene)"
                  : "x, y, z, qw, qx, qy, qz, vx, vy, vz, wx, wy, wz (spatial scene)"));
    }
    const int b = scene.FindBody(body);
    if (b < 0) {
      std::string names;
      for (const auto& sb : scene.bodies) names += (names.empty() ? "" : ", ") + sb.name;
      throw std::invalid_argument(where_header + "column '" + name + "': body '" + body +
                                  "' is not in the scene (bodies: " + names + ")");
    }
    int track = -1;
    for (size_t k = 0; k < ep.bodies.size(); ++k)
      if (ep.bodies[k].body_index == b) track = static_cast<int>(k);
    if (track < 0) {
      BodyTrack bt;
      bt.body = body;
      bt.body_index = b;
      bt.dynamic = scene.bodies[b].kind == sim::BodyKind::kDynamic;
      ep.bodies.push_back(bt);
      has_pose.emplace_back(planar ? 3 : 7, false);
      has_vel.emplace_back(planar ? 3 : 6, false);
      track = static_cast<int>(ep.bodies.size()) - 1;
    }
    targets[c] = {track, it->second.kind, it->second.index, false};
    (it->second.kind == 0 ? has_pose : has_vel)[track][it->second.index] = true;
  }
  if (!has_time) throw std::invalid_argument(where_header + "no 't' column (time in s)");
  const int npos = planar ? 2 : 3;
  bool any_dynamic = false;
  for (size_t k = 0; k < ep.bodies.size(); ++k) {
    BodyTrack& bt = ep.bodies[k];
    for (int i = 0; i < npos; ++i) {
      if (!has_pose[k][i]) {
        throw std::invalid_argument(where_header + "body '" + bt.body + "' has no '" + bt.body +
                                    "." +
                                    (i == 0   ? "x"
                                     : i == 1 ? "y"
                                              : "z") +
                                    "' column (every logged body needs all its position columns)");
      }
    }
    int orient = 0;
    for (size_t i = npos; i < has_pose[k].size(); ++i) orient += has_pose[k][i];
    const int norient = planar ? 1 : 4;
    if (orient != 0 && orient != norient) {
      throw std::invalid_argument(where_header + "body '" + bt.body +
                                  "' has only some of its quaternion columns (need .qw, .qx, "
                                  ".qy, .qz or none)");
    }
    bt.has_orientation = orient == norient;
    int vel = 0;
    for (bool v : has_vel[k]) vel += v;
    if (vel != 0 && vel != static_cast<int>(has_vel[k].size())) {
      throw std::invalid_argument(where_header + "body '" + bt.body +
                                  "' has only some of its velocity columns (need all of " +
                                  (planar ? ".vx, .vy, .omega" : ".vx, .vy, .vz, .wx, .wy, .wz") +
                                  " or none)");
    }
    any_dynamic = any_dynamic || bt.dynamic;
    bt.pose.resize(0, planar ? 3 : 7);
    bt.velocity.resize(0, vel ? (planar ? 3 : 6) : 0);
  }
  if (!any_dynamic)
    throw std::invalid_argument(where_header + "the log observes no dynamic body of the scene");

  // Data rows, collected row-wise then copied into the tracks.
  std::vector<std::vector<double>> pose_rows(ep.bodies.size()), vel_rows(ep.bodies.size());
  while (std::getline(in, line)) {
    ++line_no;
    if (IsComment(line)) continue;
    const std::string where = Where(path, line_no);
    const std::vector<std::string> fields = SplitCsv(line);
    if (fields.size() != header.size()) {
      throw std::invalid_argument(where + std::to_string(fields.size()) +
                                  " fields, the header has " + std::to_string(header.size()));
    }
    std::vector<std::vector<double>> pose(ep.bodies.size()), vel(ep.bodies.size());
    for (size_t k = 0; k < ep.bodies.size(); ++k) {
      pose[k].assign(planar ? 3 : 7, 0.0);
      vel[k].assign(ep.bodies[k].velocity.cols(), 0.0);
    }
    double t = 0.0;
    std::string time_field;
    for (size_t c = 0; c < header.size(); ++c) {
      if (!targets[c].is_time && targets[c].track < 0) continue;
      const std::string& f = fields[c];
      char* end = nullptr;
      const double v = std::strtod(f.c_str(), &end);
      if (f.empty() || end != f.c_str() + f.size()) {
        throw std::invalid_argument(where + "column '" + header[c] + "': '" + f +
                                    "' is not a number");
      }
      if (!std::isfinite(v)) {
        throw std::invalid_argument(where + "column '" + header[c] + "': " + f +
                                    " (values must be finite)");
      }
      if (targets[c].is_time) {
        t = v;
        time_field = f;
      } else if (targets[c].kind == 0) {
        pose[targets[c].track][targets[c].index] = v;
      } else {
        vel[targets[c].track][targets[c].index] = v;
      }
    }
    if (!ep.t.empty()) {
      if (t == ep.t.back()) {
        throw std::invalid_argument(where + "duplicated time t = " + time_field + " (line " +
                                    std::to_string(ep.lines.back()) + " has the same)");
      }
      if (t < ep.t.back()) {
        std::ostringstream m;
        m.precision(17);
        m << where << "non-monotone time: t = " << t << " after t = " << ep.t.back() << " (line "
          << ep.lines.back() << "); times must increase strictly";
        throw std::invalid_argument(m.str());
      }
    }
    for (size_t k = 0; k < ep.bodies.size(); ++k) {
      if (!planar && ep.bodies[k].has_orientation) {
        const double n = std::sqrt(pose[k][3] * pose[k][3] + pose[k][4] * pose[k][4] +
                                   pose[k][5] * pose[k][5] + pose[k][6] * pose[k][6]);
        if (std::abs(n - 1.0) > kQuaternionNormTolerance) {
          std::ostringstream m;
          m << where << "body '" << ep.bodies[k].body << "': quaternion norm " << n
            << " is not 1 (tolerance " << kQuaternionNormTolerance << ")";
          throw std::invalid_argument(m.str());
        }
        for (int i = 3; i < 7; ++i) pose[k][i] /= n;
      }
      pose_rows[k].insert(pose_rows[k].end(), pose[k].begin(), pose[k].end());
      vel_rows[k].insert(vel_rows[k].end(), vel[k].begin(), vel[k].end());
    }
    ep.t.push_back(t);
    ep.lines.push_back(line_no);
  }
  if (ep.t.empty()) throw std::invalid_argument(where_header + "the log has no samples");
  const int n = ep.num_samples();
  for (size_t k = 0; k < ep.bodies.size(); ++k) {
    BodyTrack& bt = ep.bodies[k];
    const int pc = static_cast<int>(bt.pose.cols()), vc = static_cast<int>(bt.velocity.cols());
    bt.pose.resize(n, pc);
    bt.velocity.resize(vc ? n : 0, vc);
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j < pc; ++j) bt.pose(i, j) = pose_rows[k][i * pc + j];
      for (int j = 0; j < vc; ++j) bt.velocity(i, j) = vel_rows[k][i * vc + j];
    }
  }
  return ep;
}

Log ReadLog(const std::vector<std::string>& paths, const sim::Scene& scene) {
  if (paths.empty()) throw std::invalid_argument("no log file given");
  Log log;
  for (const std::string& p : paths) log.episodes.push_back(ReadEpisode(p, scene));
  return log;
}

void CheckEnoughSamples(const Log& log, Dim dim, int shared_unknowns,
                        const std::vector<int>& episode_unknowns) {
  long long total_res = 0, total_unknowns = shared_unknowns;
  for (size_t e = 0; e < log.episodes.size(); ++e) {
    const Episode& ep = log.episodes[e];
    const long long res = static_cast<long long>(ep.num_samples()) * ResidualsPerSample(ep, dim);
    const int own = e < episode_unknowns.size() ? episode_unknowns[e] : 0;
    if (res < own) {
      throw std::invalid_argument(
          Where(ep.file, ep.lines.back()) + "fewer samples than unknowns: " +
          std::to_string(ep.num_samples()) + " samples give " + std::to_string(res) +
          " residuals for the episode's " + std::to_string(own) + " initial-state unknowns");
    }
    total_res += res;
    total_unknowns += own;
  }
  if (total_res < total_unknowns) {
    const Episode& ep = log.episodes.back();
    throw std::invalid_argument(Where(ep.file, ep.lines.back()) + "fewer samples than unknowns: " +
                                std::to_string(total_res) + " residuals in all episodes for " +
                                std::to_string(total_unknowns) + " unknowns");
  }
}

}  // namespace vinci::estimation
