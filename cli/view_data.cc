#include "view_data.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <limits>
#include <ostream>
#include <stdexcept>
#include <string>
#include <system_error>
#include <vector>

#include "json.h"
#include "vinci/sim/geometry/shape.h"
#include "vinci/sim/plate/velocity_field.h"

namespace vinci::cli {
namespace {

using sim::Dim;

const char* const kPlanarColumns[] = {"x", "y", "theta", "vx", "vy", "omega"};
const char* const kSpatialColumns[] = {"x",  "y",  "z",  "qw", "qx", "qy", "qz",
                                       "vx", "vy", "vz", "wx", "wy", "wz"};
const char* const kReportColumns[] = {"contacts", "solver_iterations", "residual", "min_gap",
                                      "status"};
constexpr int kNumReportColumns = 5;

// "path:line: " for messages.
std::string At(const std::string& path, std::int64_t line) {
  return path + ":" + std::to_string(line) + ": ";
}

// Splits one CSV line (RFC 4180 quoting, no embedded newlines). Throws on an unterminated quote.
std::vector<std::string> SplitCsv(const std::string& line, const std::string& where) {
  std::vector<std::string> fields(1);
  bool quoted = false;
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted) {
      if (c == '"') {
        if (i + 1 < line.size() && line[i + 1] == '"') {
          fields.back() += '"';
          ++i;
        } else {
          quoted = false;
        }
      } else {
        fields.back() += c;
      }
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      fields.emplace_back();
    } else {
      fields.back() += c;
    }
  }
  if (quoted) throw std::invalid_argument(where + "unterminated quoted field");
  return fields;
}

// Reads the next line without its line terminator ("\n" or "\r\n"); false at end of file.
bool NextLine(std::istream& in, std::string* line) {
  if (!std::getline(in, *line)) return false;
  if (!line->empty() && line->back() == '\r') line->pop_back();
  return true;
}

std::ifstream OpenInput(const std::string& path, const char* what) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::invalid_argument(path + ": cannot open the " + what + " for reading");
  return in;
}

double ParseDouble(const std::string& s, const std::string& where, const std::string& column) {
  double v = 0.0;
  const char* end = s.data() + s.size();
  const auto r = std::from_chars(s.data(), end, v);
  if (s.empty() || r.ec != std::errc() || r.ptr != end)
    throw std::invalid_argument(where + "column '" + column + "': expected a number, got '" + s +
                                "'");
  return v;
}

double ParseFinite(const std::string& s, const std::string& where, const std::string& column) {
  const double v = ParseDouble(s, where, column);
  if (!std::isfinite(v))
    throw std::invalid_argument(where + "column '" + column + "': expected a finite number, got '" +
                                s + "'");
  return v;
}

std::int64_t ParseInt(const std::string& s, const std::string& where, const std::string& column) {
  std::int64_t v = 0;
  const char* end = s.data() + s.size();
  const auto r = std::from_chars(s.data(), end, v);
  if (s.empty() || r.ec != std::errc() || r.ptr != end)
    throw std::invalid_argument(where + "column '" + column + "': expected an integer, got '" + s +
                                "'");
  return v;
}

// The header `vinci simulate` writes for `scene`, without the report columns.
std::vector<std::string> ExpectedColumns(const sim::Scene& scene) {
  std::vector<std::string> cols = {"step", "t"};
  const bool planar = scene.dim == Dim::kPlanar;
  for (const sim::Body& b : scene.bodies) {
    const int n = planar ? 6 : 13;
    for (int i = 0; i < n; ++i)
      cols.push_back(b.name + "." + (planar ? kPlanarColumns[i] : kSpatialColumns[i]));
  }
  return cols;
}

std::string DescribeScene(const sim::Scene& scene) {
  return "the scene '" + (scene.name.empty() ? std::string("(unnamed)") : scene.name) + "' (" +
         (scene.dim == Dim::kPlanar ? "planar" : "spatial") + ", " +
         std::to_string(scene.bodies.size()) + " bodies)";
}

bool IsNormalStatus(const std::string& s) { return s == "solved" || s == "initial"; }

// ---- JSON ------------------------------------------------------------------------------------

// A number with `digits` significant digits (locale-independent); null if not finite.
void JsonNumber(double v, std::ostream& out, int digits = 9) {
  if (!std::isfinite(v)) {
    out << "null";
    return;
  }
  char buf[40];
  const auto r = std::to_chars(buf, buf + sizeof buf, v, std::chars_format::general, digits);
  out.write(buf, r.ptr - buf);
}

template <typename Range, typename F>
void JsonArray(const Range& range, std::ostream& out, F&& item) {
  out << '[';
  bool first = true;
  for (const auto& x : range) {
    if (!first) out << ',';
    first = false;
    item(x);
  }
  out << ']';
}

void JsonVector(const sim::Vector3d& v, std::ostream& out, int digits = 9) {
  out << '[';
  JsonNumber(v.x(), out, digits);
  out << ',';
  JsonNumber(v.y(), out, digits);
  out << ',';
  JsonNumber(v.z(), out, digits);
  out << ']';
}

// Pose as "p":[x,y,z],"q":[w,x,y,z].
void JsonPose(const sim::Isometry3d& X, std::ostream& out) {
  sim::Quaterniond q(X.linear());
  q.normalize();
  out << "\"p\":";
  JsonVector(X.translation(), out);
  out << ",\"q\":[";
  JsonNumber(q.w(), out);
  out << ',';
  JsonNumber(q.x(), out);
  out << ',';
  JsonNumber(q.y(), out);
  out << ',';
  JsonNumber(q.z(), out);
  out << ']';
}

void JsonShape(const sim::Shape& shape_in, std::ostream& out) {
  sim::Shape shape = shape_in;
  if (shape.type == sim::ShapeType::kPolyhedron && shape.faces.empty()) sim::PrepareShape(&shape);
  out << "{\"type\":";
  out << JsonString(sim::ShapeKeyword(shape.type));
  out << ",\"name\":";
  out << JsonString(shape.name);
  out << ',';
  JsonPose(shape.X_BS, out);
  out << ",\"radius\":";
  JsonNumber(shape.radius, out);
  out << ",\"half_extents\":";
  JsonVector(shape.half_extents, out);
  out << ",\"half_length\":";
  JsonNumber(shape.half_length, out);
  out << ",\"exponent\":";
  JsonNumber(shape.exponent, out);
  out << ",\"material\":" << shape.material;
  if (!shape.vertices.empty()) {
    out << ",\"vertices\":";
    JsonArray(shape.vertices, out, [&](const sim::Vector3d& v) { JsonVector(v, out); });
  }
  if (!shape.faces.empty()) {
    out << ",\"faces\":";
    JsonArray(shape.faces, out, [&](const sim::HullFace& f) {
      JsonArray(f.vertices, out, [&](int i) { out << i; });
    });
  }
  out << '}';
}

const char* KindName(sim::BodyKind k) {
  switch (k) {
    case sim::BodyKind::kDynamic:
      return "dynamic";
    case sim::BodyKind::kStatic:
      return "static";
    case sim::BodyKind::kPrescribed:
      return "prescribed";
  }
  return "?";
}

}  // namespace

ViewTrajectory ReadViewTrajectory(const std::string& path, const sim::Scene& scene,
                                  std::int64_t max_frames) {
  if (max_frames < 2) throw std::logic_error("ReadViewTrajectory: max_frames < 2");
  // Pass 1: count the data rows, to choose the frames.
  std::int64_t rows = 0;
  {
    std::ifstream in = OpenInput(path, "trajectory");
    std::string line;
    if (!NextLine(in, &line))
      throw std::invalid_argument(At(path, 1) +
                                  "empty file, expected the header of a trajectory "
                                  "CSV (vinci simulate --out)");
    while (NextLine(in, &line)) ++rows;
    if (in.bad()) throw std::invalid_argument(path + ": read error");
  }
  if (rows == 0)
    throw std::invalid_argument(At(path, 2) + "expected at least one state row after the header");

  std::ifstream in = OpenInput(path, "trajectory");
  std::string line;
  NextLine(in, &line);
  const std::vector<std::string> header = SplitCsv(line, At(path, 1));
  const std::vector<std::string> expected = ExpectedColumns(scene);
  const std::size_t n_body = expected.size();
  const std::size_t n_full = n_body + kNumReportColumns;
  for (std::size_t i = 0; i < std::min(header.size(), n_full); ++i) {
    const std::string& want = i < n_body ? expected[i] : kReportColumns[i - n_body];
    if (header[i] != want)
      throw std::invalid_argument(At(path, 1) + "column " + std::to_string(i + 1) + ": expected '" +
                                  want + "' (the trajectory of " + DescribeScene(scene) +
                                  "), got '" + header[i] + "'");
  }
  if (header.size() != n_body && header.size() != n_full)
    throw std::invalid_argument(At(path, 1) + "expected " + std::to_string(n_body) +
                                " columns (step, t and the bodies of " + DescribeScene(scene) +
                                ") or " + std::to_string(n_full) +
                                " (with the step report contacts..status), got " +
                                std::to_string(header.size()));

  ViewTrajectory traj;
  traj.rows = rows;
  traj.has_report = header.size() == n_full;
  const bool planar = scene.dim == Dim::kPlanar;
  const int per_body = planar ? 6 : 13;
  const int pose_size = planar ? 3 : 7;
  traj.poses.assign(scene.bodies.size(), {});
  const std::int64_t frames = std::min(rows, max_frames);
  // Frame k shows row round(k (rows − 1) / (frames − 1)).
  const auto frame_row = [&](std::int64_t k) {
    return frames == 1 ? std::int64_t{0}
                       : static_cast<std::int64_t>(
                             std::llround(static_cast<double>(k) * static_cast<double>(rows - 1) /
                                          static_cast<double>(frames - 1)));
  };
  std::int64_t next_frame = 0;
  std::int64_t next_row = frame_row(0);

  // The report aggregated since the last frame.
  int agg_contacts = 0, agg_iterations = 0;
  double agg_residual = 0.0, agg_gap = std::numeric_limits<double>::infinity();
  std::string agg_status;
  const auto status_index = [&](const std::string& s) {
    auto it = std::find(traj.status_names.begin(), traj.status_names.end(), s);
    if (it != traj.status_names.end()) return static_cast<int>(it - traj.status_names.begin());
    traj.status_names.push_back(s);
    return static_cast<int>(traj.status_names.size()) - 1;
  };

  double t_prev = -std::numeric_limits<double>::infinity();
  std::string t_prev_text;
  for (std::int64_t r = 0; r < rows; ++r) {
    const std::int64_t line_no = r + 2;
    const std::string where = At(path, line_no);
    if (!NextLine(in, &line)) throw std::invalid_argument(where + "the file changed while read");
    const std::vector<std::string> f = SplitCsv(line, where);
    if (f.size() != header.size())
      throw std::invalid_argument(where + "expected " + std::to_string(header.size()) +
                                  " fields as in the header, got " + std::to_string(f.size()));
    const std::int64_t step = ParseInt(f[0], where, "step");
    const double t = ParseFinite(f[1], where, "t");
    if (t < t_prev)
      throw std::invalid_argument(where +
                                  "column 't': expected a time >= the previous row's, got " + f[1] +
                                  " after " + t_prev_text);
    t_prev = t;
    t_prev_text = f[1];
    // Every pose and velocity must be a finite number, also in rows that are not kept.
    for (std::size_t c = 2; c < n_body; ++c) ParseFinite(f[c], where, header[c]);
    if (traj.has_report) {
      const auto contacts = ParseInt(f[n_body], where, header[n_body]);
      const auto iterations = ParseInt(f[n_body + 1], where, header[n_body + 1]);
      const double residual = ParseDouble(f[n_body + 2], where, header[n_body + 2]);
      const double gap = ParseDouble(f[n_body + 3], where, header[n_body + 3]);
      const std::string& status = f[n_body + 4];
      if (contacts < 0 || iterations < 0)
        throw std::invalid_argument(where + "contacts and solver_iterations must be >= 0");
      if (status.empty()) throw std::invalid_argument(where + "column 'status': empty");
      agg_contacts = std::max(agg_contacts, static_cast<int>(contacts));
      agg_iterations = std::max(agg_iterations, static_cast<int>(iterations));
      if (!(residual <= agg_residual)) agg_residual = residual;  // NaN is the worst
      if (contacts > 0) agg_gap = std::min(agg_gap, gap);        // 0 means "no contact" otherwise
      if (agg_status.empty() || (IsNormalStatus(agg_status) && !IsNormalStatus(status)))
        agg_status = status;
      if (!IsNormalStatus(status)) {
        if (traj.num_flagged < ViewTrajectory::kMaxFlagged)
          traj.flagged.push_back({step, t, status});
        ++traj.num_flagged;
      }
    }
    if (r != next_row) continue;
    traj.steps.push_back(step);
    traj.t.push_back(t);
    for (std::size_t b = 0; b < scene.bodies.size(); ++b) {
      const std::size_t c0 = 2 + b * per_body;
      for (int k = 0; k < pose_size; ++k)
        traj.poses[b].push_back(ParseFinite(f[c0 + k], where, header[c0 + k]));
    }
    if (traj.has_report) {
      traj.contacts.push_back(agg_contacts);
      traj.iterations.push_back(agg_iterations);
      traj.residual.push_back(agg_residual);
      traj.min_gap.push_back(agg_gap);
      traj.status.push_back(status_index(agg_status));
      agg_contacts = agg_iterations = 0;
      agg_residual = 0.0;
      agg_gap = std::numeric_limits<double>::infinity();
      agg_status.clear();
    }
    ++next_frame;
    if (next_frame < frames) next_row = frame_row(next_frame);
  }
  return traj;
}

ViewField ReadViewField(const std::string& path, const std::string& scene_path,
                        const sim::Scene& scene) {
  const sim::FieldSpec spec = sim::LoadFieldSpec(scene_path, scene);
  ViewField field;
  field.plate = scene.bodies[spec.plate].name;
  field.part = scene.bodies[spec.part].name;
  const double dx = spec.nx > 1 ? (spec.x_max - spec.x_min) / (spec.nx - 1) : 0.0;
  const double dy = spec.ny > 1 ? (spec.y_max - spec.y_min) / (spec.ny - 1) : 0.0;
  field.spacing = dx > 0 && dy > 0 ? std::min(dx, dy) : std::max(dx, dy);

  std::ifstream in = OpenInput(path, "velocity field");
  std::string line;
  if (!NextLine(in, &line))
    throw std::invalid_argument(At(path, 1) +
                                "empty file, expected the header of a velocity-field "
                                "CSV (vinci field --out)");
  const std::vector<std::string> header = SplitCsv(line, At(path, 1));
  const std::vector<std::string> want = {"x",          "y",      "vx",     "vy",    "omega",
                                         "left_plate", "failed", "x_mean", "y_mean"};
  if (header.size() != 7 && header.size() != 9)
    throw std::invalid_argument(At(path, 1) +
                                "expected the 7 or 9 columns of vinci field "
                                "(x,y,vx,vy,omega,left_plate,failed[,x_mean,y_mean]), got " +
                                std::to_string(header.size()));
  for (std::size_t i = 0; i < header.size(); ++i)
    if (header[i] != want[i])
      throw std::invalid_argument(At(path, 1) + "column " + std::to_string(i + 1) + ": expected '" +
                                  want[i] + "', got '" + header[i] + "'");
  // Plate frame P → world, as in velocity_field.h.
  const sim::Isometry3d& X_WP = scene.bodies[spec.plate].X_WB0;
  field.normal_W =
      X_WP.linear() * (scene.dim == Dim::kPlanar ? sim::Vector3d::UnitY() : sim::Vector3d::UnitZ());
  std::int64_t line_no = 1;
  while (NextLine(in, &line)) {
    ++line_no;
    const std::string where = At(path, line_no);
    const std::vector<std::string> f = SplitCsv(line, where);
    if (f.size() != header.size())
      throw std::invalid_argument(where + "expected " + std::to_string(header.size()) +
                                  " fields as in the header, got " + std::to_string(f.size()));
    const double x = ParseFinite(f[0], where, "x"), y = ParseFinite(f[1], where, "y");
    ViewFieldPoint p;
    const auto flag = [&](int c) {
      const std::int64_t v = ParseInt(f[c], where, header[c]);
      if (v != 0 && v != 1)
        throw std::invalid_argument(where + "column '" + header[c] + "': expected 0 or 1, got '" +
                                    f[c] + "'");
      return v == 1;
    };
    p.left_plate = flag(5);
    p.failed = flag(6);
    const double vx = ParseDouble(f[2], where, "vx"), vy = ParseDouble(f[3], where, "vy");
    p.omega = ParseDouble(f[4], where, "omega");
    p.p_W = X_WP * sim::Vector3d(x, y, 0.0);
    p.v_W = X_WP.linear() * sim::Vector3d(vx, vy, 0.0);
    if (!p.v_W.allFinite() && !p.failed)
      throw std::invalid_argument(where + "expected finite vx, vy for a point that did not fail");
    field.points.push_back(p);
  }
  if (in.bad()) throw std::invalid_argument(path + ": read error");
  if (field.points.empty())
    throw std::invalid_argument(At(path, 2) + "expected at least one point after the header");
  return field;
}

void WriteViewJson(const sim::Scene& scene, const std::string& scene_path,
                   const ViewTrajectory* traj, const std::string& trajectory_path,
                   const ViewField* field, const std::string& field_path, std::ostream& out) {
  const bool planar = scene.dim == Dim::kPlanar;
  out << "{\"format\":\"vinci-view-1\",\"sources\":{\"scene\":";
  out << JsonString(scene_path);
  out << ",\"trajectory\":";
  if (traj)
    out << JsonString(trajectory_path);
  else
    out << "null";
  out << ",\"field\":";
  if (field)
    out << JsonString(field_path);
  else
    out << "null";
  out << "},\n\"scene\":{\"name\":";
  out << JsonString(scene.name);
  out << ",\"dim\":" << (planar ? 2 : 3) << ",\"gravity\":";
  JsonVector(scene.gravity_W, out);
  out << ",\"dt\":";
  JsonNumber(scene.options.dt, out);
  out << ",\"duration\":";
  JsonNumber(scene.options.duration, out);
  out << ",\"bodies\":[";
  for (std::size_t b = 0; b < scene.bodies.size(); ++b) {
    const sim::Body& body = scene.bodies[b];
    if (b > 0) out << ",\n";
    out << "{\"name\":";
    out << JsonString(body.name);
    out << ",\"kind\":\"" << KindName(body.kind) << "\",";
    JsonPose(body.X_WB0, out);
    out << ",\"shapes\":";
    JsonArray(body.shapes, out, [&](const sim::Shape& s) { JsonShape(s, out); });
    out << '}';
  }
  out << "]},\n\"trajectory\":";
  if (traj == nullptr) {
    out << "null";
  } else {
    out << "{\"rows\":" << traj->rows << ",\"frames\":" << traj->t.size() << ",\"step\":";
    JsonArray(traj->steps, out, [&](std::int64_t s) { out << s; });
    out << ",\n\"t\":";
    JsonArray(traj->t, out, [&](double v) { JsonNumber(v, out, 12); });
    out << ",\n\"poses\":[";
    for (std::size_t b = 0; b < traj->poses.size(); ++b) {
      if (b > 0) out << ",\n";
      JsonArray(traj->poses[b], out, [&](double v) { JsonNumber(v, out, 8); });
    }
    out << "],\n\"report\":";
    if (!traj->has_report) {
      out << "null";
    } else {
      out << "{\"contacts\":";
      JsonArray(traj->contacts, out, [&](int v) { out << v; });
      out << ",\n\"iterations\":";
      JsonArray(traj->iterations, out, [&](int v) { out << v; });
      out << ",\n\"residual\":";
      JsonArray(traj->residual, out, [&](double v) { JsonNumber(v, out, 3); });
      out << ",\n\"min_gap\":";
      JsonArray(traj->min_gap, out, [&](double v) { JsonNumber(v, out, 4); });
      out << ",\n\"status\":";
      JsonArray(traj->status, out, [&](int v) { out << v; });
      out << ",\"status_names\":";
      JsonArray(traj->status_names, out, [&](const std::string& s) { out << JsonString(s); });
      out << ",\n\"flagged\":";
      JsonArray(traj->flagged, out, [&](const ViewTrajectory::Flag& f) {
        out << "{\"step\":" << f.step << ",\"t\":";
        JsonNumber(f.t, out, 12);
        out << ",\"status\":";
        out << JsonString(f.status);
        out << '}';
      });
      out << ",\"num_flagged\":" << traj->num_flagged << '}';
    }
    out << '}';
  }
  out << ",\n\"field\":";
  if (field == nullptr) {
    out << "null";
  } else {
    out << "{\"plate\":";
    out << JsonString(field->plate);
    out << ",\"part\":";
    out << JsonString(field->part);
    out << ",\"spacing\":";
    JsonNumber(field->spacing, out);
    out << ",\"normal\":";
    JsonVector(field->normal_W, out);
    out << ",\"points\":";
    JsonArray(field->points, out, [&](const ViewFieldPoint& p) {
      out << "{\"p\":";
      JsonVector(p.p_W, out);
      out << ",\"v\":";
      JsonVector(p.v_W, out, 6);
      out << ",\"omega\":";
      JsonNumber(p.omega, out, 6);
      out << ",\"left_plate\":" << (p.left_plate ? 1 : 0) << ",\"failed\":" << (p.failed ? 1 : 0)
          << '}';
    });
    out << '}';
  }
  out << "}\n";
}

}  // namespace vinci::cli
