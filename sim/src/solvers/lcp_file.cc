// The plain-text LCP reader and writer (format: docs/lcp-format.md).
//
// The text is split into whitespace-separated tokens, each remembering its 1-based line, so
// every rejection names the file, the line, what was expected there and what was found.
// Numbers are read and written with std::from_chars / std::to_chars: locale-independent, and the
// shortest form written reads back bit for bit.
#include "vinci/sim/solvers/lcp_file.h"

#include <Eigen/Core>
#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "vinci/sim/solvers/input_file.h"

namespace vinci::sim {
namespace {

using RowMajorMatrixXd = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

struct Token {
  std::string_view text;
  int line = 0;
};

bool IsSpace(char c) {
  return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f';
}

// Splits text into tokens; `#` to the end of the line is a comment.
class Lexer {
 public:
  explicit Lexer(std::string_view text) : text_(text) {}

  bool Next(Token* token) {
    while (pos_ < text_.size()) {
      const char c = text_[pos_];
      if (c == '\n') {
        ++line_;
        ++pos_;
      } else if (IsSpace(c)) {
        ++pos_;
      } else if (c == '#') {
        while (pos_ < text_.size() && text_[pos_] != '\n') ++pos_;
      } else {
        const std::size_t begin = pos_;
        while (pos_ < text_.size() && !IsSpace(text_[pos_]) && text_[pos_] != '#') ++pos_;
        token->text = text_.substr(begin, pos_ - begin);
        token->line = line_;
        return true;
      }
    }
    return false;
  }

  // The line to report for "end of file": the last line of the text (1 for an empty text).
  int last_line() const {
    const bool ends_with_newline = !text_.empty() && text_.back() == '\n';
    return ends_with_newline ? line_ - 1 : line_;
  }

 private:
  std::string_view text_;
  std::size_t pos_ = 0;
  int line_ = 1;
};

// A token for a message: quoted, at most 40 characters, bytes that are not printable ASCII
// (a UTF-8 BOM, a stray control character) spelled \xNN so that they are visible.
std::string Quote(std::string_view s) {
  constexpr std::size_t kMax = 40;
  static const char kHex[] = "0123456789abcdef";
  std::string q = "'";
  for (std::size_t i = 0; i < s.size() && i < kMax; ++i) {
    const auto c = static_cast<unsigned char>(s[i]);
    if (c >= 0x20 && c < 0x7f) {
      q += static_cast<char>(c);
    } else {
      q += "\\x";
      q += kHex[c >> 4];
      q += kHex[c & 0xf];
    }
  }
  if (s.size() > kMax) q += "...";
  return q + "'";
}

[[noreturn]] void Fail(const std::string& source, int line, const std::string& what) {
  throw std::invalid_argument(source + ":" + std::to_string(line) + ": " + what);
}

enum class NumberError { kNone, kNotANumber, kNotFinite, kOutOfRange };

// A decimal floating-point number, the whole token, optionally with one leading '+'.
NumberError ParseNumber(std::string_view s, double* value) {
  if (s.size() > 1 && s[0] == '+' &&
      (std::isdigit(static_cast<unsigned char>(s[1])) || s[1] == '.'))
    s.remove_prefix(1);
  const char* end = s.data() + s.size();
  const std::from_chars_result r = std::from_chars(s.data(), end, *value);
  if (r.ptr != end) return NumberError::kNotANumber;  // includes "no number at all"
  if (r.ec == std::errc::result_out_of_range) return NumberError::kOutOfRange;
  if (r.ec != std::errc()) return NumberError::kNotANumber;
  if (!std::isfinite(*value)) return NumberError::kNotFinite;
  return NumberError::kNone;
}

// Reads the number `token` stands for, or fails with "expected a finite number<bound> for
// <what>, got ...".
double ReadNumber(const std::string& source, const Token& token, const std::string& what,
                  bool nonnegative = false) {
  double v = 0.0;
  const NumberError e = ParseNumber(token.text, &v);
  const char* expected =
      nonnegative ? "expected a finite number >= 0 for " : "expected a finite number for ";
  switch (e) {
    case NumberError::kNone:
      if (nonnegative && !(v >= 0.0)) break;
      return v;
    case NumberError::kOutOfRange:
      Fail(source, token.line,
           expected + what + ", got " + Quote(token.text) + " (outside the range of double)");
    case NumberError::kNotANumber:
    case NumberError::kNotFinite:
      break;
  }
  Fail(source, token.line, expected + what + ", got " + Quote(token.text));
}

// The size n: a decimal integer in [1, kMaxLcpFileSize] (digits only, optionally a leading '+').
int ReadSize(const std::string& source, const Token& token) {
  std::string_view s = token.text;
  if (s.size() > 1 && s[0] == '+') s.remove_prefix(1);
  long long n = 0;
  const char* end = s.data() + s.size();
  const std::from_chars_result r = std::from_chars(s.data(), end, n);
  const bool digits_only = !s.empty() && std::all_of(s.begin(), s.end(), [](char c) {
    return std::isdigit(static_cast<unsigned char>(c));
  });
  if (!digits_only || r.ptr != end || r.ec != std::errc() || n < 1 || n > kMaxLcpFileSize) {
    Fail(source, token.line,
         "expected the problem size n, an integer from 1 to " + std::to_string(kMaxLcpFileSize) +
             ", got " + Quote(token.text));
  }
  return static_cast<int>(n);
}

std::string Entries(std::int64_t count, const char* name) {
  return std::to_string(count) + (count == 1 ? " entry of " : " entries of ") + name;
}

void AppendNumber(double v, std::string* s) {
  char buf[32];
  const std::to_chars_result r = std::to_chars(buf, buf + sizeof(buf), v);
  s->append(buf, r.ptr);
}

}  // namespace

LcpProblem ParseLcp(const std::string& text, const std::string& source_name) {
  const std::string& src = source_name;
  Lexer lexer(text);
  Token token;
  if (!lexer.Next(&token)) {
    Fail(src, lexer.last_line(),
         "expected the problem size n, an integer from 1 to " + std::to_string(kMaxLcpFileSize) +
             ", got the end of the file (no numbers)");
  }
  const int n = ReadSize(src, token);
  const std::int64_t num_m = static_cast<std::int64_t>(n) * n;
  const std::int64_t total = num_m + n;

  // Values are collected before M is allocated, so a mistyped n in a short file costs nothing.
  std::vector<double> values;
  values.reserve(static_cast<std::size_t>(
      std::min<std::int64_t>(total, static_cast<std::int64_t>(text.size() / 2 + 1))));
  while (static_cast<std::int64_t>(values.size()) < total && lexer.Next(&token)) {
    const std::int64_t k = static_cast<std::int64_t>(values.size());
    std::string what;
    if (k < num_m) {
      what = "entry (" + std::to_string(k / n + 1) + ", " + std::to_string(k % n + 1) + ") of M";
    } else {
      what = "entry " + std::to_string(k - num_m + 1) + " of q";
    }
    values.push_back(ReadNumber(src, token, what));
  }
  if (static_cast<std::int64_t>(values.size()) < total) {
    Fail(src, lexer.last_line(),
         "expected " + Entries(num_m, "M") + " and " + std::to_string(n) +
             " of q after n = " + std::to_string(n) + ", got the end of the file after " +
             std::to_string(values.size()) + (values.size() == 1 ? " number" : " numbers"));
  }
  if (lexer.Next(&token)) {
    double ignored;
    const bool is_number = ParseNumber(token.text, &ignored) != NumberError::kNotANumber;
    Fail(src, token.line,
         "expected the end of the file after the " + Entries(n, "q") + ", got " +
             (is_number ? "an extra number " : "") + Quote(token.text));
  }

  LcpProblem problem;
  problem.M = Eigen::Map<const RowMajorMatrixXd>(values.data(), n, n);
  problem.q = Eigen::Map<const VectorXd>(values.data() + num_m, n);
  return problem;
}

LcpProblem ReadLcpFile(const std::string& path) {
  return ParseLcp(ReadInputFile(path, "LCP file"), path);
}

void WriteLcpFile(const LcpProblem& problem, std::ostream& out) {
  const Eigen::Index n = problem.q.size();
  if (n < 1 || n > kMaxLcpFileSize || problem.M.rows() != n || problem.M.cols() != n) {
    throw std::invalid_argument(
        "WriteLcpFile: M is " + std::to_string(problem.M.rows()) + "x" +
        std::to_string(problem.M.cols()) + " and q has size " + std::to_string(n) +
        "; expected a square M matching q, with 1 <= n <= " + std::to_string(kMaxLcpFileSize));
  }
  if (!problem.M.allFinite() || !problem.q.allFinite()) {
    throw std::invalid_argument(
        "WriteLcpFile: M and q must be finite (the format has no NaN or inf), got a non-finite "
        "entry in " +
        std::string(problem.M.allFinite() ? "q" : "M"));
  }
  std::string s;
  s += "# LCP: find z >= 0 with w = M z + q >= 0 and z'w = 0 (format: docs/lcp-format.md)\n";
  s += "# n\n" + std::to_string(n) + "\n# M, one row per line\n";
  for (Eigen::Index i = 0; i < n; ++i) {
    for (Eigen::Index j = 0; j < n; ++j) {
      if (j > 0) s += ' ';
      AppendNumber(problem.M(i, j), &s);
    }
    s += '\n';
  }
  s += "# q\n";
  for (Eigen::Index i = 0; i < n; ++i) {
    if (i > 0) s += ' ';
    AppendNumber(problem.q(i), &s);
  }
  s += '\n';
  out.write(s.data(), static_cast<std::streamsize>(s.size()));
}

VectorXd ParseLcpVector(const std::string& text, int n, const std::string& source_name) {
  if (n < 1 || n > kMaxLcpFileSize) {
    throw std::invalid_argument("ParseLcpVector: n = " + std::to_string(n) +
                                "; expected 1 <= n <= " + std::to_string(kMaxLcpFileSize));
  }
  Lexer lexer(text);
  Token token;
  VectorXd v(n);
  for (int i = 0; i < n; ++i) {
    if (!lexer.Next(&token)) {
      Fail(source_name, lexer.last_line(),
           "expected " + std::to_string(n) + (n == 1 ? " number" : " numbers") +
               ", got the end of the file after " + std::to_string(i) +
               (i == 1 ? " number" : " numbers"));
    }
    v(i) = ReadNumber(source_name, token, "entry " + std::to_string(i + 1), true);
  }
  if (lexer.Next(&token)) {
    Fail(source_name, token.line,
         "expected the end of the file after " + std::to_string(n) +
             (n == 1 ? " number" : " numbers") + ", got " + Quote(token.text));
  }
  return v;
}

VectorXd ReadLcpVectorFile(const std::string& path, int n) {
  return ParseLcpVector(ReadInputFile(path, "vector file"), n, path);
}

}  // namespace vinci::sim
