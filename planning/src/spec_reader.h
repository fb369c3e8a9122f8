// The YAML reader shared by the planning specs (field design, plan): dotted field names with
// their lines, and file:line errors in the scene loader's form
// "<file>:<line>: <field>: expected <what>, got <what was found>". Private to planning/src.
#pragma once

#include <yaml-cpp/yaml.h>

#include <Eigen/Core>
#include <cmath>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace vinci::planning::internal {

inline std::string Join(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& x : v) s += (s.empty() ? "" : ", ") + x;
  return s;
}

// A node with its dotted name and line, for error messages.
struct Field {
  YAML::Node node;
  std::string name;
  int line;
};

class Reader {
 public:
  explicit Reader(std::string source) : source_(std::move(source)) {}

  const std::string& source() const { return source_; }
  [[noreturn]] void Fail(const Field& f, const std::string& expected,
                         const std::string& got) const {
    throw std::invalid_argument(source_ + ":" + std::to_string(f.line) + ": " + f.name +
                                ": expected " + expected + ", got " + got);
  }
  [[noreturn]] void Fail(const Field& f, const std::string& expected) const {
    Fail(f, expected, Describe(f.node));
  }
  static std::string Describe(const YAML::Node& n) {
    if (!n || n.IsNull()) return "nothing";
    if (n.IsScalar()) return "'" + n.Scalar() + "'";
    if (n.IsSequence()) return "a list of " + std::to_string(n.size());
    return "a map";
  }
  static int LineOf(const YAML::Node& n, int fallback) {
    const YAML::Mark m = n.Mark();
    return m.line >= 0 ? m.line + 1 : fallback;
  }
  Field Child(const Field& f, const std::string& key) const {
    const YAML::Node c = f.node[key];
    return {c, f.name.empty() ? key : f.name + "." + key, c ? LineOf(c, f.line) : f.line};
  }
  Field Item(const Field& f, std::size_t i) const {
    const YAML::Node c = f.node[i];
    return {c, f.name + "[" + std::to_string(i) + "]", LineOf(c, f.line)};
  }
  // A map whose keys are all in `allowed` (empty: any key), each once.
  void Map(const Field& f, const std::vector<std::string>& allowed, const std::string& what) const {
    if (!f.node.IsMap()) Fail(f, what);
    std::set<std::string> seen;
    for (const auto& kv : f.node) {
      const std::string key = kv.first.Scalar();
      const Field kf{kv.first, f.name.empty() ? key : f.name + "." + key, LineOf(kv.first, f.line)};
      if (!seen.insert(key).second) Fail(kf, "each key once", "a duplicate");
      bool ok = allowed.empty();
      for (const auto& a : allowed) ok = ok || a == key;
      if (!ok) Fail(kf, "one of the keys (" + Join(allowed) + ")", "unknown key '" + key + "'");
    }
  }
  Field Require(const Field& f, const std::string& key, const std::string& expected) const {
    Field c = Child(f, key);
    if (!c.node) Fail(c, expected, "nothing (missing key)");
    return c;
  }
  double Number(const Field& f) const {
    if (!f.node.IsScalar()) Fail(f, "a number");
    std::istringstream s(f.node.Scalar());
    double v = 0.0;
    s >> v;
    if (!s || !s.eof() || !std::isfinite(v)) Fail(f, "a finite number");
    return v;
  }
  double Positive(const Field& f) const {
    const double v = Number(f);
    if (!(v > 0.0)) Fail(f, "a number > 0");
    return v;
  }
  long long Integer(const Field& f, long long lo, long long hi) const {
    const std::string expected =
        "an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
    if (!f.node.IsScalar()) Fail(f, expected);
    const std::string& t = f.node.Scalar();
    if (t.empty() || t.size() > 18 || t == "-" ||
        t.find_first_not_of("0123456789", t[0] == '-' ? 1 : 0) != std::string::npos)
      Fail(f, expected);
    const long long v = std::stoll(t);
    if (v < lo || v > hi) Fail(f, expected);
    return v;
  }
  std::string String(const Field& f) const {
    if (!f.node.IsScalar() || f.node.Scalar().empty()) Fail(f, "a string");
    return f.node.Scalar();
  }
  bool Bool(const Field& f) const {
    if (f.node.IsScalar() && f.node.Scalar() == "true") return true;
    if (f.node.IsScalar() && f.node.Scalar() == "false") return false;
    Fail(f, "true or false");
  }
  // [a, b] with a ≤ b (strict: a < b).
  std::pair<double, double> Range(const Field& f, bool strict = false) const {
    if (!f.node.IsSequence() || f.node.size() != 2) Fail(f, "[lo, hi]");
    const double a = Number(Item(f, 0));
    const double b = Number(Item(f, 1));
    if (strict ? !(a < b) : a > b)
      Fail(f, strict ? "[lo, hi] with lo < hi" : "[lo, hi] with lo <= hi",
           "[" + f.node[0].Scalar() + ", " + f.node[1].Scalar() + "]");
    return {a, b};
  }
  Eigen::Vector2d Vec2(const Field& f) const {
    if (!f.node.IsSequence() || f.node.size() != 2) Fail(f, "[x, y]");
    return {Number(Item(f, 0)), Number(Item(f, 1))};
  }

 private:
  std::string source_;
};

inline std::string Resolve(const std::string& base_dir, const std::string& p) {
  if (p.empty() || p[0] == '/' || base_dir.empty()) return p;
  return base_dir + "/" + p;
}

}  // namespace vinci::planning::internal
