// Reading and writing LCPs as plain text (format: docs/lcp-format.md).
//
// A file holds the size n, then the n·n entries of M in row-major order, then the n entries of
// q: whitespace-separated numbers in any line layout; `#` starts a comment that runs to the end
// of the line; blank lines are ignored. Example (the 1×1 problem z = 9.8):
//
//   # n, then M, then q
//   1
//   1
//   -9.8
#pragma once

#include <ostream>
#include <string>

#include "vinci/sim/solvers/lcp.h"

namespace vinci::sim {

/// The largest n a file may declare. Guards against a mistyped size (M alone is 8·n² bytes).
inline constexpr int kMaxLcpFileSize = 100000;

/// Parses an LCP from text in the format above. `source_name` (a file name) prefixes error
/// messages. Throws std::invalid_argument with "<source>:<line>: expected <what>, got <what was
/// found>" (lines 1-based) for a missing or invalid n (not a positive integer written as one, or
/// larger than kMaxLcpFileSize), a token that is not a number, NaN or ±inf, a number outside
/// the range of double, too few numbers (reported at the last line) and anything after q.
/// `blocks` of the result is empty (the format has no block structure).
LcpProblem ParseLcp(const std::string& text, const std::string& source_name = "<string>");

/// Reads and parses an LCP file. Throws std::invalid_argument if it cannot be read or parsed.
LcpProblem ReadLcpFile(const std::string& path);

/// Writes `problem` in the format above (a comment line, n, M one row per line, q on one
/// line), with every number in the shortest form that reads back exactly, so that
/// ParseLcp(written text) reproduces M and q bit for bit. `blocks` is not written. Throws
/// std::invalid_argument if M is not n×n for n = q.size() ≥ 1, n > kMaxLcpFileSize, or any entry
/// is NaN or ±inf (the reader would reject the file).
void WriteLcpFile(const LcpProblem& problem, std::ostream& out);

/// Parses a vector of exactly `n` finite numbers ≥ 0 in the same lexical format (comments,
/// any line layout), e.g. a warm start for z. Errors as for ParseLcp.
VectorXd ParseLcpVector(const std::string& text, int n,
                        const std::string& source_name = "<string>");

/// Reads and parses a vector file (see ParseLcpVector).
VectorXd ReadLcpVectorFile(const std::string& path, int n);

}  // namespace vinci::sim
