#include "json.h"

#include <charconv>
#include <cmath>

namespace vinci::cli {

std::string JsonString(const std::string& text) {
  static const char* const kHex = "0123456789abcdef";
  std::string out = "\"";
  for (const char c : text) {
    const auto u = static_cast<unsigned char>(c);
    switch (c) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\r':
        out += "\\r";
        break;
      case '\t':
        out += "\\t";
        break;
      case '<':
      case '>':
      case '&':
        out += "\\u00";
        out += kHex[u >> 4];
        out += kHex[u & 15];
        break;
      default:
        if (u < 0x20) {
          out += "\\u00";
          out += kHex[u >> 4];
          out += kHex[u & 15];
        } else {
          out += c;
        }
    }
  }
  return out + '"';
}

std::string JsonNumber(double v) {
  if (!std::isfinite(v)) return "null";
  char buf[32];
  const auto res = std::to_chars(buf, buf + sizeof(buf), v);
  return std::string(buf, res.ptr);
}

std::string JsonNamedNumbers(const std::vector<std::string>& names, const Eigen::VectorXd& values) {
  std::string o = "{";
  for (std::size_t i = 0; i < names.size(); ++i)
    o += (i ? ", " : "") + JsonString(names[i]) + ": " +
         JsonNumber(values[static_cast<Eigen::Index>(i)]);
  return o + "}";
}

std::string JsonMatrix(const Eigen::MatrixXd& m) {
  std::string o = "[";
  for (Eigen::Index i = 0; i < m.rows(); ++i) {
    o += i ? ", [" : "[";
    for (Eigen::Index j = 0; j < m.cols(); ++j) o += (j ? ", " : "") + JsonNumber(m(i, j));
    o += "]";
  }
  return o + "]";
}

}  // namespace vinci::cli
