// Small JSON writing helpers shared by the subcommands that write result files.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

namespace vinci::cli {

/// A JSON string literal (RFC 8259): quotes, backslashes and control characters escaped, and
/// '<', '>', '&' written as \u escapes so the text is also safe inside an HTML <script> element
/// (`vinci view`); other bytes pass through (names and messages are expected to be UTF-8).
std::string JsonString(const std::string& text);

/// A JSON number: the shortest text that reads back as exactly `v`; null for NaN and ±inf (JSON
/// has neither).
std::string JsonNumber(double v);

/// {"name": number, ...} for names[i] and values[i].
std::string JsonNamedNumbers(const std::vector<std::string>& names, const Eigen::VectorXd& values);

/// [[m00, m01, ...], [m10, ...], ...]: a matrix by rows (non-finite entries null).
std::string JsonMatrix(const Eigen::MatrixXd& m);

}  // namespace vinci::cli
